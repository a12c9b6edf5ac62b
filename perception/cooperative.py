"""Cooperative perception: objects another vehicle saw, brought into the ego's frame and fused.

The fourth source design's fusion node, as three small steps on struct-of-arrays
``ObjectList``s (positions on the ground, m):

1. ``to_frame``: a ``SharedObjects`` message (the design's ``DetectionsWithOdom``: the
   sender, its capture time, its world pose, its objects in its own ego frame) into the
   receiver's ego frame *at the receiver's current time*: every object moved on by its own
   velocity over the message's age (constant velocity), the sender's pose (world) to the
   receiver's; the covariance rotated with it and grown by the motion's uncertainty over
   the age (``accel_sigma``).
2. ``match``: the receiver's objects against one sender's, by the Hungarian assignment on
   the Mahalanobis distance of their combined covariance, gated (chi-square, 2 dof) and
   class-aware. One sender at a time: with several senders each is matched against the
   ego's list in turn (a sequential assignment; a multi-sender graph matching is for when
   senders' lists overlap beyond the ego's view).
3. ``fuse``: matched pairs fused in information form (inverse covariances add), so the
   source with the smaller uncertainty dominates; unmatched objects are kept, marked
   ``own`` or ``other``.

Uncertainty follows range (``range_covariance``): a camera measures bearing well and range
poorly, more so far away, so each object's covariance is long along its line of sight.
Frames: an ego frame has x forward, y left, origin at the front bumper on the ground
(m); world poses are (x, y, heading) of that origin (m, rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from lookahead.perception.detections import CLASSES
from lookahead.perception.geometry import nearest_x_extent, rotation_2d

GATE_CHI2 = 13.82  # chi-square, 2 dof, 0.999: the Mahalanobis gate of a match (squared)
SYSTEMATIC_RANGE_REL = 0.05  # std of a monocular range's systematic error, relative to the range
UNKNOWN_VELOCITY_SIGMA = 10.0  # m/s, std of a velocity component nobody estimated
MOVING_SPEED = 1.0  # m/s; slower objects may lie any way (``centre_offset``)
REMOTE_ID_BASE = 1_000_000  # fused ids of objects only others see start here (track ids stay below)
#: Classes that may be the same object seen by two detectors (a car read as a truck, a cyclist as
#: a motorcyclist): ``match`` pairs only within a group.
CLASS_GROUP: dict[str, str] = {
    "pedestrian": "person", "cyclist": "rider", "motorcyclist": "rider", "tricycle": "rider",
    "car": "vehicle", "truck": "vehicle", "bus": "vehicle", "animal": "animal", "obstacle": "obstacle",
}
_BIG = 1e12  # stands in for +inf inside linear_sum_assignment

SOURCES = ("own", "other", "both")  # ``ObjectList.source`` codes: 0, 1, 2


@dataclass
class ObjectList:
    """Objects on the ground in one ego frame (struct of arrays, N rows).

    xy: (N, 2) the object's centre (m); velocity: (N, 2) ground velocity in the frame's axes
    (m/s); cov: (N, 2, 2) position covariance (m^2); class_id: (N,) int; score: (N,) in [0, 1];
    object_id: (N,) the id its source gave it (a track id; a remote id once fused, ``FusionNode``);
    source: (N,) int, ``SOURCES``; velocity_sigma: (N, 2) std of each velocity component (m/s,
    ``UNKNOWN_VELOCITY_SIGMA`` when unknown); settled: (N,) 1 once the source's velocity estimate
    has converged (``perception.estimator``), else 0; truth: (N,) the ground-truth actor the
    simulator associates with the object, -1 none -- for scoring only: fusion never reads it;
    xyxy: (N, 4) the object's box in its source camera's image (px; NaN where it has none in
    this frame's camera: objects from others); size: (N, 3) length, width, height (m, NaN
    unknown) -- the design's 2D and 3D boxes.
    """

    xy: np.ndarray
    velocity: np.ndarray
    cov: np.ndarray
    class_id: np.ndarray
    score: np.ndarray
    object_id: np.ndarray
    source: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    velocity_sigma: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    settled: np.ndarray = field(default_factory=lambda: np.zeros(0))
    truth: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    xyxy: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    size: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    FIELDS = ("xy", "velocity", "cov", "class_id", "score", "object_id", "source", "velocity_sigma", "settled",
              "truth", "xyxy", "size")

    def __post_init__(self) -> None:
        n = len(self.xy)
        if len(self.source) != n:
            self.source = np.zeros(n, dtype=np.int64)
        if len(self.velocity_sigma) != n:
            self.velocity_sigma = np.full((n, 2), UNKNOWN_VELOCITY_SIGMA)
        if len(self.settled) != n:
            self.settled = np.ones(n)
        if len(self.truth) != n:
            self.truth = np.full(n, -1, dtype=np.int64)
        if len(self.xyxy) != n:
            self.xyxy = np.full((n, 4), np.nan)
        if len(self.size) != n:
            self.size = np.full((n, 3), np.nan)

    @classmethod
    def empty(cls) -> ObjectList:
        z = np.zeros(0)
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2, 2)), z.astype(np.int64), z,
                   z.astype(np.int64))

    @classmethod
    def concat(cls, parts: list[ObjectList]) -> ObjectList:
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in cls.FIELDS))

    def __len__(self) -> int:
        return len(self.xy)

    def __getitem__(self, mask) -> ObjectList:
        return ObjectList(*(getattr(self, f)[mask] for f in self.FIELDS))


@dataclass
class SharedObjects:
    """One vehicle's message (the design's ``DetectionsWithOdom``).

    sender: who sent it; t: capture time (s); pose: the sender's world (x, y, heading)
    (m, rad) at ``t``, as the sender knows it; objects: in the sender's ego frame at ``t``;
    pose_sigma: the std of the sender's pose (m, rad), which ``to_frame`` adds to every
    object's covariance.
    """

    sender: str
    t: float
    pose: tuple[float, float, float]
    objects: ObjectList
    pose_sigma: tuple[float, float] = (0.0, 0.0)


def centre_offset(velocity: np.ndarray, length: np.ndarray, width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) x from an object's nearest face to its centre (m) and its std (m), for footprints
    ``length`` x ``width`` (class priors) with ground ``velocity`` (N, 2) in the frame's axes.

    An object moving faster than ``MOVING_SPEED`` lies along its velocity: the footprint's half
    extent at that heading (``geometry.nearest_x_extent``), std 0. A slower one may lie any way (a parked
    truck across a side street): the mean of the half width and the half length, std a
    quarter of their difference."""
    v = np.nan_to_num(np.asarray(velocity, dtype=np.float64).reshape(-1, 2))
    length, width = np.asarray(length, dtype=np.float64), np.asarray(width, dtype=np.float64)
    moving = np.hypot(v[:, 0], v[:, 1]) > MOVING_SPEED
    along = nearest_x_extent(np.arctan2(v[:, 1], v[:, 0]), length, width)
    return (np.where(moving, along, 0.25 * (length + width)),
            np.where(moving, 0.0, 0.25 * np.abs(length - width)))


