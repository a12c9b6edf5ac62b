"""Vectorised per-class non-maximum suppression (numpy)."""

from __future__ import annotations

import numpy as np

#: up to this many boxes, the pairwise overlaps are computed at once (an N x N matrix, a few
#: numpy calls) and the greedy pass only reads it; above it, one box's row at a time.
MATRIX_MAX = 512


def _nms_matrix(
    boxes: np.ndarray, order: np.ndarray, iou_threshold: float, max_det: int, ioa_threshold: float | None,
) -> np.ndarray:
    """``nms`` on ``boxes`` already sorted best first (``order``: their input indices), with the
    same arithmetic as the row-at-a-time loop, so the same boxes are kept."""
    x0, y0, x1, y1 = boxes.T
    area = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    w = np.clip(np.minimum(x1[:, None], x1) - np.maximum(x0[:, None], x0), 0, None)
    h = np.clip(np.minimum(y1[:, None], y1) - np.maximum(y0[:, None], y0), 0, None)
    inter = w * h
    union = area[:, None] + area - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        drop = np.where(union > 0, inter / union, 0.0) > iou_threshold
        if ioa_threshold is not None:
            drop |= np.where(area > 0, inter / area, 0.0) > ioa_threshold  # [i, j]: of j's area
    removed = np.zeros(len(boxes), dtype=bool)
    keep: list[int] = []
    for i in range(len(boxes)):
        if removed[i]:
            continue
        keep.append(i)
        if len(keep) == max_det:
            break
        removed |= drop[i]
    return order[np.asarray(keep, dtype=np.int64)]


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
    order = np.argsort(-scores, kind="stable")
    if n <= MATRIX_MAX:
        return _nms_matrix(boxes[order], order, iou_threshold, max_det, ioa_threshold)
    x0, y0, x1, y1 = boxes.T
    area = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    keep: list[int] = []
    while order.size and len(keep) < max_det:
        i = order[0]
        keep.append(int(i))
        rest = order[1:]
        w = np.clip(np.minimum(x1[i], x1[rest]) - np.maximum(x0[i], x0[rest]), 0, None)
        h = np.clip(np.minimum(y1[i], y1[rest]) - np.maximum(y0[i], y0[rest]), 0, None)
        inter = w * h
        union = area[i] + area[rest] - inter
        with np.errstate(divide="ignore", invalid="ignore"):
            iou = np.where(union > 0, inter / union, 0.0)
        drop = iou > iou_threshold
        if ioa_threshold is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                drop |= np.where(area[rest] > 0, inter / area[rest], 0.0) > ioa_threshold
        order = rest[~drop]
    return np.asarray(keep, dtype=np.int64)
