"""The command line: run directories, determinism, and one-line errors for bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from lookahead.tools.cli import app

ROOT = Path(__file__).resolve().parents[2]
PED = ROOT / "scenarios" / "ped_crossing_nearside.yaml"
runner = CliRunner()


def test_run_writes_the_run_directory(tmp_path):
    res = runner.invoke(app, ["run", str(PED), "--out", str(tmp_path / "r"), "--no-render"])
    assert res.exit_code == 0, res.output
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    assert run["complete"] and run["seed"] == 7 and len(run["config_hash"]) == 16
    assert run["summary"]["collisions"][0]["name"] == "ped1"  # no AEB: it hits the pedestrian
    lines = (tmp_path / "r" / "ticks.jsonl").read_text().splitlines()
    assert len(lines) == run["summary"]["frames"] > 30
    rec = json.loads(lines[10])
    assert set(rec) >= {"tick", "t", "ego", "ground_truth", "detections"}
    assert rec["ground_truth"]["name"] == ["ped1"]
    timings = (tmp_path / "r" / "timings.jsonl").read_text().splitlines()
    assert len(timings) == len(lines) and "tick" in json.loads(timings[0])


def test_same_scenario_and_seed_give_identical_ticks_without_rendering(tmp_path):
    for name in ("a", "b"):
        assert runner.invoke(app, ["run", str(PED), "--out", str(tmp_path / name), "--no-render"]).exit_code == 0
    assert (tmp_path / "a" / "ticks.jsonl").read_bytes() == (tmp_path / "b" / "ticks.jsonl").read_bytes()


def bad_cases(tmp_path: Path) -> list[tuple[list[str], str]]:
    malformed = tmp_path / "malformed.yaml"
    malformed.write_text("name: x\nego: {lane: 1\n")
    alien = tmp_path / "alien.yaml"
    alien.write_text("name: x\nactors:\n  - id: a\n    type: alien\n    start: {x: 1, y: 1}\n")
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text("name: x\nduration: -3\n")
    return [
        (["run", str(malformed), "--out", str(tmp_path / "o1")], "malformed.yaml:"),
        (["run", str(alien), "--out", str(tmp_path / "o2")], "actors[0].type"),
        (["run", str(wrong), "--out", str(tmp_path / "o3")], "duration"),
        (["run", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "o4")], "no such scenario file"),
    ]


def test_bad_input_exits_2_with_one_line_and_no_traceback(tmp_path):
    for args, needle in bad_cases(tmp_path):
        res = runner.invoke(app, args)
        assert res.exit_code == 2, (args, res.output)
        out = res.output.strip()
        assert needle in out and "Traceback" not in out
        assert len(out.splitlines()) == 1, out


def test_unwritable_output_is_a_clear_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("keep me")
    res = runner.invoke(app, ["run", str(PED), "--out", str(blocker / "sub"), "--no-render"])
    assert res.exit_code == 2 and "cannot write" in res.output
    assert blocker.read_text() == "keep me"


@pytest.mark.skipif(not (Path(sys.executable).parent / "lookahead").exists(), reason="console script not installed")
def test_console_script_reports_bad_yaml_on_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    exe = Path(sys.executable).parent / "lookahead"
    env = {**os.environ, "COLUMNS": "200"}
    p = subprocess.run([str(exe), "run", str(bad), "--out", str(tmp_path / "o")], capture_output=True, text=True, env=env)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr and p.stderr.strip().count("\n") == 0
    assert "bad.yaml:" in p.stderr


def test_a_file_that_is_not_a_database_is_refused_untouched(tmp_path):
    db = tmp_path / "notes.db"
    db.write_bytes(b"these are my notes, not a database\n")
    res = runner.invoke(app, ["run", str(PED), "--out", str(tmp_path / "r"), "--no-render", "--db", str(db)])
    assert res.exit_code == 2 and "not a SQLite database" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert db.read_bytes() == b"these are my notes, not a database\n"


def _gt_scenario(tmp_path: Path) -> Path:
    """PED with the ground-truth detector written out (the default ONNX model may be absent)."""
    import yaml

    data = yaml.safe_load(PED.read_text())
    data.setdefault("perception", {}).setdefault("detector", {})["kind"] = "gt"
    path = tmp_path / "ped_gt.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _snapshot(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def test_bad_video_path_leaves_an_existing_run_dir_byte_identical(tmp_path):
    """`--video` that is a directory or under a file: one line, exit 2, the old run untouched."""
    sc, out = _gt_scenario(tmp_path), tmp_path / "r"
    res = runner.invoke(app, ["run", str(sc), "--out", str(out), "--no-render"])
    assert res.exit_code == 0, res.output
    assert json.loads((out / "run.json").read_text())["complete"]
    before = _snapshot(out)
    assert (out / "ticks.jsonl").stat().st_size > 0
    blocker = tmp_path / "blocker"
    blocker.write_text("keep me")
    (out / "video_dir.mp4").mkdir()
    before_dirs = sorted(p.name for p in out.iterdir())
    for video, needle in [(out / "video_dir.mp4", "is a directory"), (blocker / "a.mp4", "video's directory")]:
        res = runner.invoke(app, ["run", str(sc), "--out", str(out), "--no-render", "--video", str(video)])
        assert res.exit_code == 2, res.output
        text = res.output.strip()
        assert len(text.splitlines()) == 1 and needle in text and "Traceback" not in text, text
        assert _snapshot(out) == before
        assert sorted(p.name for p in out.iterdir()) == before_dirs
    assert blocker.read_text() == "keep me"


def test_bad_rerun_path_leaves_an_existing_run_dir_byte_identical(tmp_path):
    sc, out = _gt_scenario(tmp_path), tmp_path / "r"
    assert runner.invoke(app, ["run", str(sc), "--out", str(out), "--no-render"]).exit_code == 0
    before = _snapshot(out)
    (out / "rec.rrd").mkdir()
    res = runner.invoke(app, ["run", str(sc), "--out", str(out), "--no-render", "--rerun", str(out / "rec.rrd"),
                              "--video", str(out / "annotated.mp4")])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output
    assert _snapshot(out) == before and not (out / "annotated.mp4").exists()


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("perception:\n  tracker:\n    max_lost: 1.0\n", ":4: perception.tracker.max_lost: unknown field"),
        ("perception:\n  detector: {noise: {miss_rat: 0.1}}\n", ":3: perception.detector.noise.miss_rat: unknown field"),
        ("perception:\n  estimator: {motion_modl: cv}\n", ":3: perception.estimator.motion_modl: unknown field"),
        ("intent:\n  horizon: soon\n", ":3: intent.horizon: Input should be a valid number"),
        ("expect:\n  - alert: {actor: nobody, level_at_least: HUGE}\n", ":3: expect[0].alert.level_at_least"),
        ("actors:\n  - {id: p, type: pedestrian, start: {x: .nan, y: 2}}\n", ":3: actors[0].start.x: expected a finite"),
        ("seed: 4294967296\n", ":2: seed: Input should be less than or equal to 4294967295"),
        # what run refuses when it loads the detector, validate refuses too
        ("perception:\n  detector: {kind: onnx, model: /nonexistent/m.onnx}\n",
         ": perception.detector.model: /nonexistent/m.onnx: model file not found"),
    ],
)
def test_validate_prints_one_line_per_file_and_exits_2(tmp_path, body, needle):
    deep = tmp_path / ("a_rather_long_directory_name_" * 6)  # the line is far wider than 80 columns
    deep.mkdir()
    bad = deep / "bad.yaml"
    bad.write_text("name: x\n" + body)
    res = runner.invoke(app, ["validate", str(PED), str(bad)])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 2 and "Traceback" not in res.output, res.output
    assert lines[0].startswith("ok ") and lines[1].startswith("bad ")
    assert f"{bad}{needle}" in lines[1], lines[1]


@pytest.mark.parametrize(("windows", "needle"), [
    ("[[0.6, 0.2, 0.4, 0.8]]", "--windows: window 0: fractions of the image"),
    ("[[0.1, 0.2]]", "--windows: window 0: four numbers"),
    ("[[0.1, 0.2, 0.5, 0.6, 9]]", "--windows: window 0: zoom (input px per image px) in (0, 8] expected, got 9"),
    ("[[0.1, 0.2", "--windows: malformed YAML: did not find expected ',' or ']' (at the end)"),
    ("[[0.1, 0.2]]]", "--windows: malformed YAML: did not find expected <document start> (column 13)"),
])
def test_eval_detector_refuses_a_bad_zoom_window_on_one_line(tmp_path, windows, needle):
    res = runner.invoke(app, ["eval-detector", str(tmp_path / "m.onnx"), str(tmp_path), "--windows", windows])
    assert res.exit_code == 2, res.output
    assert needle in res.output and "Traceback" not in res.output
    assert len(res.output.strip().splitlines()) == 1


def test_packaged_scenarios_by_name(tmp_path, monkeypatch):
    """``lookahead catalogue`` lists the names ``run`` / ``suite`` accept from any directory."""
    res = runner.invoke(app, ["catalogue"])
    assert res.exit_code == 0, res.output
    names = res.stdout.split()
    assert {"ped_crossing_nearside", "suites/smoke", "sweeps/aeb_stationary_car", "generators/detector"} <= set(names)
    monkeypatch.chdir(tmp_path)  # no scenarios/ folder here
    res = runner.invoke(app, ["run", "stationary_car", "--out", "r", "--no-render"])
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "r" / "run.json").read_text())["scenario"]["name"] == "stationary_car"
    res = runner.invoke(app, ["run", "no_such_scenario", "--out", "r2", "--no-render"])
    assert res.exit_code == 2 and "no_such_scenario" in res.stderr and "Traceback" not in res.output


@pytest.mark.parametrize("command", [
    ["run", "stationary_car", "--no-render"],
    ["suite", "smoke"],
    ["regress", "smoke", "--baseline", "b.json"],
    ["sweep", "aeb_stationary_car"],
])
def test_a_bad_aeb_switch_is_one_line_and_exit_2(tmp_path, command):
    out = tmp_path / "out"
    res = runner.invoke(app, [*command, "--aeb", "maybe", "--out", str(out)])
    assert res.exit_code == 2, res.output
    text = res.output.strip()
    assert len(text.splitlines()) == 1 and "--aeb 'maybe': expected on or off" in text, text
    assert not out.exists()  # refused before anything ran


def one_error_line(res, *needles: str) -> str:
    """The single ``error:`` line of a user mistake: exit code 2, one non-empty stderr line holding
    every needle, no traceback and nothing on stdout."""
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = [x for x in res.stderr.splitlines() if x.strip()]
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("error: ") and "Traceback" not in res.output, res.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


@pytest.mark.parametrize(("args", "needles"), [
    (["render", "stationary_car", "--out", "o", "--every", "x"], ["--every"]),
    (["render", "stationary_car", "--out", "o", "--every", "0"], ["--every", "greater than or equal to 1"]),
    (["render", "stationary_car", "--out", "o", "--every", "-3"], ["--every"]),
    (["render", "stationary_car", "--out", "o", "--renderer", "vulkan"], ["--renderer 'vulkan'", "auto, egl, tiny"]),
    (["run", "stationary_car", "--out", "o", "--renderer", "vulkan"], ["--renderer 'vulkan'"]),
    (["render", "stationary_car", "--out", "o", "--bogus"], ["No such option: --bogus"]),
    (["render", "stationary_car"], ["Missing option '--out'"]),
    (["run"], ["Missing argument"]),
    (["no-such-command"], ["No such command 'no-such-command'"]),
    (["suite", "smoke", "--out", "o", "--workers", "0"], ["--workers"]),
    (["replay", "r", "--out", "o", "--miss-rate", "2"], ["--miss-rate"]),
    (["run", "stationary_car", "--out", "o", "--no-render", "--lang", "fr"], ["--lang must be en or zh"]),
    (["bench", "detect", "--out", "o.json", "--frames", "zero"], ["--frames"]),
    (["bench", "sim", "--out", "o.json", "--ticks", "-1"], ["--ticks"]),
    (["bench", "sim", "--out", "o.json", "--frames", "0"], ["--frames"]),
    (["bench", "env", "--out", "o.json", "--steps", "-5"], ["--steps"]),
    (["bench", "sinks", "--out", "o.json", "--repeats", "0"], ["--repeats"]),
    (["bench", "track", "--out", "o.json", "--repeats", "-1"], ["--repeats"]),
    (["bench", "all", "--out", "o.json", "--repeats", "0"], ["--repeats"]),
    (["bench", "sweep", "--out", "o.json", "--variants", "0"], ["--variants"]),
    (["eval-detector", "m.onnx", "split", "--conf", "nan"], ["--conf 'nan': a number in [0, 1] expected"]),
    (["eval-detector", "m.onnx", "split", "--conf", "5"], ["--conf '5': a number in [0, 1] expected"]),
])
def test_an_option_mistake_is_one_line_and_exit_2(tmp_path, monkeypatch, args, needles):
    """click's usage errors (bad value, unknown option or command, missing one) and BadParameter
    raised in a command end as one ``error:`` line, not click's usage box; nothing is written."""
    monkeypatch.chdir(tmp_path)
    one_error_line(runner.invoke(app, args), *needles)
    assert not (tmp_path / "o").exists()


