"""``OnnxDetector``: run any YOLO-family ONNX detector with onnxruntime.

Output layouts (detected from the output shape and the number of class names):

- YOLOv5-style ``[1, N, 5+C]``: cx, cy, w, h, objectness, C class scores;
  score = objectness * best class score.
- YOLOv8/11-style ``[1, 4+C, N]``: cx, cy, w, h, C class scores; score = best class score.

Boxes are in letterboxed input pixels; they are mapped back to the original
image, clipped, and filtered with per-class NMS. With zoom ``windows``
(``perception.detectors.windows``) the model also runs on each window's crop,
magnified into its input; small objects whole inside a window are taken from the
window, the rest from the whole frame. Class names come from the
``names`` argument (list, dict or names file), else the model's ``names``
metadata (Ultralytics dict string), else a ``<model>.names`` file beside the
model. When any name matches one of our ``CLASSES`` (directly or via
``NAME_ALIASES``), ids are mapped to ours and unmatched classes are dropped
(counted in ``dropped_unknown``); otherwise raw model class indices are kept.
"""

from __future__ import annotations

import ast
import json
import logging
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.detectors.windows import (
    check_windows,
    merge_windows,
    window_pixels,
    window_zoom,
)
from lookahead.perception.geometry import clip_boxes
from lookahead.perception.letterbox import letterbox, padded_size, unletterbox_boxes
from lookahead.perception.nms import nms
from lookahead.perception.safe_yaml import load_yaml

log = logging.getLogger(__name__)

#: Other datasets' names for our classes (COCO and common driving sets), lower-case.
NAME_ALIASES: dict[str, str] = {
    "person": "pedestrian",
    "people": "pedestrian",
    "child": "pedestrian",
    "bicycle": "cyclist",
    "bicyclist": "cyclist",
    "rider": "cyclist",
    "e-bike": "cyclist",
    "motorcycle": "motorcyclist",
    "motorbike": "motorcyclist",
    "motor": "motorcyclist",
    "van": "car",
    "dog": "animal",
    "cat": "animal",
    "horse": "animal",
    "sheep": "animal",
    "cow": "animal",
    "cattle": "animal",
    "deer": "animal",
    "bear": "animal",
}

#: Providers in order of preference; CPU is always the last resort.
PREFERRED_PROVIDERS = ("TensorrtExecutionProvider", "CUDAExecutionProvider", "CPUExecutionProvider")

#: Candidates kept before NMS (highest scores), as in Ultralytics.
MAX_NMS_CANDIDATES = 30000

#: A box with more than this fraction of its area inside a higher-scoring box of its class is
#: dropped by NMS as a part of that object (a cow's head or legs beside the whole cow).
CONTAINMENT = 0.8

#: A dynamic-size input is padded to a multiple of this (px): the coarsest stride of YOLO-family nets.
INPUT_MULTIPLE = 32

#: Input sides (px) a model may ask for (its static input, its ``imgsz`` metadata) or be given
#: (``input_size``): a bigger one would allocate gigabytes per frame (60000 x 60000 x 3 floats
#: is 43 GB), so it is a broken or hostile model, refused at load.
MIN_INPUT_SIDE, MAX_INPUT_SIDE = INPUT_MULTIPLE, 4096

#: Longest metadata value read (``imgsz``, ``names``), in characters; a longer one is refused
#: before it is parsed.
MAX_METADATA_CHARS = 1 << 16

_V5, _V8 = "v5", "v8"


class ModelError(ValueError):
    """A model file that is missing, unreadable or of an unsupported shape; one-line message."""


def _one_line(text: object, limit: int = 240) -> str:
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


def _fmt_shape(shape: Sequence[Any]) -> str:
    return "[" + ", ".join(str(d) if d is not None else "?" for d in shape) + "]"


def _names_from_obj(obj: Any) -> list[str] | None:
    """Names from a list, an {index: name} dict, or a dict holding ``names``."""
    if isinstance(obj, Mapping):
        if "names" in obj:
            return _names_from_obj(obj["names"])
        try:
            items = sorted((int(k), str(v)) for k, v in obj.items())
        except (TypeError, ValueError):
            return None
        if [k for k, _ in items] != list(range(len(items))):
            return None
        return [v for _, v in items]
    if isinstance(obj, list | tuple) and all(isinstance(v, str) for v in obj):
        return [str(v) for v in obj]
    return None


