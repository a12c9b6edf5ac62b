"""The ``intent``, ``danger``, ``closed_loop``, ``aeb`` and ``expectations`` sections of metrics.json.

Definitions (documented constants):

* Matching: per frame, reported tracks (confirmed or briefly coasting) to ground-truth
  visible boxes by Hungarian IoU >= 0.5 (``matching.class_iou``: boxes under 8 px
  grown), class-agnostic (class errors are the detection section's business).
  Unmatched objects and tracks are left to the tracking metrics; predictions still
  ``initializing`` are don't-care (``n_initializing`` counts those matched pairs,
  beside ``n``, the scored ones).
* Intent label time tolerance ``LABEL_TOLERANCE_S`` = 0.3 s: a prediction
  counts as correct when the object's ground-truth label equals it at any time
  within ±0.3 s (labels change at thresholds; a 3-frame slack at 10 Hz).
* Danger event: a maximal run of frames in which an object's ground-truth
  label is ``danger`` (gaps of up to ``EPISODE_GAP_FRAMES`` merged), counted
  only if the object was visible in the image at some frame of it.
* Warned: an alert >= HIGH (``fcw`` or ``critical`` event) on a track
  associated with that object, issued from ``ALERT_LEAD_WINDOW_S`` = 1 s before
  the episode starts until it ends. Lead time = the object's ground-truth TTC
  when the first such alert was issued.
* False alarm: an alert >= HIGH whose object has no danger frame from
  ``FA_BEFORE_S`` = 0.5 s before to ``FA_AFTER_S`` = 1 s after the alert, or
  whose track is associated with no object.
* A track's object: the ground-truth actor it is matched with most often. An object only
  other cameras see (cooperative runs: a remote id, ``REMOTE_ID_BASE`` = 1_000_000 and up,
  in the record's ``alerts``) has no box to match: its object is the ground-truth actor its
  fused objects (``cooperative.fused``, truth >= 1) carry most often, and per frame the one
  it carries then.
* ``ttc_when_first_visible``: the object's true TTC at the first frame it was
  visible (``NEVER`` = 1e9 when not closing): a warning cannot come earlier than that.
* AEB brake onset (``aeb`` section): a frame whose AEB brake is non-null after a
  frame where it was null (or the first frame, braking). The AEB brake is the AEB's own
  command, ``ego.aeb_brake``, so a driver model's braking (``ego.driver_brake``) is no
  onset; run directories written before that field existed fall back to ``ego.brake``
  (the command applied), except runs whose ``run.json`` says the AEB was off, which
  have no AEB brake (``aeb_brake_of``); ``closed_loop.aeb_active_s`` counts the same
  frames. An onset is *justified* when some ground-truth actor, at a frame from
  ``AEB_BEFORE_S`` = 0.5 s before the onset to ``AEB_AFTER_S`` = 0.3 s after it, is labelled ``danger`` (in path, TTC or closing
  range under its class's HIGH thresholds) or is in path with a true TTC below
  ``AEB_TTC_BOUND_S`` (the largest default CRITICAL TTC, the AEB's trigger, 2.0 s, plus
  0.5 s). The window is the label tolerance (0.3 s) either side of the decision, which
  came the AEB's default latency (0.2 s) before the brake. Any other onset is a
  *false activation*; ``false_activation_rate`` = false / onsets (None without onsets).
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import LABEL_NAMES, Label, Risk
from lookahead.perception.cooperative import REMOTE_ID_BASE
from lookahead.tools.scoring.matching import IOU_THRESHOLD, class_iou, hungarian_match
from lookahead.tools.sinks.rundir import NEVER, RUN_FILE, RunDir, RunDirError, as_rundir, decode

LABEL_TOLERANCE_S = 0.3
EPISODE_GAP_FRAMES = 2
ALERT_LEAD_WINDOW_S = 1.0
FA_BEFORE_S = 0.5
FA_AFTER_S = 1.0
AEB_BEFORE_S = 0.5  # the AEB's default latency (0.2 s) + LABEL_TOLERANCE_S
AEB_AFTER_S = LABEL_TOLERANCE_S
AEB_TTC_BOUND_S = max(r.critical_ttc for r in IntentConfig().risk.values()) + 0.5
SCORED_LABELS = (Label.STABLE, Label.APPROACHING, Label.RECEDING, Label.DANGER)
_RISK = {r.name: int(r) for r in Risk}


@dataclass
class IntentRun:
    """What intent scoring needs from ``ticks.jsonl`` and ``run.json``."""

    t: list[float] = field(default_factory=list)
    gt_label: dict[int, dict[int, int]] = field(default_factory=lambda: defaultdict(dict))  # actor -> frame -> label
    gt_ttc: dict[int, dict[int, float]] = field(default_factory=lambda: defaultdict(dict))
    gt_visible: dict[int, set[int]] = field(default_factory=lambda: defaultdict(set))  # actor -> frames visible
    gt_inpath_ttc: list[float] = field(default_factory=list)
    names: dict[int, str] = field(default_factory=dict)
    pairs: list[tuple[int, int, int, int]] = field(default_factory=list)  # frame, actor, track, predicted label
    alerts: list[dict] = field(default_factory=list)
    collisions: list[dict] = field(default_factory=list)
    expect: list[dict] = field(default_factory=list)
    aeb_frames: int = 0
    gt_in_path: dict[int, set[int]] = field(default_factory=lambda: defaultdict(set))  # actor -> frames in path
    braking: list[bool] = field(default_factory=list)  # per frame: the AEB brake non-null (aeb_brake_of)
    aeb_on: bool | None = None  # run.json's scenario.ego.aeb is on (None: not recorded)
    latency_frames: int = 0  # run.json's scenario.perception.latency: alerts reach the driver this many frames late
    cooperative: bool = False  # some record carries ``cooperative`` (other cameras' objects, fused)
    remote_pairs: list[tuple[int, int, int]] = field(default_factory=list)  # frame, actor, remote id (fused truth)
    alerts_alone: list[dict] = field(default_factory=list)  # cooperative.alerts_alone: the ego's own camera alone


def load_intent_run(run: RunDir | Path) -> IntentRun:
    """What intent scoring needs of a run directory (``RunDir.ticks`` and ``run.json``'s
    ``expect``); ``RunDirError`` naming ``file:line`` when a record lacks an intent field."""
    rd = as_rundir(run)
    records = rd.ticks  # FileNotFoundError / RunDirError before run.json is looked at
    out = IntentRun()
    if rd.has(RUN_FILE):
        scenario = rd.run.get("scenario", {}) or {}
        out.expect = list(scenario.get("expect", []) or [])
        ego = scenario.get("ego")
        if isinstance(ego, dict) and "aeb" in ego:
            out.aeb_on = ego["aeb"] not in (None, False)
        perception = scenario.get("perception")
        if isinstance(perception, dict):
            out.latency_frames = int(perception.get("latency") or 0)
    for f, rec in enumerate(records):
        try:
            out.t.append(float(rec["t"]))
            _read_frame(out, f, rec)
        except (KeyError, TypeError, ValueError) as e:
            raise RunDirError(f"{rd.where(f)}: cannot read intent fields ({e})") from None
    _deliver_alerts(out)
    return out


def _deliver_alerts(out: IntentRun) -> None:
    """Alerts reach the driver ``latency_frames`` after the frame they were raised on: each
    alert's ``frame`` and ``t`` become the delivery frame's (``perceived_frame`` keeps the
    frame it was raised on), so warning lead times count the latency."""
    lag = out.latency_frames
    if not lag:
        return
    dt = _frame_period(out)
    for a in out.alerts + out.alerts_alone:
        f = a["perceived_frame"] = a["frame"]
        a["frame"] = f + lag
        a["t"] = out.t[f + lag] if f + lag < len(out.t) else out.t[f] + lag * dt


def _read_frame(out: IntentRun, f: int, rec: dict) -> None:
    gt = rec["ground_truth"]
    ids = np.asarray(gt["actor_id"], dtype=np.int64)
    vis = np.array([[np.nan if v is None else v for v in (b or [None] * 4)] for b in gt["visible"]],
                   dtype=np.float64).reshape(-1, 4)
    for i, a in enumerate(ids.tolist()):
        out.names[a] = gt["name"][i]
        out.gt_label[a][f] = int(gt["label"][i])
        ttc = decode(gt["ttc"][i])
        out.gt_ttc[a][f] = math.inf if math.isnan(ttc) else ttc  # null: never, as the sentinel
        if np.all(np.isfinite(vis[i])) and gt["class_id"][i] >= 0:
            out.gt_visible[a].add(f)
        if gt["in_path"][i]:
            out.gt_inpath_ttc.append(out.gt_ttc[a][f])
            out.gt_in_path[a].add(f)
    tr, asm = rec.get("tracks"), rec.get("assessments")
    if tr and asm and len(tr.get("track_id", [])):
        state = np.array([s in ("confirmed", "lost", 1, 2) for s in tr["state"]])  # reported tracks
        xyxy = np.asarray(tr["xyxy"], dtype=np.float64).reshape(-1, 4)[state]
        tids = np.asarray(tr["track_id"], dtype=np.int64)[state]
        labels = np.asarray(asm["label"], dtype=np.int64)[state]
        ok = np.all(np.isfinite(vis), axis=1)
        if len(tids) and ok.any():
            iou = class_iou(xyxy, None, vis[ok], None)
            t_idx, g_idx = hungarian_match(iou, IOU_THRESHOLD)
            gids = ids[ok]
            for t, g in zip(t_idx.tolist(), g_idx.tolist(), strict=True):
                out.pairs.append((f, int(gids[g]), int(tids[t]), int(labels[t])))
    out.alerts += [{**a, "frame": f} for a in rec.get("alerts") or []]
    coop = rec.get("cooperative")
    if coop is not None:
        out.cooperative = True
        fused = coop.get("fused") or {}
        for fid, actor in zip(fused.get("id") or [], fused.get("truth") or [], strict=True):
            if fid >= REMOTE_ID_BASE and actor > 0:
                out.remote_pairs.append((f, int(actor), int(fid)))
        out.alerts_alone += [{**a, "frame": f} for a in coop.get("alerts_alone") or []]
    out.collisions += rec.get("collisions") or []
    brake = aeb_brake_of(rec.get("ego") or {}, out.aeb_on)
    out.braking.append(brake is not None)
    if brake:
        out.aeb_frames += 1


def aeb_brake_of(ego: dict, aeb_on: bool | None = None) -> float | None:
    """The AEB's own brake command (m/s^2, None while off) in a record's ``ego``.

    ``aeb_brake`` when recorded (runs with the AEB on); without it, None if the run had no
    AEB (``aeb_on`` False, from run.json: any ``brake`` is a driver model's), else ``brake``
    (run directories written before ``aeb_brake`` existed, where it was the AEB's)."""
    if "aeb_brake" in ego:
        return ego["aeb_brake"]
    if aeb_on is False:
        return None
    return ego.get("brake")


def _label_near(run: IntentRun, actor: int, f: int, label: int, tol_frames: int) -> bool:
    timeline = run.gt_label[actor]
    return any(timeline.get(k) == label for k in range(f - tol_frames, f + tol_frames + 1))


def _frame_period(run: IntentRun) -> float:
    """The run's camera frame period (s, median); 0 with fewer than two frames."""
    return float(np.median(np.diff(run.t))) if len(run.t) > 1 else 0.0


def frame_tolerance(run: IntentRun, seconds: float) -> int:
    if len(run.t) < 2:
        return 0
    return int(round(seconds / _frame_period(run)))


def evaluate_intent(run: IntentRun) -> dict:
    tol = frame_tolerance(run, LABEL_TOLERANCE_S)
    n = len(SCORED_LABELS)
    conf = np.zeros((n, n), dtype=np.int64)
    index = {int(lab): i for i, lab in enumerate(SCORED_LABELS)}
    n_init = 0
    for f, actor, _track, pred in run.pairs:
        truth = run.gt_label[actor].get(f)
        if pred == Label.INITIALIZING and truth in index:
            n_init += 1
        if pred == Label.INITIALIZING or truth not in index or pred not in index:
            continue
        eff = pred if _label_near(run, actor, f, pred, tol) else truth
        conf[index[eff], index[pred]] += 1
    total = int(conf.sum())
    per_class, f1s = {}, []
    for lab, i in index.items():
        tp, fp, fn = conf[i, i], conf[:, i].sum() - conf[i, i], conf[i, :].sum() - conf[i, i]
        p = tp / (tp + fp) if tp + fp else None
        r = tp / (tp + fn) if tp + fn else None
        f1 = 2 * p * r / (p + r) if p is not None and r is not None and p + r > 0 else (0.0 if (tp + fp + fn) else None)
        name = LABEL_NAMES[Label(lab)]
        per_class[name] = {"precision": rounded(p), "recall": rounded(r), "f1": rounded(f1), "support": int(conf[i, :].sum())}
        if conf[i, :].sum() > 0 or conf[:, i].sum() > 0:
            f1s.append(f1 or 0.0)
    return {
        "accuracy": rounded(np.trace(conf) / total) if total else None,
        "macro_f1": rounded(float(np.mean(f1s))) if f1s else None,
        "per_class": per_class,
        "confusion": {"labels": [LABEL_NAMES[Label(k)] for k in index], "matrix": conf.tolist()},
        "n": total,
        "n_initializing": n_init,
        "tolerance_s": LABEL_TOLERANCE_S,
    }


def _episodes(frames: list[int]) -> list[tuple[int, int]]:
    out: list[list[int]] = []
    for f in sorted(frames):
        if out and f - out[-1][1] <= EPISODE_GAP_FRAMES + 1:
            out[-1][1] = f
        else:
            out.append([f, f])
    return [(a, b) for a, b in out]


def track_actors(run: IntentRun) -> dict[int, int]:
    """Each track's object (the actor it is matched with most often), and each remote id's
    (the actor its fused objects carry most often; cooperative runs)."""
    votes: dict[int, Counter] = defaultdict(Counter)
    for _f, actor, track, _ in run.pairs:
        votes[track][actor] += 1
    for _f, actor, remote in run.remote_pairs:
        votes[remote][actor] += 1
    return {t: c.most_common(1)[0][0] for t, c in votes.items()}


def evaluate_danger(run: IntentRun, alerts: list[dict] | None = None,
                    visible: dict[int, set[int]] | None = None) -> dict:
    """The ``danger`` section: of ``alerts`` (default the run's, as acted on; each raised one
    gets its ``actor``, false alarms ``false_alarm``), with events counted where the actor is
    in ``visible`` (actor -> frames; default the ego camera's ``gt_visible``)."""
    owner = track_actors(run)
    frame_actor = {(f, tr): a for f, a, tr, _ in run.pairs}
    frame_actor.update({(f, r): a for f, a, r in run.remote_pairs})
    seen_frames = run.gt_visible if visible is None else visible
    raised = [a for a in (run.alerts if alerts is None else alerts) if a.get("kind") in ("fcw", "critical")]
    for a in raised:
        a["actor"] = frame_actor.get((a.get("perceived_frame", a["frame"]), a["track_id"]), owner.get(a["track_id"]))
    t = np.asarray(run.t)
    events, missed, leads = [], 0, []
    danger_frames = {a: [f for f, lab in tl.items() if lab == Label.DANGER] for a, tl in run.gt_label.items()}
    for actor, frames in danger_frames.items():
        for start, end in _episodes(frames):
            if not any(start <= f <= end for f in seen_frames.get(actor, ())):
                continue
            mine = [a for a in raised if a["actor"] == actor and t[start] - ALERT_LEAD_WINDOW_S <= a["t"] <= t[end]]
            seen = [f for f in seen_frames.get(actor, ()) if f <= end]
            ttc_seen = run.gt_ttc[actor].get(min(seen), float("inf")) if seen else None
            ev = {"actor": run.names.get(actor, str(actor)), "t_start": rounded(t[start]), "t_end": rounded(t[end]),
                  "warned": bool(mine), "lead_time_s": None,
                  "ttc_when_first_visible": rounded(min(ttc_seen, NEVER)) if ttc_seen is not None else None}
            if mine:
                first = min(mine, key=lambda a: a["t"])
                ttc = run.gt_ttc[actor].get(first["frame"], float("inf"))
                ev["lead_time_s"] = rounded(ttc) if np.isfinite(ttc) else None
                if np.isfinite(ttc):
                    leads.append(ttc)
            else:
                missed += 1
            events.append(ev)
    false_alarms = 0
    for a in raised:
        actor = a["actor"]
        frames = danger_frames.get(actor, []) if actor is not None else []
        if not any(a["t"] - FA_BEFORE_S <= t[f] <= a["t"] + FA_AFTER_S for f in frames):
            false_alarms += 1
            a["false_alarm"] = True
    n_ev, n_al = len(events), len(raised)
    return {
        "events": n_ev,
        "missed": missed,
        "alerts": n_al,
        "false_alarms": false_alarms,
        "miss_rate": rounded(missed / n_ev) if n_ev else None,
        "false_alarm_rate": rounded(false_alarms / n_al) if n_al else None,
        "lead_time_s_median": rounded(float(np.median(leads))) if leads else None,
        "lead_time_s_min": rounded(float(np.min(leads))) if leads else None,
        "event_list": events,
    }


def evaluate_closed_loop(run: IntentRun) -> dict:
    first = run.collisions[0] if run.collisions else None
    finite = [x for x in run.gt_inpath_ttc if np.isfinite(x)]
    return {
        "collision": bool(first),
        "impact_speed": rounded(abs(first["relative_speed"])) if first else 0.0,
        "collided_with": first["name"] if first else None,
        "min_ttc": rounded(min(finite)) if finite else None,
        "aeb_active_s": rounded(run.aeb_frames * (float(np.median(np.diff(run.t))) if len(run.t) > 1 else 0.0)),
    }


def brake_onsets(run: IntentRun) -> list[int]:
    """Frames at which the AEB's own brake comes on (non-null after null, or braking at the
    first frame); a driver model's braking is not the AEB's (``aeb_brake_of``)."""
    return [f for f, b in enumerate(run.braking) if b and (f == 0 or not run.braking[f - 1])]


def evaluate_aeb(run: IntentRun) -> dict:
    """Brake onsets, and which of them no ground-truth danger justified (false activations)."""
    t = np.asarray(run.t)
    onsets = []
    for f0 in brake_onsets(run):
        lo, hi = t[f0] - AEB_BEFORE_S - 1e-6, t[f0] + AEB_AFTER_S + 1e-6
        window = [f for f in range(len(t)) if lo <= t[f] <= hi]
        best = None  # (ttc, frames from the onset, actor, frame)
        for actor, labels in run.gt_label.items():
            for f in window:
                ttc = run.gt_ttc[actor].get(f, math.inf)
                danger = labels.get(f) == Label.DANGER
                if danger or (f in run.gt_in_path[actor] and ttc < AEB_TTC_BOUND_S):
                    key = (ttc, abs(f - f0), actor, f)
                    best = key if best is None or key < best else best
        item = {"t": rounded(t[f0]), "justified": best is not None, "actor": None, "ttc": None, "label": None}
        if best is not None:
            ttc, _, actor, f = best
            item.update(actor=run.names.get(actor, str(actor)), ttc=rounded(min(ttc, NEVER)),
                        label=LABEL_NAMES[Label(run.gt_label[actor][f])])
        onsets.append(item)
    n, false = len(onsets), sum(1 for o in onsets if not o["justified"])
    return {
        "brake_onsets": n,
        "false_activations": false,
        "false_activation_rate": rounded(false / n) if n else None,
        "onset_list": onsets,
    }


def evaluate_expectations(run: IntentRun, metrics: dict) -> list[dict]:
    """Each scenario ``expect:`` item as passed / failed with a reason."""
    out = []
    danger = metrics.get("danger") or evaluate_danger(run)
    closed = metrics.get("closed_loop") or evaluate_closed_loop(run)
    by_name = {v: k for k, v in run.names.items()}
    owner = track_actors(run)
    for item in run.expect:
        (kind, spec), = item.items() if len(item) == 1 else [("?", item)]
        passed, detail = False, ""
        if kind in ("alert", "no_alert"):
            spec = spec or {}
            actor = by_name.get(spec.get("actor"))
            level = _RISK.get(str(spec.get("level_at_least", "HIGH")).upper(), int(Risk.HIGH))
            hits = [a for a in run.alerts if a.get("level", 0) >= level and a.get("kind") in ("fcw", "critical")
                    and (a.get("actor") if "actor" in a else owner.get(a["track_id"])) == actor]
            if kind == "no_alert":
                passed = not hits
                detail = "no alert" if passed else f"{len(hits)} alert(s), first at t={hits[0]['t']:.2f} s"
            elif not hits:
                detail = f"no alert >= {Risk(level).name} for {spec.get('actor')}"
            else:
                first = min(hits, key=lambda a: a["t"])
                ttc = run.gt_ttc[actor].get(first["frame"], float("inf"))
                need = spec.get("before_ttc")
                passed = need is None or ttc >= float(need)
                detail = f"first {Risk(first['level']).name} alert at t={first['t']:.2f} s, true TTC {ttc:.2f} s"
                if need is not None:
                    detail += f" (needed >= {float(need):.2f} s)"
        elif kind == "collision":
            passed = closed["collision"] == bool(spec)
            detail = f"collision with {closed['collided_with']} at {closed['impact_speed']} m/s" if closed["collision"] else "no collision"
        elif kind == "max_impact_speed":
            passed = (closed["impact_speed"] or 0.0) <= float(spec)
            detail = f"impact speed {closed['impact_speed']} m/s"
        elif kind == "danger_warned":
            passed = danger["missed"] == 0
            detail = f"{danger['missed']} of {danger['events']} danger events missed"
        elif kind == "metric":
            value = metrics.get(spec["section"], {}).get(spec["name"])
            lo, hi = spec.get("min"), spec.get("max")
            passed = value is not None and (lo is None or value >= lo) and (hi is None or value <= hi)
            detail = f"{spec['section']}.{spec['name']} = {value}"
        else:
            detail = f"unknown expectation {kind!r}"
        out.append({"expectation": item, "passed": bool(passed), "detail": detail})
    return out


def intent_sections(run: IntentRun) -> dict:
    sections = {"intent": evaluate_intent(run), "danger": evaluate_danger(run), "closed_loop": evaluate_closed_loop(run),
                "aeb": evaluate_aeb(run)}
    sections["expectations"] = evaluate_expectations(run, sections)
    return sections


def rounded(x) -> float | None:
    """A metric as written: rounded to 4 decimals, None kept."""
    return None if x is None else round(float(x), 4)
