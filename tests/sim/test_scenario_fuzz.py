"""Property test of the scenario model against mutated scenario files.

From a valid packaged scenario (enriched with a few more kinds of field), hypothesis replaces
values with NaN, +-inf, huge, tiny, negative numbers and values of the wrong type, drops fields
and adds unknown ones; ``parse_scenario`` must then either return a ``Scenario`` whose every float
is finite, or raise ``ScenarioError`` whose ``str()`` is one non-empty line. Any other exception
(a RecursionError, a TypeError, an OverflowError...) fails. Deterministic (derandomize=True).
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lookahead.sim.scenario import Scenario, ScenarioError, parse_scenario

ROOT = Path(__file__).resolve().parents[2]
PACKAGED = ROOT / "scenarios" / "ped_crossing_nearside.yaml"


def base_scenario() -> dict:
    data = yaml.safe_load(PACKAGED.read_text())
    data["traffic"] = {"count": 2, "density": 1.0, "speed": [8.0, 12.0], "lane_change": True}
    data["weather"] = {"kind": "fog", "visibility": 200.0, "variation": 0.3}
    data["ego"]["aeb"] = {"latency": 0.3}
    data["actors"].append({
        "id": "car1", "type": "car", "start": {"lane": 0, "s": 60.0, "offset": 0.2}, "heading": 0.0, "speed": 5.0,
        "script": [
            {"when": {"t": 1.0, "actor": {"id": "ped1", "speed_gt": 0.5}}, "delay": 0.5,
             "do": {"speed": 3.0, "accel": 2.0, "heading": 10.0, "turn_rate": 20.0}},
            {"when": {"ttc_lt": 3.0}, "do": {"waypoints": [[70.0, 2.0], [80.0, 3.5]], "lateral": 1.0}},
        ],
    })
    data["expect"].append({"metric": {"section": "intent", "name": "macro_f1", "min": 0.5, "max": 1.0}})
    data["expect"].append({"max_impact_speed": 2.0})
    return data


BASE = base_scenario()


def paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path into ``node`` (mapping keys, list indices), containers and leaves alike."""
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            out.append((*prefix, k))
            out += paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out.append((*prefix, i))
            out += paths(v, (*prefix, i))
    return out


PATHS = paths(BASE)


def value_at(node: Any, path: tuple) -> Any:
    for k in path:
        node = node[k]
    return node


NUMERIC_PATHS = [p for p in PATHS if type(value_at(BASE, p)) in (int, float)]

HOSTILE = [
    float("nan"), float("inf"), float("-inf"), 1e308, -1e308, 1e-300, -1e-300, -1, -1.5, 0, 0.0, 2**32 - 1, 2**32,
    2**63, 2**64 + 1, 10**30, -(10**30), "x", "", "1e999", None, True, False, [], {}, [1, 2, 3], [float("nan")] * 2,
    {"a": 1}, [[float("inf"), 0.0]],
]

mutation = st.one_of(
    st.tuples(st.just("set"), st.sampled_from(NUMERIC_PATHS), st.sampled_from(HOSTILE)),
    st.tuples(st.just("set"), st.sampled_from(PATHS), st.sampled_from(HOSTILE)),
    st.tuples(st.just("set"), st.sampled_from(NUMERIC_PATHS),
              st.floats(allow_nan=True, allow_infinity=True) | st.integers(min_value=-(2**70), max_value=2**70)),
    st.tuples(st.just("drop"), st.sampled_from(PATHS), st.none()),
    st.tuples(st.just("extra"), st.sampled_from(PATHS), st.sampled_from(HOSTILE)),
)


def mutate(data: dict, op: str, path: tuple, value: Any) -> None:
    parent = data
    for k in path[:-1]:
        try:
            parent = parent[k]
        except (KeyError, IndexError, TypeError):
            return  # an earlier mutation removed or replaced the way there
    key = path[-1]
    if isinstance(parent, dict) and op != "extra":
        if op == "drop":
            parent.pop(key, None)
        else:
            parent[key] = copy.deepcopy(value)
    elif isinstance(parent, list) and isinstance(key, int) and key < len(parent):
        if op == "drop":
            del parent[key]
        elif op == "set":
            parent[key] = copy.deepcopy(value)
    if op == "extra" and isinstance(parent, dict):
        parent[f"unknown_{key}"] = copy.deepcopy(value)


def floats_in(node: Any, where: str = "") -> list[tuple[str, float]]:
    """Every float (path, value) in a dumped model."""
    if isinstance(node, float):
        return [(where, node)]
    if isinstance(node, dict):
        return [f for k, v in node.items() for f in floats_in(v, f"{where}.{k}")]
    if isinstance(node, list | tuple):
        return [f for i, v in enumerate(node) for f in floats_in(v, f"{where}[{i}]")]
    return []


def check(text: str) -> None:
    try:
        sc = parse_scenario(text, "fuzz.yaml")
    except ScenarioError as e:
        msg = str(e)
        assert msg.strip(), "empty ScenarioError"
        assert "\n" not in msg and "\r" not in msg, f"ScenarioError of {len(msg.splitlines())} lines: {msg!r}"
        assert "fuzz.yaml" in msg, f"ScenarioError does not name the file: {msg!r}"
        return
    assert isinstance(sc, Scenario)
    bad = [(w, v) for w, v in floats_in(sc.model_dump()) if not math.isfinite(v)]
    assert not bad, f"accepted non-finite values: {bad[:5]}"


def test_base_is_valid() -> None:
    check(yaml.safe_dump(BASE))
    parse_scenario(yaml.safe_dump(BASE), "base.yaml")  # really valid, not merely refused in one line
    assert len(NUMERIC_PATHS) >= 30


@settings(max_examples=400, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(st.lists(mutation, min_size=1, max_size=3))
def test_mutated_scenario_is_finite_or_one_line_error(mutations: list) -> None:
    data = copy.deepcopy(BASE)
    for op, path, value in mutations:
        mutate(data, op, path, value)
    check(yaml.safe_dump(data, allow_unicode=True))


@settings(max_examples=150, derandomize=True, deadline=None, database=None)
@given(st.sampled_from(NUMERIC_PATHS), st.sampled_from([".nan", ".NaN", ".inf", "-.inf", "+.inf", ".Inf",
                                                        "1e999", "-1e999", "0x7fffffffffffffffffff", "1_000e300"]))
def test_yaml_spellings_of_non_finite(path: tuple, spelling: str) -> None:
    """The YAML spellings of NaN and infinity (and overflowing literals) in any numeric field."""
    data = copy.deepcopy(BASE)
    mutate(data, "set", path, "__HOLE__")
    text = yaml.safe_dump(data).replace("__HOLE__", spelling)
    check(text)
