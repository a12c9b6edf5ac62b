"""The ``occlusion`` section of ``metrics.json``: is a track's identity kept through an occlusion?

Ground truth knows who is who, so every time an actor passes behind something nearer to
the camera and comes back, the scorer checks whether the tracker gives it back the id it had.

Per frame, each ground-truth actor of a detection class (``class_id >= 0``) is
    seen   -- *evaluated* GT of ``tools.scoring.detection`` (visible box, visible fraction
              >= 0.5, visible box height >= 10 px);
    hidden -- in the field of view (present in the frame's GT with truncation
              < ``MAX_TRUNCATION`` = 0.5, or truncation not recorded) but without a visible
              box or with visible fraction < ``HIDDEN_FRACTION`` = 0.1;
    out    -- absent from the frame's GT, or truncation >= 0.5 (left the field of view);
    partly -- anything else (partly occluded, or too small).

An **occlusion episode** is a gap between two *seen* frames of an actor -- ``a`` the last
seen frame before it, ``b`` the first seen frame after it -- made of hidden and partly
frames only (no ``out`` frame: leaving the image is not an occlusion), with at least one
hidden frame, whose hidden span lasts ``MIN_HIDDEN_S`` (0.3) to ``MAX_HIDDEN_S`` (3.0) s.
The hidden span is ``duration_s`` = time of the last hidden frame - time of the first
hidden frame + one frame period (the run's median frame interval): at 10 fps, 3 hidden
frames are 0.3 s. ``t_hidden`` is the time of the first hidden frame, ``t_back`` that of
``b``. Shorter gaps (an actor crossing in front for a frame or two) and longer ones
(parked for good behind a truck) are not episodes.

Tracks are assigned to GT per frame as the ``tracking`` section does
(``tracking.frame_rows``): reported tracks (confirmed, or lost and still output), one-to-one
Hungarian matching, IoU >= 0.5 (boxes under 8 px grown to 8 px), class-aware with evaluated
GT and any detection class with don't-care GT (visible but not evaluated).
    id_before -- the track matched to the actor in frame ``a``; when none is, in the latest
                 of the ``BEFORE_FRAMES`` (5) frames up to ``a`` where one is (None: the actor
                 was not tracked before the occlusion -- the episode is ``untracked`` and not
                 scored).
    id_after  -- within the re-acquisition window, frames ``b`` .. ``b + REACQUIRE_FRAMES - 1``
                 (5 frames, 0.5 s at 10 fps; clipped at the run's end), the track matched to
                 the actor in the *last* frame of the window in which one is: the id the
                 actor settled on (a coasting box that overlaps for a frame before a new id
                 takes over is not credited).
An episode is ``kept`` when id_after == id_before, ``lost`` when id_after is another id (a new
identity, or another object's), ``missed`` when no track matches the actor in the window.

Section: ``episodes`` (all), ``scored`` (kept + lost + missed), ``kept``, ``lost``, ``missed``,
``untracked``, ``kept_rate`` = kept / scored (null when nothing is scored), ``per_class``
{class: {episodes, scored, kept, lost, missed, kept_rate}}, ``duration_s_median``, and
``episode_list`` [{actor, class, t_hidden, t_back, duration_s, id_before, id_after, outcome,
kept}], ``actor`` being the GT actor id. Suite and sweep totals sum the counts and recompute
the rates (``occlusion_totals``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lookahead.tools.scoring.detection import class_name, gt_selection
from lookahead.tools.scoring.io import GTFrame, RunData, TrackFrame, load_run, ticks_records
from lookahead.tools.scoring.matching import class_iou, hungarian_match
from lookahead.tools.sinks.rundir import RunDir, as_rundir

HIDDEN_FRACTION = 0.1
MAX_TRUNCATION = 0.5
MIN_HIDDEN_S = 0.3
MAX_HIDDEN_S = 3.0
BEFORE_FRAMES = 5
REACQUIRE_FRAMES = 5

SEEN, PARTLY, HIDDEN, OUT = 0, 1, 2, 3
OUTCOMES = ("kept", "lost", "missed", "untracked")
_COUNTS = ("episodes", "scored", "kept", "lost", "missed", "untracked")


def frame_states(gt: GTFrame) -> dict[int, int]:
    """State (``SEEN``, ``PARTLY``, ``HIDDEN``) of every detection-class actor present in a
    frame's GT, by actor id (absent actors are ``OUT``)."""
    evaluated, _ = gt_selection(gt)
    box = gt.visible
    with np.errstate(invalid="ignore"):
        has_box = np.all(np.isfinite(box), axis=1) & (box[:, 2] > box[:, 0]) & (box[:, 3] > box[:, 1])
        hidden = ~has_box | ~(gt.visible_fraction >= HIDDEN_FRACTION)
        out = gt.truncation >= MAX_TRUNCATION  # NaN (not recorded): in view
    states = np.where(evaluated, SEEN, np.where(out, OUT, np.where(hidden, HIDDEN, PARTLY)))
    return {int(a): int(s) for a, s, c in zip(gt.actor_id, states, gt.class_id, strict=True) if c >= 0}


def frame_matches(gt: GTFrame, tracks: TrackFrame | None) -> dict[int, int]:
    """Track id matched to each GT actor in one frame, by actor id (``tracking.frame_rows``'
    matching: reported tracks, Hungarian, IoU >= 0.5, class-aware with evaluated GT)."""
    if tracks is None or len(tracks.track_id) == 0:
        return {}
    evaluated, dont_care = gt_selection(gt)
    shown = evaluated | dont_care
    trk = tracks[tracks.reported]
    iou = class_iou(trk.xyxy, trk.class_id, gt.visible[shown], gt.class_id[shown], any_class=dont_care[shown])
    rows, cols = hungarian_match(iou)
    actors = gt.actor_id[shown]
    return {int(actors[c]): int(trk.track_id[r]) for r, c in zip(rows, cols, strict=True)}


