"""Replay of a recorded run: reproduces tracks, assessments and alerts; perturbation; suites; CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from lookahead.tools.runs.replay import Perturbation, Perturber, replay_run, replay_suite
from lookahead.tools.runs.suite import run_one

ROOT = Path(__file__).resolve().parents[3]
#: Recorded values carry ticks.jsonl's rounding (boxes 0.01 px, odometry 1e-4): replayed floats
#: agree to about that, in their units (m, m/s, s, px).
FLOAT_TOL = {"xyxy": 0.011, "velocity_px": 0.2, "range": 0.05, "lateral": 0.01, "range_rate": 0.1,
             "ground_vx": 0.1, "ground_vy": 0.02, "lateral_rate": 0.02, "accel": 0.2, "yaw_rate": 0.02,
             "ttc": 0.05, "range_sigma": 0.01, "range_rate_sigma": 0.01, "half_width": 0.01, "score": 1e-4}
EXACT_TRACK_KEYS = ("track_id", "class_id", "age", "hits", "state", "det_index", "settled")


def _lines(run: Path) -> list[dict]:
    return [json.loads(x) for x in (run / "ticks.jsonl").read_text().splitlines() if x.strip()]


def _close(a, b, tol: float) -> bool:
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    if a.shape != b.shape:
        return False
    if not np.array_equal(np.isnan(a), np.isnan(b)):
        return False
    ok = np.isnan(a) | (np.abs(a - b) <= tol)
    # TTC near a zero range rate may flip between 'never' (1e9) and a huge finite value
    ok |= (np.minimum(np.abs(a), np.abs(b)) > 100.0)
    return bool(np.all(ok))


def assert_same_outputs(rec: list[dict], rep: list[dict]) -> None:
    assert len(rec) == len(rep)
    for x, y in zip(rec, rep, strict=True):
        assert x["ground_truth"] == y["ground_truth"] and x["ego"] == y["ego"] and x["t"] == y["t"]
        assert x["detections"] == y["detections"]
        tx, ty = x["tracks"], y["tracks"]
        assert set(tx) == set(ty)
        for k in tx:
            if k in EXACT_TRACK_KEYS:
                assert tx[k] == ty[k], (x["frame"], k)
            else:
                assert _close(tx[k], ty[k], FLOAT_TOL.get(k, 0.01)), (x["frame"], k, tx[k], ty[k])
        ax, ay = x["assessments"], y["assessments"]
        for k in ("in_path", "risk", "label", "behaviour"):
            assert ax[k] == ay[k], (x["frame"], k)
        assert _close(ax["ttc"], ay["ttc"], FLOAT_TOL["ttc"])
        assert len(x["alerts"]) == len(y["alerts"]), x["frame"]
        for p, q in zip(x["alerts"], y["alerts"], strict=True):
            for k in ("t", "track_id", "kind", "level", "class_id", "behaviour", "label"):
                assert p[k] == q[k], (x["frame"], k)
            assert abs(p["range"] - q["range"]) <= FLOAT_TOL["range"]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A short non-rendered run with a danger event, alerts and the AEB on (closed loop)."""
    tmp = tmp_path_factory.mktemp("rec")
    sc = yaml.safe_load((ROOT / "scenarios" / "ped_crossing_nearside.yaml").read_text())
    sc["ego"]["aeb"] = True
    sc["duration"] = 5.0
    path = tmp / "ped.yaml"
    path.write_text(yaml.safe_dump(sc))
    run_one(str(path), str(tmp / "run"), render=False)
    return tmp / "run"


def test_replay_reproduces_the_recorded_run(recorded, tmp_path):
    res = replay_run(recorded, tmp_path / "replay")
    rec, rep = _lines(recorded), _lines(tmp_path / "replay")
    assert any(x["alerts"] for x in rec) and any(x["ego"]["brake"] for x in rec)  # the case is not trivial
    assert_same_outputs(rec, rep)
    assert res["replay"]["aeb"] and res["replay"]["aeb_divergent_frames"] == 0
    # scored the same way: every metric section agrees
    m0 = json.loads((recorded / "metrics.json").read_text())
    m1 = json.loads((tmp_path / "replay" / "metrics.json").read_text())
    for sec in ("detection", "danger", "closed_loop", "expectations"):
        assert m0[sec] == m1[sec], sec
    for k, v in m0["tracking"].items():  # counts exact; MOTP / HOTA see the boxes' rounding
        assert m1["tracking"][k] == (pytest.approx(v, abs=0.005) if isinstance(v, float) else v), k
    assert m0["intent"]["confusion"] == m1["intent"]["confusion"]
    for k in ("range_rel_err_median", "speed_err_median", "ttc_err_median"):
        assert m1["estimation"][k] == pytest.approx(m0["estimation"][k], abs=0.01)
    run = json.loads((tmp_path / "replay" / "run.json").read_text())
    assert run["replay"]["source"] == str(recorded) and run["complete"]


