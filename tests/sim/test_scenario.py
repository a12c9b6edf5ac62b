"""Scenario files: every shipped one validates; bad input gives one clear line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim.scenario import ScenarioError, load_scenario, parse_scenario, scenario_json_schema

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
