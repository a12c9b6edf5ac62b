"""The run directory's one reader (``tools.sinks.rundir.RunDir``): decoding of null and the
"never" sentinel, one-line errors naming ``file:line``, and every command reading a run's
``ticks.jsonl`` once (score, report, suite, replay); suite and sweep totals agree."""

from __future__ import annotations

import builtins
import io
import json
import math
import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml

from lookahead.sim.records import jsonable
from lookahead.tools.sinks import rundir
from lookahead.tools.sinks.rundir import (
    NEVER,
    TICKS_FILE,
    RunDir,
    RunDirError,
    decode,
    decode_array,
    is_number,
    tick_line,
    timings_line,
)

ROOT = Path(__file__).resolve().parents[3]
BOX = [100.0, 100.0, 140.0, 200.0]


def gt_record(t: float, ttc: object) -> dict:
    return {"t": t, "ego": {"speed": 10.0}, "detections": None, "tracks": None, "alerts": [], "collisions": [],
            "ground_truth": {"actor_id": [1], "name": ["ped"], "class_id": [0], "visible": [BOX],
                             "visible_fraction": [1.0], "label": [1], "ttc": [ttc], "in_path": [True]}}


def write_ticks(run: Path, lines: list[str]) -> Path:
    run.mkdir(parents=True, exist_ok=True)
    (run / TICKS_FILE).write_text("\n".join(lines) + "\n")
    return run


# --------------------------------------------------------------------------- decoding


def test_decode_null_and_never():
    assert math.isnan(decode(None))
    assert decode(NEVER) == math.inf and decode(-NEVER) == -math.inf and decode(3e9) == math.inf
    assert decode(2.5) == 2.5 and decode(7) == 7.0 and decode(NEVER * 0.999) == NEVER * 0.999
    arr = decode_array([[1.0, None], [1e9, -1e9]])
    assert np.isnan(arr[0, 1]) and arr[0, 0] == 1.0 and list(arr[1]) == [math.inf, -math.inf]
    assert [is_number(v) for v in (1, 0.5, True, None, float("nan"), 1e9, -2e9, "x")] == [
        True, True, True, False, False, False, False, False]


def test_written_values_read_back():
    """What the writer encodes (NaN -> null, inf -> NEVER) the reader decodes back."""
    line = tick_line(jsonable({"t": 0.1, "ttc": [math.inf, -math.inf, math.nan, 2.0], "n": np.int64(3)}))
    assert line.endswith("\n") and json.loads(line) == {"t": 0.1, "ttc": [NEVER, -NEVER, None, 2.0], "n": 3}
    back = decode_array(json.loads(line)["ttc"])
    assert back[0] == math.inf and back[1] == -math.inf and np.isnan(back[2]) and back[3] == 2.0
    assert json.loads(timings_line({"track": 1.23456, "tick": 2.0})) == {"track": 1.235, "tick": 2.0}


def test_intent_reads_gt_ttc_never_and_null_as_never(tmp_path):
    from lookahead.tools.scoring.intent import load_intent_run

    run = write_ticks(tmp_path / "r", [json.dumps(gt_record(0.1 * i, v))
                                       for i, v in enumerate([3.0, 1e9, None, 2.0])])
    ttc = load_intent_run(run).gt_ttc[1]
    assert ttc == {0: 3.0, 1: math.inf, 2: math.inf, 3: 2.0}


def test_scorer_frames_decode_never_to_inf(tmp_path):
    from lookahead.tools.scoring.io import load_run

    run = write_ticks(tmp_path / "r", [json.dumps(gt_record(0.0, 1e9)), json.dumps(gt_record(0.1, None))])
    data = load_run(run)
    assert data.gt[0].ttc[0] == math.inf and np.isnan(data.gt[1].ttc[0])
    assert np.isnan(data.gt[0].range[0])  # absent optional column: NaN


# --------------------------------------------------------------------------- errors


def test_corrupt_lines_name_file_and_line(tmp_path):
    good = json.dumps(gt_record(0.0, 2.0))
    run = write_ticks(tmp_path / "a", [good, "", "{oops"])  # blank lines still count
    with pytest.raises(RunDirError, match=rf"^{run / TICKS_FILE}:3: not valid JSON"):
        _ = RunDir(run).ticks
    run = write_ticks(tmp_path / "b", [good, "[1, 2]"])
    with pytest.raises(RunDirError, match=r"ticks\.jsonl:2: expected a JSON object per line"):
        _ = RunDir(run).ticks
    (run / "timings.jsonl").write_text('{"tick": 1.0}\n{"tick": "slow"}\n')
    with pytest.raises(RunDirError, match=r"timings\.jsonl:2: expected stage: milliseconds"):
        _ = RunDir(run).timings
    (run / "run.json").write_text('{\n  "seed": 1,\n}\n')
    with pytest.raises(RunDirError, match=r"run\.json:3: not valid JSON"):
        _ = RunDir(run).run