def test_help_and_no_arguments_still_show_the_help():
    res = runner.invoke(app, ["--help"])
    assert res.exit_code == 0 and "Usage" in res.stdout and "render" in res.stdout
    res = runner.invoke(app, ["render", "--help"])
    assert res.exit_code == 0 and "--every" in res.stdout and "--renderer" in res.stdout
    res = runner.invoke(app, [])
    assert res.exit_code == 2 and "Usage" in res.stdout  # as click does: the help, exit 2
    res = runner.invoke(app, ["bench"])
    assert res.exit_code == 2 and "detect" in res.stdout
    assert runner.invoke(app, ["catalogue"]).exit_code == 0


def test_an_error_line_prints_brackets_as_they_are(tmp_path):
    """A name with rich markup look-alikes (sweep variants are ``base[v=1]``) is printed verbatim."""
    bad = tmp_path / "[bold]x[v=1][/x].yaml"
    res = runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "o")])
    one_error_line(res, "[bold]x[v=1][/x].yaml")


@pytest.mark.skipif(not (Path(sys.executable).parent / "lookahead").exists(), reason="console script not installed")
def test_console_script_reports_an_option_mistake_on_one_line(tmp_path):
    exe = Path(sys.executable).parent / "lookahead"
    p = subprocess.run([str(exe), "render", "stationary_car", "--out", str(tmp_path / "o"), "--every", "0"],
                       capture_output=True, text=True, env={**os.environ, "COLUMNS": "80"})
    assert p.returncode == 2 and "Traceback" not in p.stderr and p.stdout == ""
    assert p.stderr.strip().count("\n") == 0 and p.stderr.startswith("error: ") and "--every" in p.stderr
    p = subprocess.run([str(exe), "--help"], capture_output=True, text=True)
    assert p.returncode == 0 and "Usage" in p.stdout


def test_an_unwritable_eval_output_fails_before_the_evaluation(tmp_path):
    res = runner.invoke(app, ["eval-detector", str(ROOT / "models" / "lookahead-det.onnx"), str(tmp_path),
                              "--out", "/dev/null/m.json"])
    one_error_line(res, "/dev/null")


def test_train_detector_without_a_dataset_answers_before_importing_torch(tmp_path):
    import time

    t0 = time.perf_counter()
    res = runner.invoke(app, ["train-detector", str(tmp_path / "no_dataset"), "--out", str(tmp_path / "m.onnx")])
    one_error_line(res, str(tmp_path / "no_dataset" / "train" / "annotations.json"), "no COCO annotations")
    assert time.perf_counter() - t0 < 2.0


def test_track_on_a_missing_det_file_is_only_the_error(tmp_path):
    res = runner.invoke(app, ["track", "--det", str(tmp_path / "det.txt"), "--out", str(tmp_path / "o.txt")])
    one_error_line(res, str(tmp_path / "det.txt"))  # no frame-rate warning before it
