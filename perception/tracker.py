"""Multi-object tracker: Kalman boxes + ByteTrack two-stage association.

Pipeline per frame (``Tracker.update``), one method per step:

1. ``_prepare``: drop invalid detections (non-finite numbers, width/height <= 0,
   coordinates beyond ``max_abs_coord``) and count them in
   ``Tracker.dropped_detections``. Fold duplicates (``duplicate_iou``: one object
   detected as two classes -- overlapping detections of one class are the detector's
   NMS's business, and in a crowd they are two people) into the higher-scoring
   detection as class evidence; count them in ``Tracker.merged_duplicates``.
2. ``_predict``: predict every track one frame ahead with its Kalman filter.
3. ``_associate_high`` (stage 1): high-score detections (``score >= high_score``)
   against *all* tracks (tentative, confirmed, lost); cost ``1 - IoU`` gated at
   ``match_iou``, optionally mixed with the cosine distance of appearance features.
   IoU on the boxes themselves (floored at ``min_match_size``) first; then
   ``_associate_buffered`` (stage 1b) matches the detections and the tracks -- not
   the lost ones -- left over on buffered boxes (``match_buffer``). Buffers reach a
   box that outran its prediction, and also a neighbour: in a crowd every person
   overlaps the next once buffered, so the tight overlaps are settled first, and a
   lost track, whose prediction has drifted, is recovered only by a tight one
   (measured on MOT15 and the simulator, ``tests/tools/scoring/test_mot_real.py``:
   with a 1 s memory a single buffered pass fell below SORT on TUD-Stadtmitte's
   crowd, this does not; the rendered smoke suite's MOTA 0.915 -> 0.921). With
   appearance galleries stages 1 and 2 use the buffered IoU in one pass each: the
   occlusion cost and the re-id stage settle overlaps there (measured: stage 2 on
   the tight IoU lost one of the occlusion suite's 14 occlusions, and a tight-first
   stage 1 gave two objects boxed as one to the hidden one's track,
   ``test_one_detection_of_two_overlapping_objects_goes_to_the_nearer``).
4. ``_associate_low`` (stage 2): low-score detections (``low_score <= score <
   high_score``) against the confirmed tracks left over (IoU only, tight unless
   galleries exist, gated at ``second_match_iou``). Low-score boxes are often partly occluded objects; they
   keep tracks alive but never start one, and lost tracks are not revived by them
   (ByteTrack).
4b. ``_associate_reid`` (re-id stage, only with features and galleries): unmatched
   high-score detections, and those stage 1 gave to tentative tracks, against the lost
   tracks with an appearance gallery (see "Re-identification" below). ``_apply_matches`` then updates the matched
   tracks and ``_prune`` turns the unmatched ones lost or removes them.
5. ``_birth``: unmatched high detections with ``score >= new_track_score`` start
   tentative tracks. ``_output`` reports the confirmed and coasting ones.

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
  that, ``tools.scoring.mot_eval``).

Appearance (optional): with ``reid_weight > 0`` and a ``features`` array, the
stage-1 cost is ``(1 - w) (1 - IoU) + w * cosine_distance`` against each
track's moving-average feature, and a *lost* track may also match a detection
outside the IoU gate when the cosine distance is below ``reid_max_distance``;
its Kalman filter then restarts at that detection.

Re-identification after occlusion (issue 33; on whenever features are passed,
``gallery_size`` > 0, independent of ``reid_weight``):

* Gallery: each track keeps the features of its latest ``gallery_size`` (10)
  confident, unoccluded matches -- detection score >= ``high_score``, overlapping
  no other detection by more than ``gallery_max_overlap`` IoU (an occluded crop
  mixes two objects), finite feature, within ``reid_max_distance`` of a feature
  already stored (if any: a half-hidden object is often boxed without overlapping
  its occluder's box, but its crop does not look like it) -- in a ring buffer: rows of one
  preallocated (capacity, gallery_size, D) float32 array plus a (capacity, 3)
  count / next slot / frame-of-newest table, moved with the other track arrays.
* Retention: a lost confirmed track with a gallery is kept ``reid_max_lost_s``
  (3 s; 30 frames at 10 fps) instead of ``max_lost_s`` (1 s). Beyond
  ``max_lost_s`` it is only a re-id candidate: barred from IoU association (its
  drifting prediction must not capture another object by overlap alone) and not
  output, so the output is what it was without re-id.
* Re-id stage, after stages 1 and 2: the high-score detections still unmatched
  that have a feature, against the lost tracks with a gallery not matched yet.
  Cost: the smallest cosine distance to the gallery (plus ``class_switch_cost``
  for another class with ``per_class``; barred without it), accepted at or below
  ``reid_max_distance`` -- for another class, the distance alone when the
  detection is a partial view: it overlaps the box of a detection in front of it
  (lower bottom edge) matched this frame. The detector often names a reappearing
  object's first, partial views wrongly (measured: a car coming out from behind a
  truck, its front detected as a tricycle), and the track's class comes from its
  class votes, not from that one detection; a whole view of another class still
  pays the switch cost (measured on the rendered traffic scenarios: whole views
  re-identified across classes were other objects); motion gate: the squared Mahalanobis distance of the box
  from the track's Kalman prediction, covariance ``H P H' + R``, at most
  ``reid_gate`` (chi-square 99 %, 4 dof). The covariance grows with the time lost
  (centre 1-sigma about 1.1 box sizes after 1 s, 2.9 after 2 s, 5 after 3 s), which is the
  "generous gate scaled by time lost". A detection inside the gate of the track's
  *anchor* passes too: the filter as it was after the match that gave the newest
  gallery feature, predicted on every frame since. An object going behind an
  occluder is detected shrinking for a few frames (its visible part), which drives
  the filter's size and its covariance towards zero -- measured on the rendered
  occlusion scenarios: a cyclist's predicted width fell from 13 px to under 1, a car's
  from 38 px to about 1, and their full-size reappearances were far outside that
  gate; the anchor never saw those boxes (a track matched through its anchor only
  takes the anchor's state before its update). Appearance veto: a pair is refused
  when the detection's feature is nearer to the gallery of another track left
  unmatched by the IoU stages (lost, or confirmed and missed) -- it looks like that
  object. One optimal assignment over all pairs. Take-over: a reappearance first
  seen half hidden or unrecognised starts a tentative track; when a later detection
  of that tentative track is re-identified, the lost track takes it and the
  tentative track is removed -- it was never confirmed nor output, and no id was
  spent on it. A re-found track
  keeps its id, age, hits and class votes, becomes confirmed and gets a normal
  Kalman update: inside the gate the detection agrees with the prediction, and the
  grown covariance makes the update pull the velocity to the mean motion over the
  gap (restarting it at zero would be worse for an object that kept walking).
  ``Tracker.reidentifications`` counts these matches.
* Occlusion cost (stage 1, once galleries exist): two tracked objects overlapping
  in the image are often detected as one box, and it is the front one's. By IoU
  the farther object's track -- often standing still, so well predicted -- takes
  it and then follows the front object away: their ids swap (measured: a car
  coming out from behind a truck and stopping in front of another parked car).
  ``_occlusion_cost`` charges a pair (track i, detection j) the part of i's
  predicted box inside the box of a track k in front of it times the part of k's
  box inside the detection, when j is of k's class and k could match it too. k is
  in front of i when k was matched on the previous frame and i was not (i is
  hidden), or both were and k's bottom edge is the lower (on a flat road, the
  nearer object). The hidden track then waits, lost, for the re-id stage.
* Feature requests: ``features_needed(detections)`` (mask) / ``wants_features``
  (bool), called before ``update``, say which detections' features the update
  would use: re-id candidates (left unmatched by the IoU part of stage 1, which it
  runs, or matched there to a tentative track; inside the gate of a lost track with
  a gallery or of its anchor), refreshes (a confirmed track's best IoU detection when its
  gallery's newest feature is ``gallery_refresh_s`` old or it has none, or half that
  old when the detection touches one in front of it -- it is going behind that
  object; only if unoccluded; tracks at half that age join a frame that embeds
  anyway), and, with
  ``reid_weight > 0``, ambiguous matches (a prediction overlapping two detections
  above ``match_iou``, or a detection two predictions). Cost trade-off: a caller
  embedding only these crops runs the embedder on a fraction of frames (the
  70-frame occlusion test: 8 of 70; refreshes cost about
  ``tracks / (gallery_refresh_s * fps)`` crops per frame), for galleries that
  are up to ``gallery_refresh_s`` stale -- appearance changes slowly, and a
  10-feature gallery then spans about 10 s of views. Embedding every frame works
  too (the gallery then spans the last second).

Without features nothing of this runs: no gallery exists, ``_prune`` and stage 1
take their pre-re-id paths (no occlusion cost), and the tracks are bit-identical to those of a
tracker without re-id (checked against the previous implementation on random streams).

Kalman state (8 per track): ``[cx, cy, w, h, vcx, vcy, vw, vh]`` -- box centre and size in px, their rates
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

Implementation: the filter is filterpy's ``KalmanFilter`` model (explicit
``KF_F``, ``KF_H``, diagonal Q and R from ``kf_process_noise`` and
``kf_measurement_noise``; ``predict`` and the Joseph-form ``update``) run on
all tracks at once (``kf_predict`` / ``kf_update``: states (N, 8), covariances
(N, 8, 8); ``tests/perception/test_tracker_batch.py`` checks them against
filterpy per track to 1e-9). The tracker runs the same equations on the 16
entries of P that a box filter can make non-zero (its four 2x2 blocks:
``box_filters_predict`` / ``box_filters_update``, bit-identical to the full
form), on filters laid out one per column so that numpy works on contiguous
rows. Tracks live in preallocated arrays (rows in birth order, the order
association sees them in), so a frame builds no per-track Python objects.
Per frame the cost is a fixed number of small numpy calls (about a
microsecond each whatever the size), so the code keeps their count low and
their operands contiguous (the association IoU, for one, takes the track and
detection boxes as one array of contiguous x, y rows).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Annotated, NamedTuple

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.optimize import linear_sum_assignment

from lookahead.perception.detections import Detections
from lookahead.perception.geometry import box_area, intersection_areas

log = logging.getLogger(__name__)

_MIN_SIZE_PX = 1e-2  # floor for filtered width/height, px
_BIG_COST = 1e6  # stands in for +inf inside linear_sum_assignment


class TrackState(IntEnum):
    """Track lifecycle state."""

    TENTATIVE = 0
    CONFIRMED = 1
    LOST = 2


class TrackerConfig(BaseModel):
    """Tracker parameters (scores unitless, sizes in px; time buffers in seconds, converted
    with the frame rate). Bounds are the fields' constraints; ``low_score <= high_score``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    high_score: float = Field(0.45, description="detections at or above this score enter stage-1 association")
    low_score: float = Field(
        0.1, description="detections below this score are ignored; those in [low_score, high_score) enter stage 2"
    )
    new_track_score: float = Field(0.45, description="minimum score of an unmatched detection to start a track")
    match_iou: float = Field(0.3, ge=0, le=1, description="minimum IoU of a stage-1 (high-score) match")
    match_buffer: float = Field(
        0.3, ge=0,
        description="detections and tracks stage 1 leaves over on the boxes themselves are matched again on"
        " buffered boxes (stage 1b, lost tracks excluded), each side grown by this fraction of the box's width or"
        " height (the C-BIoU tracker's cascaded buffers, Yang et al., WACV 2023), so that a box that moves or grows"
        " faster than the constant-velocity prediction -- a near object crossing, or closing in -- still reaches"
        " its track (0 = one unbuffered pass)",
    )
    min_match_size: float = Field(
        8.0, ge=0,
        description="and those boxes are widened and heightened about their centres to at least this many px, so"
        " that one pixel of jitter does not break the track of a distant object a few pixels wide (0 = no floor)."
        " Outputs are unchanged by either",
    )
    second_match_iou: float = Field(0.3, ge=0, le=1, description="minimum IoU of a stage-2 (low-score) match")
    min_hits: int = Field(2, ge=1, description="matches needed for a tentative track to become confirmed")
    max_lost_s: float = Field(1.0, ge=0, description="a lost track is removed after this long without a match (s)")
    tentative_max_lost_frames: int = Field(
        1, ge=0, description="a tentative track is removed after more consecutive misses than this"
    )
    per_class: bool = Field(
        True,
        description="associate detections and tracks of the same class only (or, with class_switch_cost, prefer them)",
    )
    class_switch_cost: Annotated[float, Field(ge=0)] | None = Field(
        0.2,
        description="with per_class, a detection of another class than the track's may still match it at this extra"
        " cost (added to 1 - IoU); null = never. Keeps the identity of an object whose detector flickers between"
        " similar classes (pedestrian / cyclist)",
    )
    class_memory: float = Field(
        0.9, ge=0, lt=1,
        description="how much of a track's class evidence survives each match: the track's class is the argmax of"
        " its detections' scores summed per class, each earlier match weighted down by this factor; 0 = the class"
        " of its latest detection",
    )
    class_hysteresis: float = Field(
        1.25, ge=1,
        description="a track changes its class only when another class's votes exceed its current class's by this"
        " factor (1 = the plain argmax), so near-even evidence does not flip the class frame to frame",
    )
    duplicate_iou: Annotated[float, Field(ge=0, le=1)] | None = Field(
        0.55,
        description="a detection overlapping a higher-scoring one of another class by more than this IoU (boxes"
        " floored at min_match_size, unbuffered) is the same object seen as another class -- the per-class NMS of"
        " a detector keeps both when it cannot decide between pedestrian and cyclist: it takes no part in"
        " association or track births, and its score counts for its class in the class votes of whatever track"
        " the higher one joins. null = every detection is an object of its own",
    )
    reid_weight: float = Field(
        0.0, ge=0, le=1,
        description="weight of the appearance cosine distance in the stage-1 cost; 0 disables appearance even"
        " when features are passed",
    )
    reid_max_distance: float = Field(
        0.3, ge=0, le=2,
        description="cosine distance under which a lost track may be recovered by appearance: in the re-id stage"
        " (distance to the nearest feature of its gallery, motion-gated), and with reid_weight > 0 also in stage 1"
        " outside the IoU gate (distance to its moving-average feature, not motion-gated)",
    )
    gallery_size: int = Field(
        10, ge=0, le=1000,
        description="appearance features each track keeps (a ring buffer of those of its latest confident,"
        " unoccluded matches); lost tracks with a gallery are re-identified in a motion-gated re-id stage after"
        " the IoU stages. 0 = no gallery, no re-id stage. Used only when features are passed to update",
    )
    reid_max_lost_s: float = Field(
        3.0, ge=0,
        description="a lost confirmed track with a gallery is kept this long (s; never less than max_lost_s) for"
        " the re-id stage; beyond max_lost_s it takes no part in IoU association and is not output",
    )
    reid_gate: float = Field(
        13.28, gt=0,
        description="re-id motion gate: squared Mahalanobis distance of the detection box [cx, cy, w, h] from the"
        " lost track's Kalman prediction (covariance incl. measurement noise; grows with the time lost). 13.28 ="
        " chi-square 99 % for 4 degrees of freedom",
    )
    gallery_max_overlap: float = Field(
        0.2, ge=0, le=1,
        description="a feature enters its track's gallery only if its detection scores at least high_score and"
        " overlaps no other detection of the frame by more than this IoU (an occluded crop mixes two objects)",
    )
    gallery_refresh_s: float = Field(
        1.0, gt=0,
        description="features_needed / wants_features ask for a confirmed track's detection's feature when its"
        " gallery's newest feature is this old (s) or it has none; tracks at half that age join a frame that"
        " embeds anyway, so refreshes bunch into few embedder calls",
    )
    feature_momentum: float = Field(
        0.9, ge=0, lt=1, description="exponential-moving-average momentum of a track's appearance feature"
    )
    output_lost: bool = Field(
        True,
        description="also output lost (coasting) tracks -- predicted box, state LOST, det_index -1 -- for at most"
        " output_lost_s",
    )
    output_lost_s: Annotated[float, Field(ge=0)] | None = Field(
        0.2, description="how long a lost track is still output (s; at least one frame; null = as long as it is kept)"
    )
    max_abs_coord: float = Field(
        1e6, gt=0, description="detections with any |coordinate| above this (px) are treated as invalid"
    )
    std_weight_position: float = Field(
        1.0 / 20.0, gt=0, description="Kalman position noise std as a fraction of box size (per frame)"
    )
    std_weight_velocity: float = Field(
        1.0 / 80.0, gt=0,
        description="Kalman noise std of the size rates (and of the centre rates when std_weight_accel is null) as"
        " a fraction of box size, per frame",
    )
    std_weight_accel: Annotated[float, Field(gt=0)] | None = Field(
        5.0,
        description="white-noise acceleration std of the box centre as a fraction of box size per s^2; its"
        " per-frame velocity noise is std_weight_accel / frame_rate^2 (0.05 of the box size at 10 fps, 0.0056 at"
        " 30 fps), so the same value suits any frame rate",
    )
    init_velocity_std: float = Field(
        0.5, gt=0, description="std of a new track's (unknown) velocity as a fraction of its box size, per frame"
    )

    @model_validator(mode="after")
    def _score_bands(self) -> TrackerConfig:
        if self.low_score > self.high_score:
            raise ValueError(f"need low_score <= high_score, got {self.low_score} > {self.high_score}")
        return self


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

    @classmethod
    def _trusted(cls, **arrays: np.ndarray) -> Tracks:
        """Tracks from arrays already of the right dtype and shape (skips the checks)."""
        out = object.__new__(cls)
        out.__dict__ = arrays
        return out

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


