"""The closed-loop runner: world -> camera -> ground truth -> perception -> sinks.

The world steps at the scenario ``rate``; every ``frame_every = rate / camera.rate`` ticks
the camera renders a ``Frame``, ground truth is computed, the perception + intent stack
(``intent.stack``, built by ``build_stack`` from the scenario's settings) runs, the AEB
and the driver (``sim.driver``, if the scenario has one) decide, and a ``TickRecord`` goes
to every sink. ``Runner.step`` advances one camera frame (the gym env steps with it);
``Runner.run`` runs the same loop to the end, with the render worker
(``sim.render_process``) drawing frame k+1 while frame k is perceived (``overlap``;
the records are the same). Decisions on a frame reach the AEB and the driver
``perception.latency`` frames later (0: at once). Sinks are injected (observers) so
``sim`` never imports ``tools``. Each stage is timed (ms).
A record's ``ego`` holds the pose, the odometry and ``brake``, the brake command applied
(m/s^2, null while none is on: the stronger of the AEB's and the driver's); runs with the
AEB on add ``aeb_brake`` (the AEB's own command), runs with a driver ``driver_brake``
(the driver's), so a run with neither records exactly as before they existed.
A setting the stack refuses (``SettingsError``, e.g. ``onnx`` without rendering) is the
scenario's: the runner raises it as ``ScenarioError``.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from lookahead.intent.alerts import Alert
from lookahead.intent.cipv import select_cipv
from lookahead.intent.config import IntentConfig
from lookahead.intent.cooperative import FusionStage
from lookahead.intent.labels import Assessment, Risk
from lookahead.intent.stack import alert_in_path, build_stack
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import SettingsError
from lookahead.perception.cooperative import FusionNode
from lookahead.perception.detections import Detections
from lookahead.perception.detectors.base import Detector
from lookahead.perception.estimator import Estimates
from lookahead.perception.frame import Frame
from lookahead.perception.tracker import Tracks
from lookahead.sim.aeb import Aeb
from lookahead.sim.cooperation import Cooperation, cooperative_record
from lookahead.sim.driver import Driver, combine_brakes
from lookahead.sim.ego import Collision
from lookahead.sim.groundtruth import (
    GroundTruth,
    detector_truth,
    truth_ids,
    world_truth,
)
from lookahead.sim.records import Sink, TickRecord
from lookahead.sim.scenario import Scenario, ScenarioError, mounted_camera
from lookahead.sim.world import World

if TYPE_CHECKING:
    from lookahead.sim.rendered_camera import RenderedCamera

log = logging.getLogger(__name__)


OVERLAP_DETECTOR_THREADS = 1  # inference threads while the render worker draws the next frame (DetectorSpec.threads auto)
RENDER_WORKER_GL_THREADS = 1  # llvmpipe threads of the render worker then (LP_NUM_THREADS, unless set)
STAGES = ("sim", "render", "gt", "preprocess", "detect", "track", "estimate", "intent", "sinks", "tick")


def camera_from_scenario(scenario: Scenario) -> CameraModel:
    c = scenario.camera
    return mounted_camera(c.width, c.height, c.fov_h, c.mount)


def cipv_record(tracks: Tracks, est: Estimates, assessment: Assessment, gt: GroundTruth) -> dict:
    """The tick record's ``cipv``: the primary target (``intent.cipv.select_cipv``) among the ego
    camera's own tracks (``track_id``, estimated ``range``), and the ground truth's
    (``truth_actor``, ``truth_range``): the closest in-path actor of a detection class with a
    visible box. None where there is none."""
    own = select_cipv(tracks.track_id, est.range, assessment.in_path)
    visible = np.all(np.isfinite(np.asarray(gt.visible, dtype=np.float64).reshape(-1, 4)), axis=1)
    truth = select_cipv(gt.actor_id, gt.range, gt.in_path, visible & (np.asarray(gt.class_id) >= 0))
    return {"track_id": own.id, "range": None if own.range is None else round(own.range, 3),
            "truth_actor": truth.id, "truth_range": None if truth.range is None else round(truth.range, 3)}


@contextmanager
def _as_scenario_error() -> Iterator[None]:
    """Settings the stack refuses (``SettingsError``) are the scenario's: re-raised as ``ScenarioError``."""
    try:
        yield
    except ScenarioError:
        raise
    except SettingsError as e:
        raise ScenarioError(str(e)) from None


