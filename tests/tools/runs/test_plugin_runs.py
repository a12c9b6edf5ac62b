"""Detector plug-ins in closed-loop runs: the example package (examples/lookahead_example_plugin)
installed and run by its entry-point name, ``--detector hog``, and a plug-in that fails mid-run
(the run ends with its outputs intact and one error line)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import pytest
from support.clips import render_records
from typer.testing import CliRunner

from lookahead.perception.calibration import CameraCalibration, write_calibration
from lookahead.perception.plugins import PluginError
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.tools.cli import USER_ERRORS, app
from lookahead.tools.sinks.rundir import RunDirWriter

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "examples" / "lookahead_example_plugin"
cli = CliRunner()

FAILING = '''
from lookahead.perception.detections import Detections


class FailsOnThirdFrame:
    """Echoes the visible ground truth (a plug-in may use it in the simulator), then breaks."""

    def __init__(self, fail_at=3):
        self.fail_at, self.calls = fail_at, 0

    def detect(self, image, truth=None):
        self.calls += 1
        if self.calls == self.fail_at:
            raise ZeroDivisionError("division by zero\\nin my model")
        return Detections(xyxy=truth.xyxy, score=[0.9] * len(truth), class_id=truth.class_id)


def make(**options):
    return FailsOnThirdFrame(**options)
'''


def _short(tmp_path: Path, name: str = "ped_crossing_nearside", duration: float = 1.5) -> Path:
    """A copy of a shipped scenario cut to ``duration`` seconds."""
    text = (ROOT / "scenarios" / f"{name}.yaml").read_text()
    lines = [f"duration: {duration}" if line.startswith("duration:") else line for line in text.splitlines()]
    path = tmp_path / f"{name}_short.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _ticks(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "ticks.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def example_site(tmp_path_factory) -> Path:
    """The example package pip-installed (no deps, no build isolation: quick, offline) into a
    private --target directory, its dist-info included, so the venv stays as it was."""
    work = tmp_path_factory.mktemp("example-plugin")
    src = work / "src"
    shutil.copytree(EXAMPLE, src, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    site = work / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index", "-q",
         "--target", str(site), str(src)],
        check=True, capture_output=True, text=True, timeout=300,
    )
    assert list(site.glob("lookahead_example_plugin-*.dist-info/entry_points.txt"))
    return site


def test_example_plugin_runs_by_its_entry_point_name(example_site, tmp_path):
    scenario = _short(tmp_path)
    out = tmp_path / "run"
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(example_site))
        res = cli.invoke(app, ["run", str(scenario), "--detector", "example-vru", "--out", str(out)])
    assert res.exit_code == 0, res.output
    run = json.loads((out / "run.json").read_text())
    assert run["complete"] is True
    det = run["scenario"]["perception"]["detector"]
    assert (det["kind"], det["plugin"]) == ("plugin", "example-vru")
    ticks = _ticks(out)
    with_dets = [t for t in ticks if t["detections"]["score"]]
    assert len(with_dets) >= len(ticks) // 2, f"detections on {len(with_dets)} of {len(ticks)} frames"
    classes = {c for t in with_dets for c in t["detections"]["class_id"]}
    assert classes <= {0, 1, 2, 3, 7}  # vulnerable road users only
    assert 0 in classes  # the crossing pedestrian


def test_example_plugin_runs_in_a_suite_and_in_watch(example_site, tmp_path):
    """The same installed plug-in, by name, in ``suite`` (every scenario's detector) and in ``watch``
    (a folder of rendered frames)."""
    suite = tmp_path / "suite.yaml"
    suite.write_text(f"name: plugin\nscenarios: [{_short(tmp_path, duration=0.8).name}]\n")
    frames = tmp_path / "frames"
    frames.mkdir()
    records, camera = render_records(8)
    for k, rec in enumerate(records):
        cv2.imwrite(str(frames / f"f{k:02d}.png"), cv2.cvtColor(rec.frame.image, cv2.COLOR_RGB2BGR))
    write_calibration(CameraCalibration.from_camera(camera), tmp_path / "camera.yaml")
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(example_site))
        res = cli.invoke(app, ["suite", str(suite), "--render", "--detector", "example-vru", "--out", str(tmp_path / "s")])
        assert res.exit_code == 0, res.output
        res = cli.invoke(app, ["watch", str(frames), "--detector", "example-vru", "--calibration",
                               str(tmp_path / "camera.yaml"), "--out", str(tmp_path / "w"), "--no-report"])
        assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    (run,) = summary["runs"].values()
    assert run["metrics"]["detection"]["tp"] > 0  # the pedestrian, found by the plug-in
    config = json.loads((tmp_path / "w" / "run.json").read_text())["scenario"]
    assert (config["detector"]["kind"], config["detector"]["model"]) == ("plugin", "example-vru")
    ticks = _ticks(tmp_path / "w")
    assert len(ticks) == 8 and sum(0 in t["detections"]["class_id"] for t in ticks) >= 6  # the pedestrian


def test_stack_plugin_from_the_command_line(tmp_path):
    """``run --stack file.py:factory``: the scenario's perception.stack, recorded in run.json, drives
    the run with lookahead's intent and alerts on top; a broken one is one line, exit 2."""
    plugin = tmp_path / "truth_stack.py"
    plugin.write_text(TRUTH_STACK)
    out = tmp_path / "run"
    res = cli.invoke(app, ["run", str(_short(tmp_path, duration=4.0)), "--no-render", "--stack", f"{plugin}:make",
                           "--out", str(out)])
    assert res.exit_code == 0, res.output
    run = json.loads((out / "run.json").read_text())
    assert run["complete"] is True and run["scenario"]["perception"]["stack"]["plugin"] == f"{plugin}:make"
    levels = [a["level_name"] for t in _ticks(out) for a in t["alerts"]]
    assert "HIGH" in levels and "CRITICAL" in levels, levels
    res = cli.invoke(app, ["run", str(_short(tmp_path)), "--no-render", "--stack", f"{plugin}:nothing_here",
                           "--out", str(tmp_path / "run2")])
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert res.exit_code == 2 and len(lines) == 1 and "nothing_here" in lines[0], res.output


def test_hog_detector_runs_in_the_simulator(tmp_path):
    out = tmp_path / "run"
    res = cli.invoke(app, ["run", str(_short(tmp_path, duration=1.0)), "--detector", "hog", "--out", str(out)])
    assert res.exit_code == 0, res.output
    ticks = _ticks(out)
    assert ticks and json.loads((out / "run.json").read_text())["scenario"]["perception"]["detector"]["kind"] == "hog"
    assert all(set(t["detections"]["class_id"]) <= {0} for t in ticks)  # pedestrians only


def test_plugin_failing_mid_run_keeps_the_run_directory(tmp_path):
    plugin = tmp_path / "failing.py"
    plugin.write_text(FAILING)
    scenario = with_detector(load_scenario(_short(tmp_path)), f"{plugin}:make")
    out = tmp_path / "run"
    runner = Runner(scenario, render=False)
    runner.sinks = [RunDirWriter(out, scenario, source="test")]
    with pytest.raises(PluginError) as info:
        runner.run()
    msg = str(info.value)
    assert msg == f"detector plug-in '{plugin}:make': detect raised ZeroDivisionError: division by zero in my model"
    run = json.loads((out / "run.json").read_text())
    assert run["complete"] is False
    assert run["summary"]["frames"] == 2 and run["summary"]["error"] == f"PluginError: {msg}"
    ticks = _ticks(out)  # every line whole JSON
    assert [t["frame"] for t in ticks] == [0, 1]
    assert all(t["detections"]["score"] == [0.9] * len(t["detections"]["score"]) for t in ticks)


def test_cli_plugin_errors_are_one_line(tmp_path):
    assert ("lookahead.perception.plugins", "PluginError") in USER_ERRORS
    plugin = tmp_path / "failing.py"
    plugin.write_text(FAILING)
    scenario = _short(tmp_path)
    out = tmp_path / "run"
    res = cli.invoke(app, ["run", str(scenario), "--no-render", "--detector", f"{plugin}:make", "--out", str(out)])
    assert res.exit_code == 2, res.output
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: detector plug-in") and "ZeroDivisionError" in lines[0]
    assert json.loads((out / "run.json").read_text())["complete"] is False
    res = cli.invoke(app, ["run", str(scenario), "--no-render", "--detector", "no_such_mod_xyz:make",
                           "--out", str(tmp_path / "run2")])
    assert res.exit_code == 2 and "no module named 'no_such_mod_xyz'" in res.stderr
    assert not (tmp_path / "run2").exists()  # failed before an output was touched


TRUTH_STACK = '''
import numpy as np

from lookahead.intent.plugins import StackResult
from lookahead.perception.tracker import Tracks, TrackState


class TruthStack:
    """A whole perception stack from the simulator's truth: one track per visible actor, range
    from the truth, lateral offset from the box's ground contact, rates by finite differences."""

    def __init__(self, camera, frame_rate, fail_at=0, mode="ok"):
        self.camera, self.frame_rate, self.fail_at, self.mode = camera, frame_rate, fail_at, mode
        self.prev, self.ages, self.calls = {}, {}, 0

    def process(self, frame, truth=None):
        self.calls += 1
        if self.calls == self.fail_at:
            raise RuntimeError("tracker diverged")
        n = len(truth)
        bottom = np.stack([(truth.xyxy[:, 0] + truth.xyxy[:, 2]) / 2, truth.xyxy[:, 3]], axis=1)
        lat = self.camera.ground_points(bottom)[:, 1] if n else np.zeros(0)
        rng = truth.range_m
        rr, lr, age = np.zeros(n), np.zeros(n), np.zeros(n, dtype=int)
        for k, (i, r, y) in enumerate(zip(truth.source_id.tolist(), rng, lat)):
            if i in self.prev:
                t0, r0, y0 = self.prev[i]
                rr[k], lr[k] = (r - r0) / (frame.t - t0), (y - y0) / (frame.t - t0)
            self.prev[i] = (frame.t, r, y)
            self.ages[i] = age[k] = self.ages.get(i, -1) + 1
        tracks = Tracks(
            track_id=truth.source_id, xyxy=truth.xyxy, class_id=truth.class_id, score=np.ones(n), age=age,
            hits=age + 1, state=np.full(n, int(TrackState.CONFIRMED)), det_index=np.arange(n),
            velocity_px=np.zeros((n, 4)),
        )
        if self.mode == "short":
            rng = rng[:-1]
        elif self.mode == "nan":
            rng = np.full(n, np.nan)
        elif self.mode == "dict":
            return {"tracks": tracks}
        return StackResult(tracks=tracks, range=rng, lateral=lat, range_rate=rr, lateral_rate=lr)


def make(camera, frame_rate, **options):
    return TruthStack(camera, frame_rate, **options)
'''


def _stack_runner(tmp_path: Path, options: dict, duration: float = 4.0) -> tuple[Runner, Path]:
    from lookahead.intent.plugins import load_stack

    plugin = tmp_path / "truth_stack.py"
    plugin.write_text(TRUTH_STACK)
    scenario = load_scenario(_short(tmp_path, duration=duration))
    runner = Runner(scenario, render=False)
    runner.perception = load_stack(f"{plugin}:make", options, runner.camera, scenario.camera.rate,
                                   intent=runner.intent_config, alerts=scenario.alerts)
    out = tmp_path / "run"
    runner.sinks = [RunDirWriter(out, scenario, source="test")]
    return runner, out


def test_stack_plugin_drives_the_runner_with_intent_on_top(tmp_path):
    runner, out = _stack_runner(tmp_path, {})
    runner.run()
    ticks = _ticks(out)
    assert json.loads((out / "run.json").read_text())["complete"] is True
    last = [t for t in ticks if t["tracks"]["track_id"]][-1]
    assert last["tracks"]["range"][0] < 15 and last["tracks"]["range_rate"][0] < -8  # closing on the pedestrian
    assert last["tracks"]["ground_vx"][0] == pytest.approx(0.0, abs=0.1)  # derived: it walks across
    levels = [a["level_name"] for t in ticks for a in t["alerts"]]
    assert "HIGH" in levels and "CRITICAL" in levels, levels  # intent and alerts on the plug-in's tracks


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        ({"fail_at": 3}, "stack plug-in '{ref}': process raised RuntimeError: tracker diverged"),
        ({"mode": "short"}, "stack plug-in '{ref}': process returned range of shape (0,), expected (1,) (one per track)"),
        ({"mode": "nan"}, "stack plug-in '{ref}': process returned NaN or infinite range"),
        ({"mode": "dict"}, "stack plug-in '{ref}': process returned dict, expected intent.plugins.StackResult"),
    ],
)
def test_stack_plugin_failures_are_one_line_and_keep_outputs(tmp_path, options, expected):
    runner, out = _stack_runner(tmp_path, options, duration=1.0)
    with pytest.raises(PluginError) as info:
        runner.run()
    ref = f"{tmp_path / 'truth_stack.py'}:make"
    assert str(info.value).startswith(expected.format(ref=ref)), str(info.value)
    assert "\n" not in str(info.value)
    assert json.loads((out / "run.json").read_text())["complete"] is False
    _ticks(out)  # whole lines only


def test_stack_plugin_load_errors(tmp_path):
    from lookahead.intent.plugins import load_stack
    from lookahead.sim.runner import camera_from_scenario

    camera = camera_from_scenario(load_scenario(ROOT / "scenarios" / "ped_crossing_nearside.yaml"))
    (tmp_path / "stacks.py").write_text("def not_a_stack(**options):\n    return object()\n")
    with pytest.raises(PluginError, match=r"expected one with process\(frame, truth=None\)"):
        load_stack(f"{tmp_path / 'stacks.py'}:not_a_stack", {}, camera, 10.0)
    with pytest.raises(PluginError, match="no entry point of that name in group lookahead.stacks"):
        load_stack("no-such-stack", {}, camera, 10.0)
