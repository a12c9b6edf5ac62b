"""``lookahead bench watch`` writes the benchmark file issue 32 checks (no timing asserts)."""

from __future__ import annotations

import json
from pathlib import Path

import yaml
from typer.testing import CliRunner

from lookahead.tools.cli import app

ROOT = Path(__file__).resolve().parents[3]


def test_bench_watch_file_shape(tmp_path: Path) -> None:
    data = yaml.safe_load((ROOT / "scenarios" / "ped_crossing_nearside.yaml").read_text())
    data["duration"] = 0.8
    sc = tmp_path / "short.yaml"
    sc.write_text(yaml.safe_dump(data))
    out = tmp_path / "b.json"
    res = CliRunner().invoke(app, ["bench", "watch", "--out", str(out), "--scenario", str(sc), "--repeats", "1"])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    assert set(b) >= {"machine", "cases", "ratios", "fps", "latency_ms", "slowest_stage"}
    assert b["frames"] == 8
    assert set(b["fps"]) == {"capture", "stack", "sinks", "watch"} and all(v > 0 for v in b["fps"].values())
    assert b["slowest_stage"] in ("capture", "stack", "sinks")
    assert b["ratios"]["watch_over_slowest_stage"] > 0
    assert 0 < b["latency_ms"]["p50"] <= b["latency_ms"]["p95"]
    assert b["cases"]["stack"]["n"] == 8 - 3  # the warm-up frames left out
