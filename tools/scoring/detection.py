"""The ``detection`` section of ``metrics.json``: precision, recall and AP50 per class.

Which ground truth counts (per frame, on the GT *visible* box):
    evaluated  -- visible box present, ``class_id >= 0`` (-1, no detection class: obstacles in
                  runs recorded before they became one), ``visible_fraction >= MIN_VISIBLE_FRACTION``
                  (0.5) and visible box height ``>= MIN_BOX_HEIGHT_PX`` (10 px);
    don't care -- visible but failing one of those; a detection that matches no
                  evaluated GT but is of a don't-care GT -- IoU >= 0.5 with one of
                  any detection class (its class is out of scope with it), or at
                  least half of it inside the box of one of its own class
                  (``matching.dont_care_hits``) -- is ignored (neither TP nor FP;
                  any number of them, as KITTI's DontCare regions);
    invisible GT (no visible box) is neither.

Matching: per frame, detections in descending score order each take the unmatched
evaluated GT box of the same class with the highest IoU >= ``IOU_THRESHOLD`` (0.5)
(COCO-style greedy); boxes under 8 px wide or high are grown to 8 px for the IoU
(``matching.MIN_MATCH_SIZE_PX``). Unmatched, non-ignored detections are false positives;
duplicates of a matched GT are false positives.

Precision / recall are at the detector's operating point (every detection in
``ticks.jsonl``). ``ap50`` per class is the all-point interpolated average
precision (PASCAL VOC 2010+ / COCO without the 101-point sampling) of the
score-ranked detections of all frames; ties keep frame order. The overall
``ap50`` is the mean over classes with evaluated GT; a class with GT and no
detection scores 0. A class with detections but no GT has ``ap50``/``recall``
null. Overall precision and recall are micro-averaged (summed TP, FP, GT).
"""

from __future__ import annotations

import numpy as np

from lookahead.perception.detections import CLASSES
from lookahead.tools.scoring.io import DetFrame, GTFrame, RunData
from lookahead.tools.scoring.matching import class_iou, dont_care_hits, greedy_match

MIN_VISIBLE_FRACTION = 0.5
MIN_BOX_HEIGHT_PX = 10.0

TP, FP, IGNORED = 1, 0, -1


def class_name(class_id: int) -> str:
    """Detection class name of ``class_id`` (``class_<id>`` outside ``CLASSES``)."""
    return CLASSES[class_id] if 0 <= class_id < len(CLASSES) else f"class_{class_id}"


def gt_selection(gt: GTFrame) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks (N,) of evaluated and don't-care ground truth (module docstring)."""
    box = gt.visible
    visible = np.all(np.isfinite(box), axis=1)
    with np.errstate(invalid="ignore"):
        height = box[:, 3] - box[:, 1]
        visible &= (box[:, 2] > box[:, 0]) & (height > 0)
        evaluated = (
            visible
            & (gt.class_id >= 0)
            & (gt.visible_fraction >= MIN_VISIBLE_FRACTION)
            & (height >= MIN_BOX_HEIGHT_PX)
        )
    return evaluated, visible & ~evaluated


def match_frame(dets: DetFrame, gt: GTFrame) -> np.ndarray:
    """Status (M,) of each detection of one frame: ``TP``, ``FP`` or ``IGNORED``."""
    evaluated, dont_care = gt_selection(gt)
    iou = class_iou(dets.xyxy, dets.class_id, gt.visible[evaluated], gt.class_id[evaluated])
    order = np.argsort(-dets.score, kind="stable")
    matched = greedy_match(iou, order) >= 0
    ignored = ~matched & dont_care_hits(dets.xyxy, dets.class_id, gt.visible[dont_care], gt.class_id[dont_care])
    return np.where(matched, TP, np.where(ignored, IGNORED, FP))


def average_precision(score: np.ndarray, is_tp: np.ndarray, n_gt: int) -> float:
    """All-point interpolated AP of ranked detections (``score`` (M,), ``is_tp`` (M,) bool)."""
    order = np.argsort(-score, kind="stable")
    tp = np.cumsum(is_tp[order])
    fp = np.cumsum(~is_tp[order])
    recall = tp / n_gt
    precision = tp / np.maximum(tp + fp, 1)
    mrec = np.concatenate([[0.0], recall, [1.0]])
    mpre = np.concatenate([[0.0], precision, [0.0]])
    mpre = np.maximum.accumulate(mpre[::-1])[::-1]
    step = np.nonzero(mrec[1:] != mrec[:-1])[0]
    return float(np.sum((mrec[step + 1] - mrec[step]) * mpre[step + 1]))


def _cat(parts: list[np.ndarray], dtype: type) -> np.ndarray:
    return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)


def _ratio(num: int, den: int) -> float | None:
    return num / den if den > 0 else None


def evaluate_detection(run: RunData) -> dict:
    """The ``detection`` section: precision, recall, ap50, per_class, gt, tp, fp, ignored."""
    status, score, cls, gt_cls = [], [], [], []
    for dets, gt in zip(run.dets, run.gt, strict=True):
        status.append(match_frame(dets, gt))
        score.append(dets.score)
        cls.append(dets.class_id)
        gt_cls.append(gt.class_id[gt_selection(gt)[0]])
    status, score = _cat(status, np.int64), _cat(score, np.float64)
    cls, gt_cls = _cat(cls, np.int64), _cat(gt_cls, np.int64)
    counted = status != IGNORED
    per_class: dict[str, dict] = {}
    aps = []
    for c in np.union1d(gt_cls, cls[counted]):
        sel = counted & (cls == c)
        n_gt = int(np.sum(gt_cls == c))
        tp, fp = int(np.sum(status[sel] == TP)), int(np.sum(status[sel] == FP))
        ap = average_precision(score[sel], status[sel] == TP, n_gt) if n_gt else None
        if ap is not None:
            aps.append(ap)
        per_class[class_name(int(c))] = {
            "precision": _ratio(tp, tp + fp),
            "recall": _ratio(tp, n_gt),
            "ap50": ap,
            "gt": n_gt,
            "tp": tp,
            "fp": fp,
        }
    tp, fp, n_gt = int(np.sum(status == TP)), int(np.sum(status == FP)), len(gt_cls)
    return {
        "precision": _ratio(tp, tp + fp),
        "recall": _ratio(tp, n_gt),
        "ap50": float(np.mean(aps)) if aps else None,
        "per_class": per_class,
        "gt": n_gt,
        "tp": tp,
        "fp": fp,
        "ignored": int(np.sum(~counted)),
        "frames": len(run),
    }
