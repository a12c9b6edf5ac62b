"""Round trip (issue 32): a simulated run's raw camera video, calibration and ego-speed log,
watched by ``lookahead watch`` and scored against that run's ground truth, scores as the
simulated run does: tracking MOTA and IDF1 within 0.02, the same danger events and alerts."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.tools.cli import run_scenario
from lookahead.tools.runs.watch import watch
from lookahead.tools.scoring.run import score_run
from lookahead.tools.sinks.rundir import CALIBRATION_FILE, EGO_SPEED_FILE, RunDirError, read_jsonl

SCENARIO = Path(__file__).resolve().parents[3] / "scenarios" / "ped_crossing_nearside.yaml"


def alerts_of(run_dir: Path) -> list[tuple]:
    records, _ = read_jsonl(run_dir / "ticks.jsonl")
    return [(r["frame"], a["kind"], a["level"], a["track_id"], a["class_id"]) for r in records
            for a in r.get("alerts") or []]


def events_of(metrics: dict) -> list[tuple]:
    return [(e["actor"], e["warned"], e["lead_time_s"]) for e in metrics["danger"]["event_list"]]


@pytest.fixture(scope="module")
def round_trip(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("round_trip")
    sim, watched = root / "sim", root / "watch"
    run_scenario(SCENARIO, sim, detector="onnx", raw_video=sim / "camera.mp4")
    watch(sim / "camera.mp4", watched, calibration=sim / CALIBRATION_FILE, ego_speed=str(sim / EGO_SPEED_FILE))
    return sim, watched


def test_run_writes_what_watch_reads(round_trip: tuple[Path, Path]) -> None:
    sim, _ = round_trip
    import cv2

    cap = cv2.VideoCapture(str(sim / "camera.mp4"))
    n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    ok, first = cap.read()
    cap.release()
    records, _ = read_jsonl(sim / "ticks.jsonl")
    assert ok and first.shape == (360, 640, 3)
    assert n == len(records)  # one video frame per camera frame
    speeds = (sim / EGO_SPEED_FILE).read_text().splitlines()
    assert speeds[0] == "t,speed" and len(speeds) == len(records) + 1
    t0 = records[0]["t"]
    for line, rec in zip(speeds[1:], records, strict=True):
        t, v = map(float, line.split(","))
        assert t == pytest.approx(rec["t"] - t0, abs=1e-6) and v == pytest.approx(rec["ego"]["speed"], abs=1e-6)


def test_watch_scores_as_the_simulated_run(round_trip: tuple[Path, Path]) -> None:
    sim, watched = round_trip
    m_sim = score_run(sim)
    m_watch = score_run(watched, truth=sim)
    for key in ("mota", "idf1"):
        assert m_watch["tracking"][key] == pytest.approx(m_sim["tracking"][key], abs=0.02), key
    assert m_sim["tracking"]["mota"] > 0.8  # the scenario is tracked at all
    ev_sim, ev_watch = events_of(m_sim), events_of(m_watch)
    assert [e[:2] for e in ev_watch] == [e[:2] for e in ev_sim]  # the same actors, warned alike
    assert [e[2] for e in ev_watch] == pytest.approx([e[2] for e in ev_sim], abs=0.11)  # lead time (s)
    assert m_watch["danger"]["events"] == m_sim["danger"]["events"] >= 1
    assert m_watch["danger"]["missed"] == m_sim["danger"]["missed"]
    assert m_watch["danger"]["false_alarms"] == m_sim["danger"]["false_alarms"]
    assert alerts_of(watched) == alerts_of(sim) != []
    written = json.loads((watched / "metrics.json").read_text())
    assert written["tracking"]["mota"] == m_watch["tracking"]["mota"]


def test_truth_of_another_run_is_refused(round_trip: tuple[Path, Path], tmp_path: Path) -> None:
    sim, watched = round_trip
    short = tmp_path / "short"
    short.mkdir()
    (short / "run.json").write_text((sim / "run.json").read_text())
    (short / "ticks.jsonl").write_text("".join((sim / "ticks.jsonl").read_text().splitlines(True)[:5]))
    with pytest.raises(RunDirError, match="frame 5: no such camera frame in the truth run"):
        score_run(watched, truth=short)
