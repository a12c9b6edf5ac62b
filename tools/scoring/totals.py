"""Totals over several scored runs, one implementation each.

* ``suite_totals`` -- a suite's (``lookahead suite``) and a replayed suite's
  (``lookahead replay SUITE_DIR``): ``score_suite`` re-scores detection, tracking,
  estimation and timing over all runs' frames together (ids kept apart), so counts
  are sums and rates, AP, IDF1 and medians are recomputed over every frame;
  ``intent_totals`` pools intent, danger, closed loop, aeb (false AEB activations)
  and expectations from the runs' metrics; ``occlusion_totals`` (``tools.scoring.occlusion``)
  sums the occlusion episode counts and recomputes ``kept_rate``; ``cooperative_totals``
  (``tools.scoring.cooperative``) pools the cooperative matching, occluded-recall and
  warning counts -- a ``cooperative`` block only when some run has that section;
  ``behaviour_totals`` (``tools.scoring.behaviour``) adds the behaviour and risk confusion
  matrices and recomputes accuracy and macro-F1, ``cipv_totals`` (``tools.scoring.cipv``)
  sums the primary-target counts and recomputes ``correct_rate`` -- each a block only when
  some run has that section.
* ``sweep_totals`` -- a sweep's (``lookahead sweep``), from the variants' metrics
  alone (O(variants), no run re-read): detection and tracking counts summed with
  precision, recall and MOTA recomputed, estimation sample counts, ``intent_totals``
  as a suite's, and the plain mean of the given key metrics over the variants.

``score_suite`` takes run directories (paths or ``RunDir`` s, whose parsed frames
are reused) or ``RunFrames``: the frames a worker process scored, handed back so
that the driver re-reads nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lookahead.intent.labels import LABEL_NAMES, Label
from lookahead.tools.scoring.behaviour import behaviour_totals
from lookahead.tools.scoring.cipv import cipv_totals
from lookahead.tools.scoring.cooperative import cooperative_totals
from lookahead.tools.scoring.intent import SCORED_LABELS, rounded
from lookahead.tools.scoring.io import RunData, concat_runs, load_run
from lookahead.tools.scoring.occlusion import occlusion_totals
from lookahead.tools.scoring.run import evaluate
from lookahead.tools.scoring.timing import load_timings, timing_section
from lookahead.tools.sinks.rundir import RunDir, as_rundir


@dataclass(frozen=True)
class RunFrames:
    """What ``score_suite`` needs of one run: its typed frames and per-stage timings (picklable)."""

    data: RunData
    timings: dict[str, list[float]]

    @classmethod
    def of(cls, run: RunDir | Path) -> RunFrames:
        rd = as_rundir(run)
        return cls(load_run(rd), load_timings(rd))


def score_suite(runs: Sequence[RunFrames | RunDir | Path]) -> dict[str, dict]:
    """Detection, tracking, estimation (and timing) recomputed over all runs' frames together."""
    frames = [r if isinstance(r, RunFrames) else RunFrames.of(r) for r in runs]
    sections = evaluate(concat_runs([f.data for f in frames]))
    stages: dict[str, list[float]] = {}
    for f in frames:
        for k, v in f.timings.items():
            stages.setdefault(k, []).extend(v)
    if stages:
        sections["timing"] = timing_section(stages)
    return sections


def suite_totals(runs: Sequence[RunFrames | RunDir | Path], per_run: Sequence[dict]) -> dict:
    """A suite's ``totals``: ``score_suite`` of the runs, then ``intent_totals`` of their metrics."""
    totals = score_suite(runs)
    totals.update(intent_totals(per_run))
    totals["occlusion"] = occlusion_totals(per_run)  # counts summed, kept_rate recomputed
    _add_cooperative(totals, per_run)
    return totals


def _add_cooperative(totals: dict, per_run: Sequence[dict]) -> None:
    """``totals["cooperative"]`` when some run has a ``cooperative`` section (else nothing, so
    totals of runs without other cameras are as before); likewise ``behaviour`` and ``cipv``
    (runs scored before those sections existed have none)."""
    for key, pool in (("behaviour", behaviour_totals), ("cipv", cipv_totals), ("cooperative", cooperative_totals)):
        block = pool(per_run)
        if block is not None:
            totals[key] = block


