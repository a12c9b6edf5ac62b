"""Other cameras in the world and the link that carries what they see to the ego.

A scenario's ``cooperative`` section (``sim.scenario.CooperativeSpec``) gives other road
users (``actor``) and roadside units (``at``) cameras. At every ego camera frame each
sender sees the world from where it stands (``world_truth`` from its ``Viewpoint``: it
sees the ego, not itself) -- rendered from its pose by a render worker of its own when the
run renders (the ego's body in its scene; visibility measured on its frames), else with
visibility from box overlap -- runs its own perception stack (the same code as the ego's,
its own settings: ``gt`` by default, ``onnx`` on rendered frames),
turns its tracks into an ``ObjectList`` in its own frame and sends it, with the capture
time and its pose as it knows it (the true pose plus ``pose_noise``, fresh per message),
over the ``Link`` (latency, jitter, loss, timeout). ``Cooperation.receive`` hands the ego
what has arrived. Every random draw comes from the scenario seed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lookahead.intent.config import IntentConfig
from lookahead.intent.cooperative import FusionStage, tracked_objects
from lookahead.intent.stack import PerceptionStack, build_stack
from lookahead.perception.camera import CameraModel
from lookahead.perception.cooperative import ObjectList, SharedObjects
from lookahead.perception.estimator import Estimates
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.tracker import Tracks
from lookahead.sim.groundtruth import GroundTruth, detector_truth, truth_ids, world_truth
from lookahead.sim.link import Link
from lookahead.sim.scenario import CooperativeSpec, Scenario, SenderSpec, mounted_camera
from lookahead.sim.world import Viewpoint, World

LINK_SEED_KEY = 35  # the link's and the pose noise's draws: seeded with (scenario seed, this, ...)


@dataclass
class SenderView:
    """What one sender saw and sent at one frame (its own frame; ``objects.truth`` for scoring)."""

    name: str
    viewpoint: Viewpoint  # true
    frame: Frame  # its camera frame (with the image when rendered)
    gt: GroundTruth
    reported_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)  # as sent (with pose noise)
    tracks: Tracks | None = None
    estimates: Estimates | None = None
    objects: ObjectList | None = None
    message: SharedObjects | None = None
    poses: dict = field(default_factory=dict)  # what its render worker was asked to pose


class Sender:
    """One camera elsewhere: where it stands, its camera, its perception stack and, when the
    run renders, its own render worker (the ego's body in its scene, its carrier's not)."""

    def __init__(self, spec: SenderSpec, world: World, scenario: Scenario, intent: IntentConfig, index: int,
                 render: bool = False, backend: str = "auto", gl_threads: int | None = None) -> None:
        self.spec = spec
        self.name = spec.name
        c = spec.camera
        self.camera: CameraModel = mounted_camera(c.width, c.height, c.fov_h, c.mount)
        self.carrier = world.by_name[spec.actor].identity.actor_id if spec.actor is not None else None
        if spec.at is not None:
            x, y = world.to_world(np.array([spec.at.x, spec.at.y]))
            self.fixed: tuple[float, float, float] | None = (float(x), float(y), float(np.radians(spec.at.heading)))
        else:
            self.fixed = None
        seed = int(np.random.default_rng([scenario.seed, LINK_SEED_KEY, index, 1]).integers(2**31))
        self.stack: PerceptionStack = build_stack(spec.perception, self.camera, scenario.camera.rate, intent=intent,
                                                  seed=seed, render=render)
        self._rng = np.random.default_rng([scenario.seed, LINK_SEED_KEY, index, 2])
        self.intent = intent
        self.rig = None
        if render:
            from lookahead.sim.rendered_camera import (
                RenderedCamera,  # lazy: PyBullet only when rendering
            )

            shapes = {a.identity.actor_id: a.identity.shape for a in world.viewed_agents(with_ego=True)
                      if a.identity.actor_id != self.carrier}
            self.rig = RenderedCamera(self.camera, world.layout, scenario.seed, backend, shapes, scenario,
                                      gl_threads=gl_threads)

    def viewpoint(self, world: World) -> Viewpoint:
        if self.fixed is not None:
            return Viewpoint(self.fixed)
        return world.viewpoint(self.carrier)

    def look(self, world: World, frame_index: int) -> SenderView:
        """The world at its current tick from the sender's camera: its ground truth, and its
        frame asked of its render worker (collected by ``perceive``)."""
        vp = self.viewpoint(world)
        gt = world_truth(world, self.camera, self.intent, vp)
        frame = Frame(tick=world.tick, t=world.t, camera=self.camera, index=frame_index,
                      odometry=EgoOdometry(speed=vp.speed, accel=vp.accel, yaw_rate=vp.yaw_rate),
                      ground=world.layout.ground_map(vp.pose))
        view = SenderView(self.name, vp, frame, gt)
        if self.rig is not None:
            view.poses = {k: v for k, v in world.actor_poses(with_ego=True).items() if k != self.carrier}
            self.rig.submit(frame_index, vp.pose, view.poses)
        return view

    def perceive(self, view: SenderView, pose_sigma: tuple[float, float]) -> SenderView:
        """``view`` (from ``look``) developed and through the sender's stack, as a message with
        its pose as it knows it (``pose_sigma``: m, rad)."""
        if self.rig is not None:
            f = view.frame
            f.image, f.depth, f.segmentation, view.gt, _, _ = self.rig.develop(view.gt, view.viewpoint.pose, view.poses)
        _, view.tracks, view.estimates = self.stack.perceive(view.frame, detector_truth(view.gt, self.camera), {})
        view.objects = self.stack_objects(view.tracks, view.estimates, view.gt)
        noise = self._rng.normal(size=3)  # always three draws: the stream stays aligned
        pose = view.viewpoint.pose
        view.reported_pose = (pose[0] + pose_sigma[0] * noise[0], pose[1] + pose_sigma[0] * noise[1],
                              pose[2] + pose_sigma[1] * noise[2])
        view.message = SharedObjects(self.name, view.frame.t, view.reported_pose, view.objects, pose_sigma)
        return view

    def stack_objects(self, tracks: Tracks, est: Estimates, gt: GroundTruth) -> ObjectList:
        """The sender's tracks as its message's objects, each with its ground-truth actor (scoring only)."""
        objects = tracked_objects(self.stack.estimator.priors, tracks, est)
        keep = np.isfinite(est.range) & np.isfinite(est.lateral)
        objects.truth = truth_ids(tracks.xyxy, gt, self.camera)[keep]
        return objects

    def close(self) -> None:
        if self.rig is not None:
            self.rig.close()
            self.rig = None


class Cooperation:
    """Every sender of a scenario and the ego's link (module docstring).

    Per ego frame: ``look`` at the frame's tick (ground truth, renders asked), then ``send``
    (each sender's frame perceived, its message on the link at the frame's time), then
    ``receive``. ``send`` and ``receive`` run in frame order, so the link sees the same
    sequence however the runner overlaps rendering."""

    def __init__(self, spec: CooperativeSpec, world: World, scenario: Scenario, intent: IntentConfig,
                 render: bool = False, backend: str = "auto", gl_threads: int | None = None) -> None:
        self.spec = spec
        self.senders = []
        try:
            for i, s in enumerate(spec.senders):
                self.senders.append(Sender(s, world, scenario, intent, i, render, backend, gl_threads))
        except BaseException:
            self.close()
            raise
        self.link = Link(spec.link, seed=int(np.random.default_rng([scenario.seed, LINK_SEED_KEY]).integers(2**31)))
        self.pose_sigma = (spec.pose_noise.xy, float(np.radians(spec.pose_noise.heading)))

    def look(self, world: World, frame_index: int) -> list[SenderView]:
        """Every sender's view of the world's current tick (``Sender.look``)."""
        return [s.look(world, frame_index) for s in self.senders]

    def send(self, views: list[SenderView], t: float) -> list[SenderView]:
        """Each view perceived and its message put on the link at ``t`` (s, its capture time)."""
        for s, v in zip(self.senders, views, strict=True):
            self.link.send(s.perceive(v, self.pose_sigma).message, t)
        return views

    def receive(self, t: float) -> list[SharedObjects]:
        """Per sender, the newest message arrived by ``t`` (s) within the link's timeout."""
        return list(self.link.receive(t).values())

    def close(self) -> None:
        for s in self.senders:
            s.close()


