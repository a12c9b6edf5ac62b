"""The ``estimation`` section of ``metrics.json``: range, velocity and TTC errors of tracks.

Matching, per frame: reported tracks (confirmed or lost/coasting, as in
``tracking``) vs every GT with a visible box, one-to-one Hungarian on IoU of
track xyxy vs GT visible box, pairs with IoU >= 0.5 kept. Class-agnostic: the
geometry of whatever a track follows is scored even if its class is wrong
(classification is scored by ``detection``).

Initializing tracks are don't-care: a pair whose track is still
``initializing`` (the intent label of that track row in ``ticks.jsonl``, i.e.
younger than ``IntentConfig.init_frames`` frames; ``age < init_frames`` when a
run has no assessments) is matched -- so it still claims its GT box -- but not
scored. This is the architecture's rule for labels ("GT frames where a
prediction can't yet exist are don't-care"): a track's velocity, and so its
TTC, needs a few frames to exist, and the system flags those frames itself.
Nothing else is skipped; coasting tracks are scored.

Errors over the matched pairs (each metric with its count ``n_*``; a metric is
null when its set is empty; null estimates are left out of the set):
    range_rel_err_median -- median |r_hat - r| / r, r = GT range (nearest point x, m),
        over *unoccluded* GT (visible_fraction >= UNOCCLUDED_MIN_VISIBLE_FRACTION
        = 0.9, truncation < UNOCCLUDED_MAX_TRUNCATION = 0.05) at
        RANGE_MIN_M <= r <= RANGE_MAX_M (5..50 m);
    range_abs_err_p90 -- 90th percentile (linear interpolation) of |r_hat - r| (m),
        same set;
    speed_err_median -- median |g_hat - g| (m/s), Euclidean norm of the difference
        of the ground-velocity vectors (ego axes), all pairs;
    ttc_err_median -- median |TTC_hat - TTC| / TTC over pairs with
        0 < GT TTC < TTC_MAX_S (5 s); a predicted "never" counts as the large finite
        ``NEVER`` (1e9 s) it is written as (decoded to inf, clipped back here).
    ettc_err_median -- the same for the enhanced (constant-acceleration) TTC of the
        assessments (``intent.collision``) against the ground truth's, over pairs
        with 0 < GT ETTC < TTC_MAX_S;
    decel_err_median -- median |d_hat - d| (m/s^2) of the ego's required
        deceleration over the same pairs (finite on both sides).
Runs recorded before ETTC existed give null for both.
``n`` = scored pairs (matched, not initializing); ``n_initializing`` = matched
pairs left out as initializing. Without tracks in the run every metric is null,
counts 0.
"""

from __future__ import annotations

import numpy as np

from lookahead.intent.labels import NEVER
from lookahead.tools.scoring.io import GTFrame, RunData, TrackFrame
from lookahead.tools.scoring.matching import class_iou, hungarian_match

UNOCCLUDED_MIN_VISIBLE_FRACTION = 0.9
UNOCCLUDED_MAX_TRUNCATION = 0.05
RANGE_MIN_M = 5.0
RANGE_MAX_M = 50.0
TTC_MAX_S = 5.0
RANGE_ABS_PERCENTILE = 90.0

_FIELDS = ("init", "r_hat", "r", "vf", "trunc", "v_hat", "v", "ttc_hat", "ttc", "ettc_hat", "ettc",
           "decel_hat", "decel")


def match_pairs(gt: GTFrame, tracks: TrackFrame) -> dict[str, np.ndarray]:
    """Estimate / truth arrays of one frame's matched (track, GT) pairs, keyed as ``_FIELDS``
    (``init``: the track is initializing, a don't-care pair)."""
    trk = tracks[tracks.reported]
    iou = class_iou(trk.xyxy, None, gt.visible, None)
    t, g = hungarian_match(iou)
    return {
        "init": trk.initializing[t],
        "r_hat": trk.range[t], "r": gt.range[g],
        "vf": gt.visible_fraction[g], "trunc": gt.truncation[g],
        "v_hat": trk.ground_velocity[t], "v": gt.velocity[g],
        "ttc_hat": trk.ttc[t], "ttc": gt.ttc[g],
        "ettc_hat": _or_nan(trk.ettc, len(trk.range))[t], "ettc": _or_nan(gt.ettc, len(gt.range))[g],
        "decel_hat": _or_nan(trk.decel_req, len(trk.range))[t], "decel": _or_nan(gt.decel_req, len(gt.range))[g],
    }