def test_field_errors_name_the_line_after_blank_lines(tmp_path):
    """The scorers' errors point at the file's line, not the frame index."""
    from lookahead.tools.scoring.intent import load_intent_run
    from lookahead.tools.scoring.io import load_run

    bad = gt_record(0.1, 2.0)
    bad["detections"] = {"xyxy": [[1, 2, 3]], "score": [0.5], "class_id": [0]}
    run = write_ticks(tmp_path / "r", [json.dumps(gt_record(0.0, 2.0)), "", "", json.dumps(bad)])
    with pytest.raises(RunDirError, match=r"ticks\.jsonl:4: detections\.xyxy: expected 1x4"):
        load_run(run)
    no_t = gt_record(0.1, 2.0)
    del no_t["t"]
    run = write_ticks(tmp_path / "s", [json.dumps(gt_record(0.0, 2.0)), "", json.dumps(no_t)])
    with pytest.raises(RunDirError, match=r"ticks\.jsonl:3: cannot read intent fields"):
        load_intent_run(run)


def test_missing_directory_and_files_are_one_line(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such run directory") as e:
        _ = RunDir(tmp_path / "nope").ticks
    assert "\n" not in str(e.value)
    (tmp_path / "file").write_text("")
    with pytest.raises(NotADirectoryError, match="not a directory"):
        _ = RunDir(tmp_path / "file").ticks
    (tmp_path / "empty").mkdir()
    rd = RunDir(tmp_path / "empty")
    with pytest.raises(FileNotFoundError, match=r"ticks\.jsonl: no such file \(not a run directory\?\)"):
        _ = rd.ticks
    with pytest.raises(FileNotFoundError, match=r"run\.json: no such file"):
        _ = rd.run
    assert rd.timings == [] and rd.read_metrics() == {} and not rd.has("run.json")


def test_each_file_is_parsed_once_per_rundir(tmp_path, monkeypatch):
    run = write_ticks(tmp_path / "r", [json.dumps(gt_record(0.1 * i, 2.0)) for i in range(3)])
    (run / "timings.jsonl").write_text('{"tick": 1.0}\n' * 3)
    calls = Counter()
    real = rundir.read_jsonl

    def counting(path):
        calls[Path(path).name] += 1
        return real(path)

    monkeypatch.setattr(rundir, "read_jsonl", counting)
    rd = RunDir(run)
    assert len(rd.ticks) == len(rd.ticks) == 3 and rd.timings == rd.timings == [{"tick": 1.0}] * 3
    assert rd.where(2).endswith("ticks.jsonl:3")
    assert calls == {"ticks.jsonl": 1, "timings.jsonl": 1}


# --------------------------------------------------------------------------- read once per command


@pytest.fixture(scope="module")
def short_scenario(tmp_path_factory) -> Path:
    sc = yaml.safe_load((ROOT / "scenarios" / "ped_crossing_nearside.yaml").read_text())
    sc["duration"] = 4.0
    path = tmp_path_factory.mktemp("sc") / "ped.yaml"
    path.write_text(yaml.safe_dump(sc))
    return path


@pytest.fixture(scope="module")
def recorded(short_scenario, tmp_path_factory) -> Path:
    from lookahead.tools.runs.suite import run_one

    out = tmp_path_factory.mktemp("rec") / "run"
    run_one(str(short_scenario), str(out), render=False)
    return out


@pytest.fixture
def ticks_reads(monkeypatch) -> Counter:
    """Counts every opening for reading of a file named ticks.jsonl, by path (``open``,
    ``io.open``, and so ``Path.open`` / ``read_text`` / ``read_bytes``)."""
    reads: Counter = Counter()
    real = builtins.open

    def counting_open(file, mode="r", *args, **kwargs):
        if isinstance(file, str | Path) and Path(file).name == TICKS_FILE and not set(mode) & set("wax+"):
            reads[str(Path(file))] += 1
        return real(file, mode, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(io, "open", counting_open)
    return reads


def test_score_reads_ticks_once(recorded, tmp_path, ticks_reads):
    from lookahead.tools.scoring.run import score_run

    metrics = score_run(recorded)
    assert {"detection", "tracking", "estimation", "intent", "danger", "timing"} <= set(metrics)
    assert dict(ticks_reads) == {str(recorded / TICKS_FILE): 1}


def test_report_reads_ticks_once(recorded, tmp_path, ticks_reads):
    from lookahead.tools.reports.report import REPORT_FILE, build_report

    run = tmp_path / "run"
    shutil.copytree(recorded, run)
    (run / "metrics.json").unlink()  # the report scores first
    ticks_reads.clear()  # the copy's reads
    assert build_report(run) == run / REPORT_FILE
    assert (run / "metrics.json").is_file()
    assert dict(ticks_reads) == {str(run / TICKS_FILE): 1}


def test_suite_reads_ticks_once(short_scenario, tmp_path, ticks_reads):
    from lookahead.tools.runs.suite import run_suite

    suite = tmp_path / "one.yaml"
    suite.write_text(yaml.safe_dump({"name": "one", "scenarios": [str(short_scenario)]}))
    summary = run_suite(suite, tmp_path / "out", workers=1)
    assert summary["totals"]["detection"]["gt"] == summary["runs"]["ped_crossing_nearside"]["metrics"]["detection"]["gt"]
    assert dict(ticks_reads) == {str(tmp_path / "out" / "ped" / TICKS_FILE): 1}


def test_replay_reads_ticks_once(recorded, tmp_path, ticks_reads):
    from lookahead.tools.runs.replay import replay_run

    res = replay_run(recorded, tmp_path / "replay")
    assert res["metrics"]["tracking"]["mota"] is not None
    # the recording once (replayed), the replay once (scored)
    assert dict(ticks_reads) == {str(recorded / TICKS_FILE): 1, str(tmp_path / "replay" / TICKS_FILE): 1}


# --------------------------------------------------------------------------- totals


def test_suite_and_sweep_totals_agree_on_what_both_pool(recorded, tmp_path):
    """The pooled (sweep) totals and the frame-level (suite) totals are one implementation
    each; where both apply (counts, precision, recall, intent) they agree."""
    from lookahead.tools.scoring.run import score_run
    from lookahead.tools.scoring.totals import RunFrames, suite_totals, sweep_totals

    other = tmp_path / "other"
    shutil.copytree(recorded, other)
    runs = [RunDir(recorded), RunDir(other)]
    metrics = [score_run(rd) for rd in runs]
    suite = suite_totals([runs[0], RunFrames.of(runs[1])], metrics)
    sweep = sweep_totals(metrics, ["detection.recall"])
    for k in ("gt", "tp", "fp", "precision", "recall"):
        assert suite["detection"][k] == pytest.approx(sweep["detection"][k], abs=1e-4), k
    assert suite["detection"]["gt"] == 2 * metrics[0]["detection"]["gt"]
    for k in ("tp", "fp", "fn", "id_switches"):
        assert suite["tracking"][k] == sweep["tracking"][k], k
    for sec in ("intent", "danger", "closed_loop", "expectations"):
        assert suite[sec] == sweep[sec], sec
    assert sweep["mean_over_variants"] == {"detection.recall": pytest.approx(metrics[0]["detection"]["recall"],
                                                                             abs=1e-4)}


def test_a_killed_writers_torn_last_line_is_dropped_and_a_torn_middle_line_is_an_error(tmp_path):
    """A SIGKILL can cut ticks.jsonl inside its last line: the whole lines before it stay readable."""
    good = json.dumps({"tick": 0}) + "\n" + json.dumps({"tick": 1}) + "\n"
    torn = tmp_path / "torn.jsonl"
    torn.write_text(good + '{"tick": 2, "ego": {"spe')
    records, lines = rundir.read_jsonl(torn)
    assert [r["tick"] for r in records] == [0, 1] and lines == [1, 2]
    middle = tmp_path / "middle.jsonl"
    middle.write_text('{"tick": 0, "eg\n' + good)
    with pytest.raises(rundir.RunDirError, match=rf"^{middle}:1: not valid JSON"):
        rundir.read_jsonl(middle)


def test_binary_jsonl_and_json_name_the_file_and_line(tmp_path):
    binary = tmp_path / "ticks.jsonl"
    binary.write_bytes(b'{"tick": 0}\n\xff\xfe\x00\x01\n')
    with pytest.raises(rundir.RunDirError, match=rf"^{binary}:2: not UTF-8 text"):
        rundir.read_jsonl(binary)
    (tmp_path / "metrics.json").write_bytes(b"\x89PNG\r\n")
    with pytest.raises(rundir.RunDirError, match=r"metrics.json: not UTF-8 text"):
        rundir.read_metrics(tmp_path)


def test_a_run_directory_holds_its_camera_as_a_calibration_file(recorded, short_scenario):
    """``camera.yaml`` is the file ``lookahead watch --calibration`` reads, and it is the run's camera."""
    from lookahead.perception.calibration import load_calibration
    from lookahead.sim.runner import camera_from_scenario
    from lookahead.sim.scenario import load_scenario

    cam = load_calibration(recorded / rundir.CALIBRATION_FILE).to_camera()
    want = camera_from_scenario(load_scenario(short_scenario))
    assert (cam.width, cam.height) == (want.width, want.height)
    assert np.allclose(cam.K, want.K) and np.allclose(cam.mount, want.mount)
    assert np.allclose([cam.yaw, cam.pitch, cam.roll], [want.yaw, want.pitch, want.roll])
