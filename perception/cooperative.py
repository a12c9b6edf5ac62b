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

from lookahead.perception.geometry import rotation_2d

GATE_CHI2 = 13.82  # chi-square, 2 dof, 0.999: the Mahalanobis gate of a match (squared)
_BIG = 1e12  # stands in for +inf inside linear_sum_assignment

SOURCES = ("own", "other", "both")  # ``ObjectList.source`` codes: 0, 1, 2


@dataclass
class ObjectList:
    """Objects on the ground in one ego frame (struct of arrays, N rows).

    xy: (N, 2) position (m); velocity: (N, 2) ground velocity in the frame's axes (m/s);
    cov: (N, 2, 2) position covariance (m^2); class_id: (N,) int; score: (N,) in [0, 1];
    object_id: (N,) the id its source gave it (a track id); source: (N,) int, ``SOURCES``.
    """

    xy: np.ndarray
    velocity: np.ndarray
    cov: np.ndarray
    class_id: np.ndarray
    score: np.ndarray
    object_id: np.ndarray
    source: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self) -> None:
        n = len(self.xy)
        if len(self.source) != n:
            self.source = np.zeros(n, dtype=np.int64)

    @classmethod
    def empty(cls) -> ObjectList:
        z = np.zeros(0)
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2, 2)), z.astype(np.int64), z,
                   z.astype(np.int64))

    def __len__(self) -> int:
        return len(self.xy)

    def __getitem__(self, mask) -> ObjectList:
        return ObjectList(self.xy[mask], self.velocity[mask], self.cov[mask], self.class_id[mask],
                          self.score[mask], self.object_id[mask], self.source[mask])


@dataclass
class SharedObjects:
    """One vehicle's message (the design's ``DetectionsWithOdom``).

    sender: who sent it; t: capture time (s); pose: the sender's world (x, y, heading)
    (m, rad) at ``t``; objects: in the sender's ego frame at ``t``.
    """

    sender: str
    t: float
    pose: tuple[float, float, float]
    objects: ObjectList


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
    ``(accel_sigma * age^2 / 2)^2`` per axis (an unknown acceleration of ``accel_sigma``
    m/s^2 over the age). ``source`` becomes ``other``."""
    o = msg.objects
    age = float(t) - float(msg.t)
    r_sender, r_ego = rotation_2d(msg.pose[2]), rotation_2d(pose[2])
    r = r_ego.T @ r_sender  # sender frame -> receiver frame
    world = o.xy @ r_sender.T + np.asarray(msg.pose[:2]) + (o.velocity @ r_sender.T) * age
    xy = (world - np.asarray(pose[:2])) @ r_ego
    velocity = o.velocity @ r.T
    grow = (accel_sigma * age * age / 2.0) ** 2
    cov = r @ o.cov @ r.T + grow * np.eye(2)
    return ObjectList(xy, velocity, cov, o.class_id.copy(), o.score.copy(), o.object_id.copy(),
                      np.ones(len(o), dtype=np.int64))


def match(own: ObjectList, other: ObjectList, gate: float = GATE_CHI2) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (own rows, other rows) of the same objects: the assignment of least total squared
    Mahalanobis distance (combined covariance) among pairs of one class within ``gate``."""
    if not len(own) or not len(other):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    d = own.xy[:, None, :] - other.xy[None, :, :]  # (N, M, 2)
    s = own.cov[:, None] + other.cov[None, :]  # (N, M, 2, 2)
    m2 = np.einsum("nmi,nmij,nmj->nm", d, np.linalg.inv(s), d)
    ok = (m2 <= gate) & (own.class_id[:, None] == other.class_id[None, :])
    rows, cols = linear_sum_assignment(np.where(ok, m2, _BIG))
    keep = ok[rows, cols]
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)


def fuse(own: ObjectList, other: ObjectList, pairs: tuple[np.ndarray, np.ndarray]) -> ObjectList:
    """Matched pairs fused in information form (P = (P1^-1 + P2^-1)^-1, x = P (P1^-1 x1 +
    P2^-1 x2), velocity with the same weights; score 1 - (1 - s1)(1 - s2); the own id and
    class), marked ``both``; then the unmatched own objects (``own``) and other objects
    (``other``), unchanged."""
    i, j = pairs
    info_a, info_b = np.linalg.inv(own.cov[i]), np.linalg.inv(other.cov[j])
    cov = np.linalg.inv(info_a + info_b)
    w_a, w_b = cov @ info_a, cov @ info_b  # (K, 2, 2) weights, w_a + w_b = I
    xy = np.einsum("kij,kj->ki", w_a, own.xy[i]) + np.einsum("kij,kj->ki", w_b, other.xy[j])
    vel = np.einsum("kij,kj->ki", w_a, own.velocity[i]) + np.einsum("kij,kj->ki", w_b, other.velocity[j])
    score = 1.0 - (1.0 - own.score[i]) * (1.0 - other.score[j])
    both = ObjectList(xy, vel, cov, own.class_id[i], score, own.object_id[i], np.full(len(i), 2, dtype=np.int64))
    only_own = own[~np.isin(np.arange(len(own)), i)]
    only_own.source = np.zeros(len(only_own), dtype=np.int64)
    only_other = other[~np.isin(np.arange(len(other)), j)]
    only_other.source = np.ones(len(only_other), dtype=np.int64)
    parts = (both, only_own, only_other)
    return ObjectList(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                        ("xy", "velocity", "cov", "class_id", "score", "object_id", "source")))
