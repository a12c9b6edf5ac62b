"""The ``Detector`` protocol and ``DetectorTruth``, what a simulator can hand a detector."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from lookahead.perception.detections import Detections


@dataclass
class DetectorTruth:
    """Ground truth for one frame, as a simulated detector may see it.

    Attributes:
        xyxy: (N, 4) visible 2D boxes, float pixels (NaN rows = not in view).
        class_id: (N,) class ids into ``perception.detections.CLASSES``.
        source_id: (N,) actor ids.
        range_m: (N,) distance to the object (m).
        visible_fraction: (N,) visible share of the object's pixels, in [0, 1].
        truncation: (N,) share of the object outside the image, in [0, 1].
        width: image width (px).
        height: image height (px).
    """

    width: int
    height: int
    xyxy: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    class_id: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    source_id: np.ndarray | None = None
    range_m: np.ndarray | None = None
    visible_fraction: np.ndarray | None = None
    truncation: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.xyxy = np.asarray(self.xyxy, dtype=np.float64).reshape(-1, 4)
        n = len(self.xyxy)
        self.class_id = np.asarray(self.class_id, dtype=np.int64).reshape(-1)
        self.source_id = _column(self.source_id, n, -1, np.int64)
        self.range_m = _column(self.range_m, n, 0.0, np.float64)
        self.visible_fraction = _column(self.visible_fraction, n, 1.0, np.float64)
        self.truncation = _column(self.truncation, n, 0.0, np.float64)
        lengths = {
            "class_id": len(self.class_id),
            "source_id": len(self.source_id),
            "range_m": len(self.range_m),
            "visible_fraction": len(self.visible_fraction),
            "truncation": len(self.truncation),
        }
        bad = {k: v for k, v in lengths.items() if v != n}
        if bad:
            raise ValueError(f"DetectorTruth arrays disagree in length: xyxy {n}, {bad}")

    def __len__(self) -> int:
        return len(self.xyxy)


def _column(values: np.ndarray | None, n: int, default: float, dtype: type) -> np.ndarray:
    if values is None:
        return np.full(n, default, dtype=dtype)
    return np.asarray(values, dtype=dtype).reshape(-1)


@runtime_checkable
class Detector(Protocol):
    """Anything that turns an RGB uint8 (H, W, 3) image into ``Detections``.

    Real detectors ignore ``truth``; simulated ones (``GtNoiseDetector``) need it
    and may be given ``image=None`` when rendering is off.
    """

    name: str

    def detect(self, image: np.ndarray | None, truth: DetectorTruth | None = None) -> Detections:
        """Detections in ``image`` pixels (xyxy float)."""
        ...