# ------------------------------------------------------------ Kalman filter
# The box filter is filterpy's ``KalmanFilter`` with the matrices below, written
# out so that all tracks are filtered at once: state rows x (N, 8) (filterpy's
# column x, transposed), covariances P (N, 8, 8). Same F, H, Q, R and the same
# equations (filterpy ``predict`` and its Joseph-form ``update``); the 4x4
# innovation covariance is inverted by one batched solve. The tracker itself runs
# the block form below (``box_filters_predict`` / ``box_filters_update``).
# ``tests/perception/test_tracker_batch.py`` checks both against filterpy.

#: State transition, one frame of constant velocity: ``x' = F x``.
KF_F = np.block([[np.eye(4), np.eye(4)], [np.zeros((4, 4)), np.eye(4)]])
#: Measurement matrix, a detection measures the box ``[cx, cy, w, h]``: ``z = H x``.
KF_H = np.hstack([np.eye(4), np.zeros((4, 4))])
_F_T = np.ascontiguousarray(KF_F.T)
_H_T = np.ascontiguousarray(KF_H.T)
_I8 = np.eye(8)
_WH8 = np.array([2, 3] * 4)  # state columns giving [w, h, w, h, w, h, w, h]
_WH4 = np.array([2, 3] * 2)
_OFF_DIAGONAL_4 = np.flatnonzero(~np.eye(4, dtype=bool).reshape(16))  # flat indices of a 4x4's off-diagonal


def kf_process_noise(x: np.ndarray, q_weights: np.ndarray) -> np.ndarray:
    """Diagonal of Q (N, 8) for state rows x (N, 8).

    ``Q = diag((q_weights * [w, h, w, h, w, h, w, h])**2)`` with the sizes
    floored at 1 px, ``q_weights`` = ``[wp, wp, wp, wp, wc, wc, wv, wv]``:
    position, centre-rate and size-rate noise std as fractions of the box size.
    """
    return (np.maximum(x.take(_WH8, axis=1), 1.0) * q_weights) ** 2


def kf_measurement_noise(x: np.ndarray, wp: float) -> np.ndarray:
    """Diagonal of R (N, 4) for state rows x (N, 8): ``R = diag((wp * [w, h, w, h])**2)``, sizes floored at 1 px."""
    return (wp * np.maximum(x.take(_WH4, axis=1), 1.0)) ** 2


