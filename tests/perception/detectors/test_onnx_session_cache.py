"""Shared onnxruntime sessions (``onnx_detector.load_session``): one load per model file version
and options per process, detectors and embedders keep their own state, a rewritten file reloads."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from support.onnx_models import constant_output_model

from lookahead.perception.detectors import OnnxDetector
from lookahead.perception.detectors import onnx_detector as od
from lookahead.perception.embedder import AppearanceEmbedder

S = 64
IMAGE = np.zeros((48, 64, 3), dtype=np.uint8)
NAMES = "{0: 'car', 1: 'pedestrian'}"
CPU = ["CPUExecutionProvider"]


def v8_model(path: Path, score: float, x0: float = 10.0) -> Path:
    """A [1, 4+2, 3] yolov8 model with one car box (x0..x0+20, 10..30 input px) of ``score``;
    the same file size whatever ``score`` and ``x0``."""
    out = np.zeros((1, 6, 3), dtype=np.float32)
    out[0, :5, 0] = [x0 + 10, 20, 20, 20, score]
    return constant_output_model(path, out, [1, 3, S, S], {"names": NAMES})


@pytest.fixture(autouse=True)
def _fresh_cache():
    od.clear_sessions()
    yield
    od.clear_sessions()


def test_detectors_of_one_file_share_the_session_not_their_state(tmp_path: Path) -> None:
    path = v8_model(tmp_path / "m.onnx", 0.9)
    a = OnnxDetector(path, conf_threshold=0.5)
    b = OnnxDetector(Path(os.path.relpath(path)), conf_threshold=0.95)  # the same file by another name
    assert a is not b and a.session is b.session
    da = a.detect(IMAGE)
    assert len(da) == 1 and da.score[0] == pytest.approx(0.9)
    assert len(b.detect(IMAGE)) == 0  # its own threshold
    c = OnnxDetector(path, conf_threshold=0.5)
    dc = c.detect(IMAGE)
    np.testing.assert_array_equal(dc.xyxy, da.xyxy)
    np.testing.assert_array_equal(dc.score, da.score)
    assert c.session is a.session and a.last_timing_ms and c.last_timing_ms is not a.last_timing_ms


def test_a_rewritten_file_gets_a_new_session(tmp_path: Path) -> None:
    path = v8_model(tmp_path / "m.onnx", 0.9)
    first = OnnxDetector(path)
    size = path.stat().st_size
    v8_model(path, 0.6, x0=20.0)  # rewritten in place at once: the same size, maybe the same times
    assert path.stat().st_size == size
    second = OnnxDetector(path)
    assert second.session is not first.session
    d1, d2 = first.detect(IMAGE), second.detect(IMAGE)
    assert d1.score[0] == pytest.approx(0.9) and d2.score[0] == pytest.approx(0.6)
    assert d2.xyxy[0, 0] - d1.xyxy[0, 0] == pytest.approx(10.0)
    assert OnnxDetector(path).session is second.session


def test_options_are_part_of_the_key_and_the_cache_is_bounded(tmp_path: Path) -> None:
    path = v8_model(tmp_path / "m.onnx", 0.9)
    one = od.load_session(path, CPU, intra_op_threads=1)
    assert od.load_session(path, CPU, intra_op_threads=1) is one
    assert od.load_session(path, CPU, intra_op_threads=2) is not one
    od.clear_sessions()
    paths = [v8_model(tmp_path / f"m{i}.onnx", 0.5) for i in range(od.SESSION_CACHE_SIZE + 1)]
    sessions = [od.load_session(p, CPU) for p in paths]
    assert len(od._sessions) == od.SESSION_CACHE_SIZE
    assert od.load_session(paths[-1], CPU) is sessions[-1]
    assert od.load_session(paths[0], CPU) is not sessions[0]  # least recently used: dropped


def test_file_identity_hashes_only_young_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = v8_model(tmp_path / "m.onnx", 0.9)
    assert len(od.file_identity(path)) == 6  # just written: its SHA-256 too
    monkeypatch.setattr(od, "RACY_S", 0.0)
    ident = od.file_identity(path)
    assert len(ident) == 5 and ident[2] == path.stat().st_size


def test_a_missing_or_broken_file_is_one_line_and_not_cached(tmp_path: Path) -> None:
    with pytest.raises(od.ModelError, match="cannot read model file"):
        od.load_session(tmp_path / "none.onnx", CPU)
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a model")
    with pytest.raises(od.ModelError, match="not a loadable ONNX model"):
        od.load_session(bad, CPU)
    assert not od._sessions


def test_embedders_share_the_shipped_session() -> None:
    a, b = AppearanceEmbedder(), AppearanceEmbedder()
    assert a.session is b.session and AppearanceEmbedder(threads=2).session is not a.session
    boxes = np.array([[4.0, 4.0, 40.0, 44.0]])
    np.testing.assert_array_equal(a.embed(IMAGE, boxes), b.embed(IMAGE, boxes))
