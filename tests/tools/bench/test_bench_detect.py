"""``lookahead bench detect``: the shipped detector timed on rendered frames."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from lookahead.tools.cli import app


def test_bench_detect_renders_at_the_camera_size_asked_for_with_the_windows_asked_for(tmp_path):
    out = tmp_path / "detect.json"
    res = CliRunner().invoke(app, ["bench", "detect", "--out", str(out), "--frames", "2", "--repeats", "1",
                                   "--camera", "480x270", "--windows", "[[0.3, 0.3, 0.7, 0.65, 2]]"])
    assert res.exit_code == 0, res.output
    result = json.loads(out.read_text())
    assert result["image"] == [480, 270]
    assert result["windows"] == [[0.3, 0.3, 0.7, 0.65, 2.0]] and result["views"] == 2
    assert result["ratios"]["pipeline_over_session_run"] > 0 and result["fps"] > 0
    assert "detector at 480x270" in res.output


def test_bench_detect_names_a_bad_camera_size_or_window_in_one_line(tmp_path):
    for args, said in ((["--camera", "1280by720"], "--camera '1280by720': WIDTHxHEIGHT"),
                       (["--windows", "[[0.5, 0.5, 0.2, 0.9]]"], "--windows: window 0")):
        res = CliRunner().invoke(app, ["bench", "detect", "--out", str(tmp_path / "d.json"), *args])
        assert res.exit_code == 2 and said in res.output and "Traceback" not in res.output
        assert not (tmp_path / "d.json").exists()
