"""The regression gate: comparisons by hand, and a degraded configuration that must fail it."""

from __future__ import annotations

from pathlib import Path

import yaml
from typer.testing import CliRunner

from lookahead.tools.cli import app
from lookahead.tools.runs.regress import compare, markdown

ROOT = Path(__file__).resolve().parents[3]
SMOKE = ROOT / "scenarios" / "suites" / "smoke.yaml"
BASELINE = ROOT / "scenarios" / "suites" / "smoke.baseline.json"


def test_compare_directions_and_tolerances():
    base = {"tracking.mota": 0.90, "danger.miss_rate": 0.0, "estimation.speed_err_median": 0.40}
    cur = {"tracking.mota": 0.885, "danger.miss_rate": 0.01, "estimation.speed_err_median": 0.20}
    rows = {r["metric"]: r for r in compare(cur, base)}
    assert not rows["tracking.mota"]["regressed"]  # -0.015 within 0.02
    assert rows["danger.miss_rate"]["regressed"]  # any rise in missed warnings
    assert not rows["estimation.speed_err_median"]["regressed"]  # improved
    table = markdown(list(rows.values()))
    assert "| danger.miss_rate | 0 | 0.01 | +0.01 |" in table and "**REGRESSED**" in table


def test_a_metric_that_disappears_is_a_regression():
    (row,) = [r for r in compare({"intent.macro_f1": None}, {"intent.macro_f1": 0.9}) if r["metric"] == "intent.macro_f1"]
    assert row["regressed"]


def test_a_new_false_aeb_activation_fails_the_gate():
    (row,) = [r for r in compare({"aeb.false_activations": 1}, {"aeb.false_activations": 0})
              if r["metric"] == "aeb.false_activations"]
    assert row["regressed"] and row["delta"] == 1 and row["tolerance"] == 0
    assert "| aeb.false_activations | 0 | 1 | +1 |" in markdown([row])
    (row,) = [r for r in compare({"aeb.false_activations": 0}, {"aeb.false_activations": 1})
              if r["metric"] == "aeb.false_activations"]
    assert not row["regressed"]  # one fewer is an improvement


def test_a_baseline_without_the_false_activation_count_is_taken_as_zero():
    rows = {r["metric"]: r for r in compare({"aeb.false_activations": 0}, {"tracking.mota": 0.9})}
    assert rows["aeb.false_activations"]["assumed"] and not rows["aeb.false_activations"]["regressed"]
    assert "aeb.false_activations" not in markdown(list(rows.values()))  # nothing moved
    (row,) = [r for r in compare({"aeb.false_activations": 1}, {}) if r["metric"] == "aeb.false_activations"]
    assert row["regressed"] and "| aeb.false_activations | 0 (assumed) | 1 |" in markdown([row])
    # a baseline that names the metric is used as is, even when it recorded false activations
    (row,) = [r for r in compare({"aeb.false_activations": 2}, {"aeb.false_activations": 2})
              if r["metric"] == "aeb.false_activations"]
    assert not row["regressed"] and "assumed" not in row


def degraded_suite(tmp: Path, miss_rate: float) -> Path:
    suite = yaml.safe_load(SMOKE.read_text())
    paths = []
    for rel in suite["scenarios"]:
        data = yaml.safe_load((SMOKE.parent / rel).read_text())
        data.setdefault("perception", {}).setdefault("detector", {}).setdefault("noise", {})["miss_rate"] = miss_rate
        p = tmp / Path(rel).name
        p.write_text(yaml.safe_dump(data))
        paths.append(p.name)
    out = tmp / "smoke.yaml"
    out.write_text(yaml.safe_dump({"name": "smoke", "scenarios": paths}))
    return out


def test_a_degraded_detector_fails_the_gate_naming_the_metrics(tmp_path):
    res = CliRunner().invoke(app, ["regress", str(degraded_suite(tmp_path, 0.6)), "--baseline", str(BASELINE)])
    assert res.exit_code == 1, res.output
    assert "REGRESSION" in res.output
    for metric in ("detection.recall", "tracking.mota"):
        assert f"| {metric} |" in res.output and metric in res.output.splitlines()[-1]


def test_the_committed_baseline_passes_the_gate():
    res = CliRunner().invoke(app, ["regress", str(SMOKE), "--baseline", str(BASELINE)])
    assert res.exit_code == 0, res.output
    assert "no regression" in res.output


def test_a_broken_baseline_is_a_clear_error(tmp_path):
    bad = tmp_path / "b.json"
    bad.write_text("{not json")
    res = CliRunner().invoke(app, ["regress", str(SMOKE), "--baseline", str(bad)])
    assert res.exit_code == 2 and "b.json:1" in res.output
