"""Other cameras in the loop (``sim.cooperation``): what they see, what reaches the ego, and
what fusion changes in the ego's warnings."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.intent.config import IntentConfig
from lookahead.perception.cooperative import REMOTE_ID_BASE
from lookahead.sim.groundtruth import world_truth
from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner, camera_from_scenario
from lookahead.sim.scenario import ScenarioError, load_scenario, parse_scenario
from lookahead.sim.world import EGO_ACTOR_ID, Viewpoint, World

ROOT = Path(__file__).resolve().parents[2]
CHILD = ROOT / "scenarios" / "coop_child_parked_cars.yaml"


def run(sc) -> list[dict]:
    sink = RecordCollector()
    Runner(sc, sinks=[sink], render=False).run()
    return [r.to_dict() for r in sink.records]


@pytest.fixture(scope="module")
def child_records() -> list[dict]:
    return run(load_scenario(CHILD))


def first_alert_t(records: list[dict], actor: int, key: str) -> float:
    """Time of the first alert >= HIGH on an object whose truth is ``actor``."""
    for r in records:
        c = r["cooperative"]
        alerts = r["alerts"] if key == "alerts" else c["alerts_alone"]
        truth = dict(zip(c["fused"]["id"], c["fused"]["truth"], strict=True))
        if any(a["level"] >= 3 and truth.get(a["track_id"]) == actor for a in alerts):
            return r["t"]
    return float("inf")


def test_a_camera_elsewhere_sees_the_ego_and_not_its_carrier():
    sc = load_scenario(CHILD)
    w = World(sc)
    oncoming = w.by_name["oncoming"].identity.actor_id
    vp = w.viewpoint(oncoming)
    gt = world_truth(w, camera_from_scenario(sc), IntentConfig(), vp)
    assert oncoming not in gt.actor_id.tolist()
    k = gt.actor_id.tolist().index(EGO_ACTOR_ID)
    ex, ey, _ = w.ego_pose()
    # the oncoming car heads -x: the ego's centre lies ahead of it by the gap between their fronts
    assert gt.box3d[k, 0] == pytest.approx(vp.pose[0] - (ex - sc.ego.length / 2), abs=0.3)
    assert gt.box3d[k, 1] == pytest.approx(vp.pose[1] - ey, abs=0.05)
    assert gt.range_rate[k] == pytest.approx(-(sc.ego.speed + 8.0), abs=0.05)  # closing on each other
    # a roadside unit: the ego straight ahead of a unit standing on the road behind it
    rsu = Viewpoint((ex - 30.0, ey, 0.0))
    gt = world_truth(w, camera_from_scenario(sc), IntentConfig(), rsu)
    k = gt.actor_id.tolist().index(EGO_ACTOR_ID)
    assert gt.lateral[k] == pytest.approx(0.0, abs=1e-6) and 24.0 < gt.range[k] < 26.0


def test_fusion_warns_of_the_hidden_child_before_the_ego_alone_can(child_records):
    child = 3  # actor id: the third scenario actor
    hidden_until = next(r["t"] for r in child_records
                        if child in r["ground_truth"]["actor_id"]
                        and r["ground_truth"]["visible_fraction"][r["ground_truth"]["actor_id"].index(child)] > 0.3)
    fused, alone = first_alert_t(child_records, child, "alerts"), first_alert_t(child_records, child, "alone")
    assert fused < hidden_until <= alone  # warned while still hidden; alone only once seen
    assert alone - fused >= 0.5
    first = next(r for r in child_records if r["t"] == fused)
    ids = [a["track_id"] for a in first["alerts"]]
    assert any(i >= REMOTE_ID_BASE for i in ids)  # under the remote id of the oncoming car's object


def test_every_frame_records_what_was_sent_received_and_fused(child_records):
    c = child_records[30]["cooperative"]
    assert c["fusion"] is True and [s["name"] for s in c["senders"]] == ["oncoming"]
    (msg,) = c["received"]
    assert msg["sender"] == "oncoming" and 0.05 <= msg["age"] <= 0.1 + 1e-9
    assert EGO_ACTOR_ID in msg["truth"]  # the oncoming car sees the ego ...
    assert msg["fused_id"][msg["truth"].index(EGO_ACTOR_ID)] == -1  # ... which fusion drops
    f = c["fused"]
    assert len(f["id"]) == len(f["source"]) == len(f["xy"]) == len(f["cov"])
    assert set(c["remote"]["id"]) == {i for i, s in zip(f["id"], f["source"], strict=True) if s == 1}
    assert c["link"]["sent"] == 31 and c["link"]["lost"] == 0


def test_with_fusion_off_the_ego_warns_exactly_as_without_other_cameras():
    sc = load_scenario(CHILD)
    off = run(sc.model_copy(update={"cooperative": sc.cooperative.model_copy(update={"fusion": False})}))
    none = run(sc.model_copy(update={"cooperative": None}))
    assert [r["alerts"] for r in off] == [r["alerts"] for r in none]
    assert [r["alerts"] for r in off] == [r["cooperative"]["alerts_alone"] for r in off]
    assert [r["tracks"] for r in off] == [r["tracks"] for r in none]
    assert all("cooperative" not in r for r in none)


def test_the_same_seed_gives_the_same_messages_and_a_lossy_link_loses_its_share():
    sc = load_scenario(ROOT / "scenarios" / "coop_child_lossy_link.yaml")
    a, b = run(sc), run(sc)
    assert [json.dumps(r, sort_keys=True) for r in a] == [json.dumps(r, sort_keys=True) for r in b]
    link = a[-1]["cooperative"]["link"]
    assert 0.15 < link["lost"] / link["sent"] < 0.45  # 30 % loss over ~50 messages
    ages = [m["age"] for r in a for m in r["cooperative"]["received"]]
    assert min(ages) >= 0.2 - 1e-9 and max(ages) <= sc.cooperative.link.timeout


@pytest.mark.parametrize("sender, message", [
    ("{name: x, actor: nobody}", r"cooperative.senders\[0\].actor: unknown actor"),
    ("{name: x, actor: a, at: {x: 1, y: 2}}", "give either actor"),
    ("{name: x}", "give either actor"),
])
def test_a_malformed_sender_is_a_clear_scenario_error(sender, message):
    text = f"""