def test_replay_of_a_replay_is_byte_identical(recorded, tmp_path):
    replay_run(recorded, tmp_path / "a", score=False)
    replay_run(tmp_path / "a", tmp_path / "b", score=False)
    assert (tmp_path / "a" / "ticks.jsonl").read_bytes() == (tmp_path / "b" / "ticks.jsonl").read_bytes()


def test_changed_settings_show_up_and_aeb_divergence_is_counted(recorded, tmp_path):
    # alerts that never rise: the recorded AEB braked, the replayed one would not
    res = replay_run(recorded, tmp_path / "r", overrides={"alerts": {"on_frames_high": 50, "on_frames_critical": 50}})
    assert not any(x["alerts"] for x in _lines(tmp_path / "r"))
    assert res["replay"]["aeb_divergent_frames"] > 0
    assert json.loads((tmp_path / "r" / "run.json").read_text())["scenario"]["alerts"]["on_frames_high"] == 50
    with pytest.raises(ValueError, match="unknown section"):
        replay_run(recorded, tmp_path / "bad", overrides={"detector": {}})


def test_perturbation_is_seeded_and_does_what_it_says():
    from lookahead.perception.detections import Detections

    n = 400
    base = np.tile([100.0, 100.0, 140.0, 200.0], (n, 1))
    dets = Detections(xyxy=base, score=np.full(n, 0.9), class_id=np.zeros(n, dtype=int), source_id=np.arange(n))
    cfg = Perturbation(jitter=0.05, bottom_sigma=0.1, miss_rate=0.05, class_flip=0.1, seed=3)
    a = Perturber(cfg, 7, 640, 360)(dets)
    b = Perturber(cfg, 7, 640, 360)(dets)
    assert np.array_equal(a.xyxy, b.xyxy) and np.array_equal(a.class_id, b.class_id)
    assert 0.9 * n < len(a) < n  # ~5 % dropped
    assert 0.03 < np.mean(a.class_id != 0) < 0.2  # pedestrian -> cyclist
    sd = np.std(a.xyxy - base[: len(a)], axis=0)
    assert sd[0] == pytest.approx(0.05 * 40, rel=0.25) and sd[1] == pytest.approx(0.05 * 100, rel=0.25)
    assert sd[3] == pytest.approx(np.hypot(0.05, 0.1) * 100, rel=0.25)
    assert len(Perturber(Perturbation(), 7, 640, 360)(dets)) == n and not Perturbation().active
    # AR(1): the same object's noise persists from frame to frame
    p = Perturber(Perturbation(jitter=0.05, correlation=0.9), 7, 640, 360)
    one = dets[np.arange(1)]
    e = np.array([p(one).xyxy[0, 0] - 100.0 for _ in range(300)])
    assert np.corrcoef(e[:-1], e[1:])[0, 1] > 0.7


def test_perturbed_replay_and_suite_dir(recorded, tmp_path):
    suite = tmp_path / "suite"
    suite.mkdir()
    import shutil

    shutil.copytree(recorded, suite / "ped")
    (suite / "summary.json").write_text(json.dumps({"suite": "x", "runs": {"ped": {"dir": "ped"}}}))
    s = replay_suite(suite, tmp_path / "out", Perturbation(jitter=0.05, miss_rate=0.05, seed=1))
    assert s["totals"]["tracking"]["mota"] is not None and s["runs"]["ped_crossing_nearside"]["replay"]["perturbation"]
    assert _lines(tmp_path / "out" / "ped")[20]["detections"] != _lines(recorded)[20]["detections"]
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["totals"]["intent"]["n"] > 0


