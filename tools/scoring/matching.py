"""IoU matching primitives shared by the detection, tracking and estimation scores.

Constants:
    IOU_THRESHOLD = 0.5 -- a prediction matches a ground-truth box when their
        IoU is >= 0.5 (PASCAL VOC / MOTChallenge convention), everywhere in scoring.
    MIN_MATCH_SIZE_PX = 8.0 -- for that IoU both boxes are first grown about their
        centres to at least 8 px wide and high. Boxes that size or larger are scored by
        plain IoU; for smaller ones (a pedestrian seen side-on at 40 m is 2 px wide)
        plain IoU measures pixel quantisation, not detection: a one-pixel shift of a
        2-px box gives IoU 1/3. Growing them turns the test into "centres within a few
        pixels and sizes alike", which is what such a box can show (nuScenes matches
        by centre distance for the same reason). The tracker associates the same way
        (``TrackerConfig.min_match_size``). 0 restores plain IoU.
    DONT_CARE_IOA = 0.5 -- a detection is of a don't-care object (``dont_care_hits``)
        when it matches the object's box, whatever its class (the object's class is not
        scored), or when at least half its area lies inside the box of a don't-care
        object of its class, as KITTI's DontCare rule has it (intersection over the
        detection's area: a car's roof seen over the car in front).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from lookahead.perception.geometry import grow_boxes, ioa_matrix, iou_matrix

IOU_THRESHOLD = 0.5
MIN_MATCH_SIZE_PX = 8.0
DONT_CARE_IOA = 0.5


def _pairs(a: np.ndarray, b: np.ndarray, min_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boxes ``a`` (N, 4) and ``b`` (M, 4) as float, NaN-free and grown to ``min_size`` px, and the
    (N, M) mask of pairs of finite boxes."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    finite = np.all(np.isfinite(a), axis=1)[:, None] & np.all(np.isfinite(b), axis=1)[None, :]
    a, b = np.nan_to_num(a), np.nan_to_num(b)
    if min_size > 0:
        a, b = grow_boxes(a, min_size), grow_boxes(b, min_size)
    return a, b, finite


def _pair_mask(
    finite: np.ndarray, a_cls: np.ndarray | None, b_cls: np.ndarray | None, any_class: np.ndarray | None = None,
) -> np.ndarray:
    """The (N, M) mask of ``finite`` pairs that may match: when both class arrays are given,
    of one class -- or, in the columns ``any_class`` (M,) marks, with ``b`` of any detection
    class (``b_cls`` >= 0), whatever the class of ``a``."""
    if a_cls is None or b_cls is None:
        return finite
    b_cls = np.asarray(b_cls)
    ok = np.asarray(a_cls)[:, None] == b_cls[None, :]
    if any_class is not None:
        ok |= (np.asarray(any_class, dtype=bool) & (b_cls >= 0))[None, :]
    return finite & ok


def class_iou(
    a: np.ndarray, a_cls: np.ndarray | None, b: np.ndarray, b_cls: np.ndarray | None,
    min_size: float = MIN_MATCH_SIZE_PX, any_class: np.ndarray | None = None,
) -> np.ndarray:
    """IoU (N, M) of xyxy boxes ``a`` (N, 4) and ``b`` (M, 4), each grown to at least
    ``min_size`` px (see ``MIN_MATCH_SIZE_PX``); 0 where a box is NaN or, when both
    class arrays are given, where the classes differ -- except in the columns ``any_class``
    (M,) marks (don't-care objects, whose class is out of scope with them), where any box
    of a detection class matches."""
    a, b, finite = _pairs(a, b, min_size)
    return np.where(_pair_mask(finite, a_cls, b_cls, any_class), iou_matrix(a, b), 0.0)


def dont_care_hits(
    a: np.ndarray, a_cls: np.ndarray | None, b: np.ndarray, b_cls: np.ndarray | None,
    min_size: float = MIN_MATCH_SIZE_PX,
) -> np.ndarray:
    """(N,) mask of boxes ``a`` that are of one of the don't-care boxes ``b`` (module docstring):
    IoU >= ``IOU_THRESHOLD`` with one of a detection class, whatever the class of ``a``, or
    at least ``DONT_CARE_IOA`` of the box inside one of its own class (any, without classes).
    Boxes are grown to ``min_size`` px first."""
    a, b, finite = _pairs(a, b, min_size)
    matches = _pair_mask(finite, a_cls, b_cls, np.ones(len(b), dtype=bool)) & (iou_matrix(a, b) >= IOU_THRESHOLD)
    inside = _pair_mask(finite, a_cls, b_cls) & (ioa_matrix(a, b) >= DONT_CARE_IOA)
    return np.any(matches | inside, axis=1)


def greedy_match(iou: np.ndarray, order: np.ndarray, threshold: float = IOU_THRESHOLD) -> np.ndarray:
    """Greedy matching of predictions (rows of ``iou``) visited in ``order`` (best
    score first): each takes the free column with the highest IoU >= ``threshold``.

    Returns:
        (N,) matched column per row, -1 if unmatched.
    """
    n, m = iou.shape
    match = np.full(n, -1, dtype=np.int64)
    if m == 0:
        return match
    free = np.ones(m, dtype=bool)
    for i in order:
        cand = np.where(free & (iou[i] >= threshold), iou[i], -1.0)
        j = int(np.argmax(cand))
        if cand[j] >= threshold:
            match[i] = j
            free[j] = False
    return match


def hungarian_match(
    iou: np.ndarray, threshold: float = IOU_THRESHOLD
) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one matching maximising the summed IoU over pairs with IoU >= ``threshold``.

    Returns:
        (rows, cols) of the matched pairs.
    """
    if iou.size == 0:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    gain = np.where(iou >= threshold, iou, 0.0)
    rows, cols = linear_sum_assignment(gain, maximize=True)
    keep = gain[rows, cols] > 0.0
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)
