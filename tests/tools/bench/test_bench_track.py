"""``tools.bench.track``: our tracker vs deep-sort-realtime on the same detections.

One reduced run (one MOT15 sequence, one short scenario, one repeat) checks the
JSON shape, that both trackers were fed identical inputs, and that the accuracy
numbers are finite. No timing assertions: speed targets are the benchmark's job.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from lookahead.perception.detections import Detections
from lookahead.tools import cli
from lookahead.tools.bench.track import (
    DEEPSORT_EMBED_DIM,
    SIM_SCENARIOS,
    TRACKERS,
    bench_track,
    deepsort_inputs,
)

MOT_SEQ = "TUD-Campus"
SCENARIO = next(p for p in SIM_SCENARIOS if p.stem == "cut_in")


@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("bench") / "sub" / "track.json"
    result = bench_track(out, repeats=1, mot_sequences=(MOT_SEQ,), scenarios=(SCENARIO,))
    return result, out


def test_json_written_and_shaped(bench: tuple[dict, Path]) -> None:
    result, out = bench
    assert json.loads(out.read_text()) == json.loads(json.dumps(result))
    assert {"machine", "cases", "ratios", "accuracy"} <= set(result)
    assert result["machine"]["python"]
    seqs = set(result["sequences"])
    assert seqs == {MOT_SEQ, "cut_in"}
    expected_cases = set(TRACKERS) | {f"{t}/{s}" for t in TRACKERS for s in seqs}
    assert set(result["cases"]) == expected_cases
    for c in result["cases"].values():
        assert set(c) >= {"ms_median", "ms_p95", "n"}
        assert c["n"] > 0 and c["ms_median"] >= 0 and c["ms_p95"] >= c["ms_median"]
    ratio = result["ratios"]["fps_over_deepsort"]
    assert math.isfinite(ratio) and ratio > 0
    assert result["sequences"][MOT_SEQ]["source"] == "mot15"
    assert result["sequences"]["cut_in"]["source"] == "sim"


def test_both_trackers_fed_identical_inputs(bench: tuple[dict, Path]) -> None:
    result, _ = bench
    inputs = result["inputs"]
    assert inputs["ours"] == inputs["deepsort"]
    for name, seq in result["sequences"].items():
        assert inputs["ours"][name] == {"frames": seq["frames"], "detections": seq["detections"]}
        assert seq["frames"] > 0 and seq["detections"] > 0
        n = {result["cases"][f"{t}/{name}"]["n"] for t in TRACKERS}
        assert n == {seq["frames"]}  # one timing sample per frame per tracker, repeats=1
    assert result["sequences"][MOT_SEQ]["frames"] == 71  # seqinfo length, empty frames included


def test_accuracy_finite(bench: tuple[dict, Path]) -> None:
    result, _ = bench
    acc = result["accuracy"]
    assert set(acc) == set(TRACKERS)
    for t in TRACKERS:
        assert set(acc[t]) == set(result["sequences"])
        for m in acc[t].values():
            assert math.isfinite(m["mota"]) and m["mota"] <= 1.0
            assert math.isfinite(m["idf1"]) and 0.0 <= m["idf1"] <= 1.0
        for pooled in result["accuracy_pooled"][t].values():
            assert math.isfinite(pooled["mota"]) and math.isfinite(pooled["idf1"])


def test_sort_reference_accuracy(bench: tuple[dict, Path]) -> None:
    """SORT's accuracy is in the JSON for the MOT15 sequences; ours matches or beats it there."""
    result, _ = bench
    ref = result["sort_reference"]
    assert set(ref["accuracy"]) == {MOT_SEQ}  # MOT15 only
    assert set(ref["accuracy_pooled"]) == {"mot15"}
    sort, ours = ref["accuracy"][MOT_SEQ], result["accuracy"]["ours"][MOT_SEQ]
    assert result["sequences"][MOT_SEQ]["frame_rate"] == 25.0  # from its seqinfo.ini
    for key in ("mota", "idf1", "hota"):
        assert math.isfinite(sort[key]) and ours[key] >= sort[key], (key, ours, sort)
    assert ref["accuracy_pooled"]["mot15"] == {k: sort[k] for k in ("mota", "idf1")}


def test_deepsort_inputs_match_detections() -> None:
    dets = Detections(
        xyxy=np.array([[10.0, 20.0, 30.0, 60.0], [0.0, 0.0, 5.0, 5.0]]),
        score=np.array([0.9, 0.2]),
        class_id=np.array([0, 4]),
    )
    raw, embeds = deepsort_inputs(dets)
    assert [r[0] for r in raw] == [[10.0, 20.0, 20.0, 40.0], [0.0, 0.0, 5.0, 5.0]]
    assert [r[1] for r in raw] == pytest.approx([0.9, 0.2])
    assert [r[2] for r in raw] == [0, 4]
    assert len(embeds) == 2 and all(e.shape == (DEEPSORT_EMBED_DIM,) for e in embeds)
    assert all(np.linalg.norm(e) == pytest.approx(1.0) for e in embeds)
    assert deepsort_inputs(Detections()) == ([], [])


def test_print_track_bench(bench: tuple[dict, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    result, _ = bench
    buf = io.StringIO()
    monkeypatch.setattr(cli, "console", Console(file=buf, width=160))
    cli.print_track_bench(result, TRACKERS)
    text = buf.getvalue()
    assert "fps_over_deepsort" in text and MOT_SEQ in text and "cut_in" in text
    assert "sort MOTA" in text