def intent_totals(per_run: Sequence[dict]) -> dict:
    """Totals of the intent, danger, closed-loop and aeb sections: counts summed,
    rates and medians recomputed (confusion matrices added, lead times pooled; ``aeb.runs``
    counts the runs that had an ``aeb`` section, older metrics files lack it)."""
    runs = [m for m in per_run if m.get("intent")]
    labels = [LABEL_NAMES[Label(k)] for k in SCORED_LABELS]
    conf = np.zeros((len(labels), len(labels)), dtype=np.int64)
    for m in runs:
        conf += np.asarray(m["intent"]["confusion"]["matrix"], dtype=np.int64)
    total = int(conf.sum())
    per_class, f1s = {}, []
    for i, name in enumerate(labels):
        tp, fp, fn = conf[i, i], conf[:, i].sum() - conf[i, i], conf[i, :].sum() - conf[i, i]
        p = tp / (tp + fp) if tp + fp else None
        r = tp / (tp + fn) if tp + fn else None
        f1 = 2 * p * r / (p + r) if p and r else (0.0 if (tp + fp + fn) else None)
        per_class[name] = {"precision": rounded(p), "recall": rounded(r), "f1": rounded(f1), "support": int(conf[i, :].sum())}
        if tp + fp + fn:
            f1s.append(f1 or 0.0)
    events = [e for m in runs for e in m["danger"]["event_list"]]
    leads = [e["lead_time_s"] for e in events if e["lead_time_s"] is not None]
    n_ev = len(events)
    missed = sum(m["danger"]["missed"] for m in runs)
    alerts = sum(m["danger"]["alerts"] for m in runs)
    fa = sum(m["danger"]["false_alarms"] for m in runs)
    hits = [m["closed_loop"] for m in runs]
    aeb = [m["aeb"] for m in runs if isinstance(m.get("aeb"), dict)]
    onsets = sum(int(a.get("brake_onsets") or 0) for a in aeb)
    false_act = sum(int(a.get("false_activations") or 0) for a in aeb)
    return {
        "intent": {
            "accuracy": rounded(np.trace(conf) / total) if total else None,
            "macro_f1": rounded(float(np.mean(f1s))) if f1s else None,
            "per_class": per_class,
            "confusion": {"labels": labels, "matrix": conf.tolist()},
            "n": total,
            "n_initializing": sum(int(m["intent"].get("n_initializing") or 0) for m in runs),
        },
        "danger": {
            "events": n_ev, "missed": missed, "alerts": alerts, "false_alarms": fa,
            "miss_rate": rounded(missed / n_ev) if n_ev else None,
            "false_alarm_rate": rounded(fa / alerts) if alerts else None,
            "lead_time_s_median": rounded(float(np.median(leads))) if leads else None,
            "lead_time_s_min": rounded(float(np.min(leads))) if leads else None,
        },
        "closed_loop": {
            "runs": len(hits),
            "collisions": sum(1 for h in hits if h["collision"]),
            "impact_speed_max": rounded(max([h["impact_speed"] or 0.0 for h in hits], default=0.0)),
        },
        "aeb": {
            "runs": len(aeb), "brake_onsets": onsets, "false_activations": false_act,
            "false_activation_rate": rounded(false_act / onsets) if onsets else None,
        },
        "expectations": {
            "total": sum(len(m.get("expectations", [])) for m in runs),
            "failed": sum(1 for m in runs for e in m.get("expectations", []) if not e["passed"]),
        },
    }


def metric_at(metrics: dict, dotted: str) -> Any:
    """The scalar at a dotted ``metrics.json`` path (``tracking.mota``); None if absent or not a scalar."""
    node: Any = metrics
    for k in dotted.split("."):
        if not isinstance(node, dict):
            return None
        node = node.get(k)
    return None if isinstance(node, dict | list) else node


def _ratio(num: float, den: float) -> float | None:
    return round(num / den, 4) if den else None


def sweep_totals(per_run: Sequence[dict], mean_of: Sequence[str] = ()) -> dict:
    """Totals pooled from per-run ``metrics.json`` contents alone (O(runs), nothing re-read).

    ``intent``, ``danger``, ``closed_loop``, ``aeb``, ``expectations``: ``intent_totals`` (exact, as
    a suite's). ``detection``: gt / tp / fp summed, precision and recall recomputed;
    ``tracking``: tp / fp / fn / id_switches / fragmentations / mostly_* summed, MOTA
    recomputed; ``estimation``: the sample counts. Metrics that do not pool from per-run
    numbers (AP50, IDF1, HOTA, MOTP, error medians) are left out here -- ``score_suite``
    re-scores every frame of every run in one process, which a sweep of hundreds of
    variants on a cluster must not do -- and ``mean_over_variants`` gives the plain mean
    of every ``mean_of`` metric (dotted paths) instead.
    """
    def total(section: str, key: str) -> int:
        return int(sum((m.get(section) or {}).get(key) or 0 for m in per_run))

    det = {k: total("detection", k) for k in ("gt", "tp", "fp", "ignored", "frames")}
    det.update(precision=_ratio(det["tp"], det["tp"] + det["fp"]), recall=_ratio(det["tp"], det["gt"]))
    trk = {k: total("tracking", k) for k in ("tp", "fp", "fn", "id_switches", "fragmentations", "mostly_tracked",
                                             "partially_tracked", "mostly_lost", "num_gt_ids")}
    gt = trk["tp"] + trk["fn"]
    trk["mota"] = round(1.0 - (trk["fn"] + trk["fp"] + trk["id_switches"]) / gt, 4) if gt else None
    est = {k: total("estimation", k) for k in ("n_range", "n_speed", "n_ttc", "n", "n_initializing")}
    means = {}
    for k in mean_of:
        vals = [v for v in (metric_at(m, k) for m in per_run) if isinstance(v, int | float)]
        means[k] = round(sum(float(v) for v in vals) / len(vals), 4) if vals else None
    out = {"detection": {"precision": det.pop("precision"), "recall": det.pop("recall"), **det},
           "tracking": {"mota": trk.pop("mota"), **trk}, "estimation": est}
    out.update(intent_totals(per_run))
    out["occlusion"] = occlusion_totals(per_run)
    _add_cooperative(out, per_run)
    out["mean_over_variants"] = means
    return out
