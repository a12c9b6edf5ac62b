"""The ``cooperative`` section of metrics.json: how well the ego used other cameras' objects.

Present only for runs whose ``ticks.jsonl`` records carry ``cooperative``
(``sim.cooperation.cooperative_record``: a scenario with a ``cooperative:`` section);
``cooperative_section`` returns None otherwise and ``score_run`` leaves the key out.
Ground-truth ids (``truth``): an actor id >= 1; 0 is the ego itself (which senders see);
-1 unknown. A truth is *known* when >= 1. Positions are object centres (m) in the ego frame.

Definitions, per frame, messages taken in the order the record lists them (the fusion
node's order):

* ``matching`` -- a received object's *list object* is what it joined when ``matched``:
  the ego's own object of that id (``own.id == fused_id``) when there is one, with the
  own object's truth; else the earlier sender's received object that became that fused
  object (first in the frame), with its truth; else the fused row's truth. Using the
  list object's own truth, not the fused row's (which falls back to the received
  object's truth where the own one is unknown), keeps a pair from confirming itself.
    pairs        -- matched received objects whose truth and list object's truth are both known;
    correct      -- pairs whose two truths agree;
    should_match -- received objects not dropped (``fused_id`` != -1) with a known truth t
                    that the list before them holds: t is among the ego's own objects'
                    truths (``own.truth``) or among the truths of earlier messages' objects
                    (not dropped) of the same frame -- matched or not;
    precision = correct / pairs, recall = correct (of should_match ones) / should_match
    (None when the denominator is 0). ``per_sender`` gives the same per sender name.
* ``self_detections`` -- received objects whose truth is 0 (the ego): ``dropped`` (``fused_id``
  -1) and ``kept`` (fused as an object), ``drop_rate`` = dropped / (dropped + kept);
  ``wrongly_dropped``: objects with a known truth (another actor) dropped as the ego;
  ``unknown_dropped``: dropped objects of unknown truth.
* ``position_error`` (m, Euclidean) -- an object's centre against the ground-truth centre
  (``box3d[:, :2]``) of its truth in the same frame; truths absent from that frame's ground
  truth are skipped. ``own``: the ego's own objects; ``received``: received objects not
  dropped; ``fused``: every fused object; ``both``: the fused objects of source 2 (own and
  other), each against its fused truth, as ``own`` (the own object of that id), ``other``
  (the first received object that joined it) and ``fused``, so the three are on the same
  objects. Each {median, p90, n} (None without samples). Own centres are the record's
  ``own.xy``, the ego's estimates before fusion.
* ``occluded_recall`` -- ground-truth actor-frames of detection classes (class_id >= 0; the
  ego, actor 0, excluded) with centre 0 < x <= ``REGION_X_M`` (60) m and |y| <=
  ``REGION_Y_M`` (15) m whose ego visibility is poor: visible_fraction <
  ``POOR_VISIBLE_FRACTION`` (0.3; null counts as poor) or truncation >= 1 (out of the
  image). ``fused`` = share of them with a fused object of that truth, ``own`` = share with
  an own object of that truth; ``n`` actor-frames, ``n_fused`` / ``n_own`` the hits.
  ``recall_all``: the same over every actor-frame of the region, visible or not.
* ``link`` -- the last frame's link counters (``sent``, ``lost``, ``delivered``, ``expired``,
  ``overflowed``), and ``age_median_s`` / ``age_max_s`` of the messages fused (every
  ``received`` entry of every frame; None without messages), ``messages`` their count.
* ``warning`` -- ``tools.scoring.intent.evaluate_danger`` twice on the same danger events:
  ``fusion`` with the record's ``alerts`` (those acted on; remote ids associated with
  actors through the fused objects' truths, ``track_actors``) and ``alone`` with
  ``cooperative.alerts_alone`` (what the ego's own camera alone would have raised). A
  danger episode counts when its actor is, at some frame of it, visible to the ego camera
  or among the fused objects' truths (someone saw it and it reached the ego): an actor
  only others see is an event the ego alone misses. Each: ``dangers`` (events),
  ``missed``, ``alerts``, ``false_alarms``, ``lead_time_median_s``, ``lead_time_min_s`` (true
  TTC at the first warning), ``event_list``.
* ``frames``: records with ``cooperative``; ``fusion``: whether intent used the fused
  objects (``fusion`` of the records, all of them).

Suite and sweep totals (``cooperative_totals``) sum the counts and recompute the rates.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lookahead.tools.scoring.intent import IntentRun, evaluate_danger, load_intent_run, rounded
from lookahead.tools.sinks.rundir import RunDir, RunDirError, as_rundir, decode_array

REGION_X_M = 60.0
REGION_Y_M = 15.0
POOR_VISIBLE_FRACTION = 0.3
_ALERT_SCORING_KEYS = ("actor", "false_alarm")


def has_cooperative(run: RunDir | Path) -> bool:
    """Whether any record of the run carries ``cooperative``."""
    return any(rec.get("cooperative") is not None for rec in as_rundir(run).ticks)


def _stats(values: list[float]) -> dict:
    if not values:
        return {"median": None, "p90": None, "n": 0}
    v = np.asarray(values, dtype=np.float64)
    return {"median": rounded(np.median(v)), "p90": rounded(np.percentile(v, 90)), "n": len(values)}


def _ratio(num: int, den: int) -> float | None:
    return round(num / den, 4) if den else None


class _Match:
    """Matching counts (one sender, or all)."""

    def __init__(self) -> None:
        self.pairs = self.correct = self.should_match = self.correct_should = self.matched = 0

    def out(self) -> dict:
        return {"precision": _ratio(self.correct, self.pairs), "recall": _ratio(self.correct_should, self.should_match),
                "pairs": self.pairs, "correct": self.correct, "should_match": self.should_match,
                "correct_should_match": self.correct_should, "matched": self.matched}


class _Acc:
    """Everything the section counts, frame by frame."""

    def __init__(self) -> None:
        self.match = _Match()
        self.per_sender: dict[str, _Match] = defaultdict(_Match)
        self.self_det = {"dropped": 0, "kept": 0, "wrongly_dropped": 0, "unknown_dropped": 0}
        self.err: dict[str, list[float]] = defaultdict(list)
        self.occ = {"n": 0, "n_fused": 0, "n_own": 0}
        self.all = {"n": 0, "n_fused": 0, "n_own": 0}
        self.ages: list[float] = []
        self.link: dict = {}
        self.frames = 0
        self.fusion = True
        self.visible: dict[int, set[int]] = defaultdict(set)  # actor -> frames fused objects carry it


def _ints(values) -> np.ndarray:
    return np.asarray(values if values is not None else [], dtype=np.int64).reshape(-1)


def _xy(values) -> np.ndarray:
    return decode_array(values if values is not None else []).reshape(-1, 2)


def _frame(acc: _Acc, f: int, rec: dict, coop: dict) -> None:
    acc.frames += 1
    acc.fusion = acc.fusion and bool(coop.get("fusion", True))
    gt = rec["ground_truth"]
    gt_ids = _ints(gt["actor_id"])
    box = decode_array(gt["box3d"]).reshape(-1, 7) if len(gt_ids) else np.zeros((0, 7))
    centre = {int(a): box[i, :2] for i, a in enumerate(gt_ids.tolist())}

    def err(kind: str, truth: int, xy: np.ndarray) -> None:
        if truth > 0 and truth in centre and np.all(np.isfinite(xy)):
            acc.err[kind].append(float(np.hypot(*(xy - centre[truth]))))

    own = coop.get("own") or {}
    own_ids, own_truth, own_xy = _ints(own.get("id")), _ints(own.get("truth")), _xy(own.get("xy"))
    own_by_id = {int(i): (int(t), own_xy[k]) for k, (i, t) in enumerate(zip(own_ids.tolist(), own_truth.tolist(),
                                                                             strict=True))}
    for t, xy in own_by_id.values():
        err("own", t, xy)
    fused = coop.get("fused") or {}
    f_ids, f_truth, f_xy = _ints(fused.get("id")), _ints(fused.get("truth")), _xy(fused.get("xy"))
    f_source = _ints(fused.get("source")) if fused.get("source") is not None else np.zeros(len(f_ids), np.int64)
    fused_truth = dict(zip(f_ids.tolist(), f_truth.tolist(), strict=True))
    for k, t in enumerate(f_truth.tolist()):
        err("fused", t, f_xy[k])
        if t > 0:
            acc.visible[t].add(f)

    listed = {t for t in own_truth.tolist() if t > 0}  # truths the list holds before each message
    created: dict[int, int] = {}  # fused id -> truth of the earlier message's object that became it
    first_other: dict[int, np.ndarray] = {}  # fused id -> xy of the first received object that joined it
    for msg in coop.get("received") or []:
        ids, truth, xy = _ints(msg.get("id")), _ints(msg.get("truth")), _xy(msg.get("xy"))
        fid = _ints(msg.get("fused_id"))
        matched = np.asarray(msg.get("matched") or [False] * len(ids), dtype=bool).reshape(-1)
        per = acc.per_sender[str(msg.get("sender"))]
        if msg.get("age") is not None:
            acc.ages.append(float(msg["age"]))
        added: set[int] = set()
        for k in range(len(ids)):
            t, g = int(truth[k]), int(fid[k])
            if g == -1:
                if t == 0:
                    acc.self_det["dropped"] += 1
                elif t > 0:
                    acc.self_det["wrongly_dropped"] += 1
                else:
                    acc.self_det["unknown_dropped"] += 1
                continue
            if t == 0:
                acc.self_det["kept"] += 1
            err("received", t, xy[k])
            correct = False
            if matched[k]:
                for m in (acc.match, per):
                    m.matched += 1
                if g in own_by_id:
                    joined = own_by_id[g][0]
                elif g in created:
                    joined = created[g]
                else:
                    joined = int(fused_truth.get(g, -1))
                first_other.setdefault(g, xy[k])
                if t > 0 and joined > 0:
                    correct = t == joined
                    for m in (acc.match, per):
                        m.pairs += 1
                        m.correct += int(correct)
            else:
                created.setdefault(g, t)
            if t > 0 and t in listed:
                for m in (acc.match, per):
                    m.should_match += 1
                    m.correct_should += int(correct)
            if t > 0:
                added.add(t)
        listed |= added

    for k, g in enumerate(f_ids.tolist()):
        t = int(f_truth[k])
        if f_source[k] != 2 or t <= 0 or t not in centre or g not in own_by_id or g not in first_other:
            continue
        err("both_own", t, own_by_id[g][1])
        err("both_other", t, first_other[g])
        err("both_fused", t, f_xy[k])

    cls = _ints(gt["class_id"])
    vf = decode_array(gt.get("visible_fraction", [None] * len(gt_ids))).reshape(-1)
    trunc = decode_array(gt.get("truncation", [0.0] * len(gt_ids))).reshape(-1)
    fused_set, own_set = {t for t in f_truth.tolist() if t > 0}, {t for t in own_truth.tolist() if t > 0}
    for i, a in enumerate(gt_ids.tolist()):
        x, y = box[i, 0], box[i, 1]
        if a == 0 or cls[i] < 0 or not (0.0 < x <= REGION_X_M and abs(y) <= REGION_Y_M):
            continue
        poor = not (vf[i] >= POOR_VISIBLE_FRACTION) or trunc[i] >= 1.0
        for c, take in ((acc.all, True), (acc.occ, poor)):
            if take:
                c["n"] += 1
                c["n_fused"] += int(a in fused_set)
                c["n_own"] += int(a in own_set)
    acc.link = dict(coop.get("link") or {})


def _recall(c: dict) -> dict:
    return {"fused": _ratio(c["n_fused"], c["n"]), "own": _ratio(c["n_own"], c["n"]), **c}


def _warning(run: IntentRun, seen: dict[int, set[int]]) -> dict:
    visible = {a: set(run.gt_visible.get(a, ())) | seen.get(a, set()) for a in set(run.gt_visible) | set(seen)}
    out = {}
    for name, alerts in (("fusion", run.alerts), ("alone", run.alerts_alone)):
        fresh = [{k: v for k, v in a.items() if k not in _ALERT_SCORING_KEYS} for a in alerts]
        d = evaluate_danger(run, fresh, visible)
        out[name] = {"dangers": d["events"], "missed": d["missed"], "alerts": d["alerts"],
                     "false_alarms": d["false_alarms"], "lead_time_median_s": d["lead_time_s_median"],
                     "lead_time_min_s": d["lead_time_s_min"], "event_list": d["event_list"]}
    return out


def cooperative_section(run: RunDir | Path, intent_run: IntentRun | None = None) -> dict | None:
    """The ``cooperative`` section of a run directory (module docstring); None when no record
    carries ``cooperative``. ``intent_run``: the run's ``load_intent_run`` (re-read if not given)."""
    rd = as_rundir(run)
    records = rd.ticks
    if not any(rec.get("cooperative") is not None for rec in records):
        return None
    acc = _Acc()
    for f, rec in enumerate(records):
        coop = rec.get("cooperative")
        if coop is None:
            continue
        try:
            _frame(acc, f, rec, coop)
        except (KeyError, TypeError, ValueError, IndexError) as e:
            raise RunDirError(f"{rd.where(f)}: cannot read cooperative fields ({e})") from None
    irun = intent_run if intent_run is not None else load_intent_run(rd)
    e = acc.err
    link = {**acc.link, "messages": len(acc.ages),
            "age_median_s": rounded(np.median(acc.ages)) if acc.ages else None,
            "age_max_s": rounded(max(acc.ages)) if acc.ages else None}
    sd = acc.self_det
    return {
        "frames": acc.frames,
        "fusion": acc.fusion,
        "matching": {**acc.match.out(), "per_sender": {k: v.out() for k, v in sorted(acc.per_sender.items())}},
        "self_detections": {**sd, "drop_rate": _ratio(sd["dropped"], sd["dropped"] + sd["kept"])},
        "position_error": {
            "own": _stats(e["own"]), "received": _stats(e["received"]), "fused": _stats(e["fused"]),
            "both": {"own": _stats(e["both_own"]), "other": _stats(e["both_other"]), "fused": _stats(e["both_fused"])},
        },
        "occluded_recall": {**_recall(acc.occ), "recall_all": _recall(acc.all)},
        "link": link,
        "warning": _warning(irun, acc.visible),
    }


