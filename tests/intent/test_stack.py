"""``intent.stack``: the perception + intent stack, built from settings without the simulator."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from lookahead.intent.alerts import AlertConfig
from lookahead.intent.config import IntentConfig
from lookahead.intent.stack import PerceptionStack, build_detector, build_stack, resolve_detector
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import DEFAULT_MODEL, DetectorSpec, PerceptionSpec, SettingsError
from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.tracker import TrackState

CAMERA = CameraModel.from_fov(640, 360, 90.0)
EXACT_GT = {"miss_rate": 0.0, "miss_occlusion": 0.0, "miss_truncation": 0.0, "box_sigma": 0.0, "fp_rate": 0.0,
            "class_confusion": 0.0}  # the gt detector without noise


def test_importing_the_stack_loads_no_simulator():
    code = (
        "import sys\n"
        "import lookahead.intent.stack\n"
        "bad = [m for m in ('highway_env', 'gymnasium', 'pybullet') if m in sys.modules]\n"
        "bad += [m for m in sys.modules if m.startswith(('lookahead.sim', 'lookahead.tools'))]\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"importing lookahead.intent.stack loaded: {out.stdout.strip()}"


def _car_box(range_m: float) -> list[float]:
    """xyxy (px) of a 1.8 m wide, 1.5 m high car straight ahead, its rear at ``range_m``."""
    x, y, z = np.meshgrid([range_m, range_m + 4.5], [-0.9, 0.9], [0.0, 1.5], indexing="ij")
    uv = CAMERA.project(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1))
    return [*uv.min(axis=0), *uv.max(axis=0)]


def _frames(n: int, speed: float = 10.0):
    """n frames at 10 Hz, a stationary car 25 m ahead closing in, with what a simulated detector sees of it."""
    for i in range(n):
        t = i / 10.0
        truth = DetectorTruth(width=640, height=360, xyxy=[_car_box(25.0 - speed * t)],
                              class_id=[CLASS_ID["car"]], source_id=[7], range_m=[25.0 - speed * t])
        yield Frame(tick=2 * i, t=t, camera=CAMERA, odometry=EgoOdometry(speed=speed), index=i), truth


def test_factory_builds_a_working_stack_from_settings():
    settings = PerceptionSpec.model_validate(
        {"detector": {"kind": "gt", "noise": EXACT_GT}, "tracker": {"min_hits": 2}, "estimator": {"motion_model": "cv"}}
    )
    stack = build_stack(settings, CAMERA, 10.0, intent={"horizon": 2.0}, alerts=AlertConfig(off_frames=4), seed=3,
                        render=False)
    assert isinstance(stack, PerceptionStack)
    assert stack.detector.name.startswith("gt")
    assert stack.tracker.config.min_hits == 2 and stack.tracker.frame_rate == 10.0
    assert stack.estimator.config.motion_model == "cv"
    assert stack.intent_config.horizon == 2.0 and stack.alerts.config.off_frames == 4
    states, ranges = [], []
    for frame, truth in _frames(4):
        timings: dict[str, float] = {}
        dets, tracks, est, assessment, alerts = stack.process(frame, truth, timings)
        assert len(dets) == 1 and set(timings) == {"preprocess", "detect", "track", "estimate", "intent"}
        assert len(assessment.label) == len(tracks)
        states.append(tracks.state.tolist())
        ranges.append(est.range.tolist())
    assert states == [[], [TrackState.CONFIRMED]] + [[TrackState.CONFIRMED]] * 2  # confirmed on the 2nd hit
    assert ranges[-1][0] == pytest.approx(25.0 - 10.0 * 0.3, abs=1.0)  # the car's range at t = 0.3 s


def test_an_injected_detector_replaces_the_settings_one():
    class Recorded:
        name = "recorded"

        def detect(self, image, truth=None):
            return Detections([[100.0, 150.0, 140.0, 250.0]], [0.9], [CLASS_ID["pedestrian"]])

    stack = build_stack(PerceptionSpec(), CAMERA, 10.0, detector=Recorded(), render=False)
    assert stack.detector.name == "recorded"
    assert stack.intent_config == IntentConfig() and stack.alerts.config == AlertConfig()
    for frame, _ in _frames(3):
        _, tracks, *_ = stack.process(frame, None, {})
    assert tracks.track_id.tolist() == [1]


def test_detector_settings_resolve_and_refuse_onnx_without_images():
    assert resolve_detector(DetectorSpec(), render=False).kind == "gt"
    onnx = resolve_detector(DetectorSpec(), render=True)
    assert onnx.kind == "onnx" and onnx.model == str(DEFAULT_MODEL)
    with pytest.raises(SettingsError, match="perception.detector.kind: onnx needs rendered frames"):
        build_detector(DetectorSpec(kind="onnx"), seed=0, render=False)


def test_the_simulator_reports_refused_settings_as_scenario_errors():
    from lookahead.sim.catalogue import SCENARIOS
    from lookahead.sim.runner import Runner
    from lookahead.sim.scenario import ScenarioError, load_scenario, with_detector

    sc = with_detector(load_scenario(SCENARIOS / "stationary_car.yaml"), "onnx")
    with pytest.raises(ScenarioError, match="onnx needs rendered frames"):
        Runner(sc, render=False)


def test_appearance_keeps_the_id_of_an_object_that_was_hidden():
    """``perception.appearance.enabled``: the stack embeds only the detections the tracker asks for,
    and a pedestrian hidden for 1.5 s comes back under its old id; without appearance, a new id."""
    from lookahead.tools.bench.appearance import scene

    image, _ = scene(1, 1)  # a seeded noise image: every crop looks different

    class Scripted:
        name = "scripted"

        def __init__(self):
            self.i = 0

        def detect(self, image, truth=None):
            self.i += 1
            if 10 <= self.i < 25:  # hidden behind something for 1.5 s
                return Detections()
            x = 100.0 + 4.0 * self.i
            boxes = [[x, 150.0, x + 30.0, 220.0], [500.0, 100.0, 530.0, 170.0]]  # the walker, a bystander
            return Detections(boxes, [0.9, 0.9], [CLASS_ID["pedestrian"]] * 2)

    ids = {}
    for on in (False, True):
        spec = PerceptionSpec.model_validate({"appearance": {"enabled": on}})
        stack = build_stack(spec, CAMERA, 10.0, detector=Scripted(), render=True)
        assert (stack.embedder is not None) == on
        first = last = None
        embedded = 0
        for i in range(40):
            timings: dict[str, float] = {}
            frame = Frame(tick=i, t=i / 10.0, camera=CAMERA, odometry=EgoOdometry(speed=0.0), image=image, index=i)
            _, tracks, *_ = stack.process(frame, None, timings)
            assert ("embed" in timings) == on
            embedded += on and timings["embed"] > 1.0  # the embedder ran (ms), not just the tracker's question
            walker = tracks.track_id[(tracks.xyxy[:, 0] < 400) & (tracks.state == TrackState.CONFIRMED)]
            if len(walker):
                first = first if first is not None else int(walker[0])
                last = int(walker[0])
        ids[on] = (first, last)
        if on:
            assert 0 < embedded < 20  # only when asked: refreshes and the return
    assert ids[True][0] == ids[True][1]  # kept through the 1.5 s gap
    assert ids[False][0] != ids[False][1]  # without appearance: a new track
    assert not build_stack(PerceptionSpec.model_validate({"appearance": {"enabled": True}}), CAMERA, 10.0,
                           detector=Scripted(), render=False).embedder  # no pixels, no embedder
