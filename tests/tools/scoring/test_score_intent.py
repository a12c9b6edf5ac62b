"""Intent, danger, closed-loop and expectation scoring on a tiny hand-computed run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.tools.scoring.intent import intent_sections, load_intent_run

GT_LABELS = [1, 1, 1, 1, 1, 4, 4, 4, 4, 4]  # stable x5, danger x5
PRED = [0, 1, 1, 1, 1, 1, 4, 4, 2, 4]  # initializing, stable..., late by one frame, one wrong 'approaching'
TTC = [9, 9, 9, 9, 9, 3.0, 2.8, 2.6, 2.4, 2.2]
BOX = [100.0, 100.0, 140.0, 200.0]


def write_run(tmp: Path, expect: list) -> Path:
    run = tmp / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"scenario": {"expect": expect}}))
    lines = []
    for f in range(10):
        tracks = {"track_id": [10], "xyxy": [BOX], "state": ["confirmed"]}
        labels = [PRED[f]]
        alerts = []
        if f == 2:  # a track on nothing: a false alarm
            tracks = {"track_id": [10, 11], "xyxy": [BOX, [500, 10, 520, 40]], "state": ["confirmed"] * 2}
            labels = [PRED[f], 4]
            alerts = [{"t": 0.2, "track_id": 11, "kind": "fcw", "level": 3}]
        if f == 6:
            alerts = [{"t": 0.6, "track_id": 10, "kind": "fcw", "level": 3}]
        lines.append({
            "t": round(0.1 * f, 4), "ego": {"brake": None},
            "ground_truth": {"actor_id": [1], "name": ["ped"], "class_id": [0], "visible": [BOX],
                             "label": [GT_LABELS[f]], "ttc": [TTC[f]], "in_path": [f >= 5]},
            "tracks": tracks, "assessments": {"label": labels}, "alerts": alerts, "collisions": [],
        })
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    return run


def test_hand_computed_intent_danger_and_expectations(tmp_path):
    expect = [
        {"alert": {"actor": "ped", "level_at_least": "HIGH", "before_ttc": 2.5}},
        {"alert": {"actor": "ped", "level_at_least": "CRITICAL"}},
        {"collision": False},
    ]
    s = intent_sections(load_intent_run(write_run(tmp_path, expect)))
    it = s["intent"]
    # 9 scored predictions (the initializing one is don't-care); frame 5's 'stable' is within
    # the 0.3 s tolerance of the ground truth's change; frame 8's 'approaching' is wrong.
    assert it["n"] == 9
    assert it["n_initializing"] == 1  # frame 0: initializing, a don't-care pair, counted apart
    assert it["accuracy"] == pytest.approx(8 / 9, abs=1e-4)
    m = it["confusion"]["matrix"]
    assert m[0][0] == 5 and m[3][3] == 3 and m[3][1] == 1
    assert it["per_class"]["danger"]["recall"] == pytest.approx(0.75)
    assert it["per_class"]["danger"]["f1"] == pytest.approx(6 / 7, abs=1e-4)
    assert it["macro_f1"] == pytest.approx((1 + 6 / 7 + 0) / 3, abs=1e-4)

    d = s["danger"]
    assert (d["events"], d["missed"], d["alerts"], d["false_alarms"]) == (1, 0, 2, 1)
    assert d["miss_rate"] == 0.0 and d["false_alarm_rate"] == 0.5
    assert d["lead_time_s_median"] == pytest.approx(2.8)

    assert s["closed_loop"]["collision"] is False and s["closed_loop"]["min_ttc"] == pytest.approx(2.2)
    assert s["aeb"] == {"brake_onsets": 0, "false_activations": 0, "false_activation_rate": None, "onset_list": []}
    assert [e["passed"] for e in s["expectations"]] == [True, False, True]
    assert "true TTC 2.80 s" in s["expectations"][0]["detail"]
