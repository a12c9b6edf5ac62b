"""The closed-loop runner: world -> camera -> ground truth -> perception -> sinks.

The world steps at the scenario ``rate``; every ``rate / camera.rate`` ticks
the camera renders a ``Frame``, ground truth is computed, the detector runs,
and a ``TickRecord`` goes to every sink. Sinks are injected (observers) so
``sim`` never imports ``tools``. Each stage is timed (ms).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from lookahead.intent.alerts import Alert, AlertConfig, AlertManager
from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Assessment, Kinematics, Risk, assess
from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import Detections
from lookahead.perception.detectors.base import Detector, DetectorTruth
from lookahead.perception.estimator import Estimates, Estimator, EstimatorConfig
from lookahead.perception.frame import Frame
from lookahead.perception.preprocess import PreprocessChain
from lookahead.perception.tracker import Tracker, TrackerConfig, Tracks
from lookahead.sim.aeb import Aeb
from lookahead.sim.catalogue import DEFAULT_MODEL
from lookahead.sim.groundtruth import GroundTruth, compute_ground_truth
from lookahead.sim.records import Sink, TickRecord
from lookahead.sim.scenario import DetectorSpec, Scenario, ScenarioError
from lookahead.sim.world import World

log = logging.getLogger(__name__)


STAGES = ("sim", "render", "gt", "preprocess", "detect", "track", "estimate", "intent", "sinks", "tick")


def camera_from_scenario(scenario: Scenario) -> CameraModel:
    c = scenario.camera
    m = c.mount
    return CameraModel.from_fov(
        c.width, c.height, c.fov_h, mount=(m.x, m.y, m.z), yaw_deg=m.yaw, pitch_deg=m.pitch, roll_deg=m.roll
    )


def resolve_detector(spec: DetectorSpec, render: bool) -> DetectorSpec:
    """``kind: auto`` made concrete: the shipped ONNX model when frames are rendered, else ``gt``."""
    kind = spec.kind if spec.kind != "auto" else ("onnx" if render else "gt")
    model = spec.model or (str(DEFAULT_MODEL) if kind == "onnx" else None)
    return spec.model_copy(update={"kind": kind, "model": model})


def build_detector(spec: DetectorSpec, seed: int, render: bool = True) -> Detector:
    """The scenario's detector (``gt`` noise model or an ``onnx`` model, see ``resolve_detector``)."""
    spec = resolve_detector(spec, render)
    if spec.kind == "onnx":
        from lookahead.perception.detectors.onnx_detector import OnnxDetector

        if not render:
            raise ScenarioError("perception.detector.kind: onnx needs rendered frames, and rendering is off")
        return OnnxDetector(spec.model, conf_threshold=spec.conf, iou_threshold=spec.iou, windows=spec.windows)
    from lookahead.perception.detectors.gt_detector import GtNoiseConfig, GtNoiseDetector

    return GtNoiseDetector(GtNoiseConfig(**spec.noise), seed=seed)


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


