"""Multi-object tracker: Kalman boxes + ByteTrack two-stage association.

Pipeline per frame (``Tracker.update``):

1. Drop invalid detections (non-finite numbers, width/height <= 0, coordinates
   beyond ``max_abs_coord``) and count them in ``Tracker.dropped_detections``.
2. Predict every track one frame ahead with its Kalman filter.
3. Stage 1: high-score detections (``score >= high_score``) against *all*
   tracks (tentative, confirmed, lost); cost ``1 - IoU`` gated at ``match_iou``,
   optionally mixed with the cosine distance of appearance features.
4. Stage 2: low-score detections (``low_score <= score < high_score``) against
   the confirmed tracks left over (IoU only, gated at ``second_match_iou``).
   Low-score boxes are often partly occluded objects; they keep tracks alive
   but never start one, and lost tracks are not revived by them (ByteTrack).
5. Unmatched high detections with ``score >= new_track_score`` start tentative
   tracks.

Lifecycle: tentative --(``min_hits`` hits)--> confirmed --(miss)--> lost
--(match)--> confirmed; a lost track keeps predicting and is removed after
``max_lost_s`` (at least one frame) without a match, a tentative one after
more than ``tentative_max_lost_frames`` misses. Track ids (1, 2, ...) are
assigned on confirmation, so they are contiguous.

Defaults, and why:

* ``min_hits`` 2: a track is confirmed on its second match, as ByteTrack
  activates a track on the frame after its birth. A random false positive
  almost never repeats at the same place, and at 10 fps a third hit costs
  every object another 0.1 s of being unreported.
* ``new_track_score`` 0.5 = ``high_score``: any high-score detection left
  unmatched starts a (tentative) track. Small, far objects score just above
  0.5 (the ``gt`` detector's score model; real detectors behave alike), and
  a 0.6 bar left objects at 40-50 m untracked for a second or more; the
  second hit still has to confirm them.
* ``output_lost`` with ``output_lost_s`` 0.2: a confirmed track that misses a
  detection is still reported, at its prediction (``state`` LOST,
  ``det_index`` -1), for up to 0.2 s -- two frames at 10 fps, enough to
  bridge the isolated misses of a detector (5 % each) without inventing
  objects: a coasting box that drifts off its object (or off the image) is
  scored as a false positive. ADAS trackers coast confirmed tracks through
  short dropouts; downstream (intent, alerts) sees the state. Off, only
  tracks matched this frame are output (MOTChallenge-style evaluation does
  that, ``tools.mot_eval``).

Appearance (optional): with ``reid_weight > 0`` and a ``features`` array, the
stage-1 cost is ``(1 - w) (1 - IoU) + w * cosine_distance`` against each
track's moving-average feature, and a *lost* track may also match a detection
outside the IoU gate when the cosine distance is below ``reid_max_distance``;
its Kalman filter then restarts at that detection.

Kalman state (8, per track, filterpy ``KalmanFilter``):
``[cx, cy, w, h, vcx, vcy, vw, vh]`` -- box centre and size in px, their rates
in px/frame, constant-velocity model. Unlike SORT's ``[cx, cy, s, r, ...]``
state, width and height are filtered independently and the noise scales with
the box size (as in ByteTrack/BoT-SORT), so near and far objects get the same
relative uncertainty. Sizes are kept positive: a size rate that would shrink
the box to zero is zeroed before predicting, and sizes are floored at
``_MIN_SIZE_PX``. Position noise and the size rates' noise are per frame
(1/20 and 1/80 of the box; ByteTrack: 1/20 and 1/160 at 30 fps). The centre
rates' noise is a white
acceleration per second^2 (``std_weight_accel``), converted with the frame
rate: objects near a moving camera sweep across the image faster and faster
(a dog running across 5 m ahead moves 20, 27, 36, 47 px per frame at 10 fps),
which ByteTrack's 30 fps per-frame value cannot follow at 10 fps, while at
25-30 fps the same value is close to ByteTrack's. The size rates stay quiet:
a walking pedestrian's box width swings with its legs, and letting that into
the predicted width loses the track.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np
from filterpy.kalman import KalmanFilter
from scipy.optimize import linear_sum_assignment

from perception.detections import Detections
from perception.geometry import iou_matrix

log = logging.getLogger(__name__)

_MIN_SIZE_PX = 1e-2  # floor for filtered width/height, px
_BIG_COST = 1e6  # stands in for +inf inside linear_sum_assignment


class TrackState(IntEnum):
    """Track lifecycle state."""

    TENTATIVE = 0
    CONFIRMED = 1
    LOST = 2


@dataclass
class TrackerConfig:
    """Tracker parameters. Time buffers are in seconds (converted with the frame rate).

    Attributes:
        high_score: detections at or above this score enter stage-1 association.
        low_score: detections below this score are ignored; those in
            ``[low_score, high_score)`` enter stage 2.
        new_track_score: minimum score of an unmatched detection to start a track.
        match_iou: minimum IoU of a stage-1 (high-score) match.
        second_match_iou: minimum IoU of a stage-2 (low-score) match.
        min_hits: matches needed for a tentative track to become confirmed.
        max_lost_s: a lost track is removed after this long without a match, s.
        tentative_max_lost_frames: a tentative track is removed after more
            consecutive misses than this.
        per_class: associate only detections and tracks of the same class.
        reid_weight: weight in [0, 1] of the appearance cosine distance in the
            stage-1 cost; 0 disables appearance even when features are passed.
        reid_max_distance: cosine distance under which a lost track may be
            recovered by appearance alone (IoU gate not met).
        feature_momentum: exponential-moving-average momentum of a track's
            appearance feature.
        output_lost: also output lost (coasting) tracks -- predicted box, ``state``
            LOST, ``det_index`` -1 -- for at most ``output_lost_s``.
        output_lost_s: how long a lost track is still output, s (at least one
            frame; None = as long as it is kept, ``max_lost_s``).
        max_abs_coord: detections with any |coordinate| above this (px) are
            treated as invalid.
        std_weight_position: Kalman position noise std as a fraction of box size
            (per frame).
        std_weight_velocity: Kalman noise std of the size rates (and of the centre
            rates when ``std_weight_accel`` is None) as a fraction of box size,
            per frame.
        std_weight_accel: white-noise acceleration std of the box centre as a
            fraction of box size per s^2; its per-frame velocity noise is
            ``std_weight_accel / frame_rate**2`` (0.05 of the box size at 10 fps,
            0.0056 at 30 fps), so the same value suits any frame rate.
        init_velocity_std: std of a new track's (unknown) velocity as a fraction
            of its box size, per frame.
    """

    high_score: float = 0.5
    low_score: float = 0.1
    new_track_score: float = 0.5
    match_iou: float = 0.3
    second_match_iou: float = 0.5
    min_hits: int = 2
    max_lost_s: float = 1.0
    tentative_max_lost_frames: int = 1
    per_class: bool = True
    reid_weight: float = 0.0
    reid_max_distance: float = 0.3
    feature_momentum: float = 0.9
    output_lost: bool = True
    output_lost_s: float | None = 0.2
    max_abs_coord: float = 1e6
    std_weight_position: float = 1.0 / 20.0
    std_weight_velocity: float = 1.0 / 80.0
    std_weight_accel: float | None = 5.0
    init_velocity_std: float = 0.5

    def __post_init__(self) -> None:
        checks = {
            "low_score <= high_score": self.low_score <= self.high_score,
            "0 <= match_iou <= 1": 0.0 <= self.match_iou <= 1.0,
            "0 <= second_match_iou <= 1": 0.0 <= self.second_match_iou <= 1.0,
            "min_hits >= 1": self.min_hits >= 1,
            "max_lost_s >= 0": self.max_lost_s >= 0.0,
            "output_lost_s >= 0 or None": self.output_lost_s is None or self.output_lost_s >= 0.0,
            "tentative_max_lost_frames >= 0": self.tentative_max_lost_frames >= 0,
            "0 <= reid_weight <= 1": 0.0 <= self.reid_weight <= 1.0,
            "0 <= feature_momentum < 1": 0.0 <= self.feature_momentum < 1.0,
            "max_abs_coord > 0": self.max_abs_coord > 0.0,
            "std weights > 0": self.std_weight_position > 0
            and self.std_weight_velocity > 0
            and self.init_velocity_std > 0
            and (self.std_weight_accel is None or self.std_weight_accel > 0),
        }
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"invalid TrackerConfig: need {', '.join(bad)}")


@dataclass
class Tracks:
    """Tracks output for one frame, struct of arrays (N rows).

    Attributes:
        track_id: (N,) int, >= 1.
        xyxy: (N, 4) float px, Kalman posterior (or prediction for lost tracks).
        class_id: (N,) int.
        score: (N,) float, score of the last matched detection.
        age: (N,) int, frames since birth (0 on the birth frame).
        hits: (N,) int, number of matched detections.
        state: (N,) int, ``TrackState`` values.
        det_index: (N,) int, row of the ``Detections`` passed to ``update`` that
            updated the track this frame, -1 if none.
        velocity_px: (N, 4) float, Kalman rates ``[vcx, vcy, vw, vh]`` in px/s.
    """

    track_id: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    xyxy: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    class_id: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    score: np.ndarray = field(default_factory=lambda: np.zeros(0))
    age: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    hits: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    state: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    det_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    velocity_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))

    def __post_init__(self) -> None:
        self.track_id = np.asarray(self.track_id, dtype=np.int64).reshape(-1)
        self.xyxy = np.asarray(self.xyxy, dtype=np.float64).reshape(-1, 4)
        self.class_id = np.asarray(self.class_id, dtype=np.int64).reshape(-1)
        self.score = np.asarray(self.score, dtype=np.float64).reshape(-1)
        self.age = np.asarray(self.age, dtype=np.int64).reshape(-1)
        self.hits = np.asarray(self.hits, dtype=np.int64).reshape(-1)
        self.state = np.asarray(self.state, dtype=np.int64).reshape(-1)
        self.det_index = np.asarray(self.det_index, dtype=np.int64).reshape(-1)
        self.velocity_px = np.asarray(self.velocity_px, dtype=np.float64).reshape(-1, 4)
        n = len(self.track_id)
        lengths = {name: len(getattr(self, name)) for name in self._FIELDS}
        if any(v != n for v in lengths.values()):
            raise ValueError(f"Tracks arrays disagree in length: {lengths}")

    _FIELDS = (
        "track_id",
        "xyxy",
        "class_id",
        "score",
        "age",
        "hits",
        "state",
        "det_index",
        "velocity_px",
    )

    def __len__(self) -> int:
        return len(self.track_id)

    def __getitem__(self, index: np.ndarray | slice | int) -> Tracks:
        if isinstance(index, int | np.integer):
            index = np.array([index])
        return Tracks(**{name: getattr(self, name)[index] for name in self._FIELDS})

    def to_dict(self) -> dict:
        return {
            "track_id": self.track_id.tolist(),
            "xyxy": np.round(self.xyxy, 2).tolist(),
            "class_id": self.class_id.tolist(),
            "score": np.round(self.score, 4).tolist(),
            "age": self.age.tolist(),
            "hits": self.hits.tolist(),
            "state": [TrackState(s).name.lower() for s in self.state],
            "det_index": self.det_index.tolist(),
            "velocity_px": np.round(self.velocity_px, 2).tolist(),
        }


def xyxy_to_cxcywh(b: np.ndarray) -> np.ndarray:
    """(..., 4) xyxy boxes -> (..., 4) centre x, centre y, width, height (px)."""
    b = np.asarray(b, dtype=np.float64)
    wh = b[..., 2:] - b[..., :2]
    return np.concatenate([b[..., :2] + wh / 2.0, wh], axis=-1)


def cxcywh_to_xyxy(b: np.ndarray) -> np.ndarray:
    """(..., 4) centre x, centre y, width, height -> (..., 4) xyxy boxes (px)."""
    b = np.asarray(b, dtype=np.float64)
    half = b[..., 2:] / 2.0
    return np.concatenate([b[..., :2] - half, b[..., :2] + half], axis=-1)


class _BoxKalman:
    """Constant-velocity Kalman filter on ``[cx, cy, w, h, vcx, vcy, vw, vh]`` (px, px/frame)."""

    _F = np.block([[np.eye(4), np.eye(4)], [np.zeros((4, 4)), np.eye(4)]])
    _H = np.hstack([np.eye(4), np.zeros((4, 4))])

    def __init__(self, cxcywh: np.ndarray, wp: float, wv: float, v0: float, wc: float | None = None) -> None:
        self.wp, self.wv = wp, wv
        self.wc = wv if wc is None else wc  # centre-rate noise
        self.kf = KalmanFilter(dim_x=8, dim_z=4)
        self.kf.F = self._F.copy()
        self.kf.H = self._H.copy()
        self.kf.x = np.concatenate([cxcywh, np.zeros(4)]).reshape(8, 1)
        w, h = cxcywh[2], cxcywh[3]
        size = np.array([w, h, w, h])
        std = np.concatenate([2.0 * wp * size, v0 * size])
        self.kf.P = np.diag(std**2)

    @property
    def box(self) -> np.ndarray:
        """Current ``[cx, cy, w, h]`` (px)."""
        return self.kf.x[:4, 0]

    @property
    def rate(self) -> np.ndarray:
        """Current ``[vcx, vcy, vw, vh]`` (px/frame)."""
        return self.kf.x[4:, 0]

    def _size(self) -> np.ndarray:
        w, h = np.maximum(self.kf.x[2:4, 0], 1.0)
        return np.array([w, h, w, h])

    def predict(self) -> None:
        x = self.kf.x
        for i in (2, 3):  # never predict a size through zero
            if x[i, 0] + x[i + 4, 0] <= _MIN_SIZE_PX:
                x[i + 4, 0] = 0.0
        size = self._size()
        wv = np.array([self.wc, self.wc, self.wv, self.wv])
        self.kf.Q = np.diag(np.concatenate([self.wp * size, wv * size]) ** 2)
        self.kf.predict()
        self._floor_size()

    def update(self, cxcywh: np.ndarray) -> None:
        self.kf.R = np.diag((self.wp * self._size()) ** 2)
        self.kf.update(cxcywh.reshape(4, 1))
        self._floor_size()

    def _floor_size(self) -> None:
        self.kf.x[2:4, 0] = np.maximum(self.kf.x[2:4, 0], _MIN_SIZE_PX)

    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.kf.x)) and np.all(np.isfinite(self.kf.P)))


@dataclass(eq=False)
class _Track:
    kf: _BoxKalman
    class_id: int
    score: float
    feature: np.ndarray | None
    track_id: int = -1
    state: TrackState = TrackState.TENTATIVE
    hits: int = 1
    age: int = 0
    time_since_update: int = 0
    det_index: int = -1


class Tracker:
    """Online multi-object tracker (see the module docstring for the algorithm).

    Args:
        config: parameters; ``TrackerConfig()`` defaults when None.
        frame_rate: frames per second of the input, used to convert time
            buffers to frames and velocities to px/s.
    """

    def __init__(self, config: TrackerConfig | None = None, frame_rate: float = 10.0) -> None:
        if not (np.isfinite(frame_rate) and frame_rate > 0):
            raise ValueError(f"frame_rate must be a positive number, got {frame_rate!r}")
        self.config = config or TrackerConfig()
        self.frame_rate = float(frame_rate)
        self.max_lost_frames = max(1, round(self.config.max_lost_s * self.frame_rate))
        out_s = self.config.output_lost_s
        self.output_lost_frames = (
            self.max_lost_frames if out_s is None else max(1, round(out_s * self.frame_rate))
        ) if self.config.output_lost else 0
        self.reset()

    def reset(self) -> None:
        """Forget all tracks, restart ids at 1 and zero the counters."""
        self._tracks: list[_Track] = []
        self._next_id = 1
        self.frame_count = 0
        self.dropped_detections = 0

    # ------------------------------------------------------------------ input
    def _valid_mask(self, dets: Detections) -> np.ndarray:
        b = dets.xyxy
        with np.errstate(invalid="ignore", over="ignore"):
            ok = dets.finite() & np.all(np.abs(b) <= self.config.max_abs_coord, axis=1)
        return ok

    def _clean_features(self, features: np.ndarray | None, n: int) -> np.ndarray | None:
        """Unit-norm (n, D) features with NaN rows where missing, or None."""
        if features is None:
            return None
        f = np.asarray(features, dtype=np.float64)
        if f.ndim != 2 or len(f) != n:
            log.warning("ignoring features of shape %s for %d detections", f.shape, n)
            return None
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            norm = np.linalg.norm(f, axis=1, keepdims=True)
            f = f / norm
        bad = ~np.all(np.isfinite(f), axis=1)
        f[bad] = np.nan
        return f

    # ------------------------------------------------------------ association
    def _cost(
        self,
        tracks: list[_Track],
        boxes: np.ndarray,
        classes: np.ndarray,
        feats: np.ndarray | None,
        iou_gate: float,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(T, D) association cost (+inf where a pair is not allowed) and IoU."""
        trk_boxes = cxcywh_to_xyxy(np.array([t.kf.box for t in tracks]).reshape(-1, 4))
        iou = iou_matrix(trk_boxes, boxes)
        cost = 1.0 - iou
        ok = iou >= iou_gate
        if feats is not None:
            w = self.config.reid_weight
            dim = feats.shape[1]
            trk_feats = np.array(
                [t.feature if t.feature is not None else np.full(dim, np.nan) for t in tracks]
            ).reshape(-1, dim)
            cos = 1.0 - trk_feats @ feats.T  # NaN where either feature is missing
            has = np.isfinite(cos)
            cost = np.where(has, (1.0 - w) * cost + w * cos, cost)
            lost = np.array([t.state == TrackState.LOST for t in tracks], dtype=bool)
            ok |= lost[:, None] & has & (cos <= self.config.reid_max_distance)
        if self.config.per_class:
            trk_cls = np.array([t.class_id for t in tracks], dtype=np.int64)
            ok &= trk_cls[:, None] == classes[None, :]
        return np.where(ok, cost, np.inf), iou

    @staticmethod
    def _assign(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Optimal (rows, cols) of the finite entries of ``cost``."""
        if cost.size == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        finite = np.isfinite(cost)
        rows, cols = linear_sum_assignment(np.where(finite, cost, _BIG_COST))
        keep = finite[rows, cols]
        return rows[keep], cols[keep]

    # ---------------------------------------------------------------- update
    def update(self, detections: Detections, features: np.ndarray | None = None) -> Tracks:
        """Advance one frame with this frame's detections; return the tracks to output.

        Args:
            detections: this frame's detections (invalid rows are dropped and counted).
            features: optional (N, D) appearance embeddings, one row per detection;
                used only when ``config.reid_weight > 0``.
        """
        cfg = self.config
        self.frame_count += 1
        valid = self._valid_mask(detections)
        self.dropped_detections += int(np.count_nonzero(~valid))
        orig_index = np.flatnonzero(valid)
        boxes = detections.xyxy[valid]
        scores = detections.score[valid]
        classes = detections.class_id[valid]
        feats = self._clean_features(features, len(detections)) if cfg.reid_weight > 0 else None
        if feats is not None:
            feats = feats[valid]

        for t in self._tracks:
            t.kf.predict()
            t.age += 1
            t.time_since_update += 1
            t.det_index = -1
        self._tracks = [t for t in self._tracks if t.kf.finite()]

        high = np.flatnonzero(scores >= cfg.high_score)
        low = np.flatnonzero((scores >= cfg.low_score) & (scores < cfg.high_score))

        # Stage 1: high-score detections against every track.
        tracks = self._tracks
        cost, iou = self._cost(
            tracks,
            boxes[high],
            classes[high],
            None if feats is None else feats[high],
            cfg.match_iou,
        )
        rows, cols = self._assign(cost)
        matched_trk = set(rows.tolist())
        # A match below the IoU gate is an appearance re-identification: the
        # motion model was wrong, so the filter restarts at the detection.
        jumped = iou[rows, cols] < cfg.match_iou
        pairs = [(tracks[r], high[c], j) for r, c, j in zip(rows, cols, jumped, strict=True)]
        unmatched_high = np.setdiff1d(high, high[cols])

        # Stage 2: low-score detections against confirmed tracks left over.
        rest = [
            t
            for i, t in enumerate(tracks)
            if i not in matched_trk and t.state == TrackState.CONFIRMED
        ]
        cost, _ = self._cost(rest, boxes[low], classes[low], None, cfg.second_match_iou)
        rows, cols = self._assign(cost)
        pairs += [(rest[r], low[c], False) for r, c in zip(rows, cols, strict=True)]

        for trk, d, jump in pairs:
            if jump:
                trk.kf = self._new_filter(boxes[d])
            else:
                trk.kf.update(xyxy_to_cxcywh(boxes[d]))
            self._apply_match(trk, scores[d], classes[d], orig_index[d], feats, d)

        survivors = []
        for t in self._tracks:
            if t.time_since_update > 0:
                if t.state == TrackState.TENTATIVE:
                    if t.time_since_update > cfg.tentative_max_lost_frames:
                        continue
                elif t.time_since_update > self.max_lost_frames:
                    continue
                else:
                    t.state = TrackState.LOST
            survivors.append(t)
        self._tracks = survivors

        for d in unmatched_high[scores[unmatched_high] >= cfg.new_track_score]:
            self._birth(boxes[d], scores[d], classes[d], orig_index[d], feats, d)

        return self._output()

    def _apply_match(
        self,
        trk: _Track,
        score: float,
        class_id: int,
        det_index: int,
        feats: np.ndarray | None,
        d: int,
    ) -> None:
        trk.hits += 1
        trk.time_since_update = 0
        trk.score = float(score)
        trk.class_id = int(class_id)
        trk.det_index = int(det_index)
        if feats is not None and np.all(np.isfinite(feats[d])):
            if trk.feature is None:
                trk.feature = feats[d].copy()
            else:
                m = self.config.feature_momentum
                f = m * trk.feature + (1.0 - m) * feats[d]
                trk.feature = f / max(float(np.linalg.norm(f)), 1e-12)
        if trk.state == TrackState.LOST:
            trk.state = TrackState.CONFIRMED
        elif trk.state == TrackState.TENTATIVE and trk.hits >= self.config.min_hits:
            self._confirm(trk)

    def _new_filter(self, box: np.ndarray) -> _BoxKalman:
        cfg = self.config
        return _BoxKalman(
            xyxy_to_cxcywh(box),
            cfg.std_weight_position,
            cfg.std_weight_velocity,
            cfg.init_velocity_std,
            None if cfg.std_weight_accel is None else cfg.std_weight_accel / self.frame_rate**2,
        )

    def _confirm(self, trk: _Track) -> None:
        trk.state = TrackState.CONFIRMED
        trk.track_id = self._next_id
        self._next_id += 1

    def _birth(
        self,
        box: np.ndarray,
        score: float,
        class_id: int,
        det_index: int,
        feats: np.ndarray | None,
        d: int,
    ) -> None:
        cfg = self.config
        feature = None
        if feats is not None and np.all(np.isfinite(feats[d])):
            feature = feats[d].copy()
        trk = _Track(
            kf=self._new_filter(box), class_id=int(class_id), score=float(score), feature=feature
        )
        trk.det_index = int(det_index)
        if cfg.min_hits <= 1:
            self._confirm(trk)
        self._tracks.append(trk)

    def _output(self) -> Tracks:
        out = [
            t
            for t in self._tracks
            if t.state == TrackState.CONFIRMED
            or (t.state == TrackState.LOST and t.time_since_update <= self.output_lost_frames)
        ]
        out.sort(key=lambda t: t.track_id)
        if not out:
            return Tracks()
        return Tracks(
            track_id=[t.track_id for t in out],
            xyxy=cxcywh_to_xyxy(np.array([t.kf.box for t in out])),
            class_id=[t.class_id for t in out],
            score=[t.score for t in out],
            age=[t.age for t in out],
            hits=[t.hits for t in out],
            state=[int(t.state) for t in out],
            det_index=[t.det_index for t in out],
            velocity_px=np.array([t.kf.rate for t in out]) * self.frame_rate,
        )

    @property
    def num_tracks(self) -> int:
        """Number of live tracks (tentative, confirmed and lost)."""
        return len(self._tracks)