def frame_period(times: np.ndarray) -> float:
    """The run's frame period (s): the median interval between frames (0.1 with one frame)."""
    dt = np.diff(np.asarray(times, dtype=np.float64))
    dt = dt[np.isfinite(dt) & (dt > 0)]
    return float(np.median(dt)) if dt.size else 0.1


def find_episodes(states: Sequence[int], times: np.ndarray, period: float) -> list[tuple[int, int, int, int]]:
    """Occlusion episodes of one actor's per-frame states (module docstring).

    Returns:
        (a, first_hidden, last_hidden, b) frame indices per episode: last seen frame
        before, first and last hidden frames, first seen frame after.
    """
    out = []
    seen = [i for i, s in enumerate(states) if s == SEEN]
    for a, b in zip(seen, seen[1:], strict=False):
        gap = states[a + 1:b]
        if not gap or OUT in gap or HIDDEN not in gap:
            continue
        hid = [a + 1 + k for k, s in enumerate(gap) if s == HIDDEN]
        duration = float(times[hid[-1]] - times[hid[0]]) + period
        if MIN_HIDDEN_S - 1e-6 <= duration <= MAX_HIDDEN_S + 1e-6:
            out.append((a, hid[0], hid[-1], b))
    return out


def evaluate_occlusion(run: RunData, times: Sequence[float] | np.ndarray | None = None) -> dict:
    """The ``occlusion`` section (module docstring) of loaded run data.

    Args:
        times: each frame's time (s); None or non-finite values: frame index x 0.1 s.
    """
    n = len(run)
    t = np.asarray(times if times is not None else np.full(n, np.nan), dtype=np.float64)
    if t.shape != (n,) or not np.all(np.isfinite(t)):
        t = np.arange(n) * 0.1
    period = frame_period(t)
    per_frame = [frame_states(g) for g in run.gt]
    matches = [frame_matches(g, run.tracks[i] if run.tracks is not None else None) for i, g in enumerate(run.gt)]
    classes: dict[int, int] = {}
    for g in run.gt:
        classes.update({int(a): int(c) for a, c in zip(g.actor_id, g.class_id, strict=True) if c >= 0})
    episodes = []
    for actor in sorted(classes):
        states = [f.get(actor, OUT) for f in per_frame]
        for a, h0, h1, b in find_episodes(states, t, period):
            before = next((matches[i][actor] for i in range(a, max(a - BEFORE_FRAMES, -1), -1)
                           if actor in matches[i]), None)
            window = [matches[i][actor] for i in range(b, min(b + REACQUIRE_FRAMES, n)) if actor in matches[i]]
            after = window[-1] if window else None
            if before is None:
                outcome = "untracked"
            elif after is None:
                outcome = "missed"
            else:
                outcome = "kept" if after == before else "lost"
            episodes.append({
                "actor": actor, "class": class_name(classes[actor]),
                "t_hidden": round(float(t[h0]), 3), "t_back": round(float(t[b]), 3),
                "duration_s": round(float(t[h1] - t[h0]) + period, 3),
                "id_before": before, "id_after": after, "outcome": outcome, "kept": outcome == "kept",
            })
    return occlusion_section(episodes)


def run_occlusion(run: RunDir | Path) -> dict:
    """The ``occlusion`` section of a run directory (frames parsed once, shared with the other
    scorers; frame times from the records' ``t``)."""
    rd = as_rundir(run)
    data = load_run(rd)
    times = [rec.get("t") for rec in ticks_records(rd)]
    ok = all(isinstance(v, int | float) and not isinstance(v, bool) for v in times)
    return evaluate_occlusion(data, times if ok else None)


def _counts(episodes: Sequence[dict]) -> dict:
    c = {k: sum(1 for e in episodes if e["outcome"] == k) for k in OUTCOMES}
    scored = c["kept"] + c["lost"] + c["missed"]
    return {"episodes": len(episodes), "scored": scored, **c, "kept_rate": _rate(c["kept"], scored)}


def _rate(num: int, den: int) -> float | None:
    return round(num / den, 4) if den else None


def occlusion_section(episodes: Sequence[dict]) -> dict:
    """The section from its episode list (counts, rates, per class, median duration)."""
    by_class: dict[str, list[dict]] = {}
    for e in episodes:
        by_class.setdefault(e["class"], []).append(e)
    durations = [e["duration_s"] for e in episodes]
    return {
        **_counts(episodes),
        "per_class": {k: _counts(v) for k, v in sorted(by_class.items())},
        "duration_s_median": round(float(np.median(durations)), 3) if durations else None,
        "episode_list": list(episodes),
    }


def occlusion_totals(per_run: Sequence[dict]) -> dict:
    """Pooled ``occlusion`` of several runs' metrics: counts summed (overall and per class), rates
    recomputed; no episode list. Runs without the section are skipped (``runs`` counts the others)."""
    sections = [m["occlusion"] for m in per_run if isinstance(m.get("occlusion"), dict)]

    def pooled(parts: Sequence[dict]) -> dict:
        c = {k: int(sum(p.get(k) or 0 for p in parts)) for k in _COUNTS}
        return {**c, "kept_rate": _rate(c["kept"], c["scored"])}

    names = sorted({k for s in sections for k in (s.get("per_class") or {})})
    return {
        "runs": len(sections),
        **pooled(sections),
        "per_class": {k: pooled([s["per_class"][k] for s in sections if k in (s.get("per_class") or {})])
                      for k in names},
    }
