"""Vectorised per-class non-maximum suppression (numpy)."""

from __future__ import annotations

import numpy as np

#: up to this many boxes, the pairwise overlaps are computed at once (an N x N matrix, a few
#: numpy calls) and the greedy pass only reads it; above it, one kept box's row at a time.
MATRIX_MAX = 512


def _suppresses(
    corners: tuple[np.ndarray, ...], area: np.ndarray, i: np.ndarray | int, j: np.ndarray,
    iou_threshold: float, ioa_threshold: float | None,
) -> np.ndarray:
    """Whether box ``i`` suppresses box ``j`` (indices broadcast: one row, or (N, 1) against
    (N,) for every pair): IoU above ``iou_threshold``, or, with ``ioa_threshold``, more than
    that fraction of ``j``'s area inside ``i``."""
    x0, y0, x1, y1 = corners
    w = np.clip(np.minimum(x1[i], x1[j]) - np.maximum(x0[i], x0[j]), 0, None)
    h = np.clip(np.minimum(y1[i], y1[j]) - np.maximum(y0[i], y0[j]), 0, None)
    inter = w * h
    union = area[i] + area[j] - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        drop = np.where(union > 0, inter / union, 0.0) > iou_threshold
        if ioa_threshold is not None:
            drop |= np.where(area[j] > 0, inter / area[j], 0.0) > ioa_threshold
    return drop


def nms(
    xyxy: np.ndarray,
    score: np.ndarray,
    class_id: np.ndarray | None = None,
    iou_threshold: float = 0.45,
    max_det: int = 300,
    ioa_threshold: float | None = None,
) -> np.ndarray:
    """Greedy per-class NMS; returns kept indices, highest score first.

    A box is suppressed when its IoU with a higher-scoring kept box of the same
    class is strictly greater than ``iou_threshold`` (torchvision convention), or, with
    ``ioa_threshold``, when more than that fraction of its own area lies inside one (a
    part of an object -- a cow's head or legs -- found beside the whole).
    Classes are separated with the offset trick: each class's boxes are shifted
    by ``class_index * span`` so boxes of different classes never overlap. Ties in
    score keep the lower index first (stable sort), so results are deterministic.

    Args:
        xyxy: (N, 4) boxes, float pixels.
        score: (N,) scores.
        class_id: (N,) integer classes; None = class-agnostic.
        iou_threshold: IoU above which a lower-scoring box is dropped.
        max_det: at most this many indices are returned.
        ioa_threshold: fraction of a lower-scoring box's area inside a kept box above which
            it is dropped too; None: IoU only.

    Returns:
        (K,) int64 indices into the inputs, K <= max_det.
    """
    boxes = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(score, dtype=np.float64).reshape(-1)
    n = len(boxes)
    if n == 0 or max_det <= 0:
        return np.zeros(0, dtype=np.int64)
    if class_id is not None:
        cls = np.asarray(class_id).reshape(-1)
        _, dense = np.unique(cls, return_inverse=True)
        lo = boxes.min()
        span = boxes.max() - lo + 1.0
        boxes = boxes - lo + (dense.astype(np.float64) * span)[:, None]
    corners = tuple(boxes.T)
    x0, y0, x1, y1 = corners
    area = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    order = np.argsort(-scores, kind="stable")
    keep: list[int] = []
    if n <= MATRIX_MAX:  # every pair at once; the greedy pass only reads the matrix
        drop = _suppresses(corners, area, order[:, None], order, iou_threshold, ioa_threshold)
        removed = np.zeros(n, dtype=bool)
        for r in range(n):
            if removed[r]:
                continue
            keep.append(int(order[r]))
            if len(keep) == max_det:
                break
            removed |= drop[r]
        return np.asarray(keep, dtype=np.int64)
    while order.size and len(keep) < max_det:  # one row at a time
        i = order[0]
        keep.append(int(i))
        rest = order[1:]
        order = rest[~_suppresses(corners, area, i, rest, iou_threshold, ioa_threshold)]
    return np.asarray(keep, dtype=np.int64)