name: bad
actors: [{{id: a, type: car, start: {{x: 20, y: 0}}}}]
cooperative: {{senders: [{sender}]}}
"""
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(text)


def test_an_onnx_sender_without_rendering_is_a_scenario_error():
    sc = load_scenario(CHILD)
    spec = sc.cooperative.senders[0].model_copy(update={"perception": sc.perception.model_copy(
        update={"detector": sc.perception.detector.model_copy(update={"kind": "onnx"})})})
    sc = sc.model_copy(update={"cooperative": sc.cooperative.model_copy(update={"senders": [spec]})})
    with pytest.raises(ScenarioError, match="onnx needs rendered frames"):
        Runner(sc, render=False)


def test_sender_names_are_unique():
    text = """
name: bad
cooperative: {senders: [{name: x, at: {x: 1, y: 2}}, {name: x, at: {x: 5, y: 2}}]}
"""
    with pytest.raises(ScenarioError, match="repeated"):
        parse_scenario(text)


def test_once_the_ego_sees_the_child_its_warning_goes_on_under_the_own_track(child_records):
    child = 3
    events = [(r["t"], a["track_id"], a["kind"]) for r in child_records for a in r["alerts"]]
    # raised under the remote id (an FCW may escalate to critical on that track) ...
    assert events and len({tid for _, tid, _ in events}) == 1 and events[0][1] >= REMOTE_ID_BASE
    assert len({kind for _, _, kind in events}) == len(events)  # each level once
    both = next(r for r in child_records
                if any(t == child and s == 2 for t, s in zip(r["cooperative"]["fused"]["truth"],
                                                              r["cooperative"]["fused"]["source"], strict=True)))
    own_id = [i for i, t, s in zip(both["cooperative"]["fused"]["id"], both["cooperative"]["fused"]["truth"],
                                   both["cooperative"]["fused"]["source"], strict=True) if t == child and s == 2][0]
    assert own_id < REMOTE_ID_BASE  # ... then the ego's own track carries it: no second alert, no new debounce
    assert [a["track_id"] for r in child_records for a in r["cooperative"]["alerts_alone"]] == [own_id]
