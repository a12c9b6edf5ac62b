"""``lookahead bench appearance`` writes the benchmark file issue 33 checks (no timing asserts)."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from lookahead.tools.cli import app


def test_bench_appearance_file_shape(tmp_path: Path) -> None:
    out = tmp_path / "b.json"
    res = CliRunner().invoke(app, ["bench", "appearance", "--out", str(out), "--objects", "4", "--frames", "25",
                                   "--repeats", "1"])
    assert res.exit_code == 0, res.output
    b = json.loads(out.read_text())
    assert set(b["cases"]) == {"track", "track_appearance", "track_embed_all"}
    assert all(c["n"] == 25 for c in b["cases"].values())
    assert 0 < b["embedded_frames"] < 1  # only when the tracker asks
    assert b["ratios"]["appearance_over_track"] > 0
