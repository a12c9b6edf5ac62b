"""Per-class NMS against a plain greedy reference."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.geometry import iou_matrix
from lookahead.perception.nms import nms


def _reference(xyxy, score, cls, thr, max_det):
    order = sorted(range(len(score)), key=lambda i: (-score[i], i))
    iou = iou_matrix(xyxy, xyxy)
    keep: list[int] = []
    for i in order:
        if all(cls[i] != cls[k] or iou[i, k] <= thr for k in keep):
            keep.append(i)
    return keep[:max_det]


def _clustered(rng: np.random.Generator, n: int) -> np.ndarray:
    centres = rng.uniform(0, 600, (8, 2))
    c = centres[rng.integers(0, 8, n)] + rng.normal(0, 6, (n, 2))
    wh = rng.uniform(20, 80, (n, 2))
    return np.concatenate([c - wh / 2, c + wh / 2], axis=1)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("thr", [0.3, 0.5, 0.7])
def test_matches_greedy_reference(seed: int, thr: float) -> None:
    rng = np.random.default_rng(seed)
    n = 150
    xyxy, score, cls = _clustered(rng, n), rng.random(n), rng.integers(0, 3, n)
    got = nms(xyxy, score, cls, thr, 300)
    assert got.dtype == np.int64
    assert got.tolist() == _reference(xyxy, score, cls, thr, 300)


def test_other_class_overlap_kept_and_agnostic_mode() -> None:
    xyxy = np.array([[0, 0, 10, 10], [0, 0, 10, 10], [1, 0, 11, 10]], dtype=float)
    score = np.array([0.9, 0.8, 0.7])
    cls = np.array([0, 1, 0])
    assert nms(xyxy, score, cls, 0.5, 10).tolist() == [0, 1]
    assert nms(xyxy, score, None, 0.5, 10).tolist() == [0]


def test_threshold_is_strict_and_max_det() -> None:
    xyxy = np.array([[0, 0, 10, 10], [5, 0, 15, 10]], dtype=float)  # IoU = 50/150 = 1/3
    score = np.array([0.9, 0.8])
    assert nms(xyxy, score, np.zeros(2), 1 / 3, 10).tolist() == [0, 1]
    assert nms(xyxy, score, np.zeros(2), 0.33, 10).tolist() == [0]
    boxes = np.arange(10)[:, None] * [100.0, 0.0, 100.0, 0.0] + [0.0, 0.0, 50.0, 50.0]
    assert nms(boxes, np.linspace(0.1, 1, 10), None, 0.5, 3).tolist() == [9, 8, 7]


def test_empty_and_ties() -> None:
    assert nms(np.zeros((0, 4)), np.zeros(0), np.zeros(0), 0.5, 10).shape == (0,)
    xyxy = np.array([[0, 0, 10, 10]] * 3, dtype=float)
    assert nms(xyxy, np.full(3, 0.5), np.zeros(3), 0.5, 10).tolist() == [0]


def test_a_part_inside_a_better_box_of_its_class_is_dropped_with_a_containment_threshold():
    cow = [300.0, 170.0, 340.0, 190.0]
    head = [332.0, 170.0, 340.0, 182.0]  # all inside the cow, IoU 0.12
    dog = [332.0, 170.0, 340.0, 182.0]  # the same box, another class
    xyxy = np.array([cow, head, dog])
    score, cls = np.array([0.7, 0.5, 0.4]), np.array([7, 7, 0])
    assert nms(xyxy, score, cls, 0.45).tolist() == [0, 1, 2]
    assert nms(xyxy, score, cls, 0.45, ioa_threshold=0.8).tolist() == [0, 2]
    # the part scoring higher than the whole keeps both: the whole is not inside the part
    assert nms(xyxy, np.array([0.4, 0.5, 0.4]), cls, 0.45, ioa_threshold=0.8).tolist() == [1, 0, 2]


@pytest.mark.parametrize("seed", range(3))
def test_the_matrix_and_the_row_at_a_time_passes_keep_the_same_boxes(seed: int, monkeypatch) -> None:
    import lookahead.perception.nms as nms_module

    rng = np.random.default_rng(seed)
    n = 300
    xyxy, score, cls = _clustered(rng, n), rng.random(n).round(2), rng.integers(0, 3, n)  # rounded: ties
    for ioa in (None, 0.8):
        matrix = nms(xyxy, score, cls, 0.45, 100, ioa)
        with monkeypatch.context() as m:
            m.setattr(nms_module, "MATRIX_MAX", 0)
            rows = nms(xyxy, score, cls, 0.45, 100, ioa)
        assert matrix.tolist() == rows.tolist()
    assert nms(xyxy, score, cls, 0.45, 300).tolist() == _reference(xyxy, score, cls, 0.45, 300)


def test_many_boxes_take_the_row_at_a_time_pass_and_match_the_reference() -> None:
    from lookahead.perception.nms import MATRIX_MAX

    rng = np.random.default_rng(7)
    n = MATRIX_MAX + 100
    xyxy, score, cls = _clustered(rng, n), rng.random(n), rng.integers(0, 3, n)
    assert nms(xyxy, score, cls, 0.5, 300).tolist() == _reference(xyxy, score, cls, 0.5, 300)