def _objects_dict(o: ObjectList) -> dict:
    return {"id": o.object_id, "truth": o.truth, "class_id": o.class_id, "score": np.round(o.score, 3),
            "xy": np.round(o.xy, 3), "velocity": np.round(o.velocity, 3), "size": np.round(o.size, 3)}


def cooperative_record(views: list[SenderView], stage: FusionStage, own_truth: np.ndarray,
                       link: Link) -> dict:
    """The tick record's ``cooperative`` entry (plain types; ``truth`` fields for scoring only):

    * ``fusion``: whether intent saw the fused objects;
    * ``senders``: per sender, what it sent (the design's ``DetectionsWithOdom``): capture time,
      its true and reported pose (world) and its objects in its frame (id, class, score,
      centre, ground velocity, size: length, width, height; image box, px);
    * ``received``: per message fused, its sender, capture time, age (s) and per object its id,
      truth, position in the ego frame (``to_frame``), the fused object it became or joined
      (-1: dropped as the ego itself), whether it ``matched`` an object already listed and that
      object's ``source`` then;
    * ``own``: the ego's own objects before fusion (track id, truth, ego-frame centre);
    * ``fused``: every fused object (id: a track id, or a remote id for others-only objects),
      its source (0 own, 1 other, 2 both), class, centre, ground velocity, covariance
      (xx, xy, yy; m^2) and truth;
    * ``remote``: the others-only objects as intent assessed them (empty with fusion off);
    * ``alerts_alone``: the alert events the ego's own objects alone raised this frame (the
      comparison without fusion; the record's ``alerts`` are those acted on);
    * ``link``: the link's counters so far."""
    r = stage.result
    assert r is not None
    objs = r.objects
    own_rows = r.own_row >= 0
    truth = objs.truth.copy()
    known = own_truth[r.own_row[own_rows]]
    truth[own_rows] = np.where(known >= 0, known, truth[own_rows])
    own = stage.own
    remote = stage.remote
    return {
        "fusion": stage.enabled,
        "senders": [{"name": v.name, "t": round(v.frame.t, 4), "pose": np.round(v.viewpoint.pose, 4),
                     "reported_pose": np.round(v.reported_pose, 4),
                     "objects": {**_objects_dict(v.objects), "xyxy": np.round(v.objects.xyxy, 2)}} for v in views],
        "received": [{"sender": m.sender, "t": round(m.t, 4), "age": round(m.age, 4), "id": m.object_id,
                      "truth": m.truth, "xy": np.round(m.xy, 3), "fused_id": m.fused_id, "matched": m.matched,
                      "matched_source": m.matched_source} for m in r.senders],
        "own": {"id": own.object_id, "truth": own_truth, "xy": np.round(own.xy, 3)},
        "fused": {**_objects_dict(objs), "truth": truth, "source": objs.source,
                  "cov": np.round(np.column_stack([objs.cov[:, 0, 0], objs.cov[:, 0, 1], objs.cov[:, 1, 1]]), 4)},
        "remote": {"id": remote.ids if remote else [], **(remote.assessment.to_dict() if remote else {})},
        "alerts_alone": [a.to_dict() for a in stage.alone_alerts],
        "link": vars(link.stats).copy(),
    }
