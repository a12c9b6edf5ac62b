"""``Detections``: a struct of arrays for 2D detections in one image.

Modelled on supervision's ``Detections``: parallel numpy arrays, boolean-mask
or index filtering with ``dets[mask]``, and ``len(dets)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Detection classes, in class-id order (docs/architecture.md, "Classes").
CLASSES: tuple[str, ...] = (
    "pedestrian",
    "cyclist",
    "motorcyclist",
    "tricycle",
    "car",
    "truck",
    "bus",
    "animal",
    "obstacle",  # static: cone, barrier, debris, box, riderless bicycle
)
CLASS_ID: dict[str, int] = {name: i for i, name in enumerate(CLASSES)}


@dataclass
class Detections:
    """N detections: ``xyxy`` (N, 4) float pixels, ``score`` (N,), ``class_id`` (N,) int.

    ``source_id`` (N,) optionally carries the ground-truth actor id a simulated
    detection came from (-1 for false positives and real detectors).
    """

    xyxy: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    score: np.ndarray = field(default_factory=lambda: np.zeros(0))
    class_id: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    source_id: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.xyxy = np.asarray(self.xyxy, dtype=np.float64).reshape(-1, 4)
        n = len(self.xyxy)
        self.score = np.asarray(self.score, dtype=np.float64).reshape(-1)
        self.class_id = np.asarray(self.class_id, dtype=np.int64).reshape(-1)
        if self.source_id is None:
            self.source_id = np.full(n, -1, dtype=np.int64)
        self.source_id = np.asarray(self.source_id, dtype=np.int64).reshape(-1)
        if not (len(self.score) == len(self.class_id) == len(self.source_id) == n):
            raise ValueError(
                f"Detections arrays disagree in length: xyxy {n}, score {len(self.score)}, "
                f"class_id {len(self.class_id)}, source_id {len(self.source_id)}"
            )

    @classmethod
    def empty(cls) -> Detections:
        return cls()

    def __len__(self) -> int:
        return len(self.xyxy)

    def __getitem__(self, index: np.ndarray | slice | int) -> Detections:
        if isinstance(index, int | np.integer):
            index = np.array([index])
        return Detections(
            xyxy=self.xyxy[index],
            score=self.score[index],
            class_id=self.class_id[index],
            source_id=self.source_id[index],
        )

    def finite(self) -> np.ndarray:
        """Mask of rows with finite coordinates, positive width/height and a finite score."""
        b = self.xyxy
        ok = np.all(np.isfinite(b), axis=1) & np.isfinite(self.score)
        with np.errstate(invalid="ignore"):
            ok &= (b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1])
        return ok

    @property
    def class_names(self) -> list[str]:
        return [CLASSES[i] if 0 <= i < len(CLASSES) else str(i) for i in self.class_id]

    def to_dict(self) -> dict:
        return {
            "xyxy": np.round(self.xyxy, 2).tolist(),
            "score": np.round(self.score, 4).tolist(),
            "class_id": self.class_id.tolist(),
            "source_id": self.source_id.tolist(),
        }
