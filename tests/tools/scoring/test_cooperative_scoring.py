"""The ``cooperative`` section on a hand-built run whose answers are known, its totals and
regression gate, and a real run of a cooperative scenario."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.tools.runs.regress import compare, flatten, write_baseline
from lookahead.tools.scoring.cooperative import cooperative_section, cooperative_totals
from lookahead.tools.scoring.intent import intent_sections, load_intent_run, track_actors
from lookahead.tools.scoring.run import score_run
from lookahead.tools.scoring.totals import intent_totals, sweep_totals

ROOT = Path(__file__).resolve().parents[3]
COOP_SCENARIO = ROOT / "scenarios" / "coop_child_parked_cars.yaml"

# Ground truth (ego frame): a car ahead (1), an occluded child (2), a car further on (3).
GT = {"actor_id": [1, 2, 3], "name": ["car", "child", "far"], "class_id": [4, 0, 4],
      "box3d": [[20.0, 0.0, 0.7, 4.5, 1.8, 1.5, 0.0], [15.0, -3.0, 0.6, 0.3, 0.3, 1.1, 1.57],
                [30.0, 3.0, 0.7, 4.5, 1.8, 1.5, 3.14]],
      "visible": [[300, 150, 340, 180], None, [320, 160, 330, 170]],
      "visible_fraction": [1.0, 0.0, 1.0], "truncation": [0.0, 0.0, 0.0], "in_path": [False, True, False]}
CHILD_LABEL = [2, 4, 4, 4, 4]  # approaching, then danger
CHILD_TTC = [3.2, 3.0, 2.8, 2.6, 2.4]
REMOTE_CHILD = 1_000_002


def cooperative(f: int) -> dict:
    """One frame's record. Sender a: object 10 (car 1) joins own 1 (right), object 11 (car 3)
    is not matched though own 2 is car 3 (a missed pair), object 12 (the child) only a sees
    (remote id), object 13 is the ego (dropped). Sender b: object 20 (the child) joins a's
    remote object (right), object 21 (car 1) joins own 2, which is car 3 (a wrong match)."""
    return {
        "fusion": True,
        "senders": [],
        "received": [
            {"sender": "a", "t": 0.1 * f - 0.1, "age": 0.1, "id": [10, 11, 12, 13], "truth": [1, 3, 2, 0],
             "xy": [[21.0, 0.0], [30.0, 4.0], [15.0, -3.0], [-2.0, 0.0]],
             "fused_id": [1, 1_000_001, REMOTE_CHILD, -1], "matched": [True, False, False, False],
             "matched_source": [0, -1, -1, -1]},
            {"sender": "b", "t": 0.1 * f - 0.2, "age": 0.2, "id": [20, 21], "truth": [2, 1],
             "xy": [[15.0, -2.0], [31.0, 3.0]], "fused_id": [REMOTE_CHILD, 2], "matched": [True, True],
             "matched_source": [1, 0]},
        ],
        "own": {"id": [1, 2], "truth": [1, 3], "xy": [[20.5, 0.0], [30.0, 3.5]]},
        "fused": {"id": [1, 2, 1_000_001, REMOTE_CHILD], "truth": [1, 3, 3, 2], "class_id": [4, 4, 4, 0],
                  "xy": [[20.2, 0.0], [30.0, 3.4], [30.0, 4.0], [15.0, -2.5]], "velocity": [[0, 0]] * 4,
                  "source": [2, 2, 1, 1], "cov": [[1, 0, 1]] * 4},
        "remote": {"id": [1_000_001, REMOTE_CHILD]},
        "alerts_alone": [],
        "link": {"sent": 2 * f + 2, "lost": f, "delivered": f + 2, "expired": 0, "overflowed": 0},
    }


def write_run(tmp: Path, with_cooperative: bool = True) -> Path:
    run = tmp / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"scenario": {"expect": []}}))
    lines = []
    for f in range(5):
        gt = {**GT, "label": [2, CHILD_LABEL[f], 2], "ttc": [9.0, CHILD_TTC[f], 9.0]}
        rec = {"t": round(0.1 * f, 4), "ego": {"brake": None}, "ground_truth": gt,
               "tracks": {"track_id": [1, 2], "xyxy": [[300, 150, 340, 180], [320, 160, 330, 170]],
                          "state": ["confirmed"] * 2},
               "assessments": {"label": [2, 2]}, "collisions": [],
               "alerts": [{"t": 0.2, "track_id": REMOTE_CHILD, "kind": "fcw", "level": 3}] if f == 2 else []}
        if with_cooperative:
            rec["cooperative"] = cooperative(f)
            if f == 4:  # the ego alone warns at the last frame, on its own track of car 1: not the child
                rec["cooperative"]["alerts_alone"] = [{"t": 0.4, "track_id": 1, "kind": "fcw", "level": 3}]
        lines.append(rec)
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    return run


@pytest.fixture
def section(tmp_path) -> dict:
    s = cooperative_section(write_run(tmp_path))
    assert s is not None
    return s


def test_matching_precision_and_recall(section):
    m = section["matching"]
    # per frame: 3 pairs with known truths (a10 right, b20 right, b21 wrong) -> precision 2/3;
    # 4 should have matched (a10, a11 -- missed --, b20, b21) of which 2 did, rightly -> recall 1/2
    assert (m["pairs"], m["correct"], m["should_match"], m["correct_should_match"]) == (15, 10, 20, 10)
    assert m["precision"] == pytest.approx(2 / 3, abs=1e-4) and m["recall"] == 0.5
    a, b = m["per_sender"]["a"], m["per_sender"]["b"]
    assert (a["precision"], a["recall"]) == (1.0, 0.5)  # right match; the missed pair
    assert (b["precision"], b["recall"]) == (0.5, 0.5)  # one right (with a's object), one wrong


def test_self_detections(section):
    assert section["self_detections"] == {"dropped": 5, "kept": 0, "wrongly_dropped": 0, "unknown_dropped": 0,
                                          "drop_rate": 1.0}


def test_position_errors(section):
    pe = section["position_error"]
    assert pe["own"] == {"median": 0.5, "p90": 0.5, "n": 10}
    assert pe["received"]["n"] == 25  # the ego's detection dropped
    both = pe["both"]
    assert both["own"] == {"median": 0.5, "p90": 0.5, "n": 10}
    assert both["other"] == {"median": 1.0, "p90": 1.0, "n": 10}  # a's object on car 1, b's on car 3
    assert both["fused"]["median"] == pytest.approx(0.3) and both["fused"]["n"] == 10


def test_occluded_child_counts_for_fusion_not_own(section):
    occ = section["occluded_recall"]
    assert (occ["n"], occ["n_fused"], occ["n_own"]) == (5, 5, 0)
    assert occ["fused"] == 1.0 and occ["own"] == 0.0
    assert occ["recall_all"]["n"] == 15 and occ["recall_all"]["own"] == pytest.approx(2 / 3, abs=1e-4)
    assert occ["recall_all"]["fused"] == 1.0


def test_link(section):
    link = section["link"]
    assert (link["sent"], link["lost"], link["delivered"]) == (10, 4, 6)  # the last frame's counters
    assert (link["messages"], link["age_median_s"], link["age_max_s"]) == (10, 0.15, 0.2)


def test_remote_alert_gives_lead_time_and_the_ego_alone_misses(section, tmp_path):
    w = section["warning"]
    # the child is never in the ego's image, but fused objects carry it: a danger event
    assert (w["fusion"]["dangers"], w["fusion"]["missed"]) == (1, 0)
    assert w["fusion"]["lead_time_median_s"] == 2.8 and w["fusion"]["lead_time_min_s"] == 2.8
    assert w["fusion"]["false_alarms"] == 0
    assert (w["alone"]["dangers"], w["alone"]["missed"]) == (1, 1)
    assert w["alone"]["lead_time_median_s"] is None and w["alone"]["false_alarms"] == 1  # warned of car 1
    # the danger section now associates the remote id with the child: no false alarm
    run = load_intent_run(tmp_path / "run")
    assert track_actors(run)[REMOTE_CHILD] == 2
    d = intent_sections(run)["danger"]
    assert d["alerts"] == 1 and d["false_alarms"] == 0


def test_absent_without_cooperative_records(tmp_path):
    run = write_run(tmp_path, with_cooperative=False)
    assert cooperative_section(run) is None
    assert not load_intent_run(run).cooperative
    assert "cooperative" not in sweep_totals([{}])


def test_totals_pool_counts_and_the_gate(section):
    per_run = [{"cooperative": section}, {"cooperative": section}, {}]
    tot = cooperative_totals(per_run)
    assert tot["runs"] == 2 and tot["matching_pairs"] == 30
    assert tot["matching_precision"] == pytest.approx(2 / 3, abs=1e-4) and tot["matching_recall"] == 0.5
    assert (tot["occluded_recall_fused"], tot["occluded_recall_own"], tot["occluded_n"]) == (1.0, 0.0, 10)
    assert tot["lead_time_median_s_fusion"] == 2.8 and tot["lead_time_median_s_alone"] is None
    assert (tot["missed_fusion"], tot["missed_alone"]) == (0, 2)
    assert cooperative_totals([{}, {"detection": {}}]) is None
    assert intent_totals([]) is not None  # (unchanged)

    current = flatten({"cooperative": tot})
    assert current["cooperative.matching_recall"] == 0.5
    assert not any(k.startswith("cooperative.") for k in flatten({"detection": {"recall": 0.9}}))
    # an old baseline without the keys: listed, not gated
    rows = {r["metric"]: r for r in compare(current, {})}
    assert not rows["cooperative.matching_precision"]["regressed"]
    worse = {**current, "cooperative.matching_precision": current["cooperative.matching_precision"] - 0.05,
             "cooperative.occluded_recall_fused": 0.9}
    rows = {r["metric"]: r for r in compare(worse, current)}
    assert rows["cooperative.matching_precision"]["regressed"] and rows["cooperative.occluded_recall_fused"]["regressed"]
    assert not rows["cooperative.matching_recall"]["regressed"]


def test_baseline_of_a_suite_without_cooperation_names_no_cooperative_metric(tmp_path):
    path = tmp_path / "b.json"
    write_baseline(path, "smoke", flatten({"detection": {"recall": 0.9}}))
    assert "cooperative" not in path.read_text()


@pytest.mark.skipif(not COOP_SCENARIO.is_file(), reason="no cooperative scenario")
def test_real_cooperative_run(tmp_path):
    from lookahead.sim.runner import Runner
    from lookahead.sim.scenario import load_scenario
    from lookahead.tools.sinks.rundir import RunDirWriter

    sc = load_scenario(COOP_SCENARIO)
    Runner(sc, sinks=[RunDirWriter(tmp_path / "run", sc)], render=False).run()
    c = score_run(tmp_path / "run")["cooperative"]
    assert c["frames"] > 0 and c["matching"]["pairs"] > 0
    assert c["self_detections"]["dropped"] > 0  # the oncoming car sees the ego
    occ = c["occluded_recall"]
    assert occ["n"] > 0 and occ["n_fused"] > occ["n_own"]  # the hidden child, seen by the other car
    assert c["warning"]["fusion"]["dangers"] >= 1
