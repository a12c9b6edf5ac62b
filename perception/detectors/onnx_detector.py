"""``OnnxDetector``: run any YOLO-family ONNX detector with onnxruntime.

Output layouts (``layout=`` argument, else the model's metadata, else the output shape and the
number of class names; see "Choosing the layout" below):

- ``yolov5`` ``[1, N, 5+C]``: cx, cy, w, h, objectness, C class scores;
  score = objectness * best class score. YOLOv7 and YOLOX exported with decoding in the graph
  (``decode_in_inference=True``) read the same way.
- ``yolov8`` ``[1, 4+C, N]`` (YOLOv8/9/11/12): cx, cy, w, h, C class scores; score = best class score.
- ``yolox`` ``[1, N, 5+C]``, raw (YOLOX's ``tools/export_onnx.py`` without ``--decode_in_inference``,
  its default): one row per grid cell of the strides 8, 16, 32 (p6 models: and 64), cell by cell
  in row-major order, stride by stride, so N = sum over strides of (H/s)*(W/s) for an H x W input;
  x, y are offsets in cells and w, h logs of cells, decoded as YOLOX's ``demo_postprocess`` does:
  cx, cy = (offset + cell) * s, w, h = exp(log) * s; objectness and class scores are already
  sigmoids; score = objectness * best class score.
- ``end2end`` ``[1, N, 6]`` (NMS-free: YOLOv10, Ultralytics ``end2end`` / ``nms=True`` exports,
  TensorRT-style exports): rows x1, y1, x2, y2, score, class id, already deduplicated, so no NMS
  (the score threshold and ``max_det`` still apply; a class id outside the model's classes is
  dropped).

Choosing the layout (``layout="auto"``, the default):

1. The model's metadata, when it names one: a ``layout`` or ``model_type`` value beginning with
   ``yolov5``/``v5``/``yolov7`` (yolov5), ``yolov8``/``v8``/``yolov9``/``yolo11``/``yolo12``
   (yolov8), ``yolox`` (yolox; yolov5 when a ``decode_in_inference`` value is true), or
   ``end2end``/``e2e``/``nms_free``/``yolov10`` (end2end); else Ultralytics' ``end2end: True`` or
   ``args`` holding ``nms: True`` (end2end); else a producer name containing ``yolox`` (yolox).
   A named layout the output does not fit is ignored (logged) and the shape decides; so a model
   named yolox is read raw only when N is its grid count for the input size.
2. The shape: ``[1, N, 6]`` with a number of class names other than 1 is end2end; ``[1, N, 5+C]``
   is yolov5; ``[1, 4+C, N]`` is yolov8 (both fitting: the shorter axis holds the features).
   ``[1, N, 6]`` with one class name or none is read as yolov5 with one class (logged): pass
   ``layout="end2end"`` (or names) for an NMS-free model. A raw YOLOX output has the shape of a
   yolov5 one, so it is never guessed from the shape: it needs metadata or ``layout="yolox"``.

An explicit ``layout=`` the output does not fit is a ``ModelError``, as is an output no layout
fits; both one line naming the shape found and the layouts expected. YOLOX's reference
preprocessing (BGR, 0..255, padded at the bottom right) differs from the one here (RGB, 0..1,
centred letterbox): the decoding does not depend on it, but a model trained on YOLOX's input
needs its input converted, which is not done here.

Loaded sessions are shared within a process (``load_session``): detectors (and appearance
embedders) built from the same model file with the same session options use one
``onnxruntime.InferenceSession``, so a sweep worker that runs many variants loads each model
once. The key is the resolved path, the file's identity (device, inode, size, mtime and ctime
in ns; plus its SHA-256 while the file is younger than ``RACY_S``, when a rewrite may leave its
times unchanged, so a file that has just aged past it is loaded once more) and the options
(providers, thread counts): a rewritten file gets a new session. At most
``SESSION_CACHE_SIZE`` sessions are kept, least recently used dropped first. Only the session
is shared (onnxruntime runs one session from several threads, and it keeps no per-call
state); each detector keeps its own per-run state (thresholds, grids, counters, timings).

Boxes are in letterboxed input pixels; they are mapped back to the original
image, clipped, and (except end2end) filtered with per-class NMS. With zoom ``windows``
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
import hashlib
import json
import logging
import threading
import time
from collections import OrderedDict
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
from lookahead.perception.score_calibration import ScoreCalibration

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
    "traffic cone": "obstacle",
    "cone": "obstacle",
    "barrier": "obstacle",
    "road barrier": "obstacle",
    "debris": "obstacle",
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

_V5, _V8, _YOLOX, _E2E = "v5", "v8", "yolox", "end2end"

#: ``layout=`` values (``DetectorSpec.layout``) -> the ``layout`` attribute they set; auto: None.
LAYOUTS: dict[str, str | None] = {"auto": None, "yolov5": _V5, "yolov8": _V8, "yolox": _YOLOX, "end2end": _E2E}

#: The strides of YOLOX's output grids, tried in turn: the usual three, then p6 models' four.
YOLOX_STRIDES = ((8, 16, 32), (8, 16, 32, 64))

#: Metadata keys that may name the layout or model family, and the values' prefixes (lower-case,
#: without ``-``, ``_`` or spaces) naming a layout; longest prefix first.
LAYOUT_KEYS = ("layout", "model_type")
_FAMILY_PREFIXES = sorted(
    {
        "yolov5": _V5, "v5": _V5, "yolov7": _V5,
        "yolov8": _V8, "v8": _V8, "yolov9": _V8, "yolo11": _V8, "yolov11": _V8, "yolo12": _V8, "yolov12": _V8,
        "yolox": _YOLOX,
        "end2end": _E2E, "e2e": _E2E, "nmsfree": _E2E, "yolov10": _E2E,
    }.items(),
    key=lambda kv: -len(kv[0]),
)

#: Largest raw YOLOX log-width/height decoded (e^20 cells is far beyond any image; avoids inf).
_YOLOX_MAX_LOG_WH = 20.0

#: Raw YOLOX grids cached per (input size, N); a dynamic input varies with the frame and windows.
_GRID_CACHE_SIZE = 8


class ModelError(ValueError):
    """A model file that is missing, unreadable or of an unsupported shape; one-line message."""


def _one_line(text: object, limit: int = 240) -> str:
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


# ------------------------------------------------------------------ shared sessions

#: Loaded sessions kept per process by ``load_session`` (least recently used dropped first).
SESSION_CACHE_SIZE = 4

#: A model file changed less than this long (s) ago may be rewritten again within the file
#: system's timestamp granularity with its size and times unchanged: it is identified by its
#: SHA-256 as well (git's "racily clean" rule).
RACY_S = 2.0

_sessions: OrderedDict[tuple, Any] = OrderedDict()
_sessions_lock = threading.Lock()


def file_identity(path: Path) -> tuple:
    """What tells one version of the file ``path`` from another: device, inode, size, mtime and
    ctime (ns), and its SHA-256 while it is younger than ``RACY_S``; ``OSError`` when unreadable."""
    st = path.stat()
    ident: tuple = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    if time.time_ns() - max(st.st_mtime_ns, st.st_ctime_ns) < RACY_S * 1e9:
        ident += (hashlib.sha256(path.read_bytes()).hexdigest(),)
    return ident


def load_session(
    path: str | Path, providers: Sequence[str], intra_op_threads: int = 0, inter_op_threads: int = 0,
    label: str | None = None,
) -> Any:
    """The ``onnxruntime.InferenceSession`` of the model file ``path`` with these options, loaded
    once per process and file version (see the module docstring, "Loaded sessions").

    ``providers``: in order of preference; ``*_threads``: onnxruntime's thread counts (0: its
    default). ``ModelError`` (one line, starting with ``label``, default the path) for a missing
    or unloadable file; failures are not cached."""
    import onnxruntime as ort  # heavy; imported only when a model is loaded

    label = str(path) if label is None else label
    try:
        resolved = Path(path).resolve(strict=True)
        ident = file_identity(resolved)
    except OSError as e:
        raise ModelError(f"{label}: cannot read model file ({_one_line(e)})") from None
    key = (str(resolved), ident, tuple(providers), int(intra_op_threads), int(inter_op_threads))
    with _sessions_lock:
        session = _sessions.get(key)
        if session is not None:
            _sessions.move_to_end(key)
            return session
    options = ort.SessionOptions()
    options.log_severity_level = 3
    options.intra_op_num_threads = int(intra_op_threads)
    options.inter_op_num_threads = int(inter_op_threads)
    # idle pool threads wait rather than spin: on two cores a spinning pool takes the CPU the
    # renderer and the tracker need (measured: the rendered loop at 9.2 frames/s spinning, 12.4 not)
    options.add_session_config_entry("session.intra_op.allow_spinning", "0")
    options.add_session_config_entry("session.inter_op.allow_spinning", "0")
    try:
        session = ort.InferenceSession(str(resolved), sess_options=options, providers=list(providers))
    except Exception as e:  # onnxruntime raises its own exception types
        raise ModelError(f"{label}: not a loadable ONNX model ({_one_line(e)})") from e
    with _sessions_lock:  # a thread that loaded the same meanwhile: share its session
        session = _sessions.setdefault(key, session)
        _sessions.move_to_end(key)
        while len(_sessions) > SESSION_CACHE_SIZE:
            _sessions.popitem(last=False)
    log.debug("%s: loaded session (%d cached)", label, len(_sessions))
    return session


def clear_sessions() -> None:
    """Forget every shared session (sessions in use stay alive with their users)."""
    with _sessions_lock:
        _sessions.clear()


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


def _truthy(value: str | None) -> bool:
    return value is not None and value.strip().lower() in ("true", "1", "yes")


def _family_layout(value: str) -> str | None:
    """The layout a metadata value names (``"YOLOX-s"`` -> yolox), or None."""
    key = "".join(value.lower().split()).replace("-", "").replace("_", "")
    return next((layout for prefix, layout in _FAMILY_PREFIXES if key.startswith(prefix)), None)


def yolox_strides(input_hw: tuple[int, int], n: int | None) -> tuple[int, ...] | None:
    """The strides (``YOLOX_STRIDES``) whose grids over an ``input_hw`` input have ``n`` cells in
    all, as YOLOX's ``demo_postprocess`` counts them (``H // s`` x ``W // s`` per stride); None
    when none do."""
    h, w = input_hw
    for strides in YOLOX_STRIDES:
        if n == sum((h // s) * (w // s) for s in strides):
            return strides
    return None


def yolox_grid(input_hw: tuple[int, int], strides: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Each row's cell (N, 2: x, y) and stride (N, 1) of a raw YOLOX output, float32: stride by
    stride, cells row-major (x fastest), as YOLOX's ``demo_postprocess`` lays them out."""
    h, w = input_hw
    cells, sizes = [], []
    for s in strides:
        yv, xv = np.mgrid[: h // s, : w // s]
        cells.append(np.stack([xv.ravel(), yv.ravel()], axis=1))
        sizes.append(np.full(xv.size, s))
    return (
        np.concatenate(cells).astype(np.float32),
        np.concatenate(sizes).astype(np.float32)[:, None],
    )


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
        layout: the output layout (``LAYOUTS``): ``"auto"`` (metadata, else shape; see the module
            docstring), ``"yolov5"``, ``"yolov8"``, ``"yolox"`` (raw, undecoded) or ``"end2end"``.
        calibration: the model's score calibration (``perception.score_calibration``), or None:
            every score returned is calibrated, and ``conf_threshold`` is on the calibrated scale.
        threads: onnxruntime's intra-op threads (0: its default, one per core).

    Attributes:
        session: the ``onnxruntime.InferenceSession`` (time ``session.run`` alone via ``infer``),
            shared with other detectors of the same model file and providers (``load_session``).
        names: model class names (None when unknown).
        class_map: (C,) model class index -> our class id (-1 unknown), or None for raw indices.
        layout: ``"v5"``, ``"v8"``, ``"yolox"`` or ``"end2end"`` once known (static output
            shape: at load).
        num_classes: C (None when unknown: an end2end model without names).
        dropped_unknown: detections dropped so far for an unknown class name (or, end2end, a
            class id outside the model's classes).
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
        layout: str = "auto",
        calibration: ScoreCalibration | None = None,
        threads: int = 0,
    ) -> None:
        import onnxruntime as ort  # heavy; imported only when a model is loaded

        self.model_path = Path(model_path)
        self._label = str(model_path)
        self.name = f"onnx:{self.model_path.stem}"
        self.conf_threshold = float(conf_threshold)
        self.iou_threshold = float(iou_threshold)
        self.calibration = calibration
        self.max_det = int(max_det)
        self.dropped_unknown = 0
        self.last_timing_ms: dict[str, float] = {}
        self._grids: dict[tuple[tuple[int, int], int], tuple[np.ndarray, np.ndarray]] = {}
        if layout not in LAYOUTS:
            raise ModelError(f"{self._label}: layout {layout!r} is not one of {', '.join(LAYOUTS)}")
        try:
            self.windows = check_windows(windows)
        except ValueError as e:
            raise ModelError(f"{self._label}: {e}") from None

        if not self.model_path.is_file():
            raise ModelError(f"{self._label}: model file not found")
        if providers is None:
            available = set(ort.get_available_providers())
            providers = [p for p in PREFERRED_PROVIDERS if p in available]
        self.session = load_session(self.model_path, providers, intra_op_threads=threads, label=self._label)
        log.info("%s: providers %s", self._label, self.session.get_providers())

        self._read_input(input_size)
        out = self.session.get_outputs()[0]
        self.output_name = out.name
        self.names = self._resolve_names(names) or None
        self.class_map = self._build_class_map(self.names)
        self.layout: str | None = None
        self.num_classes: int | None = len(self.names) if self.names is not None else None
        # (layout, where it was named, whether binding): the argument binds, metadata only hints
        wanted = LAYOUTS[layout]
        self._layout_hint = (wanted, f"layout={layout!r}", True) if wanted else self._metadata_layout()
        shape = tuple(out.shape)
        if len(shape) != 3 or any(_static(d) is not None for d in shape[1:]):
            # else: fully dynamic, resolved on the first output; a dynamic input's size (hence a
            # raw YOLOX grid) is known only then too
            self._resolve_layout(shape, None if self.dynamic_input else self.input_hw)

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

    def _metadata_layout(self) -> tuple[str, str, bool] | None:
        """The layout the model's metadata names (module docstring, rule 1), where, and False
        (a hint, not binding); None when it names none."""
        for key in LAYOUT_KEYS:
            value = self._metadata(key)
            if not value:
                continue
            layout = _family_layout(value)
            if layout is None:
                log.info("%s: metadata %s=%r names no layout we know", self._label, key, value[:80])
                continue
            if layout == _YOLOX and _truthy(self._metadata("decode_in_inference")):
                layout = _V5  # decoded in the graph: cx, cy, w, h in input pixels
            return layout, f"metadata {key}={value[:80]!r}", False
        if _truthy(self._metadata("end2end")):
            return _E2E, "metadata end2end=True", False
        args = self._metadata("args")
        if args:
            try:
                parsed = ast.literal_eval(args)
            except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
                parsed = None
            if isinstance(parsed, Mapping) and parsed.get("nms") is True:
                return _E2E, "metadata args nms=True", False
        producer = self.session.get_modelmeta().producer_name or ""
        if "yolox" in producer.lower():
            return _YOLOX, f"producer {producer[:80]!r}", False
        return None

    @staticmethod
    def _shape_fits(
        layout: str, a: int | None, b: int | None, nc: int | None, input_hw: tuple[int, int] | None
    ) -> bool:
        """Whether a ``[1, a, b]`` output (None: dynamic) fits ``layout`` with ``nc`` classes
        (None: unknown); a raw YOLOX N is checked only when it and the input size are known."""
        if layout == _V8:
            return a is not None and (a == nc + 4 if nc is not None else a >= 5)
        if layout == _E2E:
            return b == 6
        v5 = b is not None and (b == nc + 5 if nc is not None else b >= 6)
        if layout == _YOLOX and v5 and a is not None and input_hw is not None:
            return yolox_strides(input_hw, a) is not None
        return v5

    def _expected(self, layout: str, input_hw: tuple[int, int] | None) -> str:
        if layout == _YOLOX and input_hw is not None:
            h, w = input_hw
            counts = " or ".join(
                f"{sum((h // s) * (w // s) for s in st)} (strides {', '.join(map(str, st))})"
                for st in YOLOX_STRIDES
            )
            return f"[1, N, 5+C] with N = {counts} grid cells for a {h}x{w} input"
        return {_V8: "[1, 4+C, N]", _E2E: "[1, N, 6]"}.get(layout, "[1, N, 5+C]")

    def _resolve_layout(self, shape: tuple[Any, ...], input_hw: tuple[int, int] | None = None) -> None:
        """Set ``layout`` and ``num_classes`` from an output shape (and, for a raw YOLOX grid, the
        input size: None when not known yet), or raise ``ModelError``."""
        nc = len(self.names) if self.names is not None else None
        dims = [_static(d) for d in shape]
        s, with_c = _fmt_shape(shape), f" with C={nc} class names" if nc is not None else ""
        ok = len(shape) == 3 and dims[0] in (1, None)
        a, b = (dims[1], dims[2]) if ok else (None, None)
        layout: str | None = None
        if self._layout_hint is not None:
            wanted, where, binding = self._layout_hint
            if ok and self._shape_fits(wanted, a, b, nc, input_hw):
                layout = wanted
            elif binding:
                raise ModelError(
                    f"{self._label}: output shape {s} does not fit {where}: expected "
                    f"{self._expected(wanted, input_hw)}{with_c}"
                )
            else:
                log.warning(
                    "%s: output shape %s does not fit %s (%s); choosing the layout by the shape",
                    self._label, s, where, self._expected(wanted, input_hw),
                )
        if layout is None and ok:
            v5 = self._shape_fits(_V5, a, b, nc, input_hw)
            v8 = self._shape_fits(_V8, a, b, nc, input_hw)
            e2e = b == 6 and nc is not None and nc != 1  # (then 5+C != 6: not v5)
            rows = v5 or e2e  # the [1, N, features] layouts
            if rows and v8 and nc is None:  # the feature axis is the short one
                rows, v8 = b < a, a < b
            if rows and v8:
                log.warning(
                    "%s: output %s fits both [1, N, features] and [1, 4+C, N]; assuming [1, 4+C, N]",
                    self._label, s,
                )
                rows = False
            layout = (_E2E if e2e else _V5) if rows else _V8 if v8 else None
            if layout == _V5 and b == 6:
                log.warning(
                    "%s: output %s read as [1, N, 5+C] with one class; pass layout='end2end' if its "
                    "rows are x1, y1, x2, y2, score, class id",
                    self._label, s,
                )
        if layout is None:
            raise ModelError(
                f"{self._label}: output shape {s} is neither [1, N, 5+C] nor [1, 4+C, N] nor "
                f"[1, N, 6]{with_c} (layouts yolov5 or yolox, yolov8, end2end)"
            )
        if nc is None and layout != _E2E:
            nc = a - 4 if layout == _V8 else b - 5
        self.layout, self.num_classes = layout, nc

    def _fits(self, shape: tuple[int, ...], input_hw: tuple[int, int]) -> bool:
        """Whether a run-time output shape fits the layout already chosen."""
        if self.layout is None or len(shape) != 3 or shape[0] != 1:
            return False
        if self.layout == _E2E:
            return shape[2] == 6
        if self.num_classes is None:
            return False
        if self.layout == _V8:
            return shape[1] == self.num_classes + 4
        if shape[2] != self.num_classes + 5:
            return False
        return self.layout == _V5 or yolox_strides(input_hw, shape[1]) is not None

    def _yolox_grid(self, input_hw: tuple[int, int], n: int) -> tuple[np.ndarray, np.ndarray]:
        """``yolox_grid`` for this input size and N (which ``_fits`` checked), cached."""
        key = (input_hw, n)
        grid = self._grids.get(key)
        if grid is None:
            strides = yolox_strides(input_hw, n)
            assert strides is not None  # checked by _fits / _resolve_layout
            if len(self._grids) >= _GRID_CACHE_SIZE:
                self._grids.clear()
            grid = self._grids[key] = yolox_grid(input_hw, strides)
        return grid

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
        input_hw: tuple[int, int] | None = None,
    ) -> Detections:
        """Decode a raw output into ``Detections`` in original image pixels (vectorised + NMS).

        ``input_hw``: the size (px) of the input tensor ``raw`` came from, which places a raw
        YOLOX output's grid; default the model's input size (a fixed input's)."""
        hw = self.input_hw if input_hw is None else (int(input_hw[0]), int(input_hw[1]))
        if not self._fits(raw.shape, hw):
            self._resolve_layout(tuple(raw.shape), hw)  # raises when the run-time shape fits no layout
        pred = np.asarray(raw[0], dtype=np.float32)
        conf = self._raw_conf()
        if self.layout == _V8:
            # [4+C, N] as it comes: best score per column over contiguous rows, then the
            # class argmax only for the few columns above the threshold
            cls_scores = pred[4:]
            keep = np.flatnonzero(cls_scores.max(axis=0) > conf)
            kept = cls_scores[:, keep]
            cls = kept.argmax(axis=0)
            score = kept[cls, np.arange(len(keep))]
            xyxy = _xyxy(pred[:4, keep].T)
        elif self.layout == _E2E:
            # x1, y1, x2, y2, score, class id: already one box per object
            keep = np.flatnonzero(pred[:, 4] > conf)
            score, cls_f = pred[keep, 4], pred[keep, 5]
            top = self.num_classes if self.num_classes is not None else np.iinfo(np.int32).max
            valid = (cls_f > -0.5) & (cls_f < top - 0.5)  # NaN: False
            n_invalid = int(np.count_nonzero(~valid))
            if n_invalid:
                self.dropped_unknown += n_invalid
                log.debug("%s: dropped %d detections of class ids out of range", self._label, n_invalid)
            keep, score = keep[valid], score[valid]
            cls = np.rint(cls_f[valid]).astype(np.int64)
            xyxy = pred[keep, :4].astype(np.float64)
        else:
            cls_scores = pred[:, 5:] * pred[:, 4:5]
            cls = cls_scores.argmax(axis=1)
            score = np.take_along_axis(cls_scores, cls[:, None], axis=1)[:, 0]
            keep = np.flatnonzero(score > conf)
            score, cls, boxes = score[keep], cls[keep], pred[keep, :4]
            if self.layout == _YOLOX:  # decode only the rows kept: offsets and logs in cells
                cells, stride = self._yolox_grid(hw, pred.shape[0])
                cells, stride = cells[keep], stride[keep]
                boxes = np.concatenate(
                    [(boxes[:, :2] + cells) * stride,
                     np.exp(np.minimum(boxes[:, 2:4], _YOLOX_MAX_LOG_WH)) * stride],
                    axis=1,
                )
            xyxy = _xyxy(boxes)
        if self.class_map is not None:
            cls = self.class_map[cls]
            known = cls >= 0
            n_unknown = int(np.count_nonzero(~known))
            if n_unknown:
                self.dropped_unknown += n_unknown
                log.debug("%s: dropped %d detections of unmapped classes", self._label, n_unknown)
                xyxy, score, cls = xyxy[known], score[known], cls[known]
        if self.layout == _E2E:  # NMS-free: the best max_det, highest score first
            idx = np.argsort(-score, kind="stable")[: self.max_det]
        else:
            if len(score) > MAX_NMS_CANDIDATES:
                top = np.argsort(-score, kind="stable")[:MAX_NMS_CANDIDATES]
                xyxy, score, cls = xyxy[top], score[top], cls[top]
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
            dets = self.postprocess(raw, scale, pad, crop.shape[:2], tensor.shape[2:])
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
        if self.calibration is not None:
            found[0].score = self.calibration.apply(found[0].score)
        return found[0]

    def _raw_conf(self) -> float:
        """``conf_threshold`` on the model's own score scale (the calibration inverted)."""
        if self.calibration is None:
            return self.conf_threshold
        return float(self.calibration.invert(self.conf_threshold))

    def warmup(self, runs: int = 1) -> None:
        """Run the session on a grey input ``runs`` times (first-run allocations, TensorRT builds)."""
        h, w = self.input_hw
        tensor = np.full((1, 3, h, w), 114 / 255.0, dtype=self._input_dtype)
        for _ in range(runs):
            self.infer(tensor)


def _xyxy(cxcywh: np.ndarray) -> np.ndarray:
    """(N, 4) cx, cy, w, h -> x0, y0, x1, y1 (float64)."""
    xy, half = cxcywh[:, :2].astype(np.float64), cxcywh[:, 2:4].astype(np.float64) / 2.0
    return np.concatenate([xy - half, xy + half], axis=1)


def _as_hw(size: int | tuple[int, int]) -> tuple[int, int]:
    if isinstance(size, int | np.integer):
        return int(size), int(size)
    h, w = size
    return int(h), int(w)