def half_width_seen(velocity: np.ndarray, length: np.ndarray, width: np.ndarray) -> np.ndarray:
    """(N,) half the y extent (m) of footprints as ``centre_offset`` places them (a slow
    object: the mean of the half width and the half length)."""
    v = np.nan_to_num(np.asarray(velocity, dtype=np.float64).reshape(-1, 2))
    length, width = np.asarray(length, dtype=np.float64), np.asarray(width, dtype=np.float64)
    moving = np.hypot(v[:, 0], v[:, 1]) > MOVING_SPEED
    across = nearest_x_extent(np.arctan2(v[:, 1], v[:, 0]) + np.pi / 2, length, width)
    return np.where(moving, across, 0.25 * (length + width))


def objects_from_estimates(
    track_id: np.ndarray, class_id: np.ndarray, score: np.ndarray, est, length: np.ndarray,
    width: np.ndarray, length_sigma: np.ndarray, xyxy: np.ndarray | None = None,
) -> ObjectList:
    """One camera's tracks as an ``ObjectList`` in its ego frame (rows with a finite range).

    ``est`` is the tracks' ``perception.estimator.Estimates`` (range of the nearest face,
    lateral of the centre, ground velocity and their stds, half width, height); ``xyxy`` their
    boxes in the camera's image (px); size = (prior ``length``, estimated width and height). The centre lies beyond the nearest
    face by ``centre_offset`` (class prior ``length`` x ``width``, m, and ``length_sigma``);
    its covariance is the estimator's (range_sigma along x, lateral_sigma along y) plus the
    offset's uncertainty, or ``range_covariance`` where
    the estimator gives none, plus a systematic part along the line of sight,
    ``SYSTEMATIC_RANGE_REL`` x range (1 sigma): an object on a pavement 0.15 m high reads
    about 11 % farther to a camera 1.4 m up, and the filter's covariance cannot know it.
    """
    rng, lat = np.asarray(est.range, dtype=np.float64), np.asarray(est.lateral, dtype=np.float64)
    keep = np.isfinite(rng) & np.isfinite(lat)
    vel = np.column_stack([est.ground_vx, est.ground_vy]).astype(np.float64)
    vsig = np.column_stack([est.ground_vx_sigma, est.ground_vy_sigma]).astype(np.float64)
    unknown = ~np.isfinite(vel) | ~np.isfinite(vsig)
    vel, vsig = np.where(unknown, 0.0, vel), np.where(unknown, UNKNOWN_VELOCITY_SIGMA, vsig)
    half, half_sigma = centre_offset(vel, length, width)
    xy = np.column_stack([rng + half, lat])
    sx = np.asarray(est.range_sigma, dtype=np.float64) ** 2 + half_sigma**2 + (0.5 * length_sigma) ** 2
    sy = np.asarray(est.lateral_sigma, dtype=np.float64) ** 2
    cov = np.zeros((len(rng), 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = sx, sy
    model = ~(np.isfinite(sx) & np.isfinite(sy))
    if model.any():
        cov[model] = range_covariance(np.nan_to_num(xy[model]))
    # what the filter cannot know: the ground's height under the object (kerbs, pavements) and the
    # class's true size scale the whole range; along the line of sight
    cov[~model] += range_covariance(xy[~model], sigma0=0.0, range_rel=SYSTEMATIC_RANGE_REL, bearing_sigma=0.0)
    settled = np.nan_to_num(np.asarray(est.settled, dtype=np.float64), nan=0.0)
    size = np.column_stack([length, 2.0 * np.asarray(est.half_width, dtype=np.float64),
                            np.asarray(est.height, dtype=np.float64)])
    boxes = np.full((len(rng), 4), np.nan) if xyxy is None else np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    out = ObjectList(xy, vel, cov, np.asarray(class_id, dtype=np.int64), np.asarray(score, dtype=np.float64),
                     np.asarray(track_id, dtype=np.int64), velocity_sigma=vsig, settled=settled, xyxy=boxes, size=size)
    return out[keep]


def range_covariance(xy: np.ndarray, sigma0: float = 0.3, range_rel: float = 0.05,
                     bearing_sigma: float = 0.005) -> np.ndarray:
    """(N, 2, 2) position covariance (m^2) of camera measurements at ego-frame ``xy`` (N, 2):
    along the line of sight ``sigma0 + range_rel * range``, across it ``sigma0 + bearing_sigma
    * range`` (m, 1 sigma); the camera sits near the frame's origin."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    r = np.hypot(xy[:, 0], xy[:, 1])
    along, across = sigma0 + range_rel * r, sigma0 + bearing_sigma * r
    u = np.where(r[:, None] > 1e-9, xy / np.maximum(r, 1e-9)[:, None], np.array([1.0, 0.0]))
    n = np.column_stack([-u[:, 1], u[:, 0]])
    return (along**2)[:, None, None] * u[:, :, None] * u[:, None, :] + \
        (across**2)[:, None, None] * n[:, :, None] * n[:, None, :]


def to_frame(msg: SharedObjects, pose: tuple[float, float, float], t: float,
             accel_sigma: float = 1.0) -> ObjectList:
    """``msg``'s objects in the ego frame of world ``pose`` at time ``t`` (s): each moved by
    its velocity over the age ``t - msg.t``; the covariance rotated into that frame plus
    ``(accel_sigma * age^2 / 2)^2 + (velocity_sigma * age)^2`` per axis (an unknown
    acceleration of ``accel_sigma`` m/s^2 and the velocity's own error over the age) plus the
    sender's pose error (``msg.pose_sigma``: position, and heading times the object's
    distance from the sender, across its line of sight). ``source`` becomes ``other``; sizes
    are kept, image boxes dropped (they are the sender's image's)."""
    o = msg.objects
    age = float(t) - float(msg.t)
    r_sender, r_ego = rotation_2d(msg.pose[2]), rotation_2d(pose[2])
    r = r_ego.T @ r_sender  # sender frame -> receiver frame
    world = o.xy @ r_sender.T + np.asarray(msg.pose[:2]) + (o.velocity @ r_sender.T) * age
    xy = (world - np.asarray(pose[:2])) @ r_ego
    velocity = o.velocity @ r.T
    grow = (accel_sigma * age * age / 2.0) ** 2 + (np.max(o.velocity_sigma, axis=1) * age) ** 2
    sig_xy, sig_yaw = msg.pose_sigma
    across = o.xy @ np.array([[0.0, 1.0], [-1.0, 0.0]])  # (x, y) -> (-y, x): the heading error's direction
    cov = r @ o.cov @ r.T + (grow + sig_xy**2)[:, None, None] * np.eye(2)
    if sig_yaw > 0:
        a = across @ r.T
        cov = cov + sig_yaw**2 * a[:, :, None] * a[:, None, :]
    vel_sig = np.abs(o.velocity_sigma @ np.abs(r).T)  # a conservative bound of the rotated stds
    return ObjectList(xy, velocity, cov, o.class_id.copy(), o.score.copy(), o.object_id.copy(),
                      np.ones(len(o), dtype=np.int64), vel_sig, o.settled.copy(), o.truth.copy(),
                      np.full((len(o), 4), np.nan), o.size.copy())


_GROUP_NAMES = sorted(set(CLASS_GROUP.values()))
_GROUP_OF_CLASS = np.array([_GROUP_NAMES.index(CLASS_GROUP[c]) if c in CLASS_GROUP else len(_GROUP_NAMES) + i
                            for i, c in enumerate(CLASSES)])
_VEHICLE = _GROUP_NAMES.index("vehicle")


def _groups(class_id: np.ndarray) -> np.ndarray:
    """Each class id's ``CLASS_GROUP`` as an int (unknown classes: a group of their own)."""
    cid = np.asarray(class_id, dtype=np.int64)
    known = (cid >= 0) & (cid < len(CLASSES))
    return np.where(known, _GROUP_OF_CLASS[np.clip(cid, 0, len(CLASSES) - 1)], -1 - cid)


def inv2(m: np.ndarray) -> np.ndarray:
    """Inverses of a stack (..., 2, 2) of 2x2 matrices, in closed form (np.linalg.inv's
    per-call overhead is most of the cost at these sizes)."""
    a, b, c, d = m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1]
    det = a * d - b * c
    return np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2) / det[..., None, None]


