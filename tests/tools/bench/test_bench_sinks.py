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


def test_bench_sinks_memory_shape():
    """The long-run memory figure on a short run: lengthened, and not ended by the collision that
    ends the scenario at frame 40; every sink; RSS sampled from ``start`` to the end (no memory
    asserts: that is the benchmark's job)."""
    from lookahead.tools.bench.sinks import bench_sinks_memory

    b = bench_sinks_memory(ROOT / "scenarios" / "ped_crossing_nearside.yaml", frames=50, start=45)
    assert set(b) >= {"machine", "cases", "ratios", "memory", "rss_growth_mb_45_to_end", "video_mb", "rrd_mb"}
    assert b["frames"] == b["memory"]["sinks"]["frames"] == 50
    assert b["cases"]["tick_with_sinks"]["n"] == 49
    m = b["memory"]["sinks"]
    assert m["rss_mb_peak"] >= max(m["rss_mb_frame_45"], m["rss_mb_end"]) > 0
    assert b["rss_growth_mb_45_to_end"] == m["rss_growth_mb_45_to_end"]
