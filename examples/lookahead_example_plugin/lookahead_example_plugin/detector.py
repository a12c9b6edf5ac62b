"""Two detector plug-ins: what a plug-in module looks like.

A detector plug-in is a factory: ``factory(**options)`` returns an object with ``name`` (optional)
and ``detect(image, truth=None) -> Detections``. ``image`` is the camera image, RGB uint8
(H, W, 3), or None when a run does not render; ``truth`` is what the simulator knows (None on real
video): a real detector ignores it. Boxes are xyxy image pixels, scores in [0, 1], class ids index
``lookahead.perception.detections.CLASSES``. lookahead checks each returned ``Detections`` and
turns an exception into a one-line error naming the plug-in.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lookahead.perception.detections import CLASS_ID, Detections

#: Vulnerable road users: the classes ``VruDetector`` keeps by default.
VRU = ("pedestrian", "cyclist", "motorcyclist", "tricycle", "animal")


class VruDetector:
    """Vulnerable road users from another detector: its detections of ``classes`` at or above
    ``min_score`` whose boxes are at least ``min_height`` px high."""

    name = "example-vru"

    def __init__(self, inner, classes: Sequence[str] = VRU, min_score: float = 0.3, min_height: float = 6.0):
        unknown = [c for c in classes if c not in CLASS_ID]
        if unknown:  # raised in the factory: lookahead reports it as one line naming the plug-in
            raise ValueError(f"unknown classes {unknown}; expected some of {sorted(CLASS_ID)}")
        if not 0.0 <= min_score <= 1.0:
            raise ValueError(f"min_score {min_score}: expected 0..1")
        self.inner = inner
        self.class_ids = np.array([CLASS_ID[c] for c in classes], dtype=np.int64)
        self.min_score = float(min_score)
        self.min_height = float(min_height)

    def detect(self, image: np.ndarray | None, truth=None) -> Detections:
        if image is None:
            raise ValueError("example-vru needs camera images: run with rendering on")
        dets = self.inner.detect(image)
        h = dets.xyxy[:, 3] - dets.xyxy[:, 1]
        keep = np.isin(dets.class_id, self.class_ids) & (dets.score >= self.min_score) & (h >= self.min_height)
        return dets[keep]


def make_vru_detector(
    classes: Sequence[str] = VRU, min_score: float = 0.3, min_height: float = 6.0, model: str | None = None,
) -> VruDetector:
    """The ``example-vru`` plug-in: ``VruDetector`` on lookahead's shipped ONNX detector (or ``model``)."""
    from lookahead.perception.config import DEFAULT_MODEL
    from lookahead.perception.detectors.onnx_detector import OnnxDetector
    from lookahead.perception.detectors.windows import DEFAULT_WINDOWS

    inner = OnnxDetector(model or DEFAULT_MODEL, conf_threshold=min(min_score, 0.25), windows=DEFAULT_WINDOWS)
    return VruDetector(inner, classes=classes, min_score=min_score, min_height=min_height)


def make_hog_detector(**options):
    """The ``example-hog`` plug-in: lookahead's HOG people detector with ``options`` (``HogConfig``)."""
    from lookahead.perception.detectors.hog_detector import HogDetector

    return HogDetector(**options)
