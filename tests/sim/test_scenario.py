"""Scenario files: every shipped one validates; bad input gives one clear line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.sim.scenario import (
    ScenarioError,
    load_scenario,
    parse_scenario,
    scenario_json_schema,
)

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.yaml"))


def test_at_least_ten_scenarios_cover_the_seeds():
    assert len(SCENARIOS) >= 10
    types = {a.type for p in SCENARIOS for a in load_scenario(p).actors}
    subtypes = {a.subtype for p in SCENARIOS for a in load_scenario(p).actors}
    assert {"pedestrian", "cyclist", "motorcyclist", "tricycle", "car", "animal"} <= types
    assert {"adult", "child", "dog", "deer", "e-bike"} <= subtypes
    assert any(load_scenario(p).traffic.count > 0 for p in SCENARIOS)
    assert any(load_scenario(p).road.kind == "intersection" for p in SCENARIOS)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_shipped_scenarios_validate(path):
    sc = load_scenario(path)
    assert sc.name == path.stem


def test_shipped_schema_is_the_generated_one():
    shipped = json.loads((ROOT / "scenarios" / "scenario.schema.json").read_text())
    assert shipped == scenario_json_schema()


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("name: a\nego: {lane: 1, speed: fast}\n", ["x.yaml:2", "ego.speed", "'fast'"]),
        ("name: a\nactors:\n  - id: p\n    type: alien\n    start: {x: 1, y: 2}\n", ["x.yaml:4", "actors[0].type", "'alien'"]),
        ("name: a\n  bad: [\n", ["x.yaml:2", "malformed YAML"]),
        ("name: a\ncamera: {fov_h: 200}\n", ["x.yaml:2", "camera.fov_h", "less than 170"]),
        ("name: a\nfoo: 1\n", ["x.yaml:2", "foo", "unknown field"]),
        ("name: a\nego: {lane: 5}\n", ["ego.lane 5 is outside"]),
        ("- 1\n- 2\n", ["expected a mapping"]),
        (
            "name: a\nactors:\n  - {id: p, type: pedestrian, subtype: dog, start: {x: 1, y: 2}}\n",
            ["actors[0]", "subtype 'dog'"],
        ),
    ],
)
def test_bad_input_is_one_line_naming_file_field_and_expectation(text, expected):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, "x.yaml")
    msg = str(e.value)
    assert "\n" not in msg
    for part in expected:
        assert part in msg


def test_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "nope.yaml")


# --- the perception / intent override sections, expectations, AEB and alert settings ----------

BASE = "name: a\nactors:\n  - {id: p, type: pedestrian, start: {x: 20, y: 2}}\n"


@pytest.mark.parametrize(
    ("text", "where", "field"),
    [
        ("perception:\n  detector:\n    noise: {box_sigma: 0.1, miss_rat: 0.1}\n", "x.yaml:6", "perception.detector.noise.miss_rat"),
        ("perception:\n  detector:\n    noise:\n      miss_rate: 3\n", "x.yaml:7", "perception.detector.noise.miss_rate"),
        ("perception:\n  tracker:\n    max_lost: 1.0\n", "x.yaml:6", "perception.tracker.max_lost"),
        ("perception:\n  tracker:\n    min_hits: 2\n    max_lost_s: -1\n", "x.yaml:7", "perception.tracker.max_lost_s"),
        ("perception:\n  tracker:\n    class_hysteresis: 0.5\n", "x.yaml:6", "perception.tracker.class_hysteresis"),
        ("perception:\n  tracker:\n    duplicate_iou: 1.5\n", "x.yaml:6", "perception.tracker.duplicate_iou"),
        ("perception:\n  estimator:\n    motion_model: kalman\n", "x.yaml:6", "perception.estimator.motion_model"),
        ("perception:\n  estimator:\n    edge_sigma_rell: 0.1\n", "x.yaml:6", "perception.estimator.edge_sigma_rell"),
        ("intent:\n  horizn: 3\n", "x.yaml:5", "intent.horizn"),
        ("perception:\n  detector:\n    windows: [[0.6, 0.2, 0.4, 0.8]]\n", "x.yaml:6", "perception.detector.windows"),
        ("perception:\n  detector:\n    windows: [[0.2, 0.2, 0.4, 0.8, 0]]\n", "x.yaml:6", "perception.detector.windows"),
        ("perception:\n  detector:\n    windows: [[0.2, 0.2, 0.4]]\n", "x.yaml:6", "perception.detector.windows[0]"),
        ("intent:\n  risk:\n    pedestrian:\n      high_ttc: soon\n", "x.yaml:7", "intent.risk.pedestrian.high_ttc"),
    ],
)
def test_bad_perception_and_intent_overrides_are_located_errors(text, where, field):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(BASE + text, "x.yaml")
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(f"{where}: {field}: "), msg


def test_tracker_cross_field_check_and_coercion():
    with pytest.raises(ScenarioError, match=r"x.yaml:5: perception.tracker: .*low_score <= high_score"):
        parse_scenario(BASE + "perception:\n  tracker: {low_score: 0.9}\n", "x.yaml")
    sc = parse_scenario(BASE + "perception:\n  tracker: {max_lost_s: '2', min_hits: 3}\n", "x.yaml")
    assert sc.perception.tracker == {"max_lost_s": 2.0, "min_hits": 3}  # what TrackerConfig(**...) gets


def test_good_overrides_stay_plain_mappings():
    text = BASE + (
        "perception:\n  detector: {noise: {miss_rate: 0.1}}\n  estimator: {motion_model: cv}\n"
        "intent: {risk: {pedestrian: {high_ttc: 2.5}}}\n"
    )
    sc = parse_scenario(text, "x.yaml")
    assert sc.intent == {"risk": {"pedestrian": {"high_ttc": 2.5}}}
    assert sc.perception.estimator == {"motion_model": "cv"}
    dumped = sc.model_dump(mode="json")
    assert dumped["intent"] == sc.intent and dumped["perception"]["estimator"] == {"motion_model": "cv"}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("expect:\n  - alrt: {actor: p}\n", ["x.yaml:5", "expect[0]", "unknown expectation 'alrt'"]),
        ("expect:\n  - alert: {actor: p, level_at_least: HUGE}\n",
         ["x.yaml:5", "expect[0].alert.level_at_least", "'HIGH' or 'CRITICAL'", "'HUGE'"]),
        ("expect:\n  - collision: false\n  - no_alert:\n      actor: q\n", ["x.yaml:7", "expect[1].no_alert.actor", "unknown actor", "'q'"]),
        ("expect:\n  - {collision: false, danger_warned: true}\n", ["expect[0]", "exactly one"]),
        ("expect:\n  - max_impact_speed: -1\n", ["expect[0].max_impact_speed", "greater than or equal to 0"]),
        ("expect:\n  - metric: {section: danger, name: missed}\n", ["expect[0].metric", "min and/or max"]),
    ],
)
def test_bad_expectation_is_one_line(text, expected):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(BASE + text, "x.yaml")
    msg = str(e.value)
    assert "\n" not in msg
    for part in expected:
        assert part in msg, msg


def test_expectations_dump_as_given_for_the_scorer():
    text = BASE + (
        "expect:\n  - alert: {actor: p, level_at_least: CRITICAL}\n  - no_alert: {actor: p}\n"
        "  - collision: false\n  - danger_warned: true\n  - metric: {section: closed_loop, name: min_ttc, min: 1}\n"
    )
    dumped = parse_scenario(text, "x.yaml").model_dump(mode="json")["expect"]
    assert dumped == [
        {"alert": {"actor": "p", "level_at_least": "CRITICAL"}}, {"no_alert": {"actor": "p"}},
        {"collision": False}, {"danger_warned": True},
        {"metric": {"section": "closed_loop", "name": "min_ttc", "min": 1.0}},
    ]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("ego: {aeb: {latency: -1}}\n", "x.yaml:4: ego.aeb.latency: Input should be greater than or equal to 0"),
        ("ego:\n  aeb: {latncy: 0.3}\n", "x.yaml:5: ego.aeb.latncy: unknown field"),
        ("ego: {aeb: fast}\n", "x.yaml:4: ego.aeb: expected true, false or a mapping"),
        ("alerts: {off_frames: 0}\n", "x.yaml:4: alerts.off_frames: Input should be greater than or equal to 1"),
    ],
)
def test_bad_aeb_and_alert_settings(text, expected):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(BASE + text, "x.yaml")
    assert str(e.value).startswith(expected), str(e.value)


def test_aeb_and_alert_settings_reach_the_runner():
    from lookahead.intent.alerts import AlertConfig
    from lookahead.sim.aeb import AebConfig
    from lookahead.sim.runner import Runner

    sc = parse_scenario(BASE + "ego: {aeb: {latency: 0.5, decel: 4}}\nalerts: {on_frames_high: 3, off_frames: 5}\n")
    r = Runner(sc, render=False)
    assert r.aeb.config == AebConfig(latency=0.5, decel=4.0)
    assert r.perception.alerts.config == AlertConfig(on_frames_high=3, off_frames=5)
    assert Runner(parse_scenario(BASE + "ego: {aeb: true}\n"), render=False).aeb.config == AebConfig()
    assert Runner(parse_scenario(BASE + "ego: {aeb: off}\n"), render=False).aeb is None


def _aeb_run(aeb: str) -> tuple[float, float, list]:
    """(time the brake came on, final range to the stationary car (m), collisions) of
    ``scenarios/stationary_car.yaml`` with ``ego.aeb: AEB``, closed loop without rendering."""
    from lookahead.sim.records import RecordCollector
    from lookahead.sim.runner import Runner

    text = (ROOT / "scenarios" / "stationary_car.yaml").read_text()
    assert "controller: cruise}" in text
    sc = parse_scenario(text.replace("controller: cruise}", f"controller: cruise, aeb: {aeb}}}"), "stationary_car.yaml")
    sink = RecordCollector()
    summary = Runner(sc, sinks=[sink], render=False).run()
    braking = [r.t for r in sink.records if r.ego["brake"] is not None]
    gt = sink.records[-1].ground_truth
    return braking[0], float(gt.range[gt.class_id >= 0].min()), summary.collisions


def test_longer_aeb_latency_stops_later():
    t_quick, gap_quick, hits_quick = _aeb_run("{latency: 0.2}")
    t_slow, gap_slow, hits_slow = _aeb_run("{latency: 0.8}")
    assert not hits_quick and not hits_slow
    assert t_slow - t_quick == pytest.approx(0.6, abs=0.15)  # camera frames are 0.1 s apart
    assert gap_slow < gap_quick - 1.0, (gap_quick, gap_slow)


def test_schema_describes_overrides_aeb_alerts_and_expectations():
    s = scenario_json_schema()
    defs = s["$defs"]
    assert {"type": "boolean"} in defs["EgoSpec"]["properties"]["aeb"]["anyOf"]
    assert {"$ref": "#/$defs/AebConfig"} in defs["EgoSpec"]["properties"]["aeb"]["anyOf"]
    assert s["properties"]["alerts"]["$ref"] == "#/$defs/AlertConfig"
    assert s["properties"]["expect"]["items"] == {"$ref": "#/$defs/Expectation"}
    assert defs["AlertExpect"]["properties"]["level_at_least"]["enum"] == ["SAFE", "LOW", "MEDIUM", "HIGH", "CRITICAL"]
    tracker = defs["PerceptionSpec"]["properties"]["tracker"]
    assert tracker["additionalProperties"] is False and tracker["properties"]["max_lost_s"]["minimum"] == 0
    assert defs["PerceptionSpec"]["properties"]["estimator"]["$ref"] == "#/$defs/EstimatorConfig"
    assert "horizon" in s["properties"]["intent"]["properties"]
    assert "required" not in defs["RiskThresholds"]  # intent overrides may be partial


ACTOR = "actors:\n  - {id: p, type: pedestrian, start: {x: 20, y: 2}, heading: 90, speed: 1.4}\n"


@pytest.mark.parametrize(
    ("text", "expected"),
    [  # values the schema once let through, each crashing later or meaning nothing
        ("name: a\n" + ACTOR.replace("x: 20", "x: .nan"), ["x.yaml:3", "actors[0].start.x", "finite", "nan"]),
        ("name: a\n" + ACTOR.replace("heading: 90", "heading: .inf"), ["x.yaml:3", "actors[0].heading", "inf"]),
        ("name: a\n" + ACTOR.replace("x: 20", "x: 1e308"), ["x.yaml:3", "actors[0].start.x", "20000"]),
        ("name: a\n" + ACTOR.replace("x: 20", "x: 19000"), ["actors[0].start.x", "along a road of 2000 m"]),
        ("name: a\n" + ACTOR.replace("heading: 90", "heading: 1e9"), ["actors[0].heading", "720"]),
        ("name: a\nseed: 4294967296\n", ["x.yaml:2", "seed", "4294967295"]),
        ("name: a\nseed: -1\n", ["seed", "greater than or equal to 0"]),
        ("name: a\nrate: 1e-300\n", ["x.yaml:2", "rate", "greater than or equal to 1"]),
        ("name: a\nduration: 1e-300\n", ["x.yaml:2", "duration", "greater than or equal to 0.1"]),
        ("name: a\nduration: 0.15\ncamera: {rate: 5}\n", ["duration", "shorter than one camera frame"]),
        ("name: a\ncamera: {rate: 1e-300}\n", ["camera.rate", "greater than or equal to 1"]),
        ("name: a\ntraffic: {speed: [30, 10]}\n", ["traffic.speed", "low <= high", "[30.0, 10.0]"]),
        ("name: a\ntraffic: {speed: [.nan, 10]}\n", ["traffic.speed[0]", "finite"]),
        ("name: a\nego: {s: 1e6}\n", ["ego.s", "20000"]),
        ("name: a\nego: {s: 5000}\n", ["ego.s", "beyond the road's end"]),
        ("name: a\nego: {controller: profile, profile: [[0, .nan]]}\n", ["ego.profile[0][1]", "finite"]),
        ("name: a\nperception: {tracker: {max_age: .inf}}\n", ["perception.tracker.max_age", "finite"]),
        ("name: a\nexpect: [{metric: {section: intent, name: macro_f1, min: 0.9, max: 0.5}}]\n", ["min 0.9 is above max 0.5"]),
        ("name: a\n" + ACTOR.replace("speed: 1.4", "speed: 1.4, script: [{do: {waypoints: [[1e300, 0]]}}]"),
         ["actors[0].script[0].do.waypoints[0][0]"]),
    ],
)
def test_nan_inf_and_unphysical_values_are_refused_by_validate_and_run(text, expected):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, "x.yaml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("x.yaml")
    for part in expected:
        assert part in msg, (part, msg)
