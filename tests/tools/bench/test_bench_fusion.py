"""``bench fusion`` times the real fusion stage on a scene whose identities it knows (no timing asserts)."""

from __future__ import annotations

from lookahead.tools.bench.fusion import bench_fusion


def test_bench_fusion_times_real_matching():
    b = bench_fusion(senders=3, objects=12, frames=5)
    assert set(b["cases"]) == {"fusion", "fusion_node"} and all(c["n"] == 5 for c in b["cases"].values())
    # the timed work really matches: most pairs are right (a dense scene with camera noise)
    assert b["matching_precision"] > 0.8 and b["matching_recall"] > 0.8
    assert b["ratios"]["fusion_over_frame_period"] > 0


def test_bench_fusion_command_writes_its_file(tmp_path):
    import json

    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    out = tmp_path / "f.json"
    res = CliRunner().invoke(app, ["bench", "fusion", "--out", str(out), "--objects", "6", "--frames", "3"])
    assert res.exit_code == 0, res.output
    assert json.loads(out.read_text())["cases"]["fusion"]["n"] == 3
