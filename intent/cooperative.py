"""The fusion stage: other road users' objects joined to the ego's before intent and alerts.

``FusionStage`` sits between the ego's estimator and its intent (``PerceptionStack.fusion``).
Each frame it turns the ego's tracks into an ``ObjectList`` (``objects_from_estimates``),
fuses the messages received since (``perception.cooperative.FusionNode``), and hands intent
one ``Kinematics`` over the union:

* the ego's own tracks, in their order; those another sender also sees (``both``) take the
  fused centre, ground velocity and its stds, and are settled if either source is;
* then the objects only others see (``other``), with remote ids, their class priors'
  size, and ``age`` counted from when their id first appeared.

Intent labels, risk and alerts then run on the union, so a child only an oncoming car sees
is warned of under its remote id; once the ego's own camera sees it too, its alert goes on
under the own track's id (``handovers``, ``AlertManager.hand_over``), without a new debounce. ``split`` hands the own rows' assessment back to the
stack (aligned with its tracks) and keeps the others' in ``remote``. With ``enabled``
False the stage still fuses and keeps the result (for scoring the matching) but intent
sees the ego's own tracks only.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from lookahead.intent.alerts import Alert, AlertConfig, AlertManager
from lookahead.intent.labels import Assessment, Kinematics
from lookahead.perception.cooperative import (
    FusionNode,
    FusionResult,
    ObjectList,
    SharedObjects,
    centre_offset,
    half_width_seen,
    objects_from_estimates,
)
from lookahead.perception.estimator import Estimates
from lookahead.perception.estimator_config import PriorTable
from lookahead.perception.frame import Frame
from lookahead.perception.tracker import Tracks

#: What an own track's Kinematics field means when its stack leaves it None (plug-in stacks).
_NONE_MEANS = {"age": 0.0, "range_rate_sigma": 0.0, "settled": 1.0, "accel_x": 0.0, "ground_vx_sigma": 0.0,
               "ground_vy_sigma": 0.0, "lateral_sigma": 0.0, "height": np.nan}


def tracked_objects(priors: PriorTable, tracks: Tracks, est: Estimates) -> ObjectList:
    """A stack's tracks with a finite range as an ``ObjectList`` in its frame
    (``objects_from_estimates`` with the class priors' sizes): what a sender sends, and the
    ego's own list before fusion."""
    c = tracks.class_id
    return objects_from_estimates(tracks.track_id, c, tracks.score, est, priors.of(c, "length"),
                                  priors.of(c, "width"), priors.of(c, "length_sigma"), tracks.xyxy)


def take(a: Assessment, rows: np.ndarray | slice) -> Assessment:
    """The assessment of ``rows`` only."""
    return Assessment(**{f.name: None if getattr(a, f.name) is None else getattr(a, f.name)[rows]
                         for f in fields(a)})


@dataclass
class Remote:
    """The objects only others see, as intent saw them in one frame (rows aligned)."""

    ids: np.ndarray
    class_id: np.ndarray
    assessment: Assessment


class FusionStage:
    """The fusion node between the ego's estimator and its intent (module docstring).

    Args:
        node: the fusion node (the ego's footprint, the gate).
        priors: class priors (length, width, height) of the ego's estimator.
        enabled: whether intent sees the fused objects (else the ego's own only).
        alert_config: the ego's alert settings, for ``alone``: the alerts of the same frames
            assessed without fusion, so one run scores warnings with and without it.
    """

    def __init__(self, node: FusionNode, priors: PriorTable, enabled: bool = True,
                 alert_config: AlertConfig | None = None) -> None:
        self.node = node
        self.alone = AlertManager(alert_config)  # the ego's alerts had it seen alone (the stack feeds it)
        self.alone_alerts: list[Alert] = []  # its events of the last frame
        self.priors = priors
        self.enabled = enabled
        self._messages: list[SharedObjects] = []
        self._pose = (0.0, 0.0, 0.0)
        self._first_seen: dict[int, int] = {}  # remote id -> frame index it first appeared
        self.result: FusionResult | None = None  # the last frame's fusion
        self.remote: Remote | None = None  # the last frame's others-only objects as assessed
        self._n_own = 0
        self.own_track_rows = np.zeros(0, dtype=np.int64)  # the last frame's own objects' rows in its tracks
        self.own = ObjectList.empty()  # the last frame's own objects, before fusion
        self.handovers: list[tuple[int, int]] = []  # the last frame's (remote id, own track id) hand-overs

    def receive(self, messages: list[SharedObjects], pose: tuple[float, float, float]) -> None:
        """The messages to fuse into the next frame, and the ego's world pose (x, y, heading; m,
        rad) at that frame."""
        self._messages, self._pose = list(messages), pose

    def own_objects(self, tracks: Tracks, est: Estimates) -> ObjectList:
        return tracked_objects(self.priors, tracks, est)

    def __call__(self, frame: Frame, tracks: Tracks, est: Estimates,
                 kin: Kinematics) -> tuple[Kinematics, np.ndarray, np.ndarray]:
        """(Kinematics, ids, class ids) of the objects intent assesses this frame."""
        self.own = own = self.own_objects(tracks, est)
        finite = np.nonzero(np.isfinite(est.range) & np.isfinite(est.lateral))[0]  # own's rows in tracks
        self.result = result = self.node.update(own, self._messages, self._pose, frame.t)
        self.handovers = self._handovers(result)
        self._n_own = len(tracks)
        self.own_track_rows = finite
        if not self.enabled:
            self.remote = None
            return kin, tracks.track_id, tracks.class_id
        objs = result.objects
        both = np.nonzero((result.own_row >= 0) & (objs.source == 2))[0]
        others = np.nonzero(result.own_row < 0)[0]
        odo = frame.odometry
        columns = {f.name: self._own_column(kin, f.name, len(tracks)) for f in fields(Kinematics)}
        rows = finite[result.own_row[both]]  # rows of tracks fused with others
        b = objs[both]
        self._put(columns, rows, b, self._offset(b), odo)
        o = objs[others]
        for rid in o.object_id.tolist():
            self._first_seen.setdefault(int(rid), frame.index)
        length, width = self.priors.of(o.class_id, "length"), self.priors.of(o.class_id, "width")
        extra = {name: np.full(len(o), np.nan) for name in columns}
        extra["class_id"] = o.class_id
        extra["half_width"] = half_width_seen(o.velocity, length, width)
        extra["age"] = np.array([frame.index - self._first_seen[int(r)] for r in o.object_id], dtype=np.float64)
        extra["accel_x"] = np.zeros(len(o))
        extra["height"] = self.priors.of(o.class_id, "height")
        self._put(extra, slice(None), o, self._offset(o), odo)
        union = {name: np.concatenate([columns[name], extra[name]]) for name in columns}
        union["class_id"] = union["class_id"].astype(np.int64)
        self.remote = Remote(o.object_id, o.class_id, None)  # type: ignore[arg-type]
        return (Kinematics(**union), np.concatenate([tracks.track_id, o.object_id]),
                np.concatenate([tracks.class_id, o.class_id]))

    def _offset(self, objs: ObjectList) -> np.ndarray:
        """x from each object's centre back to its nearest face (m; ``centre_offset``)."""
        return centre_offset(objs.velocity, self.priors.of(objs.class_id, "length"),
                             self.priors.of(objs.class_id, "width"))[0]

    def _handovers(self, result: FusionResult) -> list[tuple[int, int]]:
        """(remote id, own track id) of objects intent knew only from others that the ego's own
        camera now sees: their alerts go on under the track id (``AlertManager.hand_over``)."""
        out = []
        for m in result.senders:
            for rid, fid, src in zip(m.remote_id.tolist(), m.fused_id.tolist(), m.matched_source.tolist(), strict=True):
                if rid in self._first_seen and src in (0, 2) and fid >= 0:
                    del self._first_seen[rid]
                    out.append((rid, fid))
        return out

    @staticmethod
    def _own_column(kin: Kinematics, name: str, n: int) -> np.ndarray:
        v = getattr(kin, name)
        return np.full(n, _NONE_MEANS[name]) if v is None else np.asarray(v, dtype=np.float64).copy()

    @staticmethod
    def _put(columns: dict[str, np.ndarray], rows, objs: ObjectList, half: np.ndarray, odo) -> None:
        """Fused positions and velocities of ``objs`` into ``columns`` at ``rows`` (ego frame;
        range = the centre's x less the footprint's ``half`` extent; relative rates from the
        ground velocity and the ego's speed and yaw rate)."""
        x, y = objs.xy[:, 0], objs.xy[:, 1]
        vx, vy = objs.velocity[:, 0], objs.velocity[:, 1]
        columns["range"][rows] = x - half
        columns["lateral"][rows] = y
        columns["ground_vx"][rows], columns["ground_vy"][rows] = vx, vy
        columns["ground_vx_sigma"][rows], columns["ground_vy_sigma"][rows] = objs.velocity_sigma.T
        columns["range_rate"][rows] = vx - odo.speed + odo.yaw_rate * y
        columns["lateral_rate"][rows] = vy - odo.yaw_rate * x
        columns["range_rate_sigma"][rows] = objs.velocity_sigma[:, 0]
        columns["lateral_sigma"][rows] = np.sqrt(objs.cov[:, 1, 1])
        columns["settled"][rows] = np.maximum(np.nan_to_num(columns["settled"][rows], nan=0.0), objs.settled)

    def split(self, a: Assessment) -> Assessment:
        """The own tracks' rows of the union's assessment ``a``; the others' go to ``remote``."""
        if self.remote is None:
            return a
        self.remote.assessment = take(a, slice(self._n_own, None))
        return take(a, slice(0, self._n_own))