def cooperative_totals(per_run: Sequence[dict]) -> dict | None:
    """Pooled ``cooperative`` of several runs' metrics (None when none has the section): the
    matching, self-detection and occluded-recall counts summed with the rates recomputed
    (``matching_precision``, ``matching_recall``, ``occluded_recall_fused`` / ``_own``,
    ``recall_all_fused`` / ``_own``), and lead times pooled over the runs' danger events with
    fusion and alone (median, min), ``missed`` summed."""
    sections = [m["cooperative"] for m in per_run if isinstance(m.get("cooperative"), dict)]
    if not sections:
        return None

    def total(path: str) -> int:
        out = 0
        for s in sections:
            node = s
            for k in path.split("."):
                node = node.get(k) if isinstance(node, dict) else None
            out += int(node or 0)
        return out

    m = {k: total(f"matching.{k}") for k in ("pairs", "correct", "should_match", "correct_should_match")}
    occ = {k: total(f"occluded_recall.{k}") for k in ("n", "n_fused", "n_own")}
    all_ = {k: total(f"occluded_recall.recall_all.{k}") for k in ("n", "n_fused", "n_own")}
    out = {
        "runs": len(sections),
        "matching_precision": _ratio(m["correct"], m["pairs"]),
        "matching_recall": _ratio(m["correct_should_match"], m["should_match"]),
        **{f"matching_{k}": v for k, v in m.items()},
        "self_dropped": total("self_detections.dropped"), "self_kept": total("self_detections.kept"),
        "wrongly_dropped": total("self_detections.wrongly_dropped"),
        "occluded_recall_fused": _ratio(occ["n_fused"], occ["n"]),
        "occluded_recall_own": _ratio(occ["n_own"], occ["n"]),
        "occluded_n": occ["n"],
        "recall_all_fused": _ratio(all_["n_fused"], all_["n"]),
        "recall_all_own": _ratio(all_["n_own"], all_["n"]),
        "recall_all_n": all_["n"],
    }
    for name in ("fusion", "alone"):
        parts = [(s.get("warning") or {}).get(name) or {} for s in sections]
        leads = [ev["lead_time_s"] for p in parts for ev in p.get("event_list") or [] if ev.get("lead_time_s") is not None]
        out[f"dangers_{name}"] = sum(int(p.get("dangers") or 0) for p in parts)
        out[f"missed_{name}"] = sum(int(p.get("missed") or 0) for p in parts)
        out[f"lead_time_median_s_{name}"] = rounded(float(np.median(leads))) if leads else None
        out[f"lead_time_min_s_{name}"] = rounded(float(np.min(leads))) if leads else None
    return out