def load_names_file(path: str | Path) -> list[str]:
    """Class names from a file: YAML/JSON list or dict (``.yaml``, ``.yml``, ``.json``), else one per line."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ModelError(f"{path}: cannot read names file ({_one_line(e)})") from e
    if p.suffix.lower() in (".yaml", ".yml", ".json"):
        try:
            obj = json.loads(text) if p.suffix.lower() == ".json" else load_yaml(text, str(p))[0]
        except (ValueError, RecursionError) as e:  # YamlError is a ValueError
            raise ModelError(f"{path}: cannot parse names file ({_one_line(e)})") from e
        names = _names_from_obj(obj)
        if names is None:
            raise ModelError(
                f"{path}: names file holds no list or {{index: name}} dict of class names"
            )
        return names
    return [line.strip() for line in text.splitlines() if line.strip()]


def _parse_metadata_names(value: str) -> list[str] | None:
    try:
        obj = ast.literal_eval(value)
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        try:
            obj = json.loads(value)
        except (ValueError, RecursionError):
            return None
    return _names_from_obj(obj)


def _our_class(name: str) -> int:
    key = name.strip().lower().replace("_", " ")
    key = NAME_ALIASES.get(key, key)
    return CLASS_ID.get(key, -1)


def _static(dim: Any) -> int | None:
    return int(dim) if isinstance(dim, int | np.integer) and dim > 0 else None


class OnnxDetector:
    """YOLO-family ONNX detector (onnxruntime); see the module docstring for layouts and names.

    Args:
        model_path: the ``.onnx`` file.
        conf_threshold: minimum score kept (strictly greater).
        iou_threshold: per-class NMS IoU threshold (boxes mostly inside a better one of their
            class, ``CONTAINMENT``, are dropped too).
        max_det: most detections returned per image.
        input_size: (px) side or (height, width) used only when the model's input is dynamic: the
            whole frame is fitted into it (then padded only to a multiple of 32); default the
            model's ``imgsz`` metadata, else 640.
        names: class names (list, {index: name} dict, or a names file path); overrides the metadata.
        providers: onnxruntime providers; default TensorRT/CUDA when available, else CPU.
        windows: zoom windows (x0, y0, x1, y1 as fractions of the image, optionally a zoom) run as
            well, magnified (``perception.detectors.windows``); empty: the whole frame only.

    Attributes:
        session: the ``onnxruntime.InferenceSession`` (time ``session.run`` alone via ``infer``).
        names: model class names (None when unknown).
        class_map: (C,) model class index -> our class id (-1 unknown), or None for raw indices.
        layout: ``"v5"`` or ``"v8"`` once known (static output shape: at load).
        dropped_unknown: detections dropped so far for an unknown class name.
        last_timing_ms: preprocess / infer / postprocess times of the last ``detect``, summed
            over its views (the whole frame and each window), and ``views``, their number.
    """

    def __init__(
        self,
        model_path: str | Path,
        conf_threshold: float = 0.25,
        iou_threshold: float = 0.45,
        max_det: int = 300,
        input_size: int | tuple[int, int] | None = None,
        names: Sequence[str] | Mapping[int, str] | str | Path | None = None,
        providers: Sequence[str] | None = None,
        windows: Sequence[Sequence[float]] = (),
    ) -> None:
        import onnxruntime as ort  # heavy; imported only when a model is loaded

        self.model_path = Path(model_path)
        self._label = str(model_path)
        self.name = f"onnx:{self.model_path.stem}"
        self.conf_threshold = float(conf_threshold)
        self.iou_threshold = float(iou_threshold)
        self.max_det = int(max_det)
        self.dropped_unknown = 0
        self.last_timing_ms: dict[str, float] = {}
        try:
            self.windows = check_windows(windows)
        except ValueError as e:
            raise ModelError(f"{self._label}: {e}") from None

        if not self.model_path.is_file():
            raise ModelError(f"{self._label}: model file not found")
        if providers is None:
            available = set(ort.get_available_providers())
            providers = [p for p in PREFERRED_PROVIDERS if p in available]
        options = ort.SessionOptions()
        options.log_severity_level = 3
        try:
            self.session = ort.InferenceSession(
                str(self.model_path), sess_options=options, providers=list(providers)
            )
        except Exception as e:  # onnxruntime raises its own exception types
            raise ModelError(f"{self._label}: not a loadable ONNX model ({_one_line(e)})") from e
        log.info("%s: providers %s", self._label, self.session.get_providers())

        self._read_input(input_size)
        out = self.session.get_outputs()[0]
        self.output_name = out.name
        self.names = self._resolve_names(names) or None
        self.class_map = self._build_class_map(self.names)
        self.layout: str | None = None
        self.num_classes: int | None = len(self.names) if self.names is not None else None
        shape = tuple(out.shape)
        if len(shape) != 3 or any(_static(d) is not None for d in shape[1:]):
            self._resolve_layout(shape)  # else: fully dynamic, resolved on the first output

    # ------------------------------------------------------------------ setup

    def _read_input(self, input_size: int | tuple[int, int] | None) -> None:
        inp = self.session.get_inputs()[0]
        self.input_name = inp.name
        self._input_dtype = np.float16 if inp.type == "tensor(float16)" else np.float32
        shape = list(inp.shape)
        if len(shape) != 4 or _static(shape[1]) not in (3, None):
            raise ModelError(
                f"{self._label}: input shape {_fmt_shape(shape)} is not [1, 3, H, W] (NCHW RGB)"
            )
        h, w = _static(shape[2]), _static(shape[3])
        self.dynamic_input = h is None or w is None
        if not self.dynamic_input:
            if max(h, w) > MAX_INPUT_SIDE:
                raise ModelError(
                    f"{self._label}: input {h}x{w} px is larger than {MAX_INPUT_SIDE} px a side"
                )
            if input_size is not None and _as_hw(input_size) != (h, w):
                log.warning(
                    "%s: input_size %s ignored; model input is %dx%d", self._label, input_size, h, w
                )
            self.input_hw = (h, w)
        elif input_size is not None:
            self.input_hw = _as_hw(input_size)
            if not all(MIN_INPUT_SIDE <= v <= MAX_INPUT_SIDE for v in self.input_hw):
                raise ModelError(
                    f"{self._label}: input_size {self.input_hw[0]}x{self.input_hw[1]}: each side must be "
                    f"{MIN_INPUT_SIDE}..{MAX_INPUT_SIDE} px"
                )
        else:
            self.input_hw = self._metadata_imgsz() or (640, 640)

    def _metadata(self, key: str) -> str | None:
        """The model's metadata value ``key`` (None when absent); ``ModelError`` when it is longer
        than ``MAX_METADATA_CHARS``."""
        value = (self.session.get_modelmeta().custom_metadata_map or {}).get(key)
        if value is not None and len(value) > MAX_METADATA_CHARS:
            raise ModelError(
                f"{self._label}: metadata {key!r} is {len(value)} characters long, more than {MAX_METADATA_CHARS}"
            )
        return value

    def _metadata_imgsz(self) -> tuple[int, int] | None:
        """The ``imgsz`` metadata (Ultralytics: ``[h, w]`` or a side), None when absent or unreadable;
        ``ModelError`` when a side is outside ``MIN_INPUT_SIDE..MAX_INPUT_SIDE`` or not a multiple of
        ``INPUT_MULTIPLE``."""
        value = self._metadata("imgsz")
        try:
            size = ast.literal_eval(value) if value else None
            hw = _as_hw(size if isinstance(size, int) else tuple(size)) if size is not None else None
        except (ValueError, SyntaxError, TypeError, OverflowError, MemoryError, RecursionError):
            hw = None
        if hw is None:
            return None
        if not all(MIN_INPUT_SIDE <= v <= MAX_INPUT_SIDE and v % INPUT_MULTIPLE == 0 for v in hw):
            raise ModelError(
                f"{self._label}: metadata imgsz {hw[0]}x{hw[1]}: each side must be a multiple of "
                f"{INPUT_MULTIPLE} in {MIN_INPUT_SIDE}..{MAX_INPUT_SIDE} px"
            )
        return hw

    def _resolve_names(self, names: Any) -> list[str] | None:
        if names is not None:
            if isinstance(names, str | Path):
                return load_names_file(names)
            parsed = _names_from_obj(dict(names) if isinstance(names, Mapping) else list(names))
            if parsed is None:
                raise ModelError(
                    f"{self._label}: names argument is not a list or {{index: name}} dict"
                )
            return parsed
        meta_names = self._metadata("names")
        if meta_names is not None:
            parsed = _parse_metadata_names(meta_names)
            if parsed is not None:
                return parsed
            log.warning("%s: unreadable 'names' metadata %r", self._label, meta_names[:80])
        sidecar = self.model_path.with_suffix(".names")
        if sidecar.is_file():
            return load_names_file(sidecar)
        return None

    def _build_class_map(self, names: list[str] | None) -> np.ndarray | None:
        if not names:
            return None
        ids = np.array([_our_class(n) for n in names], dtype=np.int64)
        if not np.any(ids >= 0):
            log.info("%s: no class name matches ours; keeping raw class indices", self._label)
            return None
        unknown = [n for n, i in zip(names, ids, strict=True) if i < 0]
        if unknown:
            log.info(
                "%s: %d model classes unmapped, dropped: %s",
                self._label,
                len(unknown),
                unknown[:10],
            )
        return ids

    def _resolve_layout(self, shape: tuple[Any, ...]) -> None:
        """Set ``layout`` and ``num_classes`` from an output shape, or raise ``ModelError``."""
        nc = len(self.names) if self.names is not None else None
        dims = [_static(d) for d in shape]
        layout: str | None = None
        if len(shape) == 3 and dims[0] in (1, None):
            a, b = dims[1], dims[2]
            v5 = b is not None and (b == nc + 5 if nc is not None else b >= 6)
            v8 = a is not None and (a == nc + 4 if nc is not None else a >= 5)
            if v5 and v8 and nc is None:  # the feature axis is the short one
                v5, v8 = b < a, a < b
            if v5 and v8:
                log.warning(
                    "%s: output %s fits both layouts; assuming [1, 4+C, N]", self._label, shape
                )
                v5 = False
            layout = _V5 if v5 else _V8 if v8 else None
            if layout is not None and nc is None:
                nc = b - 5 if layout == _V5 else a - 4
        if layout is None:
            with_c = f" with C={nc} class names" if nc is not None else ""
            raise ModelError(
                f"{self._label}: output shape {_fmt_shape(shape)} is neither [1, N, 5+C] "
                f"nor [1, 4+C, N]{with_c}"
            )
        self.layout, self.num_classes = layout, nc

    def _fits(self, shape: tuple[int, ...]) -> bool:
        if len(shape) != 3 or shape[0] != 1 or self.num_classes is None:
            return False
        if self.layout == _V8:
            return shape[1] == self.num_classes + 4
        return shape[2] == self.num_classes + 5

    # ------------------------------------------------------------- pipeline

    def preprocess(
        self, image: np.ndarray, zoom: float | None = None
    ) -> tuple[np.ndarray, float, tuple[float, float]]:
        """RGB uint8 (H, W, 3) -> (1, 3, h, w) float tensor in [0, 1], letterbox scale, pad (px).

        ``zoom``: input px per image px (a window's); default, and with a fixed input at most,
        the scale that fits the model's input. A dynamic input is only as large as the resized
        image, padded to a multiple of ``INPUT_MULTIPLE``."""
        if image.ndim == 2:
            image = np.repeat(image[:, :, None], 3, axis=2)
        elif image.shape[2] == 4:
            image = image[:, :, :3]
        h, w = image.shape[:2]
        size, scale = self.input_hw, zoom
        if self.dynamic_input:
            scale = min(self.input_hw[0] / h, self.input_hw[1] / w) if zoom is None else zoom
            size = padded_size(h, w, scale, INPUT_MULTIPLE)
        padded, scale, pad = letterbox(np.ascontiguousarray(image), size, scale)
        tensor = padded.transpose(2, 0, 1)[None].astype(self._input_dtype)  # one contiguous copy
        tensor *= self._input_dtype(1.0 / 255.0)  # multiply: about half the cost of a division
        return tensor, scale, pad

    def infer(self, tensor: np.ndarray) -> np.ndarray:
        """Raw model output (one ``session.run``)."""
        return self.session.run([self.output_name], {self.input_name: tensor})[0]

    def postprocess(
        self,
        raw: np.ndarray,
        scale: float,
        pad: tuple[float, float],
        image_hw: tuple[int, int],
    ) -> Detections:
        """Decode a raw output into ``Detections`` in original image pixels (vectorised + NMS)."""
        if self.layout is None or not self._fits(raw.shape):
            self._resolve_layout(tuple(raw.shape))  # raises when the run-time shape fits no layout
        pred = np.asarray(raw[0], dtype=np.float32)
        if self.layout == _V8:
            # [4+C, N] as it comes: best score per column over contiguous rows, then the
            # class argmax only for the few columns above the threshold
            cls_scores = pred[4:]
            keep = np.flatnonzero(cls_scores.max(axis=0) > self.conf_threshold)
            kept = cls_scores[:, keep]
            cls = kept.argmax(axis=0)
            score = kept[cls, np.arange(len(keep))]
            boxes = pred[:4, keep].T
        else:
            cls_scores = pred[:, 5:] * pred[:, 4:5]
            cls = cls_scores.argmax(axis=1)
            score = np.take_along_axis(cls_scores, cls[:, None], axis=1)[:, 0]
            keep = score > self.conf_threshold
            boxes, score, cls = pred[keep, :4], score[keep], cls[keep]
        if self.class_map is not None:
            cls = self.class_map[cls]
            known = cls >= 0
            n_unknown = int(np.count_nonzero(~known))
            if n_unknown:
                self.dropped_unknown += n_unknown
                log.debug("%s: dropped %d detections of unmapped classes", self._label, n_unknown)
                boxes, score, cls = boxes[known], score[known], cls[known]
        if len(score) > MAX_NMS_CANDIDATES:
            top = np.argsort(-score, kind="stable")[:MAX_NMS_CANDIDATES]
            boxes, score, cls = boxes[top], score[top], cls[top]
        xy, half = boxes[:, :2].astype(np.float64), boxes[:, 2:4].astype(np.float64) / 2.0
        xyxy = np.concatenate([xy - half, xy + half], axis=1)
        idx = nms(xyxy, score, cls, self.iou_threshold, self.max_det, CONTAINMENT)
        xyxy = unletterbox_boxes(xyxy[idx], scale, pad)
        xyxy = clip_boxes(xyxy, image_hw[1], image_hw[0])
        return Detections(xyxy=xyxy, score=score[idx], class_id=cls[idx])

    def views(self, image: np.ndarray) -> list[tuple[np.ndarray, int, int, float | None]]:
        """What one ``detect`` runs the model on: the whole image, then each window's crop,
        each with its top-left corner in the image (px) and its zoom (None: fit the input)."""
        h, w = image.shape[:2]
        crops: list[tuple[np.ndarray, int, int, float | None]] = [(image, 0, 0, None)]
        for win in self.windows:
            for x0, y0, x1, y1 in window_pixels([win], w, h).tolist():
                crops.append((image[y0:y1, x0:x1], x0, y0, window_zoom(win)))
        return crops

    def detect(self, image: np.ndarray | None, truth: DetectorTruth | None = None) -> Detections:
        """Detections in ``image`` (RGB uint8 H x W x 3); ``truth`` is ignored."""
        if image is None:
            raise ValueError(f"{self.name}: needs an image (rendering is off?)")
        timing = {"preprocess": 0.0, "infer": 0.0, "postprocess": 0.0}
        found, windows_px, scales = [], [], []
        for crop, x0, y0, zoom in self.views(image):
            t0 = time.perf_counter()
            tensor, scale, pad = self.preprocess(crop, zoom)
            t1 = time.perf_counter()
            raw = self.infer(tensor)
            t2 = time.perf_counter()
            dets = self.postprocess(raw, scale, pad, crop.shape[:2])
            dets.xyxy += (x0, y0, x0, y0)
            found.append(dets)
            windows_px.append((x0, y0, x0 + crop.shape[1], y0 + crop.shape[0]))
            scales.append(scale)
            t3 = time.perf_counter()
            timing["preprocess"] += (t1 - t0) * 1e3
            timing["infer"] += (t2 - t1) * 1e3
            timing["postprocess"] += (t3 - t2) * 1e3
        if len(found) > 1:
            t0 = time.perf_counter()
            h, w = image.shape[:2]
            found[0] = merge_windows(found[0], found[1:], np.array(windows_px[1:]), w, h,
                                     self.iou_threshold, self.max_det, scales[1:], CONTAINMENT)
            timing["postprocess"] += (time.perf_counter() - t0) * 1e3
        self.last_timing_ms = {**timing, "views": float(len(found))}
        return found[0]

    def warmup(self, runs: int = 1) -> None:
        """Run the session on a grey input ``runs`` times (first-run allocations, TensorRT builds)."""
        h, w = self.input_hw
        tensor = np.full((1, 3, h, w), 114 / 255.0, dtype=self._input_dtype)
        for _ in range(runs):
            self.infer(tensor)


def _as_hw(size: int | tuple[int, int]) -> tuple[int, int]:
    if isinstance(size, int | np.integer):
        return int(size), int(size)
    h, w = size
    return int(h), int(w)
