"""The ``cipv`` section of metrics.json: the primary target (closest in-path object) against truth.

Each tick record of a closed-loop run carries ``cipv`` (``sim.runner.cipv_record``,
``intent.cipv.select_cipv``): ``track_id`` / ``range``, the closest in-path track among the
ego camera's own tracks (in path per the assessment, smallest finite estimated range, ties by
track id), and ``truth_actor`` / ``truth_range``, the closest in-path ground-truth actor of a
detection class with a visible box (true range, ``ground_truth.in_path``). Definitions:

* The predicted target's actor: the ground-truth actor its track is matched with in that
  frame (the intent pairs: reported tracks to visible ground truth, Hungarian IoU >= 0.5),
  else the track's object over the run (the actor it is matched with most often,
  ``tools.scoring.intent.track_actors``); a track matched with no actor ever is a *ghost*,
  equal to no actor.
* ``correct``: frames where the predicted target's actor equals the true target, both none
  included; ``correct_rate`` = correct / ``frames`` (frames with a ``cipv`` record).
  Errors split into ``wrong_target`` (both some, different), ``missed`` (a true target, none
  predicted) and ``false_target`` (none true, one predicted).
* ``switches``: frames whose predicted target's actor differs from the previous frame's
  while the true target stays the same, and the new one is not the true target (none counts
  as a value: a target dropped, or jumping to another object or a ghost, is a switch; taking
  up the true target -- the first frames of a new track, or back after a dropout -- is a
  correction, not a switch, so a one-frame dropout counts once); ``truth_changes``: frames
  where the true target changes (the ones the prediction should follow).
* ``range_err_median``: median |predicted range - true range| (m) over correct frames with
  a target.

Runs without ``cipv`` in their records (older runs, real video) get no section; suite and
sweep totals (``cipv_totals``) sum the counts and recompute the rates, a block only when
some run has the section.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lookahead.tools.scoring.intent import IntentRun, rounded, track_actors
from lookahead.tools.sinks.rundir import RunDir

_GHOST = -(2**62)  # a predicted target associated with no actor: equal to none and to no actor
_COUNTS = ("frames", "correct", "wrong_target", "missed", "false_target", "switches", "truth_changes")


def cipv_section(run: RunDir, intent_run: IntentRun) -> dict | None:
    """The ``cipv`` section of a run (module docstring); None when no record has ``cipv``."""
    records = run.ticks
    if not any(isinstance(rec.get("cipv"), dict) for rec in records):
        return None
    owner = track_actors(intent_run)
    frame_actor = {(f, tr): a for f, a, tr, _ in intent_run.pairs}
    c = dict.fromkeys(_COUNTS, 0)
    errs = []
    prev: tuple[int | None, int | None] | None = None
    for f, rec in enumerate(records):
        cv = rec.get("cipv")
        if not isinstance(cv, dict):
            prev = None
            continue
        tid, truth = cv.get("track_id"), cv.get("truth_actor")
        pred = None if tid is None else frame_actor.get((f, tid), owner.get(tid, _GHOST))
        c["frames"] += 1
        if pred == truth:
            c["correct"] += 1
            if truth is not None and cv.get("range") is not None and cv.get("truth_range") is not None:
                errs.append(abs(float(cv["range"]) - float(cv["truth_range"])))
        elif truth is None:
            c["false_target"] += 1
        elif pred is None:
            c["missed"] += 1
        else:
            c["wrong_target"] += 1
        if prev is not None:
            if truth != prev[1]:
                c["truth_changes"] += 1
            elif pred != prev[0] and pred != truth:
                c["switches"] += 1
        prev = (pred, truth)
    return {
        "correct_rate": rounded(c["correct"] / c["frames"]) if c["frames"] else None,
        **c,
        "range_err_median": rounded(float(np.median(errs))) if errs else None,
    }


def cipv_totals(per_run: Sequence[dict]) -> dict | None:
    """Pooled ``cipv`` of several runs' metrics (None when none has the section): counts summed,
    ``correct_rate`` recomputed (``range_err_median`` does not pool and is left out)."""
    sections = [m["cipv"] for m in per_run if isinstance(m.get("cipv"), dict)]
    if not sections:
        return None
    c = {k: sum(int(s.get(k) or 0) for s in sections) for k in _COUNTS}
    return {"runs": len(sections), "correct_rate": rounded(c["correct"] / c["frames"]) if c["frames"] else None, **c}