class PerceptionStack:
    """Preprocess -> detector -> tracker -> estimator -> intent for one camera; each stage timed (ms).

    Knows nothing of the simulator: ``truth`` is only handed to simulated detectors.
    ``preprocess`` (``perception.preprocess.PreprocessChain``) feeds the detector
    only; ``frame.image`` stays the camera's image.
    """

    def __init__(
        self, detector: Detector, camera: CameraModel, frame_rate: float, intent_config: IntentConfig,
        tracker_config: TrackerConfig | None = None, estimator_config: EstimatorConfig | None = None,
        alert_config: AlertConfig | None = None, preprocess: PreprocessChain | None = None,
    ) -> None:
        self.preprocess = preprocess or PreprocessChain()
        self.detector = detector
        self.tracker = Tracker(tracker_config, frame_rate=frame_rate)
        self.estimator = Estimator(camera, estimator_config)
        self.intent_config = intent_config
        self.alerts = AlertManager(alert_config)

    def process(
        self, frame: Frame, truth: DetectorTruth | None, timings: dict[str, float]
    ) -> tuple[Detections, Tracks, Estimates, Assessment, list[Alert]]:
        tp = time.perf_counter()
        image = self.preprocess(frame.image)
        t0 = time.perf_counter()
        dets = self.detector.detect(image, truth)
        t1 = time.perf_counter()
        tracks = self.tracker.update(dets)
        t2 = time.perf_counter()
        est = self.estimator.update(tracks, frame.odometry, frame.t, detections=dets)
        t3 = time.perf_counter()
        kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
        assessment = assess(kin, self.intent_config, frame.odometry.speed, frame.odometry.yaw_rate)
        alerts = self.alerts.update(frame.t, tracks.track_id, tracks.class_id, est.range, assessment)
        t4 = time.perf_counter()
        timings.update(preprocess=(t0 - tp) * 1e3, detect=(t1 - t0) * 1e3, track=(t2 - t1) * 1e3,
                       estimate=(t3 - t2) * 1e3, intent=(t4 - t3) * 1e3)
        return dets, tracks, est, assessment, alerts

    def critical_in_path(self, tracks: Tracks, est: Estimates, a: Assessment) -> tuple[bool, float]:
        """Whether a CRITICAL alert is on for an in-path track, and the nearest in-path range (m)."""
        active = self.alerts.active()
        crit = any(active.get(int(t), 0) >= Risk.CRITICAL and a.in_path[i] for i, t in enumerate(tracks.track_id))
        rng = est.range[a.in_path & np.isfinite(est.range)]
        return crit, float(rng.min()) if len(rng) else float("inf")


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
    """Runs one scenario in closed loop and feeds every frame to the sinks."""

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
        p = scenario.perception
        self.perception = PerceptionStack(
            detector or build_detector(p.detector, scenario.seed, render), self.camera, scenario.camera.rate,
            self.intent_config, TrackerConfig(**p.tracker), EstimatorConfig(**p.estimator),
            alert_config=scenario.alerts, preprocess=PreprocessChain(p.preprocess),
        )
        self.renderer = None
        self.weather = None  # sim.weather.Weather: applied to the rendered RGB (not clear)
        if render:
            from lookahead.sim.renderer import Renderer

            self.renderer = Renderer(
                self.camera, self.world.layout, seed=scenario.seed,
                backend=renderer_backend or scenario.camera.renderer,
            )
            for a in self.world.agents:
                self.renderer.add_actor(a.identity.actor_id, a.identity.shape)
            if scenario.weather.kind != "clear":
                from lookahead.sim.weather import Weather

                self.weather = Weather.from_scenario(
                    scenario, self.camera, self.world.layout, far=self.renderer.far
                )
        self.aeb = Aeb(scenario.ego.aeb_config) if scenario.ego.aeb_config is not None else None
        self.frame_every = max(1, int(round(scenario.rate / scenario.camera.rate)))
        self.frame_index = 0

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
        sc = self.scenario
        n_ticks = int(round(sc.duration * sc.rate))
        info = {"scenario": sc.name, "seed": sc.seed, "ticks": n_ticks,
                "renderer": getattr(self.renderer, "backend", None)}
        for s in self.sinks:
            s.on_start(info)
        summary = RunSummary(0, 0, 0.0, renderer=info["renderer"])
        sim_ms = 0.0
        new_collisions: list = []
        try:
            for _ in range(n_ticks):
                t0 = time.perf_counter()
                if self.aeb is not None:
                    self.world.ego.brake_command = self.aeb.command(self.world.t)
                new_collisions += self.world.step()
                sim_ms += (time.perf_counter() - t0) * 1e3
                ended = bool(new_collisions) and sc.end_on_collision
                if self.world.tick % self.frame_every == 0 or ended:
                    self._emit(sim_ms, new_collisions)
                    sim_ms, new_collisions = 0.0, []
                if progress is not None:
                    progress(self.world.t / sc.duration)
                if ended:
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

    def perceive(self) -> Perceived:
        """The current camera frame through the perception stack, and the AEB's decision on it.

        Leaves ``frame_index`` for the caller to advance once the frame is recorded."""
        frame, gt, timings = self.frame()
        dets, tracks, est, assessment, alerts = self.perception.process(
            frame, detector_truth(gt, self.camera), timings
        )
        if self.aeb is not None:
            crit, nearest = self.perception.critical_in_path(tracks, est, assessment)
            self.aeb.decide(frame.t, crit, nearest, frame.odometry.speed)
        return Perceived(frame, gt, dets, tracks, est, assessment, alerts, timings)

    def _emit(self, sim_ms: float, collisions: list) -> None:
        t_start = time.perf_counter()
        p = self.perceive()
        frame, timings = p.frame, p.timings
        timings["sim"] = sim_ms
        w = self.world
        x, y, yaw = w.ego_pose()
        ego = {"x": x, "y": y, "yaw": yaw, **w.odometry.to_dict(),
               "brake": w.ego.brake_command}
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

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None
