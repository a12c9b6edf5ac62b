"""The closed-loop runner: world -> camera -> ground truth -> perception -> sinks.

The world steps at the scenario ``rate``; every ``frame_every = rate / camera.rate`` ticks
the camera renders a ``Frame``, ground truth is computed, the perception + intent stack
(``intent.stack``, built by ``build_stack`` from the scenario's settings) runs, the AEB
and the driver (``sim.driver``, if the scenario has one) decide, and a ``TickRecord`` goes
to every sink. ``Runner.step`` advances one camera frame (the gym env steps with it);
``Runner.run`` loops over it to the end. Sinks are injected (observers) so ``sim`` never
imports ``tools``. Each stage is timed (ms).
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
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from lookahead.intent.alerts import Alert
from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Assessment, Risk
from lookahead.intent.stack import alert_in_path, build_stack
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import SettingsError
from lookahead.perception.detections import Detections
from lookahead.perception.detectors.base import Detector, DetectorTruth
from lookahead.perception.estimator import Estimates
from lookahead.perception.frame import Frame
from lookahead.perception.tracker import Tracks
from lookahead.sim.aeb import Aeb
from lookahead.sim.driver import Driver, combine_brakes
from lookahead.sim.ego import Collision
from lookahead.sim.groundtruth import GroundTruth, compute_ground_truth
from lookahead.sim.records import Sink, TickRecord
from lookahead.sim.scenario import Scenario, ScenarioError, mounted_camera
from lookahead.sim.weather import Weather
from lookahead.sim.world import World

log = logging.getLogger(__name__)


STAGES = ("sim", "render", "gt", "preprocess", "detect", "track", "estimate", "intent", "sinks", "tick")


def camera_from_scenario(scenario: Scenario) -> CameraModel:
    c = scenario.camera
    return mounted_camera(c.width, c.height, c.fov_h, c.mount)


@contextmanager
def _as_scenario_error() -> Iterator[None]:
    """Settings the stack refuses (``SettingsError``) are the scenario's: re-raised as ``ScenarioError``."""
    try:
        yield
    except ScenarioError:
        raise
    except SettingsError as e:
        raise ScenarioError(str(e)) from None


def detector_truth(gt: GroundTruth, camera: CameraModel) -> DetectorTruth:
    """What a simulated detector may see: visible boxes of detection-class actors."""
    keep = (gt.class_id >= 0) & np.all(np.isfinite(gt.visible), axis=1) & (gt.visible_fraction > 0)
    return DetectorTruth(
        width=camera.width,
        height=camera.height,
        xyxy=gt.visible[keep],
        class_id=gt.class_id[keep],
        source_id=gt.actor_id[keep],
        range_m=gt.range[keep],
        visible_fraction=gt.visible_fraction[keep],
        truncation=gt.truncation[keep],
    )


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

    def to_dict(self) -> dict:
        return {
            "ticks": self.ticks,
            "frames": self.frames,
            "t_end": round(self.t_end, 4),
            "collisions": [c.to_dict() for c in self.collisions],
            "ended_on_collision": self.ended_on_collision,
            "renderer": self.renderer,
            "error": self.error,
        }