@dataclass
class Perceived:
    """One camera frame, its ground truth, and what the perception stack made of it."""

    frame: Frame
    gt: GroundTruth
    detections: Detections
    tracks: Tracks
    est: Estimates
    assessment: Assessment
    alerts: list[Alert]
    timings: dict[str, float]  # ms per stage
    cooperative: dict | None = None  # the record's ``cooperative`` entry (``sim.cooperation.cooperative_record``)


@dataclass
class _Snapshot:
    """One camera frame on its way through the loop: the world at its tick (``_snapshot``),
    asked of the render worker (``_request``), then its images and visibility (``_develop``)."""

    frame: Frame  # image, depth, segmentation: None until developed
    pose: tuple[float, float, float]  # ego (x, y, heading), world (m, rad)
    poses: dict[int, tuple[float, float, float, float]]  # actor id -> world (x, y, heading, gait phase)
    gt: GroundTruth  # world truth; with measured visibility once developed
    ego: dict  # the record's ego entry
    collisions: list[Collision]  # ego collisions since the previous frame
    timings: dict[str, float]  # ms per stage
    views: list = field(default_factory=list)  # sim.cooperation.SenderView: what other cameras see (and send)


@dataclass
class _Decision:
    """What the AEB and the driver are told about one perceived frame, and when."""

    acts: int  # frame index at whose tick it is handed over (the frame's + latency)
    t: float  # s, that frame's time
    critical_in_path: bool
    nearest_in_path: float  # m
    ego_speed: float  # m/s at the perceived frame
    fcw: bool


@dataclass
class StepResult:
    """What one ``Runner.step`` did."""

    perceived: Perceived | None  # the camera frame the step ended on; None: the run ended between frames
    collisions: list[Collision]  # ego collisions that began during the step
    ticks: int  # world ticks advanced
    ended_on_collision: bool  # a collision ended the run (``end_on_collision``)
    done: bool  # the run is over: ended on a collision, or its last tick is reached


@dataclass
class RunSummary:
    ticks: int
    frames: int
    t_end: float
    collisions: list = field(default_factory=list)
    ended_on_collision: bool = False
    renderer: str | None = None
    error: str | None = None  # "Type: message" of an exception that ended the run early
    overlapped: int = 0  # frames rendered while the previous frame was perceived (``Runner.run``)

    def to_dict(self) -> dict:
        return {
            "ticks": self.ticks,
            "frames": self.frames,
            "t_end": round(self.t_end, 4),
            "collisions": [c.to_dict() for c in self.collisions],
            "ended_on_collision": self.ended_on_collision,
            "renderer": self.renderer,
            "overlapped": self.overlapped,
            "error": self.error,
        }