def kf_initial_state(cxcywh: np.ndarray, p_weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """New filters at boxes (N, 4): x (N, 8) with zero rates, P (N, 8, 8).

    ``P = diag((p_weights * [w, h, w, h, w, h, w, h])**2)`` with the measured
    (unfloored) sizes, ``p_weights`` = ``[2 wp] * 4 + [v0] * 4``.
    """
    n = len(cxcywh)
    x = np.zeros((n, 8))
    x[:, :4] = cxcywh
    P = np.zeros((n, 8, 8))
    P.reshape(n, 64)[:, ::9] = (x.take(_WH8, axis=1) * p_weights) ** 2
    return x, P


def kf_predict(x: np.ndarray, P: np.ndarray, q: np.ndarray) -> None:
    """filterpy ``predict`` of N filters, in place: ``x = F x``, ``P = F P F' + diag(q)``."""
    np.matmul(x, _F_T, out=x)  # numpy buffers overlapping operands
    np.matmul(KF_F @ P, _F_T, out=P)
    P.reshape(len(P), 64)[:, ::9] += q


def kf_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """filterpy ``update`` of N filters with measurements z (N, 4) and ``R = diag(r)`` (r (N, 4)).

    ``y = z - H x``, ``S = H P H' + R``, ``K = P H' S^-1``, ``x += K y``,
    ``P = (I - K H) P (I - K H)' + K R K'`` (Joseph form). Returns the
    posterior x (N, 8) and P (N, 8, 8) as new arrays.
    """
    # H = [I 0] picks the box: H x = x[:4], P H' = P[:, :4], H P H' = P[:4, :4], K H = [K 0].
    n = len(x)
    y = z - x[:, :4]
    PHT = P[:, :, :4]
    S = P[:, :4, :4].copy()
    S.reshape(n, 16)[:, ::5] += r
    if np.count_nonzero(S.reshape(n, 16)[:, _OFF_DIAGONAL_4]):
        # K = P H' S^-1  <=>  K' = S'^-1 (P H')': one batched 4x4 solve, no explicit inverse.
        KT = np.linalg.solve(S.transpose(0, 2, 1), PHT.transpose(0, 2, 1))
        K = KT.transpose(0, 2, 1)
    else:  # the box filters' case: coordinates independent (F, Q, R, P0 block-diagonal), S diagonal
        K = PHT / S.reshape(n, 16)[:, None, ::5]
        KT = K.transpose(0, 2, 1)
    x = x + (K @ y[:, :, None])[:, :, 0]
    # Joseph form with (I - K H) P = P - K P[:4] =: A and A (I - K H)' = A - A[:, :4] K'.
    A = P - K @ P[:, :4, :]
    P = A - A[:, :, :4] @ KT + (K * r[:, None, :]) @ KT
    return x, P


def box_predict(x: np.ndarray, P: np.ndarray, q_weights: np.ndarray) -> None:
    """Predict N box filters one frame ahead, in place: ``kf_predict`` with the size guards.

    A size rate that would take its size to ``_MIN_SIZE_PX`` or below is
    zeroed first; Q comes from the sizes before the step; the predicted sizes
    are floored at ``_MIN_SIZE_PX``.
    """
    rates = x[:, 6:8]
    rates[x[:, 2:4] + rates <= _MIN_SIZE_PX] = 0.0  # never predict a size through zero
    kf_predict(x, P, kf_process_noise(x, q_weights))
    np.maximum(x[:, 2:4], _MIN_SIZE_PX, out=x[:, 2:4])


def box_update(x: np.ndarray, P: np.ndarray, cxcywh: np.ndarray, wp: float) -> tuple[np.ndarray, np.ndarray]:
    """Update N box filters with measured boxes (N, 4): ``kf_update``, R from the predicted sizes, sizes floored."""
    x, P = kf_update(x, P, cxcywh, kf_measurement_noise(x, wp))
    np.maximum(x[:, 2:4], _MIN_SIZE_PX, out=x[:, 2:4])
    return x, P


# ------------------------------------------------- block form of the box filter
# F, H, Q, R and a new filter's P are block-diagonal over the box's four coordinates: coordinate i
# only couples its value (state row i) with its rate (row i + 4). P keeps that pattern through
# predict and update, so a box filter's P (8, 8) has 16 non-zero entries: four 2x2 blocks, stored
# as ``Pb`` (N, 2, 2, 4) with ``Pb[:, a, b, i] = P[:, 4a + i, 4b + i]`` (a, b: 0 value, 1 rate).
# The tracker keeps one row of 24 per filter, ``[x (8) | Pb (16)]``, and runs the steps on the
# transposed rows, one filter per column (``box_filters_predict`` / ``box_filters_update``): every
# quantity is then a contiguous block of rows, the cheapest form for numpy on a few filters. The
# steps apply ``box_predict`` / ``box_update`` with the same floating-point operations in the
# same order: each product that ``kf_predict`` / ``kf_update`` sum has at most its one or two
# non-zero terms here, so the results are bit-identical (``tests/perception/test_tracker_batch.py``).

#: Flat indices, into a row-major 8x8 matrix, of the entries ``Pb`` holds (``Pb``'s order).
_BLOCK_FLAT = np.array([(4 * a + i) * 8 + 4 * b + i for a in range(2) for b in range(2) for i in range(4)])


def kf_block(P: np.ndarray) -> np.ndarray:
    """The blocks Pb (N, 2, 2, 4) of box-filter covariances P (N, 8, 8) (other entries must be 0)."""
    return P.reshape(len(P), 64)[:, _BLOCK_FLAT].reshape(len(P), 2, 2, 4)


def kf_unblock(Pb: np.ndarray) -> np.ndarray:
    """The covariances P (N, 8, 8) of blocks Pb (N, 2, 2, 4) (``kf_block``'s inverse)."""
    P = np.zeros((len(Pb), 64))
    P[:, _BLOCK_FLAT] = Pb.reshape(len(Pb), 16)
    return P.reshape(len(Pb), 8, 8)


def box_block_initial_state(cxcywh: np.ndarray, p_weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``kf_initial_state`` with the covariance as blocks: x (N, 8), Pb (N, 2, 2, 4)."""
    n = len(cxcywh)
    x = np.zeros((n, 8))
    x[:, :4] = cxcywh
    Pb = np.zeros((n, 2, 2, 4))
    Pb.reshape(n, 4, 4)[:, ::3] = ((x.take(_WH8, axis=1) * p_weights) ** 2).reshape(n, 2, 4)
    return x, Pb


def _columns(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Views of filters as columns T (24, N): states (8, N), covariance blocks (2, 2, 4, N) (splitting
    one axis, the reshape is a view whatever T's layout)."""
    return T[:8], T[8:].reshape(2, 2, 4, T.shape[1])


def box_filters_predict(T: np.ndarray, q_weights: np.ndarray) -> None:
    """``box_predict`` of N box filters given as columns T (24, N: rows x (8) and ``Pb`` (16);
    fastest C-contiguous), in place.

    Per coordinate ``F = [[1, 1], [0, 1]]``: ``F P`` adds the rate row to the value row,
    ``(F P) F'`` then the rate column to the value column; Q adds to the diagonal blocks.
    """
    x, P = _columns(T)
    rates = x[6:8]
    rates[x[2:4] + rates <= _MIN_SIZE_PX] = 0.0  # never predict a size through zero
    q = (np.maximum(x.take(_WH8, axis=0), 1.0) * q_weights[:, None]) ** 2  # kf_process_noise, transposed
    x[:4] += x[4:]
    P[0] += P[1]
    P[:, 0] += P[:, 1]
    P[0, 0] += q[:4]  # value variances
    P[1, 1] += q[4:]  # rate variances
    np.maximum(x[2:4], _MIN_SIZE_PX, out=x[2:4])


def box_filters_update(T: np.ndarray, zT: np.ndarray, wp: float) -> None:
    """``box_update`` of N box filters given as columns T (24, N, as ``box_filters_predict``) with
    measured boxes zT (4, N, cxcywh), in place.

    Per coordinate, with ``S = P00 + r`` and gain ``K = P[:, 0] / S`` (value and rate):
    ``x += K y``; Joseph form ``A = P - K P[0]``, ``P = A - A[:, 0] K' + (K r) K'``.
    """
    x, P = _columns(T)
    r = (wp * np.maximum(x.take(_WH4, axis=0), 1.0)) ** 2  # kf_measurement_noise, transposed
    y = zT - x[:4]
    K = P[:, 0] / (P[0, 0] + r)  # (2, 4, N)
    x += (K * y).reshape(x.shape)
    A = P - K[:, None] * P[0]
    Kt = K[None]
    np.add(A - A[:, :1] * Kt, (K * r)[:, None] * Kt, out=P)
    np.maximum(x[2:4], _MIN_SIZE_PX, out=x[2:4])


def _kf_views(kf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The states x (N, 8) and covariance blocks Pb (N, 2, 2, 4) of filter rows kf (N, 24), as views."""
    return kf[:, :8], kf[:, 8:].reshape(len(kf), 2, 2, 4)


def _cxcywh(b: np.ndarray, bT: np.ndarray | None = None) -> np.ndarray:
    """``xyxy_to_cxcywh`` (same arithmetic) of an (N, 4) float64 array (``bT``: its C-contiguous
    transpose, if at hand), as the (N, 4) transpose of a C-contiguous (4, N) array: computed on
    contiguous rows, and the form association and the filters' columns (``box_filters_update``) take."""
    if bT is None:
        bT = b.T.copy()
    out = np.empty((4, len(b)))
    wh = np.subtract(bT[2:], bT[:2], out=out[2:])
    np.add(bT[:2], wh / 2.0, out=out[:2])
    return out.T


#: State rows (N, 8) @ this = their boxes as xyxy (N, 4): ``[cx - w/2, cy - h/2, cx + w/2, cy + h/2]``.
#: Bit-identical to ``cxcywh_to_xyxy`` (each output adds one exactly scaled term to another).
_STATE_TO_XYXY = np.zeros((8, 4))
_STATE_TO_XYXY[:4] = [[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0], [-0.5, 0.0, 0.5, 0.0], [0.0, -0.5, 0.0, 0.5]]
#: xyxy boxes (N, 4) @ this = their widths and heights ``[x2 - x1, y2 - y1]`` (N, 2), bit-identical.
_XYXY_TO_WH = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
_TINY = np.nextafter(0.0, 1.0)  # smallest positive float: x / max(union, _TINY) is 0 where union is 0


def _iou(a: np.ndarray, b: np.ndarray, area_b: np.ndarray) -> np.ndarray:
    """``perception.geometry.iou_matrix`` (same arithmetic and result) of boxes of non-negative size.

    a (N, 4) and b (M, 4) are xyxy boxes, ``area_b`` (M,) the areas of b. Widths
    and heights are >= 0 (true for track boxes and valid detections), so areas
    need no clamping, and the union is then 0 only where the intersection is,
    where the IoU is 0.
    """
    a3 = a[:, None, :]
    wh = np.minimum(a3[..., 2:], b[:, 2:])
    wh -= np.maximum(a3[..., :2], b[:, :2])
    np.maximum(wh, 0.0, out=wh)
    inter = wh[..., 0] * wh[..., 1]
    wh_a = a @ _XYXY_TO_WH
    union = (wh_a[:, 0] * wh_a[:, 1])[:, None] + area_b - inter
    return inter / np.maximum(union, _TINY)


def _iou_centred(c: np.ndarray, h: np.ndarray, n: int) -> np.ndarray:
    """(N, M) IoU of the boxes ``[:, :n]`` and ``[:, n:]`` (N + M columns) of centres c (2, N + M) and
    half sizes h (2, N + M, >= 0, px): the association's form -- the Kalman state holds centres and
    sizes, and growing a box (``min_match_size``, ``match_buffer``) only changes its half sizes. Both
    sets in one array, x and y as contiguous rows, make each step one cheap call (same arithmetic
    as ``_iou``)."""
    lo, hi = c - h, c + h
    area = 4.0 * h[0] * h[1]
    wh = np.minimum(hi[:, :n, None], hi[:, None, n:])  # (2, N, M)
    wh -= np.maximum(lo[:, :n, None], lo[:, None, n:])
    np.maximum(wh, 0.0, out=wh)
    inter = wh[0] * wh[1]
    union = area[:n, None] + area[n:] - inter
    return inter / np.maximum(union, _TINY)


def _occlusion_cost(
    trk: np.ndarray, seen: np.ndarray, trk_class: np.ndarray, ok: np.ndarray, det: np.ndarray, det_class: np.ndarray
) -> np.ndarray:
    """(N, M) extra association cost of occluded tracks (stage 1 with appearance, ``Tracker``).

    Two tracked objects overlapping in the image are often detected as one box, and that box is the
    front one's: the other is behind it. Track k is in front of track i when k was seen (matched) on
    the previous frame and i was not -- i is hidden -- or both were and k's bottom edge is the lower
    (on a flat road the nearer object's is). The pair (track i, detection j) costs, over the tracks k
    in front of i that detection j could be (``ok[k, j]`` and of k's class), the largest product of
    the part of i's predicted box inside k's and the part of k's box inside the detection: a
    detection holding all of k is k's, however much of i it covers. Zero for a track no other
    covers, and for a detection holding little of the one in front.

    Args:
        trk: (N, 4) predicted track boxes, xyxy; seen: (N,) matched on the previous frame;
        trk_class: (N,) track classes; ok: (N, M) allowed pairs; det: (M, 4) detection boxes,
        xyxy; det_class: (M,) detection classes.
    """
    area = np.maximum((trk[:, 2] - trk[:, 0]) * (trk[:, 3] - trk[:, 1]), _TINY)
    cover = intersection_areas(trk, trk) / area[:, None]  # cover[i, k]: part of box i inside box k
    cover[~(seen[None, :] & (~seen[:, None] | (trk[:, 3][None, :] > trk[:, 3][:, None])))] = 0.0
    if not np.count_nonzero(cover):
        return np.zeros(ok.shape)
    # contain[k, j]: part of box k inside detection j, if j could be k's (an allowed pair, of k's class)
    contain = np.where(ok & (trk_class[:, None] == det_class), intersection_areas(trk, det) / area[:, None], 0.0)
    return (cover[:, :, None] * contain[None, :, :]).max(axis=1)


def _partly_hidden(det: np.ndarray, front: np.ndarray) -> np.ndarray:
    """(M,) whether each detection box (M, 4) overlaps one of the boxes ``front`` (K, 4) whose bottom
    edge is lower -- an object in front of it: the detection is a partial view (xyxy boxes)."""
    if not len(front):
        return np.zeros(len(det), dtype=bool)
    return ((intersection_areas(det, front) > 0.0) & (front[:, 3][None, :] > det[:, 3][:, None])).any(axis=1)


# ---------------------------------------------------------------- track table
# Live tracks are rows [0, n) of preallocated arrays, in birth order (the order
# association sees them in, as a list would); the integer fields are the
# columns of one (capacity, 8) array so that removing tracks is one copy per array.
# ``_LIMIT``: misses in a row after which the track is removed (by state).
_AGE, _TSU, _HITS, _STATE, _ID, _CLASS, _DET, _LIMIT = range(8)
_NUM_INT = 8
_TENTATIVE, _CONFIRMED, _LOST = int(TrackState.TENTATIVE), int(TrackState.CONFIRMED), int(TrackState.LOST)
_NO_ROWS = np.zeros(0, dtype=np.intp)
_NO_BOXES = np.zeros((0, 4))
# Gallery bookkeeping, the columns of ``Tracker._gal_meta`` (capacity, 3): features stored,
# next ring-buffer slot, ``frame_count`` of the newest feature.
_GCOUNT, _GHEAD, _GLAST = range(3)
_NEVER = -(2**40)  # ``_GLAST`` of an empty gallery


@dataclass(slots=True)
class _FrameDetections:
    """One frame's detections as association sees them (``Tracker._prepare``), M rows."""

    boxes: np.ndarray  # (M, 4) xyxy px
    meas: np.ndarray  # (M, 4) the boxes as cxcywh px (``_cxcywh``)
    scores: np.ndarray  # (M,)
    classes: np.ndarray  # (M,) class ids
    evidence: np.ndarray  # (M, W) class evidence (``Tracker._class_evidence``), duplicates folded in
    orig_index: np.ndarray | None  # (M,) row in the input ``Detections``; None: the same rows
    feats: np.ndarray | None  # (M, D) unit appearance features (NaN rows: none), or None


class _Matches(NamedTuple):
    """Matched (track row, detection row) pairs, in match order."""

    trk: np.ndarray
    det: np.ndarray
    jumped: np.ndarray | None  # (K,) appearance re-identifications (filter restarts); None without appearance


_NO_MATCHES = _Matches(_NO_ROWS, _NO_ROWS, None)


def _empty_tracks() -> Tracks:
    i = np.zeros(0, dtype=np.int64)
    return Tracks._trusted(
        track_id=i, xyxy=np.zeros((0, 4)), class_id=i.copy(), score=np.zeros(0), age=i.copy(), hits=i.copy(),
        state=i.copy(), det_index=i.copy(), velocity_px=np.zeros((0, 4)),
    )


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
        self.config = cfg = config or TrackerConfig()
        self.frame_rate = float(frame_rate)
        self.max_lost_frames = max(1, round(cfg.max_lost_s * self.frame_rate))
        out_s = cfg.output_lost_s
        self.output_lost_frames = (
            self.max_lost_frames if out_s is None else max(1, round(out_s * self.frame_rate))
        ) if cfg.output_lost else 0
        wp, wv = cfg.std_weight_position, cfg.std_weight_velocity
        wc = wv if cfg.std_weight_accel is None else cfg.std_weight_accel / self.frame_rate**2
        self._q_weights = np.array([wp] * 4 + [wc, wc, wv, wv])
        self._p_weights = np.array([2.0 * wp] * 4 + [cfg.init_velocity_std] * 4)
        self.reid_max_lost_frames = max(self.max_lost_frames, round(cfg.reid_max_lost_s * self.frame_rate))
        self.gallery_refresh_frames = max(1, round(cfg.gallery_refresh_s * self.frame_rate))
        self._newborn = np.zeros(_NUM_INT, dtype=np.int64)
        self._newborn[[_HITS, _STATE, _ID, _LIMIT]] = 1, _TENTATIVE, -1, cfg.tentative_max_lost_frames
        self.reset()

    def reset(self) -> None:
        """Forget all tracks, restart ids at 1 and zero the counters."""
        self._n = 0
        self._feat: np.ndarray | None = None
        self._gal: np.ndarray | None = None  # (capacity, gallery_size, D) float32 ring buffers, once features came
        self._gal_meta = np.zeros((0, 3), dtype=np.int64)  # (capacity, 3): _GCOUNT, _GHEAD, _GLAST
        # Anchors (with the galleries): each track's Kalman state and covariance right after the match that
        # gave its newest gallery feature, predicted on every frame since -- the motion model run from the
        # last confident view, for the re-id gate (``_reid_gate``).
        self._anc = np.zeros((0, 24))  # filter rows, as ``_kf``
        self._votes = np.zeros((0, 0))  # (capacity, classes + 1): column class_id + 1 (see _class_votes)
        self._alloc(16)
        self._next_id = 1
        self.frame_count = 0
        self.dropped_detections = 0
        self.merged_duplicates = 0
        self.reidentifications = 0

    @property
    def num_tracks(self) -> int:
        """Number of live tracks (tentative, confirmed and lost)."""
        return self._n

    # ------------------------------------------------------------ track table
    def _alloc(self, capacity: int) -> None:
        """(Re)allocate the track arrays with ``capacity`` rows, keeping rows [0, n)."""
        n = self._n
        kf = np.zeros((capacity, 24))  # Kalman filters: state x (8) and covariance blocks Pb (16) per row
        score, ints = np.zeros(capacity), np.zeros((capacity, _NUM_INT), dtype=np.int64)
        if n:
            kf[:n], score[:n], ints[:n] = self._kf[:n], self._score[:n], self._ints[:n]
        feat = None
        if self._feat is not None:
            feat = np.full((capacity, self._feat.shape[1]), np.nan)
            feat[:n] = self._feat[:n]
        votes = np.zeros((capacity, self._votes.shape[1]))
        votes[:n] = self._votes[:n]
        self._kf, self._score, self._ints, self._feat, self._votes = kf, score, ints, feat, votes
        if self._gal is not None:
            gal = np.zeros((capacity, *self._gal.shape[1:]), dtype=np.float32)
            meta = np.zeros((capacity, 3), dtype=np.int64)
            gal[:n], meta[:n] = self._gal[:n], self._gal_meta[:n]
            anc = np.zeros((capacity, 24))
            anc[:n] = self._anc[:n]
            self._gal, self._gal_meta, self._anc = gal, meta, anc
        self._views()

    _VIEWS = ("_x", "_P", "_anc_x", "_anc_P", "_track_id")

    def _views(self) -> None:
        """(Re)make the views into the track arrays: states ``_x`` (capacity, 8) and covariance blocks
        ``_P`` (capacity, 2, 2, 4) of the filter rows ``_kf`` (capacity, 24), the anchors' alike, ids."""
        self._x, self._P = _kf_views(self._kf)
        self._anc_x, self._anc_P = _kf_views(self._anc)
        self._track_id = self._ints[:, _ID]

    def __getstate__(self) -> dict:
        """Pickled (and deep-copied) without the views, which would become arrays of their own."""
        return {k: v for k, v in self.__dict__.items() if k not in self._VIEWS}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views()

    def _keep(self, keep: np.ndarray) -> None:
        """Remove the live rows where ``keep`` (n,) is False, preserving the order of the others."""
        n, m = self._n, int(np.count_nonzero(keep))
        arrays = (self._kf, self._score, self._ints, self._votes)
        arrays += () if self._feat is None else (self._feat,)
        arrays += () if self._gal is None else (self._gal, self._gal_meta, self._anc)
        for a in arrays:
            a[:m] = a[:n][keep]
        self._n = m

    def _features_of_dim(self, dim: int) -> np.ndarray:
        """The (capacity, dim) track features (NaN rows: no feature yet), reset if ``dim`` changed."""
        if self._feat is None or self._feat.shape[1] != dim:
            if self._feat is not None:
                log.warning("feature dimension changed from %d to %d: track features reset", self._feat.shape[1], dim)
            self._feat = np.full((len(self._x), dim), np.nan)
        return self._feat

    def _gallery_of_dim(self, dim: int) -> np.ndarray:
        """The (capacity, gallery_size, dim) galleries (``_gal_meta`` says which slots hold
        features), created empty on first use and emptied if ``dim`` changed."""
        if self._gal is None or self._gal.shape[2] != dim:
            if self._gal is not None:
                log.warning("feature dimension changed from %d to %d: galleries reset", self._gal.shape[2], dim)
            self._gal = np.zeros((len(self._x), self.config.gallery_size, dim), dtype=np.float32)
            self._gal_meta = np.zeros((len(self._x), 3), dtype=np.int64)
            self._gal_meta[:, _GLAST] = _NEVER
            self._anc = np.zeros((len(self._x), 24))
            self._views()
        return self._gal

    # ------------------------------------------------------------------ input
    def _valid_mask(self, b: np.ndarray, s: np.ndarray, bT: np.ndarray | None = None) -> np.ndarray | None:
        """Valid rows (finite coordinates and score, positive size, |coordinates| <= max_abs_coord); None if all are.
        ``bT``: the C-contiguous transpose of b (4, M), if at hand (its rows make the checks cheaper)."""
        limit = self.config.max_abs_coord
        # Fast path (count_nonzero is much cheaper than all() on small arrays); NaN fails <= limit.
        m = len(s)
        if (
            limit < np.inf
            and np.count_nonzero(np.abs(b) <= limit) == 4 * m
            and np.count_nonzero(b[:, 2:] > b[:, :2] if bT is None else bT[2:] > bT[:2]) == 2 * m
            and np.count_nonzero(np.isfinite(s)) == m
        ):
            return None
        with np.errstate(invalid="ignore", over="ignore"):
            ok = np.all(np.isfinite(b), axis=1) & np.isfinite(s)
            ok &= (b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1]) & np.all(np.abs(b) <= limit, axis=1)
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
    @staticmethod
    def _assign(cost: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Optimal (rows, cols) among the allowed (``ok``) entries of ``cost``."""
        if not np.count_nonzero(ok):
            return _NO_ROWS, _NO_ROWS
        rows, cols = linear_sum_assignment(np.where(ok, cost, _BIG_COST))
        keep = ok[rows, cols]
        if np.count_nonzero(keep) == len(keep):
            return rows, cols
        return rows[keep], cols[keep]

    def _class_gate(
        self, cost: np.ndarray, ok: np.ndarray, trk_class: np.ndarray, det_class: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``per_class`` cost and gate: other-class pairs barred, or charged ``class_switch_cost``."""
        same = trk_class[:, None] == det_class
        if self.config.class_switch_cost is None:
            return cost, ok & same
        if np.count_nonzero(same) == same.size:
            return cost, ok
        return np.where(same, cost, cost + self.config.class_switch_cost), ok

    def _appearance(
        self, cost: np.ndarray, ok: np.ndarray, feats: np.ndarray, lost: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Stage-1 cost and gate with appearance: cosine distance mixed in, lost tracks re-identified."""
        w = self.config.reid_weight
        trk_feats = self._features_of_dim(feats.shape[1])[: self._n]
        cos = 1.0 - trk_feats @ feats.T  # NaN where either feature is missing
        has = np.isfinite(cos)
        cost = np.where(has, (1.0 - w) * cost + w * cos, cost)
        ok |= lost[:, None] & has & (cos <= self.config.reid_max_distance)
        return cost, ok

    # ------------------------------------------------------- feature requests
    def wants_features(self, detections: Detections) -> bool:
        """Whether the next ``update(detections, ...)`` would use appearance features
        (``features_needed`` has a True row); False on most frames, so a caller embeds rarely."""
        return bool(np.count_nonzero(self.features_needed(detections)))

    def features_needed(self, detections: Detections) -> np.ndarray:
        """(N,) mask of the detections whose appearance features the next ``update`` would use.

        Call it before ``update`` with the same detections; pass features for at least the
        True rows (NaN rows, or None when no row is True, for the others). It predicts the
        tracks on copies (the tracker is unchanged) and marks valid detections scoring at
        least ``high_score`` that are

        * re-id candidates: left unmatched by (the IoU part of) stage 1, or matched there to a
          tentative track (a lost track may take that detection over), and inside the motion gate (``reid_gate``, of the prediction or of the
          anchor, ``_reid_gate``) of a lost track with a gallery (of the detection's class when
          ``class_switch_cost`` is null) -- the detections
          the re-id stage would look at;
        * refreshes: the best IoU match of a confirmed track whose gallery's newest feature is
          ``gallery_refresh_s`` old (or which has none), or half that old when the match touches a
          detection in front of it (lower bottom edge: the object is going behind it, so this is
          its last whole view, and the anchor's last chance before the occlusion -- measured: a
          child that broke into a run after the last refresh came out of hiding outside the gate of
          the stale anchor), if it overlaps no other detection by
          more than ``gallery_max_overlap`` (else its feature would not be stored). When any row
          is marked, tracks at half that age are refreshed too, so refreshes share embedder calls;
        * ambiguous, with ``reid_weight > 0`` only (appearance takes part in stage 1 only then):
          the detections overlapping a track's prediction that overlaps two or more detections at
          association IoU >= ``match_iou``, and those overlapping two or more predictions so. IoU
          margins do not tell: when two objects meet and part, the wrong pair often has the higher
          IoU (the constant-velocity prediction carries each track onto the other object).

        Cost: one (tracks x detections) IoU, a batched Kalman predict and, while lost tracks wait,
        one small Mahalanobis matrix: tens of microseconds. Empty when ``gallery_size`` is 0 and
        ``reid_weight`` is 0.
        """
        cfg = self.config
        m, n = len(detections), self._n
        need = np.zeros(m, dtype=bool)
        if not m or not n or (cfg.gallery_size == 0 and cfg.reid_weight <= 0):
            return need
        ints = self._ints[:n]
        state, tsu = ints[:, _STATE], ints[:, _TSU] + 1  # time since update at the coming update
        gallery = self._gal is not None  # (only ever created with gallery_size > 0)
        lost = ((state == _LOST) & (self._gal_meta[:n, _GCOUNT] > 0)).nonzero()[0] if gallery else _NO_ROWS
        age = np.zeros(n, dtype=np.int64)  # of the newest gallery feature at the coming update
        if cfg.gallery_size > 0:
            last = np.where(self._gal_meta[:n, _GCOUNT] > 0, self._gal_meta[:n, _GLAST], _NEVER) if gallery else _NEVER
            age += self.frame_count + 1 - last
        due = self.gallery_refresh_frames
        half = (due + 1) // 2
        if cfg.reid_weight <= 0 and not len(lost) and not np.count_nonzero((state == _CONFIRMED) & (age >= half)):
            return need  # the common, easy frame: decided without touching the detections
        boxes = np.asarray(detections.xyxy, dtype=np.float64).reshape(-1, 4)
        scores = np.asarray(detections.score, dtype=np.float64).reshape(-1)
        valid = self._valid_mask(boxes, scores)
        with np.errstate(invalid="ignore"):
            cand = scores >= cfg.high_score
        if valid is not None:
            cand &= valid
        drows = cand.nonzero()[0]
        if not len(drows):
            return need
        b = boxes[drows]
        meas = _cxcywh(b)
        x, P = _kf_views(self._predicted(self._kf[:n]))  # what update's _predict will compute
        iou = self._association_iou(x, meas, cfg.match_buffer)  # the IoU stage 1 uses with galleries
        if gallery:  # tracks kept for re-id only take no part in IoU association
            iou[tsu > self.max_lost_frames + 1] = 0.0
        hit = iou >= cfg.match_iou
        dneed = np.zeros(len(drows), dtype=bool)
        if len(lost):
            # Stage 1 as update will run it (IoU part): the detections it leaves unmatched, or gives to
            # a tentative track (which a lost track may take over), are the re-id stage's candidates.
            cost, ok = 1.0 - iou, hit
            if cfg.per_class:
                cost, ok = self._class_gate(cost, ok, ints[:, _CLASS], np.asarray(detections.class_id)[drows])
            if n > 1:
                cost = cost + _occlusion_cost(x @ _STATE_TO_XYXY, state == _CONFIRMED, ints[:, _CLASS], ok, b,
                                              np.asarray(detections.class_id)[drows])
            trk, col = self._assign(cost, ok)
            free = np.ones(len(drows), dtype=bool)
            free[col[state.take(trk) != _TENTATIVE]] = False
            if np.count_nonzero(free):
                ax, aP = _kf_views(self._predicted(self._anc[lost]))
                gate = self._motion_gate(x[lost], P[lost], meas) | self._motion_gate(ax, aP, meas)
                if cfg.per_class and cfg.class_switch_cost is None:
                    gate &= ints[lost, _CLASS][:, None] == np.asarray(detections.class_id)[drows]
                dneed |= free & gate.any(axis=0)
        if cfg.reid_weight > 0:  # ambiguous: a track hitting two detections, or a detection two tracks
            multi = np.count_nonzero(hit, axis=1) >= 2
            if np.count_nonzero(multi):
                dneed |= hit[multi].any(axis=0)
            dneed |= np.count_nonzero(hit, axis=0) >= 2
        if cfg.gallery_size > 0:
            conf = (state == _CONFIRMED) & hit.any(axis=1)
            if np.count_nonzero(conf):
                # going behind: the track's detection touches a detection in front of it (lower bottom edge)
                hiding = conf & (age >= half)
                if np.count_nonzero(hiding):
                    rows = hiding.nonzero()[0]
                    hiding[rows] = _partly_hidden(b[np.where(hit[rows], iou[rows], -1.0).argmax(axis=1)], b)
                if np.count_nonzero(conf & (age >= due)) or np.count_nonzero(dneed) or np.count_nonzero(hiding):
                    refresh = (conf & (age >= half)).nonzero()[0]  # this frame embeds: bunch them
                    best = np.where(hit[refresh], iou[refresh], -1.0).argmax(axis=1)
                    vb = boxes if valid is None else boxes[valid]
                    if len(vb) > 1:  # its own box overlaps itself (IoU 1): the runner-up is the other object
                        ov = _iou(b[best], vb, box_area(vb))
                        best = best[np.sort(ov, axis=1)[:, -2] <= cfg.gallery_max_overlap]
                    dneed[best] = True
        need[drows[dneed]] = True
        return need

    # ---------------------------------------------------------------- update
    def update(self, detections: Detections, features: np.ndarray | None = None) -> Tracks:
        """Advance one frame with this frame's detections; return the tracks to output.

        The steps of the module docstring, in order: ``_prepare``, ``_predict``,
        ``_associate_high``, ``_associate_low``, ``_apply_matches``, ``_prune``, ``_birth``,
        ``_output``.

        Args:
            detections: this frame's detections (invalid rows are dropped and counted).
            features: optional (N, D) appearance embeddings, one row per detection (NaN rows:
                none, e.g. those ``features_needed`` did not ask for); used when
                ``config.reid_weight > 0`` (stage 1) or ``config.gallery_size > 0`` (galleries, re-id stage).
        """
        cfg = self.config
        self.frame_count += 1
        d = self._prepare(detections, features)
        n = self._predict()
        m = len(d.boxes)
        if m == 0:
            if n:
                self._prune(n)
            return self._output()
        meas = d.meas  # [cx, cy, w, h]
        is_high = d.scores >= cfg.high_score
        high = is_high.nonzero()[0]
        all_high = len(high) == m
        low = _NO_ROWS if all_high else ((d.scores >= cfg.low_score) & ~is_high).nonzero()[0]
        matches, unmatched_high = _NO_MATCHES, high
        if n:
            # appearance: one buffered pass (stages 1 and 2); the occlusion cost and re-id settle overlaps
            one_pass = self._gal is not None or cfg.match_buffer <= 0
            iou = self._association_iou(self._x[:n], meas, cfg.match_buffer if self._gal is not None else 0.0)
            if len(high):
                barred = self._kept_for_reid(n)
                matches, unmatched_high = self._associate_high(iou, d, high, all_high, barred)
                if len(unmatched_high) and not one_pass:
                    matches, unmatched_high = self._associate_buffered(n, meas, d, unmatched_high, matches, barred)
            if len(low):
                matches = self._associate_low(iou, d, low, matches)
            if d.feats is not None and self._gal is not None and (
                len(unmatched_high) or np.count_nonzero(self._ints.take(matches.trk, axis=0)[:, _STATE] == _TENTATIVE)
            ):
                matches, unmatched_high = self._associate_reid(n, d, meas, unmatched_high, matches)
        if len(matches.trk):
            self._apply_matches(matches, d, meas)
        if n:
            self._prune(n)
        self._birth(unmatched_high, d, meas)
        return self._output()

    def _prepare(self, detections: Detections, features: np.ndarray | None) -> _FrameDetections:
        """Step 1: drop invalid detections and fold duplicates into their leaders (both counted)."""
        cfg = self.config
        boxes, scores, classes = detections.xyxy, detections.score, detections.class_id
        use = cfg.reid_weight > 0 or cfg.gallery_size > 0
        feats = self._clean_features(features, len(boxes)) if use else None
        orig_index = None  # row in ``detections`` of each valid row (None: the same rows)
        meas = _NO_BOXES
        if len(boxes):
            bT = boxes.T.copy()
            valid = self._valid_mask(boxes, scores, bT)
            if valid is not None:
                self.dropped_detections += len(valid) - int(np.count_nonzero(valid))
                orig_index = np.flatnonzero(valid)
                boxes, scores, classes, bT = boxes[valid], scores[valid], classes[valid], None
                if feats is not None:
                    feats = feats[valid]
            meas = _cxcywh(boxes, bT)
        evidence = self._class_evidence(classes, scores)
        if cfg.duplicate_iou is not None and len(boxes) > 1:
            lead = self._merge_duplicates(boxes, scores, classes, evidence)
            if lead is not None:
                self.merged_duplicates += len(lead) - int(np.count_nonzero(lead))
                orig_index = np.flatnonzero(lead) if orig_index is None else orig_index[lead]
                boxes, scores, classes, evidence = boxes[lead], scores[lead], classes[lead], evidence[lead]
                meas = _cxcywh(boxes)
                if feats is not None:
                    feats = feats[lead]
        return _FrameDetections(boxes, meas, scores, classes, evidence, orig_index, feats)

    def _predict(self) -> int:
        """Step 2: predict every track one frame; drop filters that are no longer finite. Returns n."""
        n = self._n
        if n:
            T = self._kf[:n].T.copy()  # one filter per column (box_filters_predict)
            box_filters_predict(T, self._q_weights)
            self._kf[:n] = T.T
            if self._gal is not None:
                self._anc[:n] = self._predicted(self._anc[:n])
            ints = self._ints[:n]
            ints[:, _AGE] += 1  # (one column at a time: cheaper than a 2-d slice)
            ints[:, _TSU] += 1
            ints[:, _DET] = -1
            if np.count_nonzero(np.isfinite(T)) < T.size:
                self._keep(np.isfinite(T).all(axis=0))
                n = self._n
        return n

    def _predicted(self, kf: np.ndarray) -> np.ndarray:
        """Filter rows kf (N, 24) predicted one frame (``box_filters_predict``), as new (N, 24) rows."""
        T = kf.T.copy()
        box_filters_predict(T, self._q_weights)
        return T.T

    def _association_iou(self, x: np.ndarray, meas: np.ndarray, buffer: float = 0.0) -> np.ndarray:
        """(N, M) IoU of the tracks whose predicted states are ``x`` (N, 8) and the detections
        (``meas``, cxcywh), each box grown by ``buffer`` of its size per side (0: tight;
        ``match_buffer``: buffered), then to at least ``min_match_size`` px."""
        boxes = np.concatenate([x[:, :4].T, meas.T], axis=1)  # (4, N + M): tracks, then detections (cxcywh)
        size = boxes[2:]
        if buffer:
            size = size * (1.0 + 2.0 * buffer)
        return _iou_centred(boxes[:2], np.maximum(size, self.config.min_match_size) * 0.5, len(x))

    def _associate_buffered(
        self, n: int, meas: np.ndarray, d: _FrameDetections, rows: np.ndarray, matches: _Matches,
        barred: np.ndarray | None,
    ) -> tuple[_Matches, np.ndarray]:
        """Step 3, stage 1b: the high-score detections stage 1 left (``rows``) against the tracks it
        left that are not lost, on the buffered IoU (``match_buffer``); returns ``matches`` extended
        and the rows still unmatched.

        Buffered boxes reach a box that moved or grew faster than its prediction -- a near object
        crossing, or closing in -- but also a neighbour: a crowd's people overlap once buffered. So
        every pair that overlaps unbuffered is settled first (stage 1), and a lost track, whose
        prediction has drifted for a while, is never recovered through the buffer.
        """
        bar = self._ints[:n, _STATE] == _LOST
        if barred is not None:
            bar |= barred
        bar[matches.trk] = True
        if bar.all():
            return matches, rows
        more, rows = self._associate_high(
            self._association_iou(self._x[:n], meas, self.config.match_buffer), d, rows, False, bar)
        if not len(more.trk):
            return matches, rows
        jumped = None if matches.jumped is None else np.concatenate([matches.jumped, more.jumped])
        return _Matches(np.concatenate([matches.trk, more.trk]), np.concatenate([matches.det, more.det]), jumped), rows

    def _associate_high(
        self, iou: np.ndarray, d: _FrameDetections, high: np.ndarray, all_high: bool, barred: np.ndarray | None = None
    ) -> tuple[_Matches, np.ndarray]:
        """Step 3, stage 1: high-score detections (rows ``high``) against every track; returns the
        matches and the high rows left unmatched.

        Cost ``1 - IoU`` gated at ``match_iou``; with appearance (``_appearance``) the
        cosine distance is mixed in and a lost track may be recovered outside the IoU gate,
        within the same optimal assignment (``jumped``: its filter restarts at the detection).
        Tracks ``barred`` (mask, or None) take no part: those kept for the re-id stage only. Once
        galleries exist, the occlusion cost (``_occlusion_cost``) is added.
        """
        cfg = self.config
        ints = self._ints[: len(iou)]
        iou1 = iou if all_high else iou.take(high, axis=1)
        ok = iou1 >= cfg.match_iou
        cost = 1.0 - iou1
        mixed = d.feats is not None and cfg.reid_weight > 0
        if mixed:
            cost, ok = self._appearance(cost, ok, d.feats.take(high, axis=0), ints[:, _STATE] == _LOST)
        if cfg.per_class:
            cost, ok = self._class_gate(cost, ok, ints[:, _CLASS], d.classes if all_high else d.classes.take(high))
        if barred is not None:
            ok[barred] = False
        if self._gal is not None and len(iou) > 1:
            cost = cost + _occlusion_cost(
                self._x[: len(iou)] @ _STATE_TO_XYXY, ints[:, _STATE] == _CONFIRMED, ints[:, _CLASS], ok,
                d.boxes if all_high else d.boxes.take(high, axis=0), d.classes if all_high else d.classes.take(high))
        trk, cols = self._assign(cost, ok)
        det = cols if all_high else high.take(cols)
        # A match below the IoU gate is an appearance re-identification:
        # the motion model was wrong, so the filter restarts at the detection.
        jumped = iou1[trk, cols] < cfg.match_iou if mixed else None
        if len(cols) == len(high):
            unmatched = _NO_ROWS
        elif len(cols):
            free = np.ones(len(high), dtype=bool)
            free[cols] = False
            unmatched = high[free]
        else:
            unmatched = high
        return _Matches(trk, det, jumped), unmatched

    def _associate_low(self, iou: np.ndarray, d: _FrameDetections, low: np.ndarray, matches: _Matches) -> _Matches:
        """Step 4, stage 2: low-score detections (rows ``low``) against the confirmed tracks
        stage 1 left over, IoU only (gated at ``second_match_iou``); returns ``matches`` extended."""
        cfg = self.config
        ints = self._ints[: len(iou)]
        rest = ints[:, _STATE] == _CONFIRMED
        rest[matches.trk] = False
        rest = rest.nonzero()[0]
        if not len(rest):
            return matches
        iou2 = iou.take(rest, axis=0).take(low, axis=1)
        ok = iou2 >= cfg.second_match_iou
        cost2 = 1.0 - iou2
        if cfg.per_class:
            cost2, ok = self._class_gate(cost2, ok, ints[:, _CLASS].take(rest), d.classes.take(low))
        rows, cols = self._assign(cost2, ok)
        if not len(rows):
            return matches
        trk, det, jumped = matches
        if jumped is not None:
            jumped = np.concatenate([jumped, np.zeros(len(rows), dtype=bool)])
        return _Matches(np.concatenate([trk, rest.take(rows)]), np.concatenate([det, low.take(cols)]), jumped)

    def _kept_for_reid(self, n: int) -> np.ndarray | None:
        """Mask of the tracks lost longer than ``max_lost_s`` -- kept only for the re-id stage,
        barred from IoU association -- or None if there are none."""
        if self._gal is None:
            return None
        barred = self._ints[:n, _TSU] > self.max_lost_frames + 1  # the tracks _prune would have removed
        return barred if np.count_nonzero(barred) else None

    def _associate_reid(
        self, n: int, d: _FrameDetections, meas: np.ndarray, unmatched: np.ndarray, matches: _Matches
    ) -> tuple[_Matches, np.ndarray]:
        """Re-id stage: lost tracks with a gallery that the IoU stages left over against the
        high-score detections with a feature that are unmatched or matched to a *tentative* track;
        returns ``matches`` updated and the rows still unmatched.

        Cost: the smallest cosine distance between the detection's feature and the track's gallery
        (plus ``class_switch_cost`` for another class with ``per_class``), accepted at or below
        ``reid_max_distance`` (without the switch cost for a partial view, ``_partly_hidden``: overlapping
        a detection in front of it matched this frame), gated by motion
        (``_reid_gate``), with ``per_class`` and no ``class_switch_cost`` by class, and by the appearance veto: a pair is refused when the
        detection's feature is nearer to the gallery of another track not matched by IoU this frame
        (lost, or confirmed and missed; any distance, no gate) -- it looks like that object, not
        this one. One optimal assignment over all pairs.

        A lost track that takes a tentative track's detection takes over: the tentative track (a
        reappearance first seen outside the gate or unrecognised, e.g. half hidden) is dropped
        before it was ever confirmed or output (``_prune`` removes it), so no id is spent on it.

        Matched tracks get a Kalman update, not a restart: inside the gate the detection is
        consistent with the prediction, and the covariance grown over the time lost lets the update
        correct the velocity to the mean motion across the gap. A track gated in only by its anchor
        (its prediction was spoilt, see ``_reid_gate``) first takes the anchor's state.
        """
        cfg = self.config
        if d.feats.shape[1] != self._gal.shape[2]:
            return matches, unmatched
        ints = self._ints[:n]
        has_gal = self._gal_meta[:n, _GCOUNT] > 0
        taken = np.zeros(n, dtype=bool)
        taken[matches.trk] = True
        rows = ((ints[:, _STATE] == _LOST) & has_gal & ~taken).nonzero()[0]
        if not len(rows):
            return matches, unmatched
        mtrk, mdet = matches.trk, matches.det
        tent = ints.take(mtrk, axis=0)[:, _STATE] == _TENTATIVE  # their detections may be taken over
        cols = np.concatenate([unmatched, mdet[tent]])  # candidate detections
        f = d.feats.take(cols, axis=0)
        good = np.isfinite(f[:, 0])  # _clean_features makes a bad row all NaN
        if not np.count_nonzero(good):
            return matches, unmatched
        pos = good.nonzero()[0]
        cols = cols.take(pos)
        f = f[good]
        rivals = (has_gal & ~taken & (ints[:, _STATE] != _TENTATIVE)).nonzero()[0]  # rows superset
        dist = self._gallery_distance(rivals, f)  # (R, U)
        cost = dist[np.searchsorted(rivals, rows)]
        ok = cost <= cfg.reid_max_distance
        if cfg.per_class:
            cost, ok = self._class_gate(cost, ok, ints[rows, _CLASS], d.classes.take(cols))
            strict = cost <= cfg.reid_max_distance  # the switch cost counts against the bar...
            if np.count_nonzero(ok & ~strict):  # ...unless the detection is a partial view (module docstring)
                strict |= _partly_hidden(d.boxes.take(cols, axis=0), d.boxes.take(mdet[~tent], axis=0))
            ok &= strict
        if len(rivals) > len(rows) and np.count_nonzero(ok):  # veto: another track's gallery is nearer
            ok &= dist[np.searchsorted(rivals, rows)] <= dist.min(axis=0)
        anchored = None
        if np.count_nonzero(ok):
            now, anchored = self._reid_gate(rows, meas.take(cols, axis=0))
            ok &= now | anchored
            anchored &= ~now
        r, c = self._assign(cost, ok)
        if not len(r):
            return matches, unmatched
        self.reidentifications += len(r)
        trk, det = rows[r], cols[c]
        if anchored is not None and np.count_nonzero(anchored[r, c]):
            a = trk[anchored[r, c]]
            self._kf[a] = self._anc[a]
        keep = ~np.isin(mdet, det)  # tentative tracks whose detection a lost track takes over
        if np.count_nonzero(~keep):
            self._ints[mtrk[~keep], _LIMIT] = -1  # unmatched now: _prune removes them
        jumped = matches.jumped
        if jumped is not None:
            jumped = np.concatenate([jumped[keep], np.zeros(len(r), dtype=bool)])
        free = ~np.isin(unmatched, det)
        return _Matches(np.concatenate([matches.trk[keep], trk]), np.concatenate([matches.det[keep], det]),
                        jumped), unmatched[free]

    def _reid_gate(self, rows: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(L, U) motion gates of the tracks ``rows`` for boxes z (U, 4, cxcywh): inside ``reid_gate`` of
        the track's prediction, and of its anchor's.

        The anchor is the track's filter as it was after its newest gallery feature's match (a
        confident, unoccluded view), predicted since. An object going behind an occluder is often
        detected shrinking for a few frames (only its visible part), which drives the filter's size
        towards zero and its size rates negative; the prediction then collapses to a point, its
        covariance (which scales with the box size) to almost nothing, and the object coming out
        at full size is far outside that gate. The anchor never saw those partial boxes.
        """
        now = self._motion_gate(self._x[rows], self._P[rows], z)
        return now, self._motion_gate(self._anc_x[rows], self._anc_P[rows], z)

    def _pair_distance(self, trk: np.ndarray, f: np.ndarray) -> np.ndarray:
        """(K,) smallest cosine distance between the gallery of track ``trk[k]`` (non-empty) and unit feature f[k]."""
        gal = self._gal
        sim = np.einsum("tkd,td->tk", gal[trk], f.astype(np.float32))
        sim = np.where(np.arange(gal.shape[1]) < self._gal_meta[trk, _GCOUNT][:, None], sim, -np.inf)
        return 1.0 - sim.max(axis=1).astype(np.float64)

    def _gallery_distance(self, rows: np.ndarray, f: np.ndarray) -> np.ndarray:
        """(L, U) smallest cosine distance between the galleries of tracks ``rows`` and unit features f (U, D)."""
        sim = self._gal[rows] @ f.T.astype(np.float32)  # (L, K, U)
        stored = np.arange(sim.shape[1]) < self._gal_meta[rows, _GCOUNT][:, None]
        sim = np.where(stored[:, :, None], sim, -np.inf)
        return 1.0 - sim.max(axis=1).astype(np.float64)

    def _motion_gate(self, x: np.ndarray, Pb: np.ndarray, z: np.ndarray) -> np.ndarray:
        """(L, U) whether boxes z (U, 4, cxcywh) lie within ``reid_gate`` (squared Mahalanobis distance,
        innovation covariance ``H P H' + R``) of the predicted states x (L, 8), covariance blocks Pb
        (L, 2, 2, 4, ``kf_block``)."""
        S = kf_unblock(Pb)[:, :4, :4].copy()
        S.reshape(len(S), 16)[:, ::5] += kf_measurement_noise(x, self.config.std_weight_position)
        y = z[None, :, :] - x[:, None, :4]  # (L, U, 4)
        d2 = np.einsum("lui,lij,luj->lu", y, np.linalg.inv(S), y)
        return d2 <= self.config.reid_gate

    def _gallery_add(self, trk: np.ndarray, det: np.ndarray, d: _FrameDetections) -> None:
        """Push the features of detections ``det`` into the galleries of tracks ``trk`` (each once):
        only finite features of detections scoring at least ``high_score``, overlapping no other
        detection by more than ``gallery_max_overlap`` and, when the gallery holds features, within
        ``reid_max_distance`` of one of them (an object half behind an undetected occluder is boxed
        whole-looking but its crop is not: such a view must neither enter the gallery nor move the
        anchor). Sets the anchors (``_reid_gate``) of the tracks whose gallery took a feature."""
        cfg = self.config
        f = d.feats.take(det, axis=0)
        ok = np.isfinite(f[:, 0]) & (d.scores.take(det) >= cfg.high_score)
        if not np.count_nonzero(ok):
            return
        trk, det, f = trk[ok], det[ok], f[ok]
        if len(d.boxes) > 1:
            ov = _iou(d.boxes.take(det, axis=0), d.boxes, box_area(d.boxes))
            ov[np.arange(len(det)), det] = 0.0
            clear = ov.max(axis=1) <= cfg.gallery_max_overlap
            trk, f = trk[clear], f[clear]
            if not len(trk):
                return
        gal = self._gallery_of_dim(f.shape[1])
        meta = self._gal_meta
        count = meta[trk, _GCOUNT]
        if np.count_nonzero(count):  # a view unlike the gallery (a partial or mixed crop) is not stored
            alike = count == 0
            alike[~alike] = self._pair_distance(trk[~alike], f[~alike]) <= cfg.reid_max_distance
            if not np.count_nonzero(alike):
                meta[trk, _GLAST] = self.frame_count  # looked at: the next refresh is due in gallery_refresh_s
                return
            meta[trk[~alike], _GLAST] = self.frame_count
            trk, f = trk[alike], f[alike]
        slot = meta[trk, _GHEAD]
        gal[trk, slot] = f
        meta[trk, _GHEAD] = (slot + 1) % cfg.gallery_size
        meta[trk, _GCOUNT] = np.minimum(meta[trk, _GCOUNT] + 1, cfg.gallery_size)
        meta[trk, _GLAST] = self.frame_count
        self._anc[trk] = self._kf[trk]

    def _apply_matches(self, matches: _Matches, d: _FrameDetections, meas: np.ndarray) -> None:
        """Update the matched tracks (rows ``trk``, each once) with their detections ``det``, in pair order."""
        trk, det, jumped = matches
        upd, det_upd = trk, det
        if jumped is not None and np.count_nonzero(jumped):
            self._x[trk[jumped]], self._P[trk[jumped]] = box_block_initial_state(meas[det[jumped]], self._p_weights)
            upd, det_upd = trk[~jumped], det[~jumped]
        if len(upd):
            T = self._kf.take(upd, axis=0).T.copy()  # one filter per column (box_filters_update)
            box_filters_update(T, meas.T.take(det_upd, axis=1), self.config.std_weight_position)
            self._kf[upd] = T.T
        self._score[trk] = d.scores.take(det)
        ints = self._ints.take(trk, axis=0)
        ints[:, _HITS] += 1
        ints[:, _TSU] = 0
        ints[:, _CLASS] = self._class_votes(trk, d, det, decay=True, current=ints[:, _CLASS])
        ints[:, _DET] = det if d.orig_index is None else d.orig_index.take(det)
        state = ints[:, _STATE]
        np.minimum(state, _CONFIRMED, out=state)  # lost -> confirmed (tentative 0 < confirmed 1 < lost 2)
        confirm = (state == _TENTATIVE).nonzero()[0]
        if len(confirm):
            confirm = confirm[ints[confirm, _HITS] >= self.config.min_hits]
        if len(confirm):  # ids in match order
            state[confirm] = _CONFIRMED
            ints[confirm, _ID] = np.arange(self._next_id, self._next_id + len(confirm))
            ints[confirm, _LIMIT] = self.max_lost_frames
            self._next_id += len(confirm)
        self._ints[trk] = ints
        if d.feats is not None:
            self._update_features(trk, d.feats[det])
            if self.config.gallery_size > 0:
                self._gallery_add(trk, det, d)

    def _update_features(self, trk: np.ndarray, f: np.ndarray) -> None:
        """Moving-average the features of tracks ``trk`` with their detections' features f (NaN rows skipped)."""
        good = np.isfinite(f).all(axis=1)
        if not np.count_nonzero(good):
            return
        trk, f = trk[good], f[good]
        store = self._features_of_dim(f.shape[1])
        old = store[trk]
        m = self.config.feature_momentum
        mixed = m * old + (1.0 - m) * f
        mixed /= np.maximum(np.linalg.norm(mixed, axis=1, keepdims=True), 1e-12)
        store[trk] = np.where(np.isnan(old[:, :1]), f, mixed)  # first feature: taken as is

    def _class_evidence(self, classes: np.ndarray, scores: np.ndarray) -> np.ndarray:
        """(M, W) class evidence of detections: each one's score (at least 1e-6, so a zero
        score still counts) in column ``class_id + 1`` (column 0: any negative, unknown,
        class); W covers the track votes' columns and these classes (the votes grow to W)."""
        m, width = len(classes), self._votes.shape[1]
        if not m:
            return np.zeros((0, width))
        col = np.maximum(classes, -1) + 1
        top = int(np.maximum.reduce(col))
        if top >= width:
            width = top + 1
            grown = np.zeros((len(self._votes), width))
            grown[:, : self._votes.shape[1]] = self._votes
            self._votes = grown
        evidence = np.zeros((m, width))
        col += np.arange(0, m * width, width)  # flat index of (row, column)
        evidence.reshape(-1)[col] = np.maximum(scores, 1e-6)
        return evidence

    def _merge_duplicates(
        self, boxes: np.ndarray, scores: np.ndarray, classes: np.ndarray, evidence: np.ndarray
    ) -> np.ndarray | None:
        """Fold duplicate detections (``duplicate_iou``) into their leaders' ``evidence`` (in place).

        A detection at or above ``low_score`` leads unless a higher-scoring one of another
        class (ties: the earlier row) overlaps it by more than ``duplicate_iou``; a non-leader
        overlapping a leader so joins the highest-scoring such leader, and one that
        overlaps only non-leaders leads after all (greedy NMS to depth two). Returns the
        (M,) mask of the detections to keep, or None when every one is kept.
        """
        cfg = self.config
        if not np.count_nonzero(classes != classes[0]):
            return None  # one class: nothing is another class's duplicate
        active = scores >= cfg.low_score
        if np.count_nonzero(active) < 2:
            return None
        g = boxes
        if cfg.min_match_size > 0:  # geometry.grow_boxes(boxes, min_match_size), same arithmetic
            centre = (boxes[:, :2] + boxes[:, 2:]) / 2.0
            half = np.maximum(boxes[:, 2:] - boxes[:, :2], cfg.min_match_size) / 2.0
            g = np.concatenate([centre - half, centre + half], axis=1)
        wh = g[:, 2:] - g[:, :2]  # >= 0: geometry.box_area's clipping changes nothing
        over = _iou(g, g, wh[:, 0] * wh[:, 1]) > cfg.duplicate_iou
        over &= classes[:, None] != classes  # the detector's own NMS already settled one class's overlaps
        if not np.count_nonzero(over):
            return None  # no two classes overlap: the usual frame
        m = len(boxes)
        rows = np.arange(m)
        higher = (scores[:, None] > scores) | ((scores[:, None] == scores) & (rows[:, None] < rows))
        over &= higher & active[:, None] & active  # over[i, j]: i suppresses j
        leader = ~over.any(axis=0)
        joins = over & leader[:, None]
        follower = joins.any(axis=0)
        if not np.count_nonzero(follower):
            return None
        f = np.flatnonzero(follower)
        to = np.where(joins[:, f], scores[:, None], -np.inf).argmax(axis=0)
        np.add.at(evidence, to, evidence[f])
        return ~follower

    def _class_votes(
        self, rows: np.ndarray, d: _FrameDetections, det: np.ndarray, decay: bool, current: np.ndarray | None = None
    ) -> np.ndarray:
        """Add the class evidence of detections ``det`` (``_class_evidence``) to the votes of tracks
        ``rows``; their classes (the detections' own when ``class_memory`` is 0).

        A new track (``decay`` False) starts from its detection alone; a matched one keeps
        its ``current`` class unless another's votes beat it by ``class_hysteresis``.
        """
        m = self.config.class_memory
        if m <= 0.0:
            return d.classes.take(det)
        votes = d.evidence.take(det, axis=0)  # a new array
        if decay:
            votes = self._votes.take(rows, axis=0) * m + votes
        self._votes[rows] = votes
        best = votes.argmax(axis=1) - 1  # class ids
        if current is None or self.config.class_hysteresis <= 1.0 or not np.count_nonzero(best != current):
            return best  # (the last: the usual case, the current class still leads)
        idx = np.arange(len(rows))
        keep = votes[idx, best + 1] <= self.config.class_hysteresis * votes[idx, current + 1]
        return np.where(keep, current, best)

    def _prune(self, n: int) -> None:
        """Tracks among the first n rows not matched this frame: remove the expired, the others turn lost."""
        ints = self._ints[:n]
        tsu = ints[:, _TSU]
        missed = tsu > 0
        if not np.count_nonzero(missed):
            return
        state = ints[:, _STATE]
        state[missed & (state == _CONFIRMED)] = _LOST
        limit = ints[:, _LIMIT]  # tentative_max_lost_frames or max_lost_frames
        if self._gal is not None:  # lost tracks with a gallery wait longer, for the re-id stage
            long = (self._gal_meta[:n, _GCOUNT] > 0) & (state != _TENTATIVE)
            if np.count_nonzero(long):
                limit = np.where(long, np.maximum(limit, self.reid_max_lost_frames), limit)
        drop = tsu > limit
        if np.count_nonzero(drop):
            self._keep(~drop)

    def _birth(self, unmatched_high: np.ndarray, d: _FrameDetections, meas: np.ndarray) -> None:
        """Step 5: start tentative tracks at the unmatched high-score detections scoring at
        least ``new_track_score``, appended in row order."""
        new = unmatched_high
        if self.config.new_track_score > self.config.high_score:
            new = new[d.scores.take(new) >= self.config.new_track_score]
        if not len(new):
            return
        n, k = self._n, len(new)
        if n + k > len(self._x):
            self._alloc(max(2 * len(self._x), n + k))
        rows = slice(n, n + k)
        self._x[rows], self._P[rows] = box_block_initial_state(meas.take(new, axis=0), self._p_weights)
        self._score[rows] = d.scores.take(new)
        ints = self._ints[rows]
        ints[:] = self._newborn  # age 0, one hit, tentative, no id
        ints[:, _CLASS] = self._class_votes(np.arange(n, n + k), d, new, decay=False)
        ints[:, _DET] = new if d.orig_index is None else d.orig_index.take(new)
        if d.feats is not None:
            f = d.feats[new]
            self._features_of_dim(f.shape[1])[rows] = np.where(np.isfinite(f).all(axis=1, keepdims=True), f, np.nan)
        elif self._feat is not None:
            self._feat[rows] = np.nan
        if self._gal is not None:
            self._gal_meta[rows] = (0, 0, _NEVER)
        self._n = n + k
        if d.feats is not None and self.config.gallery_size > 0:
            self._gallery_add(np.arange(n, n + k), new, d)
        if self.config.min_hits <= 1:
            self._ints[rows, _STATE] = _CONFIRMED
            self._ints[rows, _ID] = np.arange(self._next_id, self._next_id + k)
            self._ints[rows, _LIMIT] = self.max_lost_frames
            self._next_id += k

    def _output(self) -> Tracks:
        """Confirmed tracks and lost ones missed for at most ``output_lost_frames``, by id."""
        n = self._n
        ints = self._ints[:n]
        # A confirmed track has been matched this frame (time since update 0), a
        # lost one has not (>= 1), so one bound on the time since update does both.
        rows = ((ints[:, _STATE] != _TENTATIVE) & (ints[:, _TSU] <= self.output_lost_frames)).nonzero()[0]
        if not len(rows):
            return _empty_tracks()
        if len(rows) > 1:
            rows = rows.take(self._track_id.take(rows).argsort(kind="stable"))
        x = self._x.take(rows, axis=0)
        cols = self._ints.take(rows, axis=0).T.copy()
        return Tracks._trusted(
            track_id=cols[_ID],
            xyxy=x @ _STATE_TO_XYXY,
            class_id=cols[_CLASS],
            score=self._score.take(rows),
            age=cols[_AGE],
            hits=cols[_HITS],
            state=cols[_STATE],
            det_index=cols[_DET],
            velocity_px=x[:, 4:] * self.frame_rate,
        )
