"""Detector accuracy on a COCO split, through the run-time pipeline (``OnnxDetector``).

Evaluated ground truth: objects of the detection classes (``CLASSES``: the eight road-user
classes and ``obstacle``) at range ``RANGE_M`` (5-50 m)
with visible fraction >= ``MIN_VISIBLE`` (0.5) -- the issue's acceptance set. Every
other labelled object is *don't care*: a detection of it (IoU >= 0.5, whatever the
class, or at least half the detection inside the box of one of its class,
``matching.dont_care_hits``, KITTI's DontCare rule) is neither a true nor a false positive. Matching per image and class is
greedy by score at IoU >= 0.5 (``tools.scoring.matching``; boxes smaller than
``min_size`` px, by default ``MIN_MATCH_SIZE_PX`` = 8, are grown to it first, 0 gives
plain IoU); AP is the all-point interpolated AP of
``tools.scoring.detection.average_precision``.

Reported (``evaluate_split``):

* ``ap50``: mean over classes with evaluated objects; ``ap50_pooled``: one ranked
  list over all classes (class-aware matching), so frequent classes weigh more;
* ``recall_at_p95``: the highest recall at which precision is still >= 0.95 (pooled);
* ``precision`` / ``recall`` at the detector's operating threshold (``conf``);
* ``per_class`` AP50 and recall, and the same with a class-agnostic match
  (``agnostic``: a box of the wrong class still finds the object);
* ``outcomes``: what became of each evaluated object at the operating threshold
  (``gt_outcomes``), per class and per range band (``RANGE_BANDS``): ``found``
  (matched by a box of its class), else ``wrong_class`` (a box of another class at
  IoU >= 0.5), else ``loose`` (some box at IoU >= ``LOOSE_IOU``: found, badly
  boxed), else ``missed`` -- where to look when recall falls short; and per band of
  visible box height (``HEIGHT_BANDS``, px), which tells pixels short from objects hard;
* ``false_positives``: what each false positive is (``fp_kinds``, after TIDE's error
  types: a ``duplicate`` of a found object, the ``wrong_class`` on an object, an object
  ``badly_boxed``, ``wrong_class_and_box``, or ``background`` near no labelled object),
  how many score above ``conf``, and AP50 mean and R@P95 with that kind not counted --
  what removing those errors alone would gain; ``all``: with no false positive at all,
  the ceiling the objects not found leave.

``min_height`` (px, default 0) narrows the evaluation to what is at least that tall, as
KITTI's difficulty rule does (its Moderate and Hard sets start at 25 px): objects with a
shorter visible box are don't care, and so are detections with a shorter box that match
nothing (KITTI's devkit ignores every detection under the height; here one that matches an
evaluated object still finds it, where the devkit drops that object from the count) -- the
accuracy on what a detector can resolve.

Detections are computed at a low score threshold (``AP_CONF``) once; operating-point
figures keep those with score > ``conf``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from lookahead.perception.detections import CLASSES
from lookahead.perception.detectors.onnx_detector import OnnxDetector
from lookahead.tools.detector.data import Split, load_split
from lookahead.tools.scoring.detection import average_precision
from lookahead.tools.scoring.matching import (
    IOU_THRESHOLD,
    MIN_MATCH_SIZE_PX,
    class_iou,
    dont_care_hits,
    greedy_match,
)

log = logging.getLogger(__name__)

RANGE_M = (5.0, 50.0)
MIN_VISIBLE = 0.5
AP_CONF = 0.01
PRECISION_FLOOR = 0.95

TP, FP, IGNORED = 1, 0, -1
OUTCOMES = ("found", "wrong_class", "loose", "missed")
LOOSE_IOU = 0.1
FP_KINDS = ("duplicate", "wrong_class", "badly_boxed", "wrong_class_and_box", "background")
RANGE_BANDS = (5.0, 10.0, 20.0, 30.0, 40.0, 50.0)  # m, band edges
HEIGHT_BANDS = (0.0, 8.0, 12.0, 16.0, 25.0, 40.0, np.inf)  # px, visible box height band edges


def match_image(
    xyxy: np.ndarray, score: np.ndarray, cls: np.ndarray, gt: np.ndarray, gt_cls: np.ndarray,
    evaluated: np.ndarray, agnostic: bool = False, min_size: float = MIN_MATCH_SIZE_PX,
    min_height: float = 0.0,
) -> np.ndarray:
    """Status (M,) of each detection: TP, FP or IGNORED (module docstring); a detection
    shorter than ``min_height`` px is never a false positive."""
    dc, gc = (None, None) if agnostic else (cls, gt_cls)
    order = np.argsort(-score, kind="stable")
    iou = class_iou(xyxy, dc, gt[evaluated], None if gc is None else gc[evaluated], min_size)
    tp = greedy_match(iou, order) >= 0
    ignored = ~tp & dont_care_hits(xyxy, dc, gt[~evaluated], None if gc is None else gc[~evaluated], min_size)
    ignored |= ~tp & (xyxy[:, 3] - xyxy[:, 1] < min_height)
    return np.where(tp, TP, np.where(ignored, IGNORED, FP))


def gt_outcomes(
    xyxy: np.ndarray, score: np.ndarray, cls: np.ndarray, gt: np.ndarray, gt_cls: np.ndarray,
    min_size: float = MIN_MATCH_SIZE_PX,
) -> np.ndarray:
    """Index into ``OUTCOMES`` (K,) of each ground-truth box given the detections kept at
    the operating threshold (module docstring); greedy class-aware matching as for AP."""
    same = class_iou(xyxy, cls, gt, gt_cls, min_size)
    matched = greedy_match(same, np.argsort(-score, kind="stable"))
    found = np.zeros(len(gt), dtype=bool)
    found[matched[matched >= 0]] = True
    iou = class_iou(xyxy, None, gt, None, min_size)
    other = np.where(np.asarray(cls)[:, None] != np.asarray(gt_cls)[None, :], iou, 0.0).max(axis=0, initial=0.0)
    near = iou.max(axis=0, initial=0.0)
    return np.where(found, 0, np.where(other >= IOU_THRESHOLD, 1, np.where(near >= LOOSE_IOU, 2, 3)))


def fp_kinds(
    xyxy: np.ndarray, cls: np.ndarray, status: np.ndarray, gt: np.ndarray, gt_cls: np.ndarray,
    min_size: float = MIN_MATCH_SIZE_PX,
) -> np.ndarray:
    """Index into ``FP_KINDS`` (M,) of each false positive by its best overlap with any labelled
    box (-1 for detections that are not false positives): IoU >= 0.5 with its own class (a
    duplicate: the object was found by a higher score) or another class; else IoU >=
    ``LOOSE_IOU`` with its own class or another; else background."""
    same = class_iou(xyxy, cls, gt, gt_cls, min_size).max(axis=1, initial=0.0)
    near = class_iou(xyxy, None, gt, None, min_size).max(axis=1, initial=0.0)
    kind = np.select([same >= IOU_THRESHOLD, near >= IOU_THRESHOLD, same >= LOOSE_IOU, near >= LOOSE_IOU],
                     [0, 1, 2, 3], default=4)
    return np.where(status == FP, kind, -1)


def _fp_table(status: np.ndarray, kind: np.ndarray, score: np.ndarray, cls: np.ndarray, gt_cls: np.ndarray,
              conf: float) -> dict:
    def without(drop: np.ndarray) -> dict:
        m = _summary(np.where(drop, IGNORED, status), score, cls, gt_cls, conf)
        return {"count": int(np.sum(drop & (score > conf))), "ap50": m["ap50"],
                "recall_at_p95": m["recall_at_p95"]}

    return {**{k: without(kind == i) for i, k in enumerate(FP_KINDS)}, "all": without(status == FP)}


def _outcome_table(outcome: np.ndarray, gt_cls: np.ndarray, gt_range: np.ndarray, gt_height: np.ndarray) -> dict:
    def counts(sel: np.ndarray) -> dict:
        c = np.bincount(outcome[sel], minlength=len(OUTCOMES))
        return {"gt": int(sel.sum()), **{k: int(v) for k, v in zip(OUTCOMES, c, strict=True)}}

    def by_band(values: np.ndarray, edges: Sequence[float]) -> dict:
        band = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, len(edges) - 2)
        return {f"{edges[b]:g}-{edges[b + 1]:g}": counts(band == b) for b in range(len(edges) - 1)}

    by_class = {CLASSES[c]: counts(gt_cls == c) for c in range(len(CLASSES)) if np.any(gt_cls == c)}
    return {"by_class": by_class, "by_range": by_band(gt_range, RANGE_BANDS),
            "by_height": by_band(gt_height, HEIGHT_BANDS)}


def recall_at_precision(score: np.ndarray, is_tp: np.ndarray, n_gt: int, floor: float) -> float:
    """Highest recall over score thresholds at which precision >= ``floor`` (0 when never)."""
    if n_gt == 0 or len(score) == 0:
        return 0.0
    order = np.argsort(-score, kind="stable")
    tp = np.cumsum(is_tp[order])
    prec = tp / np.arange(1, len(order) + 1)
    ok = prec >= floor
    return float(tp[ok].max() / n_gt) if ok.any() else 0.0


def _summary(status: np.ndarray, score: np.ndarray, cls: np.ndarray, gt_cls: np.ndarray,
             conf: float) -> dict:
    counted = status != IGNORED
    per_class: dict[str, dict] = {}
    aps = []
    for c in range(len(CLASSES)):
        n = int(np.sum(gt_cls == c))
        if n == 0:
            continue
        sel = counted & (cls == c)
        ap = average_precision(score[sel], status[sel] == TP, n)
        aps.append(ap)
        op = sel & (score > conf)
        per_class[CLASSES[c]] = {"gt": n, "ap50": round(ap, 4),
                                 "recall": round(float(np.sum(status[op] == TP)) / n, 4)}
    n_gt = len(gt_cls)
    s, t = score[counted], status[counted] == TP
    op = counted & (score > conf)
    tp, fp = int(np.sum(status[op] == TP)), int(np.sum(status[op] == FP))
    return {
        "gt": n_gt,
        "ap50": round(float(np.mean(aps)), 4) if aps else None,
        "ap50_pooled": round(average_precision(s, t, n_gt), 4) if n_gt else None,
        "recall_at_p95": round(recall_at_precision(s, t, n_gt, PRECISION_FLOOR), 4),
        "precision": round(tp / (tp + fp), 4) if tp + fp else None,
        "recall": round(tp / n_gt, 4) if n_gt else None,
        "tp": tp, "fp": fp,
        "per_class": per_class,
    }


def evaluate_split(
    split: Split, detect: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
    conf: float = 0.25, range_m: tuple[float, float] = RANGE_M, min_visible: float = MIN_VISIBLE,
    min_size: float = MIN_MATCH_SIZE_PX, min_height: float = 0.0,
) -> dict:
    """Accuracy of ``detect`` (RGB image -> xyxy, score, class id in image px) on ``split``;
    ``min_size``: boxes grown to at least this many px for IoU (0: plain IoU); ``min_height``:
    objects with a shorter visible box (px), and shorter detections that match none, are don't care."""
    status = {False: [], True: []}
    scores, classes, gt_classes, gt_ranges, gt_heights, outcomes, kinds = [], [], [], [], [], [], []
    for i in range(len(split.images)):
        boxes = split.boxes[i]
        xyxy, score, cls = detect(split.images[i])
        keep = score > AP_CONF
        xyxy, score, cls = xyxy[keep], score[keep], cls[keep]
        rng, vis = split.ranges[i], split.visible[i]
        height = boxes[:, 3] - boxes[:, 1]
        evaluated = (rng >= range_m[0]) & (rng <= range_m[1]) & (vis >= min_visible) & (height >= min_height)
        for agn in (False, True):
            status[agn].append(match_image(xyxy, score, cls, boxes, split.classes[i], evaluated, agn, min_size,
                                           min_height))
        kinds.append(fp_kinds(xyxy, cls, status[False][-1], boxes, split.classes[i], min_size))
        scores.append(score)
        classes.append(cls)
        gt_classes.append(split.classes[i][evaluated])
        gt_ranges.append(rng[evaluated])
        gt_heights.append(height[evaluated])
        op = score > conf
        outcomes.append(gt_outcomes(xyxy[op], score[op], cls[op], boxes[evaluated], split.classes[i][evaluated],
                                    min_size))
    cat = lambda parts, dt: np.concatenate(parts).astype(dt) if parts else np.zeros(0, dt)  # noqa: E731
    score, cls, gt_cls = cat(scores, np.float64), cat(classes, np.int64), cat(gt_classes, np.int64)
    aware = cat(status[False], np.int64)
    result = _summary(aware, score, cls, gt_cls, conf)
    agn = _summary(cat(status[True], np.int64), score, np.zeros_like(cls), np.zeros_like(gt_cls), conf)
    result["agnostic"] = {k: agn[k] for k in ("ap50", "recall_at_p95", "precision", "recall")}
    result["outcomes"] = _outcome_table(cat(outcomes, np.int64), gt_cls, cat(gt_ranges, np.float64),
                                        cat(gt_heights, np.float64))
    result["false_positives"] = _fp_table(aware, cat(kinds, np.int64), score, cls, gt_cls, conf)
    result["images"] = len(split.images)
    result["conf"] = conf
    result["min_box_px"] = min_size
    result["min_height_px"] = min_height
    return result


def onnx_detect(model: str | Path, preprocess=None, windows: Sequence[Sequence[float]] = ()):
    """A ``detect`` callable running ``OnnxDetector`` at ``AP_CONF`` (with an optional
    ``perception.preprocess`` chain in front, and zoom ``windows``)."""
    det = OnnxDetector(model, conf_threshold=AP_CONF, windows=windows)

    def detect(img: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d = det.detect(img if preprocess is None else preprocess(img))
        return d.xyxy, d.score, d.class_id

    return detect


def evaluate_model(
    model: str | Path, split_dir: str | Path, conf: float = 0.25, preprocess=None,
    min_size: float = MIN_MATCH_SIZE_PX, windows: Sequence[Sequence[float]] = (), min_height: float = 0.0,
) -> dict:
    """``evaluate_split`` of an ONNX model run as at run time (``windows``: its zoom windows)."""
    result = evaluate_split(load_split(split_dir), onnx_detect(model, preprocess, windows), conf,
                            min_size=min_size, min_height=min_height)
    result["windows"] = [list(w) for w in windows]
    return result
