"""Primary-target (CIPV) scoring, ``tools.scoring.cipv``: hand-computed, and on a closed-loop run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.scoring.cipv import cipv_section, cipv_totals
from lookahead.tools.scoring.intent import load_intent_run
from lookahead.tools.scoring.run import compute_sections
from lookahead.tools.sinks.rundir import RunDirWriter, as_rundir

ROOT = Path(__file__).resolve().parents[3]
PED_BOX, CAR_BOX, GHOST_BOX = [100.0, 100.0, 140.0, 200.0], [300.0, 120.0, 420.0, 200.0], [600.0, 10.0, 620.0, 30.0]
# per frame: (predicted track, its range, true actor, true range)
CIPV = [
    (None, None, 2, 10.0),  # missed (the track is not out yet)
    (20, 10.5, 2, 10.0),  # correct, 0.5 m off
    (20, 10.1, 2, 10.0),  # correct
    (10, 8.0, 2, 10.0),  # wrong target (the pedestrian's track): a switch
    (20, 10.1, 2, 10.0),  # correct again: a correction, no switch
    (None, None, 2, 10.0),  # dropped: missed, a switch
    (20, 10.3, 2, 10.0),  # correct
    (20, 10.0, 1, 8.0),  # the truth changes to the pedestrian, the prediction stays: wrong target
    (30, 20.0, None, None),  # a track on nothing while no true target: false target
    (None, None, None, None),  # both none: correct
]


def write_run(tmp: Path) -> Path:
    run = tmp / "run"
    run.mkdir()
    lines = []
    for f, (tid, r, actor, tr) in enumerate(CIPV):
        ids, boxes = [10, 20], [PED_BOX, CAR_BOX]
        if tid == 30:
            ids, boxes = [10, 20, 30], [PED_BOX, CAR_BOX, GHOST_BOX]
        lines.append({
            "t": round(0.1 * f, 4), "ego": {},
            "ground_truth": {"actor_id": [1, 2], "name": ["ped", "car"], "class_id": [0, 4],
                             "visible": [PED_BOX, CAR_BOX], "label": [1, 1], "ttc": [9.0, 9.0],
                             "in_path": [False, False]},
            "tracks": {"track_id": ids, "xyxy": boxes, "state": ["confirmed"] * len(ids)},
            "assessments": {"label": [1] * len(ids)},
            "alerts": [], "collisions": [],
            "cipv": {"track_id": tid, "range": r, "truth_actor": actor, "truth_range": tr},
        })
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    return run


def test_hand_computed_correct_rate_switches_and_totals(tmp_path):
    rd = as_rundir(write_run(tmp_path))
    s = cipv_section(rd, load_intent_run(rd))
    assert s == {"correct_rate": 0.5, "frames": 10, "correct": 5, "wrong_target": 2, "missed": 2,
                 "false_target": 1, "switches": 2, "truth_changes": 2, "range_err_median": pytest.approx(0.2)}
    tot = cipv_totals([{"cipv": s}, {"cipv": {**s, "frames": 20, "correct": 20}}, {"intent": {}}])
    assert tot["runs"] == 2 and tot["frames"] == 30 and tot["correct"] == 25
    assert tot["correct_rate"] == pytest.approx(25 / 30, abs=1e-4) and tot["switches"] == 4
    assert cipv_totals([{"intent": {}}]) is None


def test_runs_without_cipv_records_have_no_section(tmp_path):
    run = write_run(tmp_path)
    lines = [json.loads(x) for x in (run / "ticks.jsonl").read_text().splitlines()]
    (run / "ticks.jsonl").write_text("\n".join(json.dumps({k: v for k, v in x.items() if k != "cipv"})
                                               for x in lines) + "\n")
    rd = as_rundir(run)
    assert cipv_section(rd, load_intent_run(rd)) is None


def test_a_closed_loop_run_records_and_scores_its_primary_target(tmp_path):
    """stationary_car (gt detector, no render): every record names a CIPV; the parked car ahead
    is the true one, and the ego's track on it is the predicted one almost every frame."""
    sc = load_scenario(ROOT / "scenarios" / "stationary_car.yaml")
    Runner(sc, sinks=[RunDirWriter(tmp_path / "run", sc)], render=False).run()
    records = [json.loads(x) for x in (tmp_path / "run" / "ticks.jsonl").read_text().splitlines()]
    assert all(set(r["cipv"]) == {"track_id", "range", "truth_actor", "truth_range"} for r in records)
    truth = {r["cipv"]["truth_actor"] for r in records} - {None}
    assert len(truth) == 1
    sections = compute_sections(tmp_path / "run")
    c = sections["cipv"]
    assert c["frames"] == len(records) and c["correct_rate"] >= 0.95 and c["wrong_target"] == 0
    assert sections["behaviour"]["n"] > 0 and sections["behaviour"]["risk"]["accuracy"] is not None