class Runner:
    """Runs one scenario in closed loop and feeds every camera frame to the sinks.

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
    ) -> None:
        self.scenario = scenario
        self.sinks = list(sinks)
        self.world = World(scenario)
        self.camera = camera_from_scenario(scenario)
        self.intent_config = intent_config or IntentConfig().with_overrides(scenario.intent)
        with _as_scenario_error():
            self.perception = build_stack(
                scenario.perception, self.camera, scenario.camera.rate, intent=self.intent_config,
                alerts=scenario.alerts, detector=detector, seed=scenario.seed, render=render,
            )
        self.renderer = None
        self.weather = None  # sim.weather.Weather: applied to the rendered RGB (not clear)
        if render:
            from lookahead.sim.renderer import Renderer  # lazy: PyBullet only when rendering

            self.renderer = Renderer(
                self.camera, self.world.layout, seed=scenario.seed,
                backend=renderer_backend or scenario.camera.renderer,
            )
            for a in self.world.agents:
                self.renderer.add_actor(a.identity.actor_id, a.identity.shape)
            if scenario.weather.kind != "clear":
                self.weather = Weather.from_scenario(
                    scenario, self.camera, self.world.layout, far=self.renderer.far
                )
        self.aeb = Aeb(scenario.ego.aeb_config) if scenario.ego.aeb_config is not None else None
        self.driver = Driver(scenario.ego.driver) if scenario.ego.driver is not None else None
        self.driver_brake: float | None = None  # the driver's brake command (m/s^2) of the last tick
        self.aeb_brake: float | None = None  # the AEB's own brake command (m/s^2) of the last tick
        self.frame_every = max(1, int(round(scenario.rate / scenario.camera.rate)))  # world ticks per frame
        self.n_ticks = int(round(scenario.duration * scenario.rate))  # world ticks of the whole run
        self.frame_index = 0  # index of the next camera frame

    def _poses(self) -> dict[int, tuple[float, float, float, float]]:
        st = self.world.agent_states()
        return {
            int(i): (float(x), float(y), float(h), float(p))
            for i, (x, y), h, p in zip(st.ids, st.xy, st.yaw, st.gait_phase, strict=True)
        }

    def frame(self) -> tuple[Frame, GroundTruth, dict[str, float]]:
        """Render (if on) and compute ground truth for the world's current state."""
        timings: dict[str, float] = {}
        w = self.world
        image = depth = seg = None
        silhouettes: Callable | None = None
        t0 = time.perf_counter()
        if self.renderer is not None:
            pose = w.ego_pose()
            poses = self._poses()
            out = self.renderer.render(pose, poses)
            image, depth, seg = out.rgb, out.depth, out.seg
            if self.weather is not None:  # only the image: depth, seg and ground truth stay exact
                image = self.weather.apply(image, depth, self.frame_index, pose)

            def silhouettes(ids: list[int], window: tuple[int, int, int, int] | None = None) -> np.ndarray:
                return self.renderer.silhouettes(pose, poses, ids, window)

        t1 = time.perf_counter()
        gt = compute_ground_truth(w, self.camera, self.intent_config, seg=seg, silhouettes=silhouettes)
        t2 = time.perf_counter()
        timings["render"] = (t1 - t0) * 1e3
        timings["gt"] = (t2 - t1) * 1e3
        frame = Frame(
            tick=w.tick, t=w.t, camera=self.camera, odometry=w.odometry,
            image=image, depth=depth, segmentation=seg, index=self.frame_index,
        )
        return frame, gt, timings

    def run(self, progress: Callable[[float], None] | None = None) -> RunSummary:
        """Step to the end (the duration, or a collision with ``end_on_collision``); ``progress``
        gets the fraction of the duration done after every step. Sinks get ``on_start``, every
        frame and ``on_end`` (also when an exception ends the run: its ``error``); closes the runner."""
        sc = self.scenario
        info = {"scenario": sc.name, "seed": sc.seed, "ticks": self.n_ticks,
                "renderer": getattr(self.renderer, "backend", None), "camera": self.camera}
        for s in self.sinks:
            s.on_start(info)
        summary = RunSummary(0, 0, 0.0, renderer=info["renderer"])
        try:
            while self.world.tick < self.n_ticks:
                result = self.step()
                if progress is not None:
                    progress(self.world.t / sc.duration)
                if result.ended_on_collision:
                    summary.ended_on_collision = True
                    break
        except BaseException as e:  # told to the sinks (an incomplete run), then re-raised
            summary.error = f"{type(e).__name__}: {e}".rstrip(": ")
            raise
        finally:
            summary.ticks, summary.frames, summary.t_end = self.world.tick, self.frame_index, self.world.t
            summary.collisions = list(self.world.collisions)
            for s in self.sinks:
                s.on_end(summary.to_dict())
            self.close()
        return summary

    def step(self, accel: float | None = None) -> StepResult:
        """Advance to the next camera frame and ``observe`` it.

        World ticks, each the brake command (the AEB's or the driver's, the stronger) then
        ``World.step``, until a frame tick (``tick % frame_every == 0``) or a collision that ends
        the run (``end_on_collision``), which are observed, or the run's last tick (``n_ticks``)
        between frames, which is not.

        Args:
            accel: the ego's longitudinal acceleration (m/s^2) for these ticks, replacing its
                controller (``EgoVehicle.accel_command``; the AEB still overrides it); None = the
                scenario's controller.
        """
        w = self.world
        w.ego.accel_command = accel
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
                perceived = self.observe(collisions, sim_ms)
                return StepResult(perceived, collisions, ticks, ended, ended or w.tick >= self.n_ticks)
        return StepResult(None, collisions, ticks, False, True)

    def observe(self, collisions: Sequence[Collision] = (), sim_ms: float = 0.0) -> Perceived:
        """The world's current state as the next camera frame: perceived (``perceive``), recorded
        to every sink as a ``TickRecord``; advances ``frame_index``.

        Args:
            collisions: ego collisions since the previous frame (they go into the record).
            sim_ms: time spent stepping the world since the previous frame (ms, stage ``sim``).
        """
        t_start = time.perf_counter()
        p = self.perceive()
        frame, timings = p.frame, p.timings
        timings["sim"] = sim_ms
        w = self.world
        x, y, yaw = w.ego_pose()
        ego = {"x": x, "y": y, "yaw": yaw, **w.odometry.to_dict(),
               "brake": w.ego.brake_command}
        if self.aeb is not None:  # only with the AEB on: runs without it record exactly as before
            ego["aeb_brake"] = self.aeb_brake
        if self.driver is not None:  # only with a driver: runs without one record exactly as before
            ego["driver_brake"] = self.driver_brake
        record = TickRecord(
            tick=w.tick, frame_index=self.frame_index, t=w.t, ego=ego, frame=frame,
            ground_truth=p.gt, detections=p.detections, tracks=p.tracks, estimates=p.est,
            assessments=p.assessment, alerts=p.alerts, collisions=list(collisions), timings=timings,
        )
        t0 = time.perf_counter()
        for s in self.sinks:
            s.on_tick(record)
        timings["sinks"] = (time.perf_counter() - t0) * 1e3
        timings["tick"] = sim_ms + (time.perf_counter() - t_start) * 1e3
        self.frame_index += 1
        return p

    def perceive(self) -> Perceived:
        """The current camera frame through the perception stack, and the AEB's decision on it.

        Records nothing and leaves ``frame_index`` alone: ``observe`` does both."""
        frame, gt, timings = self.frame()
        dets, tracks, est, assessment, alerts = self.perception.process(
            frame, detector_truth(gt, self.camera), timings
        )
        if self.aeb is not None:
            crit, nearest = self.perception.critical_in_path(tracks, est, assessment)
            self.aeb.decide(frame.t, crit, nearest, frame.odometry.speed)
        if self.driver is not None:
            fcw = alert_in_path(self.perception.alerts.active(), tracks.track_id.tolist(),
                                assessment.in_path.tolist(), Risk.HIGH)
            self.driver.decide(frame.t, fcw)
        return Perceived(frame, gt, dets, tracks, est, assessment, alerts, timings)

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None