class Runner:
    """Runs one scenario in closed loop and feeds every camera frame to the sinks.

    ``overlap`` (with ``render``): ``run`` renders the next frame while it perceives this one,
    with one inference thread and one GL thread when the detector's ``threads`` is auto.

    ``run()`` runs it to the end; ``step()`` advances one camera frame at a time (an external
    controller may command the ego's acceleration), ``observe()`` records the current state
    as a frame without advancing (the gym env's first observation).
    """

    def __init__(
        self,
        scenario: Scenario,
        sinks: Sequence[Sink] = (),
        render: bool = True,
        detector: Detector | None = None,
        intent_config: IntentConfig | None = None,
        renderer_backend: str | None = None,
        overlap: bool = True,
    ) -> None:
        self.scenario = scenario
        self.sinks = list(sinks)
        self.world = World(scenario)
        self.camera = camera_from_scenario(scenario)
        self.intent_config = intent_config or IntentConfig().with_overrides(scenario.intent)
        perception = scenario.perception
        if render and overlap and perception.detector.threads == 0:  # auto: the other core renders
            perception = perception.model_copy(
                update={"detector": perception.detector.model_copy(update={"threads": OVERLAP_DETECTOR_THREADS})})
        with _as_scenario_error():
            self.perception = build_stack(
                perception, self.camera, scenario.camera.rate, intent=self.intent_config,
                alerts=scenario.alerts, detector=detector, seed=scenario.seed, render=render,
            )
        self.rig: RenderedCamera | None = None  # the ego camera's render worker and ground truth's visibility
        if render:
            # lazy: PyBullet only when rendering
            from lookahead.sim.rendered_camera import RenderedCamera

            backend = renderer_backend or scenario.camera.renderer  # auto: the faster here (measured once)
            shapes = {a.identity.actor_id: a.identity.shape for a in self.world.agents}
            self.rig = RenderedCamera(self.camera, self.world.layout, scenario.seed, backend, shapes, scenario,
                                      gl_threads=RENDER_WORKER_GL_THREADS if overlap else None)
        self.cooperation = None  # sim.cooperation.Cooperation: other cameras and the link (``cooperative``)
        self.fusion: FusionStage | None = None  # the ego's fusion stage, before its intent
        if scenario.cooperative is not None:
            with _as_scenario_error():
                self.cooperation = Cooperation(
                    scenario.cooperative, self.world, scenario, self.intent_config, render=render,
                    backend=renderer_backend or scenario.camera.renderer,
                    gl_threads=RENDER_WORKER_GL_THREADS if overlap else None)
            node = FusionNode(length=scenario.ego.length, width=scenario.ego.width)
            self.fusion = FusionStage(node, self.perception.estimator.priors, enabled=scenario.cooperative.fusion,
                                      alert_config=self.perception.alerts.config)
            self.perception.fusion = self.fusion
        self.aeb = Aeb(scenario.ego.aeb_config) if scenario.ego.aeb_config is not None else None
        self.driver = Driver(scenario.ego.driver) if scenario.ego.driver is not None else None
        self.driver_brake: float | None = None  # the driver's brake command (m/s^2) of the last tick
        self.aeb_brake: float | None = None  # the AEB's own brake command (m/s^2) of the last tick
        self.frame_every = max(1, int(round(scenario.rate / scenario.camera.rate)))  # world ticks per frame
        self.n_ticks = int(round(scenario.duration * scenario.rate))  # world ticks of the whole run
        self.frame_index = 0  # index of the next camera frame
        self.frames_recorded = 0  # frames handed to the sinks
        self.latency = scenario.perception.latency  # frames from a frame to its decisions acting
        self.overlap = overlap
        self._decisions: deque[_Decision] = deque()  # perceived, not yet handed to the AEB / driver

    # ------------------------------------------------------------------ one frame, in stages
    def _snapshot(self, collisions: Sequence[Collision] = (), sim_ms: float = 0.0) -> _Snapshot:
        """The world at the current tick as the next camera frame, before it is rendered:
        poses, the ego's record, the world's ground truth (``world_truth``). Advances ``frame_index``."""
        w = self.world
        t0 = time.perf_counter()
        gt = world_truth(w, self.camera, self.intent_config)
        x, y, yaw = w.ego_pose()
        ego = {"x": x, "y": y, "yaw": yaw, **w.odometry.to_dict(), "brake": w.ego.brake_command}
        if self.aeb is not None:  # only with the AEB on: runs without it record exactly as before
            ego["aeb_brake"] = self.aeb_brake
        if self.driver is not None:  # only with a driver: runs without one record exactly as before
            ego["driver_brake"] = self.driver_brake
        frame = Frame(tick=w.tick, t=w.t, camera=self.camera, odometry=w.odometry, index=self.frame_index,
                      ground=w.layout.ground_map((x, y, yaw)))
        self.frame_index += 1
        timings = {"sim": sim_ms, "gt": (time.perf_counter() - t0) * 1e3}
        snap = _Snapshot(frame, (x, y, yaw), w.actor_poses(), gt, ego, list(collisions), timings)
        if self.cooperation is not None:  # the other cameras see this tick (perceived with this frame)
            t1 = time.perf_counter()
            snap.views = self.cooperation.look(w, frame.index)
            timings["senders"] = (time.perf_counter() - t1) * 1e3
        return snap

    def _request(self, snap: _Snapshot) -> None:
        """Ask the render worker for ``snap``'s frame (if rendering); ``_develop`` collects it."""
        if self.rig is not None:
            self.rig.submit(snap.frame.index, snap.pose, snap.poses)

    def _develop(self, snap: _Snapshot) -> _Snapshot:
        """Collect ``snap``'s frame from the render worker (asked by ``_request``): the image
        (with weather), depth and segmentation, then the ground truth's visibility
        (``with_visibility``). Timings: ``render``, the worker's ms (render and weather); ``gt``
        gains the visibility's."""
        if self.rig is None:
            snap.timings["render"] = 0.0
            return snap
        image, depth, seg, snap.gt, worker_ms, visibility_ms = self.rig.develop(snap.gt, snap.pose, snap.poses)
        snap.frame.image, snap.frame.depth, snap.frame.segmentation = image, depth, seg
        snap.timings["render"] = worker_ms
        snap.timings["gt"] += visibility_ms
        return snap

    def frame(self) -> tuple[Frame, GroundTruth, dict[str, float]]:
        """Render (if on) and compute ground truth for the world's current state (advances
        ``frame_index``; records nothing). Timings (ms): ``render``, ``gt``."""
        snap = self._snapshot()
        self._request(snap)
        self._develop(snap)
        return snap.frame, snap.gt, {k: snap.timings[k] for k in ("render", "gt")}

    def _perceive(self, snap: _Snapshot) -> Perceived:
        """``snap`` (developed) through the perception stack; queues the AEB's and the driver's
        decision on it, to act ``latency`` frames later, and hands over those due now
        (``_apply_decisions``)."""
        frame, timings = snap.frame, snap.timings
        if self.cooperation is not None:  # the senders' messages of this tick go out; the ego gets what arrived
            t0 = time.perf_counter()
            self.cooperation.send(snap.views, frame.t)
            self.fusion.receive(self.cooperation.receive(frame.t), snap.pose)
            timings["senders"] += (time.perf_counter() - t0) * 1e3
        dets, tracks, est, assessment, alerts = self.perception.process(
            frame, detector_truth(snap.gt, self.camera), timings
        )
        cooperative = None
        if self.fusion is not None:
            own_truth = truth_ids(tracks.xyxy, snap.gt, self.camera)[self.fusion.own_track_rows]
            cooperative = cooperative_record(snap.views, self.fusion, own_truth, self.cooperation.link)
        if self.aeb is not None or self.driver is not None:
            crit, nearest = self.perception.critical_in_path(tracks, est, assessment)  # own camera's objects only
            ids, in_path = tracks.track_id.tolist(), assessment.in_path.tolist()
            remote = self.fusion.remote if self.fusion is not None else None
            if remote is not None:  # the driver is warned of what only others see too
                ids, in_path = ids + remote.ids.tolist(), in_path + remote.assessment.in_path.tolist()
            fcw = alert_in_path(self.perception.alerts.active(), ids, in_path, Risk.HIGH)
            acts = frame.index + self.latency  # the frame whose tick the decision is made at
            t = (frame.tick + self.latency * self.frame_every) * self.world.dt
            self._decisions.append(_Decision(acts, t, crit, nearest, frame.odometry.speed, fcw))
            self._apply_decisions()
        return Perceived(frame, snap.gt, dets, tracks, est, assessment, alerts, timings, cooperative)

    def _record(self, snap: _Snapshot, p: Perceived, t_start: float) -> None:
        """``p`` as a ``TickRecord`` to every sink; ``tick`` timing = sim + everything since ``t_start``."""
        timings = p.timings
        record = TickRecord(
            tick=snap.frame.tick, frame_index=snap.frame.index, t=snap.frame.t, ego=snap.ego, frame=p.frame,
            ground_truth=p.gt, detections=p.detections, tracks=p.tracks, estimates=p.est,
            assessments=p.assessment, alerts=p.alerts, collisions=snap.collisions, timings=timings,
            cooperative=p.cooperative, sender_frames={v.name: v.frame for v in snap.views},
            cipv=cipv_record(p.tracks, p.est, p.assessment, p.gt),
        )
        t0 = time.perf_counter()
        for s in self.sinks:
            s.on_tick(record)
        self.frames_recorded += 1
        timings["sinks"] = (time.perf_counter() - t0) * 1e3
        timings["tick"] = timings["sim"] + (time.perf_counter() - t_start) * 1e3

    def _apply_decisions(self) -> None:
        """Hand the AEB and the driver every queued decision due at the world's current frame."""
        while self._decisions and self._decisions[0].acts <= self.frame_index - 1:
            d = self._decisions.popleft()
            if self.aeb is not None:
                self.aeb.decide(d.t, d.critical_in_path, d.nearest_in_path, d.ego_speed)
            if self.driver is not None:
                self.driver.decide(d.t, d.fcw)

    def _may_run_ahead(self) -> bool:
        """Whether the world may step to the next frame before the current frame is perceived
        without changing the run: its decision acts at a later frame (``latency`` >= 1), or
        no decision on it can change a brake command before the next frame: no AEB or it is
        idle and engages only ``latency`` s after deciding, at least a frame period (a
        braking AEB may release at once); no driver, or one whose reaction takes a frame
        period, or who brakes already (later warnings change nothing)."""
        if self.latency >= 1:
            return True
        period = (self.frame_every - 0.5) * self.world.dt  # commands are read at ticks before the next frame
        aeb_ok = self.aeb is None or (self.aeb.state == "idle" and self.aeb.config.latency >= period)
        driver_ok = self.driver is None or self.driver.braking or self.driver.config.reaction_s >= period
        return aeb_ok and driver_ok

    def _advance(self) -> tuple[StepResult, bool, float]:
        """World ticks, each the brake command (the AEB's or the driver's, the stronger) then
        ``World.step``, until a frame tick or a collision that ends the run (True: the caller
        observes the frame; ``perceived`` is None) or the last tick between frames (False);
        and the ms spent stepping."""
        w = self.world
        collisions: list[Collision] = []
        sim_ms, ticks = 0.0, 0
        while w.tick < self.n_ticks:
            t0 = time.perf_counter()
            if self.aeb is not None or self.driver is not None:  # the stronger brake wins
                self.driver_brake = self.driver.command(w.t) if self.driver is not None else None
                self.aeb_brake = self.aeb.command(w.t) if self.aeb is not None else None
                w.ego.brake_command = combine_brakes(self.aeb_brake, self.driver_brake)
            collisions += w.step()
            sim_ms += (time.perf_counter() - t0) * 1e3
            ticks += 1
            ended = bool(collisions) and self.scenario.end_on_collision
            if w.tick % self.frame_every == 0 or ended:
                return StepResult(None, collisions, ticks, ended, ended or w.tick >= self.n_ticks), True, sim_ms
        return StepResult(None, collisions, ticks, False, True), False, sim_ms

    # ------------------------------------------------------------------ running
    def run(self, progress: Callable[[float], None] | None = None) -> RunSummary:
        """Step to the end (the duration, or a collision with ``end_on_collision``); ``progress``
        gets the fraction of the duration done after every frame. Sinks get ``on_start``, every
        frame and ``on_end`` (also when an exception ends the run: its ``error``); closes the runner.

        With rendering and ``overlap``, the render worker (``sim.render_process``) draws frame
        k+1 while frame k is perceived, whenever the world may run ahead (``_may_run_ahead``);
        the records are the same as without overlap."""
        sc = self.scenario
        summary = self.start()
        overlap = self.overlap and self.renderer is not None
        pending: tuple[_Snapshot, float] | None = None  # asked of the render worker, not yet perceived

        def finish() -> None:
            nonlocal pending
            if pending is not None:
                snap, t_start = pending
                pending = None
                self._record(snap, self._perceive(self._develop(snap)), t_start)

        try:
            while self.world.tick < self.n_ticks:
                if pending is not None and (not overlap or not self._may_run_ahead()):
                    finish()
                self._apply_decisions()
                self.world.ego.accel_command = None
                result, framed, sim_ms = self._advance()
                if not framed:
                    break
                t_start = time.perf_counter()
                snap = self._snapshot(result.collisions, sim_ms)
                self._request(snap)  # rendered by the worker while the previous frame is perceived
                summary.overlapped += pending is not None  # only overlapping runs leave one pending here
                finish()
                pending = (snap, t_start)
                if progress is not None:
                    progress(self.world.t / sc.duration)
                if result.ended_on_collision:
                    summary.ended_on_collision = True
                    break
            finish()
        except BaseException as e:  # told to the sinks (an incomplete run), then re-raised
            summary.error = f"{type(e).__name__}: {e}".rstrip(": ")
            raise
        finally:
            self.finish(summary)
        return summary

    def start(self) -> RunSummary:
        """Every sink's ``on_start`` (scenario, seed, ticks, renderer, camera); the run's summary
        to fill. ``run`` calls it; a caller that drives ``step`` itself (``lookahead drive``) too."""
        sc = self.scenario
        info = {"scenario": sc.name, "seed": sc.seed, "ticks": self.n_ticks,
                "renderer": getattr(self.renderer, "backend", None), "camera": self.camera}
        for s in self.sinks:
            s.on_start(info)
        return RunSummary(0, 0, 0.0, renderer=info["renderer"])

    def finish(self, summary: RunSummary) -> RunSummary:
        """``summary`` completed from the world (ticks, frames, time, collisions), every sink's
        ``on_end`` with it, the runner closed."""
        try:
            summary.ticks, summary.frames, summary.t_end = self.world.tick, self.frames_recorded, self.world.t
            summary.collisions = list(self.world.collisions)
            for s in self.sinks:
                s.on_end(summary.to_dict())
        finally:
            self.close()
        return summary

    def step(self, accel: float | None = None) -> StepResult:
        """Advance to the next camera frame and ``observe`` it.

        First the AEB and the driver get the decisions due at the current frame (those on
        the frame ``latency`` frames back). Then world ticks, each the brake command (the
        AEB's or the driver's, the stronger) then ``World.step``, until a frame tick
        (``tick % frame_every == 0``) or a collision that ends the run (``end_on_collision``),
        which are observed, or the run's last tick (``n_ticks``) between frames, which is not.

        Args:
            accel: the ego's longitudinal acceleration (m/s^2) for these ticks, replacing its
                controller (``EgoVehicle.accel_command``; the AEB still overrides it); None = the
                scenario's controller.
        """
        self._apply_decisions()
        self.world.ego.accel_command = accel
        result, framed, sim_ms = self._advance()
        if not framed:
            return result
        result.perceived = self.observe(result.collisions, sim_ms)
        return result

    def observe(self, collisions: Sequence[Collision] = (), sim_ms: float = 0.0) -> Perceived:
        """The world's current state as the next camera frame: rendered, perceived, recorded to
        every sink as a ``TickRecord``; advances ``frame_index``.

        Args:
            collisions: ego collisions since the previous frame (they go into the record).
            sim_ms: time spent stepping the world since the previous frame (ms, stage ``sim``).
        """
        t_start = time.perf_counter()
        snap = self._snapshot(collisions, sim_ms)
        self._request(snap)
        p = self._perceive(self._develop(snap))
        self._record(snap, p, t_start)
        return p

    def close(self) -> None:
        if self.rig is not None:
            self.rig.close()
            self.rig = None
        if self.cooperation is not None:
            self.cooperation.close()

    @property
    def renderer(self) -> Any:
        """The ego camera's ``RenderProcess`` (None without rendering)."""
        return None if self.rig is None else self.rig.process

    @property
    def silhouettes(self) -> Any:
        """The ego camera's actors alone (``sim.silhouettes.Silhouettes``; None without rendering)."""
        return None if self.rig is None else self.rig.silhouettes
