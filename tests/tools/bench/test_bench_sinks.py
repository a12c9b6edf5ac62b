"""``lookahead bench sinks`` writes the benchmark file the issues check (no timing asserts)."""

from __future__ import annotations

import json
from pathlib import Path

import yaml
from typer.testing import CliRunner

from lookahead.tools.cli import app

ROOT = Path(__file__).resolve().parents[3]


def test_bench_sinks_file_shape(tmp_path):
    data = yaml.safe_load((ROOT / "scenarios" / "ped_crossing_nearside.yaml").read_text())
    data["duration"] = 0.6
    sc = tmp_path / "short.yaml"
    sc.write_text(yaml.safe_dump(data))
    out = tmp_path / "b.json"
    res = CliRunner().invoke(app, ["bench", "sinks", "--out", str(out), "--scenario", str(sc), "--repeats", "1"])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    assert set(b) >= {"machine", "cases", "ratios"}
    assert b["cases"]["tick_bare"]["n"] == b["cases"]["tick_with_sinks"]["n"] == 6
    assert b["ratios"]["sinks_over_bare_tick"] > 0
