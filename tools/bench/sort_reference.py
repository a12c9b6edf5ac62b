"""SORT (Bewley et al., ICIP 2016) -- port of the reference ``sort.py``, baseline only.

Same model and parameters as the reference implementation (github.com/abewley/sort):
7-state Kalman filter ``[cx, cy, s, r, vcx, vcy, vs]`` (s = area, r = aspect
ratio) with the reference's F/H/P/Q/R, IoU cost solved with the Hungarian
algorithm, ``max_age=1, min_hits=3, iou_threshold=0.3``. Detection scores are
ignored, as in the reference. Deviations, none of which change the output:
track ids are counted per ``Sort`` instance (the reference uses a class-wide
counter) and the assignment always uses scipy's ``linear_sum_assignment``.
"""

from __future__ import annotations

import numpy as np
from filterpy.kalman import KalmanFilter
from scipy.optimize import linear_sum_assignment

from lookahead.perception.geometry import iou_matrix


def bbox_to_z(bbox: np.ndarray) -> np.ndarray:
    """xyxy box -> (4, 1) measurement ``[cx, cy, s, r]``."""
    w, h = bbox[2] - bbox[0], bbox[3] - bbox[1]
    return np.array([bbox[0] + w / 2.0, bbox[1] + h / 2.0, w * h, w / float(h)]).reshape(4, 1)


def x_to_bbox(x: np.ndarray) -> np.ndarray:
    """State ``[cx, cy, s, r, ...]`` -> (4,) xyxy box (NaN if s*r < 0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.sqrt(x[2, 0] * x[3, 0])
        h = x[2, 0] / w
    return np.array([x[0, 0] - w / 2.0, x[1, 0] - h / 2.0, x[0, 0] + w / 2.0, x[1, 0] + h / 2.0])


class KalmanBoxTracker:
    """One SORT track: constant-velocity Kalman filter on ``[cx, cy, s, r]``."""

    def __init__(self, bbox: np.ndarray, track_id: int) -> None:
        kf = KalmanFilter(dim_x=7, dim_z=4)
        kf.F = np.eye(7)
        kf.F[0, 4] = kf.F[1, 5] = kf.F[2, 6] = 1.0
        kf.H = np.eye(4, 7)
        kf.R[2:, 2:] *= 10.0
        kf.P[4:, 4:] *= 1000.0  # unobservable initial velocities
        kf.P *= 10.0
        kf.Q[-1, -1] *= 0.01
        kf.Q[4:, 4:] *= 0.01
        kf.x[:4] = bbox_to_z(bbox)
        self.kf = kf
        self.id = track_id
        self.time_since_update = 0
        self.hits = 0
        self.hit_streak = 0
        self.age = 0

    def update(self, bbox: np.ndarray) -> None:
        self.time_since_update = 0
        self.hits += 1
        self.hit_streak += 1
        self.kf.update(bbox_to_z(bbox))

    def predict(self) -> np.ndarray:
        if self.kf.x[6, 0] + self.kf.x[2, 0] <= 0:
            self.kf.x[6, 0] = 0.0
        self.kf.predict()
        self.age += 1
        if self.time_since_update > 0:
            self.hit_streak = 0
        self.time_since_update += 1
        return x_to_bbox(self.kf.x)

    def get_state(self) -> np.ndarray:
        return x_to_bbox(self.kf.x)


def associate(
    dets: np.ndarray, trks: np.ndarray, iou_threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Match xyxy ``dets`` (N, 4) to predicted ``trks`` (M, 4).

    Returns (K, 2) [det, trk] matches, unmatched det indices, unmatched trk indices.
    """
    if len(trks) == 0 or len(dets) == 0:
        return np.empty((0, 2), dtype=int), np.arange(len(dets)), np.arange(len(trks))
    iou = iou_matrix(dets, trks)
    above = iou > iou_threshold
    if above.sum(1).max() == 1 and above.sum(0).max() == 1:
        matched = np.stack(np.nonzero(above), axis=1)
    else:
        matched = np.stack(linear_sum_assignment(-iou), axis=1)
    good = iou[matched[:, 0], matched[:, 1]] >= iou_threshold
    # Reference order: never-assigned first, then those rejected for low IoU.
    unmatched_dets = np.concatenate(
        [np.setdiff1d(np.arange(len(dets)), matched[:, 0]), matched[~good, 0]]
    )
    unmatched_trks = np.concatenate(
        [np.setdiff1d(np.arange(len(trks)), matched[:, 1]), matched[~good, 1]]
    )
    return matched[good], unmatched_dets.astype(int), unmatched_trks.astype(int)


class Sort:
    """The SORT tracker. Call ``update`` once per frame, also for empty frames."""

    def __init__(self, max_age: int = 1, min_hits: int = 3, iou_threshold: float = 0.3) -> None:
        self.max_age = max_age
        self.min_hits = min_hits
        self.iou_threshold = iou_threshold
        self.trackers: list[KalmanBoxTracker] = []
        self.frame_count = 0
        self._next_id = 0

    def update(self, dets: np.ndarray | None = None) -> np.ndarray:
        """Track one frame.

        Args:
            dets: (N, 4+) array ``[x1, y1, x2, y2, (score, ...)]`` in px.

        Returns:
            (K, 5) array ``[x1, y1, x2, y2, track_id]``, track ids from 1.
        """
        dets = np.empty((0, 5)) if dets is None else np.asarray(dets, dtype=np.float64)
        self.frame_count += 1
        preds = np.array([t.predict() for t in self.trackers]).reshape(-1, 4)
        ok = np.all(np.isfinite(preds), axis=1)
        self.trackers = [t for t, k in zip(self.trackers, ok, strict=True) if k]
        preds = preds[ok]

        matches, unmatched_dets, _ = associate(dets[:, :4], preds, self.iou_threshold)
        for d, t in matches:
            self.trackers[t].update(dets[d, :4])
        for d in unmatched_dets:
            self.trackers.append(KalmanBoxTracker(dets[d, :4], self._next_id))
            self._next_id += 1

        out = []
        for trk in reversed(self.trackers):
            if trk.time_since_update < 1 and (
                trk.hit_streak >= self.min_hits or self.frame_count <= self.min_hits
            ):
                out.append(np.append(trk.get_state(), trk.id + 1))
        self.trackers = [t for t in self.trackers if t.time_since_update <= self.max_age]
        return np.array(out).reshape(-1, 5)