def test_cli_replay(recorded, tmp_path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    r = CliRunner().invoke(app, ["replay", str(recorded), "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "c" / "metrics.json").is_file()
    r = CliRunner().invoke(app, ["replay", str(tmp_path / "nope"), "--out", str(tmp_path / "d")])
    assert r.exit_code == 2 and "no such" in r.output


def _one_line(capsys, code: int, *needles: str) -> str:
    """exit 2, exactly one non-empty stderr line holding every needle, no traceback."""
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


BAD_CONFIGS = [  # config file content (None: no such file), what the line says after the file name
    (None, "no such replay config file"),
    (b"\x00\xff\xfe\x80", "not UTF-8 text"),
    (b"tracker: {match_iou: [\n", "malformed YAML"),
    (b"- 1\n- 2\n", "expected a mapping of tracker / estimator / intent / alerts overrides, got list"),
    (b"just text\n", "got str"),
    (b"detector: {kind: onnx}\n", "unknown section(s) detector"),
    (b"tracker: 5\n", "tracker: expected a mapping of settings, got int"),
    (b"tracker: {bogus: 1}\n", "tracker.bogus: unknown field"),
    (b"tracker: {high_score: high}\n", "tracker.high_score: Input should be a valid number"),
    (b"alerts: {on_frames_high: [1]}\n", "alerts.on_frames_high"),
    (b"tracker: {match_iou: .nan}\n", "tracker.match_iou: expected a finite number"),
    (b"intent: {bogus_key: 1}\n", "intent"),
]


@pytest.mark.parametrize(("content", "needle"), BAD_CONFIGS)
def test_a_bad_replay_config_is_one_line_naming_it(recorded, tmp_path, capsys, lookahead, content, needle):
    config = tmp_path / "cfg.yaml"
    if content is not None:
        config.write_bytes(content)
    code = lookahead("replay", recorded, "--out", tmp_path / "out", "--config", config)
    _one_line(capsys, code, f"{config}", needle)
    assert not (tmp_path / "out").exists()  # refused before anything is written


def _copy_run(recorded: Path, dest: Path) -> Path:
    dest.mkdir()
    for f in recorded.iterdir():
        if f.is_file():
            (dest / f.name).write_bytes(f.read_bytes())
    return dest


BAD_TICKS = [  # line 3 of ticks.jsonl replaced by this, what the line says after file:3
    (b"{oops\n", "not valid JSON"),
    (b"\x00\xff\xfe\x80 binary\n", "not UTF-8 text"),
    (b"[1, 2]\n", "expected a JSON object per line"),
    (b'{"tick": 3}\n', "t: missing"),
    (b'{"t": "soon"}\n', "t: expected a finite number"),
    (b'{"t": 0.3, "ego": [1]}\n', "ego: expected an object"),
    (b'{"t": 0.3, "ego": {"speed": "fast"}}\n', "ego.speed: expected a finite number"),
    (b'{"t": 0.3, "detections": 7}\n', "detections: expected an object or null"),
    (b'{"t": 0.3, "detections": {"xyxy": [[1, 2, 3]], "score": [1], "class_id": [0]}}\n', "detections:"),
    (b'{"t": 0.3, "detections": {"xyxy": [[1, 2, 3, 4]]}}\n', "detections.score: missing"),
    (b'{"t": 0.3, "tick": "x"}\n', "tick / frame: expected integers"),
]


@pytest.mark.parametrize(("line", "needle"), BAD_TICKS)
def test_garbage_in_the_recorded_ticks_is_one_line_naming_file_and_line(recorded, tmp_path, capsys, lookahead,
                                                                       line, needle):
    run = _copy_run(recorded, tmp_path / "run")
    lines = (run / "ticks.jsonl").read_bytes().splitlines(keepends=True)
    (run / "ticks.jsonl").write_bytes(b"".join(lines[:2]) + line + b"".join(lines[3:]))
    code = lookahead("replay", run, "--out", tmp_path / "out")
    _one_line(capsys, code, f"{run / 'ticks.jsonl'}:3: ", needle)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("content", "needle"), [
    (b"{not json", "not valid JSON"),
    (b"\x89PNG\x00\xff", "not UTF-8 text"),
    (b"[]", "expected a JSON object"),
    (b"{}", "scenario: missing"),
    (b'{"scenario": 3}', "scenario: expected a mapping"),
    (b'{"scenario": {"name": "x", "duration": "long"}}', "scenario.duration"),
])
def test_a_broken_run_json_is_one_line_naming_it(recorded, tmp_path, capsys, lookahead, content, needle):
    run = _copy_run(recorded, tmp_path / "run")
    (run / "run.json").write_bytes(content)
    code = lookahead("replay", run, "--out", tmp_path / "out")
    _one_line(capsys, code, f"{run / 'run.json'}", needle)