def _or_nan(values: np.ndarray | None, n: int) -> np.ndarray:
    return np.full(n, np.nan) if values is None else values


def _stat(values: np.ndarray, fn) -> float | None:
    return float(fn(values)) if len(values) else None


def null_estimation() -> dict:
    """The section when the run has no tracks."""
    return {
        "range_rel_err_median": None, "range_abs_err_p90": None,
        "speed_err_median": None, "ttc_err_median": None, "ettc_err_median": None, "decel_err_median": None,
        "n_range": 0, "n_speed": 0, "n_ttc": 0, "n_ettc": 0, "n": 0, "n_initializing": 0,
    }


def evaluate_estimation(run: RunData) -> dict:
    """The ``estimation`` section (module docstring)."""
    if run.tracks is None or len(run) == 0:
        return null_estimation()
    frames = [match_pairs(gt, trk) for gt, trk in zip(run.gt, run.tracks, strict=True)]
    p = {k: np.concatenate([f[k] for f in frames]) for k in _FIELDS}
    n_init = int(np.count_nonzero(p["init"]))
    p = {k: v[~p["init"]] for k, v in p.items()}
    with np.errstate(invalid="ignore", divide="ignore"):
        range_err = np.abs(p["r_hat"] - p["r"])
        in_range = (
            (p["vf"] >= UNOCCLUDED_MIN_VISIBLE_FRACTION)
            & (p["trunc"] < UNOCCLUDED_MAX_TRUNCATION)
            & (p["r"] >= RANGE_MIN_M) & (p["r"] <= RANGE_MAX_M)
            & np.isfinite(range_err)
        )
        rel = range_err[in_range] / p["r"][in_range]
        abs_err = range_err[in_range]
        speed = np.linalg.norm(p["v_hat"] - p["v"], axis=1)
        speed = speed[np.isfinite(speed)]
        ttc_hat = np.clip(p["ttc_hat"], -NEVER, NEVER)  # "never" as the finite NEVER (NaN stays)
        ttc_sel = (p["ttc"] > 0) & (p["ttc"] < TTC_MAX_S) & np.isfinite(ttc_hat)
        ttc = np.abs(ttc_hat[ttc_sel] - p["ttc"][ttc_sel]) / p["ttc"][ttc_sel]
        ettc_hat = np.clip(p["ettc_hat"], -NEVER, NEVER)
        ettc_sel = (p["ettc"] > 0) & (p["ettc"] < TTC_MAX_S) & np.isfinite(ettc_hat)
        ettc = np.abs(ettc_hat[ettc_sel] - p["ettc"][ettc_sel]) / p["ettc"][ettc_sel]
        decel = np.abs(p["decel_hat"][ettc_sel] - p["decel"][ettc_sel])
        decel = decel[np.isfinite(decel)]
    return {
        "range_rel_err_median": _stat(rel, np.median),
        "range_abs_err_p90": _stat(abs_err, lambda x: np.percentile(x, RANGE_ABS_PERCENTILE)),
        "speed_err_median": _stat(speed, np.median),
        "ttc_err_median": _stat(ttc, np.median),
        "ettc_err_median": _stat(ettc, np.median),
        "decel_err_median": _stat(decel, np.median),
        "n_range": len(rel),
        "n_speed": len(speed),
        "n_ttc": len(ttc),
        "n_ettc": len(ettc),
        "n": len(p["r"]),
        "n_initializing": n_init,
    }
