"""Behaviour and risk-level scoring (``tools.scoring.behaviour``) on a tiny hand-computed run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.intent.labels import Behaviour as B
from lookahead.tools.runs.regress import flatten
from lookahead.tools.scoring.behaviour import behaviour_section, behaviour_totals
from lookahead.tools.scoring.intent import load_intent_run
from lookahead.tools.sinks.rundir import as_rundir

PED_BOX, CAR_BOX = [100.0, 100.0, 140.0, 200.0], [300.0, 120.0, 420.0, 200.0]
GT_PED = [B.WALKING] * 5 + [B.CROSSING] * 5
PRED_PED = [B.WALKING] * 6 + [B.CROSSING] * 3 + [B.STANDING]  # frame 5 late (tolerated), frame 9 wrong
GT_PED_RISK = [0] * 5 + [3] * 5
PRED_PED_RISK = [0] * 5 + [3] * 4 + [4]  # frame 9: CRITICAL where the truth is HIGH


def write_run(tmp: Path) -> Path:
    run = tmp / "run"
    run.mkdir()
    lines = []
    for f in range(10):
        wrong = f == 9
        lines.append({
            "t": round(0.1 * f, 4), "ego": {},
            "ground_truth": {
                "actor_id": [1, 2], "name": ["ped", "car"], "cls": ["pedestrian", "car"], "class_id": [0, 4],
                "visible": [PED_BOX, CAR_BOX], "label": [1, 1], "ttc": [9.0, 9.0], "in_path": [False, False],
                "behaviour": [int(GT_PED[f]), int(B.STOPPED)], "risk": [GT_PED_RISK[f], 2],
            },
            "tracks": {"track_id": [10, 20], "xyxy": [PED_BOX, CAR_BOX], "state": ["confirmed"] * 2},
            "assessments": {
                "label": [0 if f == 0 else 1, 1],  # the pedestrian's first frame: initializing, don't-care
                "behaviour": [int(PRED_PED[f]), int(B.MOVING)], "risk": [PRED_PED_RISK[f], 2],
                "behaviour_confidence": [0.6 if wrong else 0.9, 0.6],
            },
            "alerts": [], "collisions": [],
        })
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    return run


def test_hand_computed_behaviour_risk_and_totals(tmp_path):
    rd = as_rundir(write_run(tmp_path))
    s = behaviour_section(rd, load_intent_run(rd))
    ped, car = s["per_group"]["pedestrian"], s["per_group"]["vehicle"]
    assert set(s["per_group"]) == {"pedestrian", "vehicle"}
    # pedestrian: 9 scored (frame 0 initializing); frame 5's late 'walking' is within 0.3 s of the truth
    assert ped["confusion"]["labels"] == ["standing", "walking", "crossing"]
    assert ped["confusion"]["matrix"] == [[0, 0, 0], [0, 5, 0], [1, 0, 3]]
    assert ped["n"] == 9 and ped["accuracy"] == pytest.approx(8 / 9, abs=1e-4)
    assert ped["per_class"]["crossing"]["recall"] == 0.75 and ped["per_class"]["standing"]["support"] == 0
    assert ped["macro_f1"] == pytest.approx((1 + 6 / 7) / 2, abs=1e-4)  # over behaviours present in truth
    assert car["confusion"] == {"labels": ["stopped", "moving"], "matrix": [[0, 10], [0, 0]]}
    assert car["accuracy"] == 0.0 and car["macro_f1"] == 0.0
    assert s["n"] == 19 and s["n_initializing"] == 1
    assert s["accuracy"] == pytest.approx(8 / 19, abs=1e-4)
    assert s["macro_f1"] == pytest.approx((1 + 6 / 7 + 0) / 3, abs=1e-4)
    assert s["worst"][0] == {"group": "vehicle", "behaviour": "stopped", "f1": 0.0, "support": 10}
    risk = s["risk"]
    assert risk["confusion"]["labels"] == ["SAFE", "LOW", "MEDIUM", "HIGH", "CRITICAL"]
    assert risk["n"] == 19 and risk["accuracy"] == pytest.approx(18 / 19, abs=1e-4)
    assert risk["confusion"]["matrix"][3][4] == 1 and risk["confusion"]["matrix"][2][2] == 10
    conf = s["confidence"]
    assert (conf["n_correct"], conf["n_wrong"]) == (8, 11)
    assert conf["mean_correct"] == pytest.approx(0.9) and conf["mean_wrong"] == pytest.approx((0.6 * 11) / 11)

    tot = behaviour_totals([{"behaviour": s}, {"behaviour": s}, {"intent": {}}])
    assert tot["runs"] == 2 and tot["n"] == 38 and tot["n_initializing"] == 2
    assert tot["accuracy"] == s["accuracy"] and tot["macro_f1"] == s["macro_f1"]
    assert tot["per_group"]["pedestrian"]["confusion"]["matrix"] == [[0, 0, 0], [0, 10, 0], [2, 0, 6]]
    assert tot["risk"]["accuracy"] == risk["accuracy"] and tot["confidence"]["n_wrong"] == 22
    assert behaviour_totals([{"intent": {}}]) is None


def test_the_gate_watches_behaviour_only_where_totals_have_it():
    assert "behaviour.macro_f1" not in flatten({"intent": {"accuracy": 0.9}})  # totals of older metrics
    flat = flatten({"behaviour": {"macro_f1": 0.8, "accuracy": 0.9}, "cipv": {"correct_rate": 0.97}})
    assert flat["behaviour.macro_f1"] == 0.8 and flat["behaviour.accuracy"] == 0.9 and flat["cipv.correct_rate"] == 0.97
