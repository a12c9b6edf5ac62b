"""The issues' acceptance numbers on the smoke suite (gt detector at default noise, no rendering)."""

from __future__ import annotations

from pathlib import Path

import pytest

from lookahead.tools.runs.suite import run_suite

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def smoke(tmp_path_factory) -> dict:
    return run_suite(ROOT / "scenarios" / "suites" / "smoke.yaml", tmp_path_factory.mktemp("smoke"), workers=2)


def test_perception_targets(smoke):
    t = smoke["totals"]
    assert t["tracking"]["mota"] >= 0.90 and t["tracking"]["idf1"] >= 0.90
    assert t["estimation"]["range_rel_err_median"] <= 0.05
    assert t["estimation"]["speed_err_median"] <= 0.5
    assert t["estimation"]["ttc_err_median"] <= 0.10


def test_intent_and_warning_targets(smoke):
    t = smoke["totals"]
    assert t["intent"]["macro_f1"] >= 0.90
    assert t["danger"]["events"] >= 5
    assert t["danger"]["miss_rate"] <= 0.01
    assert (t["danger"]["false_alarm_rate"] or 0.0) <= 0.05
    for name, run in smoke["runs"].items():
        for ev in run["metrics"]["danger"]["event_list"]:
            if (ev["ttc_when_first_visible"] or 0.0) >= 1.7:  # visible by then: Euro NCAP FCW green band
                assert ev["warned"] and ev["lead_time_s"] >= 1.7, (name, ev)