def match(own: ObjectList, other: ObjectList, gate: float = GATE_CHI2) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (own rows, other rows) of the same objects: the assignment of least total squared
    Mahalanobis distance (combined covariance) among pairs of one class group (``CLASS_GROUP``)
    within ``gate``."""
    if not len(own) or not len(other):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    d = own.xy[:, None, :] - other.xy[None, :, :]  # (N, M, 2)
    s = own.cov[:, None] + other.cov[None, :]  # (N, M, 2, 2)
    m2 = np.einsum("nmi,nmij,nmj->nm", d, inv2(s), d)
    ok = (m2 <= gate) & (_groups(own.class_id)[:, None] == _groups(other.class_id)[None, :])
    rows, cols = linear_sum_assignment(np.where(ok, m2, _BIG))
    keep = ok[rows, cols]
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)


def fuse(own: ObjectList, other: ObjectList, pairs: tuple[np.ndarray, np.ndarray]) -> ObjectList:
    """Matched pairs fused in information form (position: P = (P1^-1 + P2^-1)^-1,
    x = P (P1^-1 x1 + P2^-1 x2); velocity per component by its own variances; size by score
    (the design's confidence weights); score 1 - (1 - s1)(1 - s2); settled if either is;
    ``own``'s id, class, image box and truth, or ``other``'s truth where ``own``'s is
    unknown), marked ``both`` (``other`` where the ``own`` side was
    itself only others'); then the unmatched ``own`` rows (their marks kept) and ``other``
    rows (``other``), unchanged. Rows: pairs in ``pairs`` order, then the rest of each list
    in order (``fused_rows``)."""
    i, j = pairs
    info_a, info_b = inv2(own.cov[i]), inv2(other.cov[j])
    cov = inv2(info_a + info_b)
    w_a, w_b = cov @ info_a, cov @ info_b  # (K, 2, 2) weights, w_a + w_b = I
    xy = np.einsum("kij,kj->ki", w_a, own.xy[i]) + np.einsum("kij,kj->ki", w_b, other.xy[j])
    va, vb = 1.0 / own.velocity_sigma[i] ** 2, 1.0 / other.velocity_sigma[j] ** 2
    vel = (va * own.velocity[i] + vb * other.velocity[j]) / (va + vb)
    score = 1.0 - (1.0 - own.score[i]) * (1.0 - other.score[j])
    source = np.where(own.source[i] == 1, 1, 2)
    truth = np.where(own.truth[i] >= 0, own.truth[i], other.truth[j])
    sa, sb = own.score[i][:, None] * np.isfinite(own.size[i]), other.score[j][:, None] * np.isfinite(other.size[j])
    with np.errstate(invalid="ignore"):  # neither size known: NaN
        size = (sa * np.nan_to_num(own.size[i]) + sb * np.nan_to_num(other.size[j])) / (sa + sb)
    both = ObjectList(xy, vel, cov, own.class_id[i], score, own.object_id[i], source, 1.0 / np.sqrt(va + vb),
                      np.maximum(own.settled[i], other.settled[j]), truth, own.xyxy[i], size)
    rest_own, rest_other = fused_rows(len(own), len(other), pairs)[2:]
    only_other = other[rest_other]
    only_other.source = np.ones(len(only_other), dtype=np.int64)
    return ObjectList.concat([both, own[rest_own], only_other])


def fused_rows(n_own: int, n_other: int, pairs: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, ...]:
    """(matched own rows, matched other rows, unmatched own rows, unmatched other rows): the
    order of ``fuse``'s output."""
    i, j = pairs
    rest_own, rest_other = np.ones(n_own, dtype=bool), np.ones(n_other, dtype=bool)
    rest_own[i], rest_other[j] = False, False
    return i, j, np.flatnonzero(rest_own), np.flatnonzero(rest_other)


@dataclass
class SenderMatches:
    """What one sender's message did in one fusion step."""

    sender: str
    t: float  # capture time (s)
    age: float  # s, at fusion
    object_id: np.ndarray  # (M,) the sender's ids of its objects, all of them
    truth: np.ndarray  # (M,) their ground-truth actors (scoring only)
    xy: np.ndarray  # (M, 2) their centres in the receiver's frame (m)
    remote_id: np.ndarray  # (M,) the remote id each has had as an object only others see, -1 never
    fused_id: np.ndarray  # (M,) the fused object each became or joined; -1: dropped as the receiver itself
    matched: np.ndarray  # (M,) bool: joined an object already in the list (own, or an earlier sender's)
    matched_source: np.ndarray  # (M,) the ``source`` of the object it joined before it joined (-1: none)


@dataclass
class FusionResult:
    """One fusion step: the fused objects and what each message did."""

    objects: ObjectList  # object_id: own track id, or a remote id (>= REMOTE_ID_BASE)
    own_row: np.ndarray  # (N,) row of the own list each fused object holds, -1 none
    senders: list[SenderMatches]


@dataclass
class FusionNode:
    """The receiver's fusion node: every received message into the receiver's frame
    (``to_frame``), others' detections of the receiver itself dropped (``is_self``), then each sender in name order matched (``match``) against the list
    so far -- the receiver's own objects and the earlier senders' -- and fused (``fuse``).
    An object only others see gets a remote id, ``REMOTE_ID_BASE`` and up, kept for as long
    as the same sender reports the same object id; one that joins an earlier sender's object
    keeps that object's id; one that joins the receiver's own object takes the own id
    (``SenderMatches.remote_id`` tells which remote id it had, for a hand-over).

    Args:
        length, width: the receiver's footprint (m); its ego frame's origin is the middle
            of its front edge, so it covers x in [-length, 0], |y| <= width / 2.
    """

    length: float = 4.6
    width: float = 1.9
    accel_sigma: float = 1.0
    gate: float = GATE_CHI2
    _remote: dict[tuple[str, int], int] = field(default_factory=dict)

    def remote_id(self, sender: str, object_id: int) -> int:
        """The fused id of ``sender``'s object ``object_id`` when only others see it."""
        key = (sender, int(object_id))
        if key not in self._remote:
            self._remote[key] = REMOTE_ID_BASE + len(self._remote)
        return self._remote[key]

    def is_self(self, other: ObjectList) -> np.ndarray:
        """(M,) whether each of ``other`` is the receiver itself: of the vehicles within the
        match gate of the receiver's centre (its footprint's spread, length / 4 and width / 4
        as stds, added to the object's covariance), the nearest (a sender sees the receiver
        once; a car parked beside it stays)."""
        out = np.zeros(len(other), dtype=bool)
        if not len(other):
            return out
        d = other.xy - np.array([-self.length / 2.0, 0.0])
        s = other.cov + np.diag([(self.length / 4.0) ** 2, (self.width / 4.0) ** 2])
        m2 = np.einsum("ni,nij,nj->n", d, inv2(s), d)
        m2[(m2 > self.gate) | (_groups(other.class_id) != _VEHICLE)] = np.inf
        k = int(np.argmin(m2))
        out[k] = np.isfinite(m2[k])
        return out

    def update(self, own: ObjectList, messages: list[SharedObjects], pose: tuple[float, float, float],
               t: float) -> FusionResult:
        """Fuse ``messages`` into ``own`` (the receiver's objects in its ego frame at time ``t``,
        s; its world ``pose``)."""
        fused = ObjectList.concat([own, ObjectList.empty()])
        fused.source = np.zeros(len(own), dtype=np.int64)
        own_row = np.arange(len(own))
        report = []
        for msg in sorted(messages, key=lambda m: m.sender):
            other = to_frame(msg, pose, t, self.accel_sigma)
            ids, truth, xy = other.object_id.copy(), other.truth.copy(), other.xy.copy()
            fused_id = np.full(len(other), -1, dtype=np.int64)
            matched = np.zeros(len(other), dtype=bool)
            matched_source = np.full(len(other), -1, dtype=np.int64)
            kept = np.nonzero(~self.is_self(other))[0]
            other = other[kept]
            pairs = match(fused, other, self.gate)
            i, j, rest_own, rest_other = fused_rows(len(fused), len(other), pairs)
            fused_id[kept[j]] = fused.object_id[i]
            matched[kept[j]] = True
            matched_source[kept[j]] = fused.source[i]
            other.object_id[rest_other] = [self.remote_id(msg.sender, k) for k in other.object_id[rest_other]]
            fused_id[kept[rest_other]] = other.object_id[rest_other]
            remote = np.array([self._remote.get((msg.sender, int(k)), -1) for k in ids], dtype=np.int64)
            fused = fuse(fused, other, pairs)
            own_row = np.concatenate([own_row[i], own_row[rest_own], np.full(len(rest_other), -1)])
            report.append(SenderMatches(msg.sender, float(msg.t), float(t) - float(msg.t), ids, truth, xy, remote,
                                        fused_id, matched, matched_source))
        return FusionResult(fused, own_row, report)
