"""The ``tracking`` section of ``metrics.json``: CLEAR (MOTA, MOTP), IDF1 and HOTA via TrackEval.

Inputs, per frame (MOT frame = position in ``ticks.jsonl`` + 1):
    ground truth -- the *evaluated* GT of ``tools.scoring.detection`` (visible box,
        class >= 0, visible fraction >= 0.5, height >= 10 px), id = ``actor_id``;
    tracker -- every track the system reports: state ``confirmed`` or ``lost``
        (a coasting track the tracker still outputs, ``TrackerConfig.output_lost``;
        it is scored like any other, so a coasting box that drifts off its object
        is a false positive). Tentative tracks are never output, hence never scored.
Don't-care GT (visible but not evaluated) is removed, and so is every reported
track that a one-to-one Hungarian matching (IoU >= 0.5; same class with evaluated GT,
any class with don't-care GT of a detection class, ``matching.class_iou``'s ``any_class``) pairs
with a don't-care GT box -- TrackEval's MOT16 distractor rule, done here before calling
``tools.scoring.mot_eval.evaluate_mot`` (which then runs with its preprocessing off).

Matching is class-aware: a track only matches GT of its own class. This is done
by shifting each box ``class_id * CLASS_SHIFT_PX`` (1e5 px) along x, so boxes of
different classes never overlap; IoU and MOTP are shift-invariant.

Metrics are TrackEval's, with IoU threshold 0.5 for CLEAR/Identity and HOTA
averaged over thresholds 0.05..0.95; every IoU here grows boxes under 8 px to that
size first (``matching.MIN_MATCH_SIZE_PX``). ``mota``, ``idf1`` and ``hota`` are null when
there is no evaluated GT (``n`` = 0), ``motp`` when nothing matched. Without
tracks in the run every metric is null and ``n`` = 0.
"""

from __future__ import annotations

import numpy as np

from lookahead.tools.scoring.detection import gt_selection
from lookahead.tools.scoring.io import GTFrame, RunData, TrackFrame
from lookahead.tools.scoring.matching import MIN_MATCH_SIZE_PX, class_iou, hungarian_match
from lookahead.tools.scoring.mot_eval import evaluate_mot

CLASS_SHIFT_PX = 1e5

_REPORTED = (
    "mota", "motp", "idf1", "hota", "id_switches", "fragmentations", "mostly_tracked",
    "partially_tracked", "mostly_lost", "fp", "fn", "tp", "num_gt_ids", "num_tracker_ids",
)
_NULL_WITHOUT_GT = ("mota", "idf1", "hota")


def frame_rows(frame: int, gt: GTFrame, tracks: TrackFrame) -> tuple[np.ndarray, np.ndarray, int]:
    """MOT rows ``frame, id, x, y, w, h, conf`` of one frame's GT and kept tracks.

    Returns:
        (GT rows (G, 7), track rows (K, 7), number of tracks dropped on don't-care GT).
    """
    evaluated, dont_care = gt_selection(gt)
    trk = tracks[tracks.reported]
    shown = evaluated | dont_care
    iou = class_iou(trk.xyxy, trk.class_id, gt.visible[shown], gt.class_id[shown], any_class=dont_care[shown])
    rows, cols = hungarian_match(iou)
    on_dont_care = rows[dont_care[shown][cols]]
    keep = np.ones(len(trk.track_id), dtype=bool)
    keep[on_dont_care] = False
    g_rows = _rows(frame, gt.actor_id[evaluated], gt.visible[evaluated], gt.class_id[evaluated])
    t_rows = _rows(frame, trk.track_id[keep], trk.xyxy[keep], trk.class_id[keep])
    return g_rows, t_rows, len(on_dont_care)


def _rows(frame: int, ids: np.ndarray, xyxy: np.ndarray, cls: np.ndarray) -> np.ndarray:
    x = xyxy[:, 0] + cls * CLASS_SHIFT_PX
    wh = xyxy[:, 2:] - xyxy[:, :2]
    return np.column_stack([np.full(len(ids), frame), ids, x, xyxy[:, 1], wh, np.ones(len(ids))])


def null_tracking() -> dict:
    """The section when the run has no tracks."""
    return {**dict.fromkeys(_REPORTED), "dont_care_tracks": None, "n": 0}


def evaluate_tracking(run: RunData) -> dict:
    """The ``tracking`` section (module docstring); ``n`` = evaluated GT boxes."""
    if run.tracks is None or len(run) == 0:
        return null_tracking()
    gt_parts, trk_parts, dropped = [], [], 0
    for i, (gt, trk) in enumerate(zip(run.gt, run.tracks, strict=True)):
        g, t, d = frame_rows(i + 1, gt, trk)
        gt_parts.append(g)
        trk_parts.append(t)
        dropped += d
    m = evaluate_mot(
        np.concatenate(gt_parts), np.concatenate(trk_parts),
        num_frames=len(run), mot16_preprocess=False, min_box=MIN_MATCH_SIZE_PX,
    )
    out: dict = {k: m[k] for k in _REPORTED}
    if m["num_gt_dets"] == 0:
        out.update(dict.fromkeys(_NULL_WITHOUT_GT))
    if m["tp"] == 0:
        out["motp"] = None
    out["dont_care_tracks"] = dropped
    out["n"] = m["num_gt_dets"]
    return out
