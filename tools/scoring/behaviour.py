"""The ``behaviour`` section of metrics.json: behaviours and risk levels against ground truth.

Both sides come from the one ``intent.labels.assess`` (ground truth on true kinematics,
``ground_truth.behaviour`` / ``risk``; predictions on the estimates, ``assessments.behaviour``
/ ``risk`` / ``behaviour_confidence``). Definitions:

* Pairs: the intent section's (``tools.scoring.intent``): per frame, reported tracks matched
  to visible ground truth of a detection class by class-agnostic Hungarian IoU >= 0.5 (boxes
  under 8 px grown). A pair whose prediction is still ``initializing`` (intent label) is
  don't-care, counted in ``n_initializing``; ``n`` counts the scored pairs.
* Class group: the ground-truth actor's class (``GROUP_OF_CLASS``: pedestrian; animal, large
  ones included; non_motor = cyclist, motorcyclist, tricycle; vehicle = car, truck, bus). A
  misclassified track keeps its own class's behaviour vocabulary and is scored in the truth's
  group (its behaviour name is simply wrong there).
* Time tolerance ``LABEL_TOLERANCE_S`` (0.3 s, as intent labels): a predicted behaviour (a
  risk level) counts as correct when the actor's true behaviour (risk) equals it at some frame
  within +-0.3 s -- behaviours change where a speed, lateral speed, deceleration or yaw rate
  crosses a threshold, risk where a TTC or range does; the cell is then the diagonal, else
  (truth at the frame, predicted).
* ``per_group[g]``: ``confusion`` (rows truth, columns predicted; ``labels`` the behaviour
  names met in the group, truth or predicted, in ``Behaviour`` order), ``accuracy`` (diagonal
  / n), ``per_class`` {behaviour: precision, recall, f1, support (truth count)} and
  ``macro_f1`` = mean F1 over the behaviours present in the group's truth (support > 0; a
  behaviour only ever predicted lowers the precision of the truths it was predicted for).
* ``accuracy`` = correct / n over all groups; ``macro_f1`` = mean F1 over every (group,
  behaviour) present in truth -- a pedestrian's running and an animal's running are
  different classes; ``worst`` lists the five lowest-F1 (group, behaviour) with support.
* ``risk``: the same pairs, risk level SAFE..CRITICAL (``Risk``), ``confusion`` 5 x 5 (rows
  truth), ``accuracy``, ``per_class`` (precision, recall, f1, support per level).
* ``confidence``: the predicted ``behaviour_confidence`` (``intent.labels.behaviour_confidence``)
  averaged over correct (``mean_correct``) and wrong (``mean_wrong``) scored pairs (None
  without; runs recorded before it existed have none).

Suite and sweep totals (``behaviour_totals``) add the confusion matrices by name and
recompute every rate; the block is present only when some run has the section.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence

import numpy as np

from lookahead.intent.labels import BEHAVIOUR_NAMES, GROUP_OF_CLASS, Behaviour, Label, Risk
from lookahead.tools.scoring.intent import LABEL_TOLERANCE_S, IntentRun, frame_tolerance, rounded
from lookahead.tools.sinks.rundir import RunDir

BEHAVIOUR_GROUPS = ("pedestrian", "animal", "non_motor", "vehicle")
RISK_NAMES = tuple(r.name for r in Risk)
_ORDER = {name: int(b) for b, name in BEHAVIOUR_NAMES.items()}


def _name(code: int) -> str:
    try:
        return BEHAVIOUR_NAMES[Behaviour(int(code))]
    except ValueError:
        return BEHAVIOUR_NAMES[Behaviour.UNKNOWN]


def _near(timeline: dict[int, int], f: int, value: int, tol: int) -> bool:
    return any(timeline.get(k) == value for k in range(f - tol, f + tol + 1))


def _prf(conf: np.ndarray, i: int) -> tuple[float | None, float | None, float | None]:
    tp, fp, fn = conf[i, i], conf[:, i].sum() - conf[i, i], conf[i, :].sum() - conf[i, i]
    p = tp / (tp + fp) if tp + fp else None
    r = tp / (tp + fn) if tp + fn else None
    f1 = 2 * p * r / (p + r) if p is not None and r is not None and p + r > 0 else (0.0 if tp + fp + fn else None)
    return p, r, f1


def _group_block(labels: list[str], conf: np.ndarray) -> dict:
    """accuracy, macro-F1 over behaviours present in truth, per_class and the confusion of one group."""
    total = int(conf.sum())
    per_class, f1s = {}, []
    for i, name in enumerate(labels):
        p, r, f1 = _prf(conf, i)
        support = int(conf[i, :].sum())
        per_class[name] = {"precision": rounded(p), "recall": rounded(r), "f1": rounded(f1), "support": support}
        if support:
            f1s.append(f1 or 0.0)
    return {
        "accuracy": rounded(np.trace(conf) / total) if total else None,
        "macro_f1": rounded(float(np.mean(f1s))) if f1s else None,
        "n": total,
        "per_class": per_class,
        "confusion": {"labels": labels, "matrix": conf.tolist()},
    }


def _matrix(cells: dict[tuple[str, str], int]) -> tuple[list[str], np.ndarray]:
    labels = sorted({a for a, _ in cells} | {b for _, b in cells}, key=lambda n: _ORDER.get(n, 99))
    idx = {n: i for i, n in enumerate(labels)}
    conf = np.zeros((len(labels), len(labels)), dtype=np.int64)
    for (a, b), c in cells.items():
        conf[idx[a], idx[b]] += c
    return labels, conf


def _section(groups: dict[str, dict[tuple[str, str], int]], risk: np.ndarray, n_init: int,
             conf_sums: tuple[float, int, float, int]) -> dict:
    per_group, f1s, worst = {}, [], []
    correct = total = 0
    for g in BEHAVIOUR_GROUPS:
        if not groups.get(g):
            continue
        labels, conf = _matrix(groups[g])
        block = per_group[g] = _group_block(labels, conf)
        correct, total = correct + int(np.trace(conf)), total + int(conf.sum())
        for name, pc in block["per_class"].items():
            if pc["support"]:
                f1s.append(pc["f1"] or 0.0)
                worst.append({"group": g, "behaviour": name, "f1": pc["f1"], "support": pc["support"]})
    worst.sort(key=lambda w: (w["f1"] or 0.0, -w["support"]))
    r_total = int(risk.sum())
    risk_per = {}
    for i, name in enumerate(RISK_NAMES):
        p, r, f1 = _prf(risk, i)
        risk_per[name] = {"precision": rounded(p), "recall": rounded(r), "f1": rounded(f1), "support": int(risk[i].sum())}
    s_ok, n_ok, s_bad, n_bad = conf_sums
    return {
        "accuracy": rounded(correct / total) if total else None,
        "macro_f1": rounded(float(np.mean(f1s))) if f1s else None,
        "n": total,
        "n_initializing": n_init,
        "tolerance_s": LABEL_TOLERANCE_S,
        "worst": worst[:5],
        "per_group": per_group,
        "risk": {
            "accuracy": rounded(np.trace(risk) / r_total) if r_total else None,
            "n": r_total,
            "per_class": risk_per,
            "confusion": {"labels": list(RISK_NAMES), "matrix": risk.tolist()},
        },
        "confidence": {"mean_correct": rounded(s_ok / n_ok) if n_ok else None,
                       "mean_wrong": rounded(s_bad / n_bad) if n_bad else None,
                       "n_correct": n_ok, "n_wrong": n_bad},
    }


def behaviour_section(run: RunDir, intent_run: IntentRun) -> dict | None:
    """The ``behaviour`` section of a run (module docstring), on ``intent_run``'s pairs; None when
    no record's ground truth carries behaviours (hand-made records). A prediction without a
    behaviour (or risk) is scored as ``unknown`` (SAFE)."""
    records = run.ticks
    if not any("behaviour" in (rec.get("ground_truth") or {}) for rec in records):
        return None
    tol = frame_tolerance(intent_run, LABEL_TOLERANCE_S)
    gt_beh: dict[int, dict[int, int]] = defaultdict(dict)
    gt_risk: dict[int, dict[int, int]] = defaultdict(dict)
    gt_group: dict[int, str] = {}
    pred: dict[tuple[int, int], tuple[int, int, float | None]] = {}  # (frame, track) -> behaviour, risk, confidence
    wanted = defaultdict(set)
    for f, _actor, track, _label in intent_run.pairs:
        wanted[f].add(track)
    for f, rec in enumerate(records):
        gt = rec["ground_truth"]
        if "behaviour" in gt:
            for i, a in enumerate(gt["actor_id"]):
                gt_beh[a][f] = int(gt["behaviour"][i])
                gt_risk[a][f] = int(gt["risk"][i]) if "risk" in gt else int(Risk.SAFE)
                cls = gt["cls"][i] if "cls" in gt else None
                gt_group.setdefault(a, GROUP_OF_CLASS.get(cls, "vehicle"))
        if f not in wanted:
            continue
        tids, asm = rec["tracks"]["track_id"], rec["assessments"]
        beh, rsk, conf = asm.get("behaviour"), asm.get("risk"), asm.get("behaviour_confidence")
        for row, tid in enumerate(tids):
            if tid in wanted[f]:
                pred[(f, tid)] = (int(Behaviour.UNKNOWN) if beh is None else int(beh[row]),
                                  int(Risk.SAFE) if rsk is None else int(rsk[row]),
                                  None if conf is None else conf[row])
    groups: dict[str, dict[tuple[str, str], int]] = defaultdict(lambda: defaultdict(int))
    risk = np.zeros((len(RISK_NAMES), len(RISK_NAMES)), dtype=np.int64)
    n_init = 0
    s_ok = s_bad = 0.0
    n_ok = n_bad = 0
    for f, actor, track, label in intent_run.pairs:
        if f not in gt_beh[actor]:
            continue
        if label == Label.INITIALIZING:
            n_init += 1
            continue
        b, rk, c = pred[(f, track)]
        truth = gt_beh[actor][f]
        eff = b if _near(gt_beh[actor], f, b, tol) else truth
        groups[gt_group[actor]][(_name(eff), _name(b))] += 1
        rt = gt_risk[actor][f]
        rk = min(max(rk, 0), len(RISK_NAMES) - 1)
        risk[rk if _near(gt_risk[actor], f, rk, tol) else min(max(rt, 0), len(RISK_NAMES) - 1), rk] += 1
        if c is not None:
            if eff == b:
                s_ok, n_ok = s_ok + float(c), n_ok + 1
            else:
                s_bad, n_bad = s_bad + float(c), n_bad + 1
    return _section(groups, risk, n_init, (s_ok, n_ok, s_bad, n_bad))


def behaviour_totals(per_run: Sequence[dict]) -> dict | None:
    """Pooled ``behaviour`` of several runs' metrics (None when none has the section): confusion
    matrices added by behaviour name per group, the risk confusion added, every rate recomputed."""
    sections = [m["behaviour"] for m in per_run if isinstance(m.get("behaviour"), dict)]
    if not sections:
        return None
    groups: dict[str, dict[tuple[str, str], int]] = defaultdict(lambda: defaultdict(int))
    risk = np.zeros((len(RISK_NAMES), len(RISK_NAMES)), dtype=np.int64)
    s_ok = s_bad = 0.0
    n_ok = n_bad = 0
    for s in sections:
        for g, block in (s.get("per_group") or {}).items():
            conf = block.get("confusion") or {}
            labels, matrix = conf.get("labels") or [], conf.get("matrix") or []
            for i, a in enumerate(labels):
                for j, b in enumerate(labels):
                    if matrix[i][j]:
                        groups[g][(a, b)] += int(matrix[i][j])
        rc = (s.get("risk") or {}).get("confusion") or {}
        if rc.get("labels") == list(RISK_NAMES):
            risk += np.asarray(rc["matrix"], dtype=np.int64)
        c = s.get("confidence") or {}
        for key, n_key in (("mean_correct", "n_correct"), ("mean_wrong", "n_wrong")):
            if c.get(key) is not None and c.get(n_key):
                if key == "mean_correct":
                    s_ok, n_ok = s_ok + c[key] * c[n_key], n_ok + int(c[n_key])
                else:
                    s_bad, n_bad = s_bad + c[key] * c[n_key], n_bad + int(c[n_key])
    out = _section(groups, risk, sum(int(s.get("n_initializing") or 0) for s in sections), (s_ok, n_ok, s_bad, n_bad))
    return {"runs": len(sections), **out}
