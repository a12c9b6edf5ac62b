"""``lookahead report``: one self-contained ``report.html`` for a run or a suite directory.

A run page holds the headline numbers, the expectations, every ``metrics.json``
section as tables, four matplotlib figures (intent confusion matrix, range
error vs true range, TTC over time per actor with alerts, per-stage timing)
and a strip of annotated key frames: the PNGs saved in ``frames/*.png``
(``tools/sinks/keyframes.py``'s ``KeyFrameSink``, captions from ``frames/key_frames.json``)
when there are any, else frames read back (OpenCV) from the run's
``annotated.mp4``; both carry the video's overlay (``tools.sinks.video.Overlay``) and
are chosen by the same rule (``tools.sinks.keyframes.key_frame_reason``: first FCW, first
critical alert, first collision, 25/50/75 % of the run; at most
``MAX_KEY_FRAMES``). Video frame k is taken to be ``ticks.jsonl`` line k (the
video holds every rendered frame). Images are inlined as base64 (PNG; frames
from the video as JPEG) and the CSS is inline: the page opens offline and can
be mailed as one file.

A cooperative run (a scenario with a ``cooperative:`` section) gets a section of its own: the
key frame ``lookahead run --coop-video`` saved in ``cooperative/`` (the own / received / fused /
matches panels and the global map, ``tools.sinks.cooperative_view``) and
``metrics["cooperative"]`` as tables of whatever keys it holds.

A suite page (a directory with ``summary.json``) has one row per scenario with
its key metrics and a relative link to that run's own report (built too), and
a totals row. Run directories without ``metrics.json`` are scored first.

A run directory is read through one ``tools.sinks.rundir.RunDir``: scoring (when
needed), the figures and the key frames share its one parse of ``ticks.jsonl``.

Figure data, from ``ticks.jsonl``:
* range error: per frame, reported tracks matched one-to-one to GT visible
  boxes by IoU >= 0.5 (``tools.scoring.estimation.match_pairs``, the pairs the
  ``estimation`` section scores); initializing tracks are left out; the pairs
  inside the scored set (unoccluded, 5..50 m) are drawn in colour.
* TTC: the same matching (with track and actor ids) gives each actor's
  predicted TTC dots; an alert belongs to the actor its track is matched with
  most often (unassociated alerts are drawn dotted in every panel). Actors are
  those with an alert, a danger label or a true TTC under ``TTC_PLOT_MAX_S``,
  nearest-TTC first, at most ``MAX_TTC_PANELS``.
"""

from __future__ import annotations

import json
import logging
import math
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from lookahead.intent.labels import Label
from lookahead.tools.reports.html import (
    REPORT_FILE,
    confusion_table,
    escape,
    figure,
    fmt,
    img,
    nested_tables,
    page,
    png_b64,
    pyplot,
    row,
    table,
)
from lookahead.tools.reports.sweep import build_sweep_report, is_sweep_dir
from lookahead.tools.scoring import estimation as est
from lookahead.tools.scoring.io import check_text, load_run, run_record, ticks_records
from lookahead.tools.scoring.matching import class_iou, hungarian_match
from lookahead.tools.scoring.run import score_run
from lookahead.tools.sinks.cooperative_view import KEY_FRAME_JSON as COOP_KEY_FRAME
from lookahead.tools.sinks.cooperative_view import MAP_PNG as COOP_MAP
from lookahead.tools.sinks.cooperative_view import PANELS_PNG as COOP_PANELS
from lookahead.tools.sinks.cooperative_view import SUBDIR as COOP_DIR
from lookahead.tools.sinks.keyframes import KEY_FRAMES_INDEX, key_frame_reason
from lookahead.tools.sinks.rundir import (
    METRICS_FILE,
    SUMMARY_FILE,
    TICKS_FILE,
    RunDir,
    as_rundir,
    decode,
    read_summary,
)

log = logging.getLogger(__name__)

TTC_PLOT_MAX_S = 10.0
MAX_TTC_PANELS = 6
MAX_KEY_FRAMES = 12
VIDEO_FILE = "annotated.mp4"
KEY_FRAME_JPEG_QUALITY = 85
_STAGE_ORDER = ("sim", "render", "gt", "detect", "track", "estimate", "intent", "sinks", "tick")
_LEVEL_COLOURS = {1: "#9aa0a6", 2: "#f4b400", 3: "#ff6d00", 4: "#d50000"}
_LEVEL_NAMES = {0: "SAFE", 1: "LOW", 2: "MEDIUM", 3: "HIGH", 4: "CRITICAL"}


class ReportError(ValueError):
    """The path is neither a run directory nor a suite directory; ``str()`` is one line."""


# --------------------------------------------------------------------------- figures






def confusion_figure(confusion: dict) -> str | None:
    """Heatmap of the intent confusion matrix (rows truth, columns prediction)."""
    labels, m = confusion.get("labels") or [], np.asarray(confusion.get("matrix") or [], dtype=float)
    if not labels or m.size == 0:
        return None
    plt = pyplot()
    rows = m.sum(axis=1, keepdims=True)
    norm = np.divide(m, rows, out=np.zeros_like(m), where=rows > 0)
    fig, ax = plt.subplots(figsize=(4.8, 4.0))
    im = ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            ax.text(j, i, f"{int(m[i, j])}", ha="center", va="center",
                    color="white" if norm[i, j] > 0.6 else "black", fontsize=10)
    ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right")
    ax.set_yticks(range(len(labels)), labels)
    ax.set_xlabel("predicted")
    ax.set_ylabel("ground truth")
    ax.set_title("intent labels (counts; colour = row share)")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    return png_b64(fig)


def range_error_figure(run: RunDir | Path) -> str | None:
    """Scatter of estimated − true range vs true range over matched (track, GT) pairs."""
    run = load_run(as_rundir(run))
    if run.tracks is None:
        return None
    pairs = [est.match_pairs(g, t) for g, t in zip(run.gt, run.tracks, strict=True)]
    p = {k: np.concatenate([f[k] for f in pairs]) for k in ("init", "r_hat", "r", "vf", "trunc")}
    keep = ~p["init"] & np.isfinite(p["r_hat"]) & np.isfinite(p["r"])
    if not keep.any():
        return None
    r, err = p["r"][keep], p["r_hat"][keep] - p["r"][keep]
    scored = ((p["vf"][keep] >= est.UNOCCLUDED_MIN_VISIBLE_FRACTION)
              & (p["trunc"][keep] < est.UNOCCLUDED_MAX_TRUNCATION)
              & (r >= est.RANGE_MIN_M) & (r <= est.RANGE_MAX_M))
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    xs = np.linspace(0, max(float(r.max()), 1.0) * 1.05, 50)
    for frac, style in ((0.05, ":"), (0.10, "--")):
        ax.plot(xs, frac * xs, style, color="#888", lw=0.8, label=f"±{frac:.0%} of range")
        ax.plot(xs, -frac * xs, style, color="#888", lw=0.8)
    ax.axhline(0, color="black", lw=0.8)
    ax.scatter(r[~scored], err[~scored], s=12, c="#bbb", label="occluded / truncated / out of 5–50 m")
    ax.scatter(r[scored], err[scored], s=14, c="#1a73e8", label="scored (unoccluded, 5–50 m)")
    ax.set_xlabel("true range (m)")
    ax.set_ylabel("estimated − true range (m)")
    ax.set_title(f"range error vs distance ({len(r)} matched pairs)")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    return png_b64(fig)


@dataclass
class _Timeline:
    """Per-actor TTC series and alerts of one run (``TTC over time`` figure)."""

    t: list[float] = field(default_factory=list)
    names: dict[int, str] = field(default_factory=dict)
    true_ttc: dict[int, dict[int, float]] = field(default_factory=lambda: defaultdict(dict))
    danger: dict[int, set[int]] = field(default_factory=lambda: defaultdict(set))
    pred: dict[int, list[tuple[int, float]]] = field(default_factory=lambda: defaultdict(list))
    owner_votes: dict[int, Counter] = field(default_factory=lambda: defaultdict(Counter))
    alerts: list[dict] = field(default_factory=list)
    collisions: list[dict] = field(default_factory=list)

    def owner(self, track_id: int) -> int | None:
        votes = self.owner_votes.get(track_id)
        return votes.most_common(1)[0][0] if votes else None


def _timeline(rd: RunDir) -> _Timeline:
    run = load_run(rd)  # the frames the scorer built from the same RunDir
    tl = _Timeline()
    for f, rec in enumerate(ticks_records(rd)):
        tl.t.append(float(rec["t"]))
        gt = rec["ground_truth"]
        for i, a in enumerate(gt["actor_id"]):
            tl.names[a] = gt["name"][i]
            ttc = decode(gt["ttc"][i])
            tl.true_ttc[a][f] = ttc if math.isfinite(ttc) else np.nan  # null or never: no line
            if gt["label"][i] == int(Label.DANGER):
                tl.danger[a].add(f)
        tl.alerts += [{**a, "frame": f} for a in rec.get("alerts") or []]
        tl.collisions += [{**c, "t": rec["t"]} for c in rec.get("collisions") or []]
        if run.tracks is None:
            continue
        g, trk = run.gt[f], run.tracks[f]
        trk = trk[trk.reported]
        ti, gi = hungarian_match(class_iou(trk.xyxy, None, g.visible, None))
        for t_idx, g_idx in zip(ti.tolist(), gi.tolist(), strict=True):
            actor, tid = int(g.actor_id[g_idx]), int(trk.track_id[t_idx])
            tl.owner_votes[tid][actor] += 1
            ttc = float(trk.ttc[t_idx])
            if not trk.initializing[t_idx] and np.isfinite(ttc):  # never (inf) is not drawn
                tl.pred[actor].append((f, ttc))
    return tl


def _ttc_actors(tl: _Timeline) -> list[int]:
    alerted = {tl.owner(int(a["track_id"])) for a in tl.alerts if a.get("level", 0) > 0}

    def min_ttc(a: int) -> float:
        v = [x for x in tl.true_ttc[a].values() if np.isfinite(x)]
        return min(v) if v else np.inf

    chosen = [a for a in tl.names if a in alerted or tl.danger.get(a) or min_ttc(a) < TTC_PLOT_MAX_S]
    return sorted(chosen, key=lambda a: (min_ttc(a), a))[:MAX_TTC_PANELS]


def ttc_figure(run: RunDir | Path) -> str | None:
    """True TTC (line) and predicted TTC (dots) per actor over time, alerts as vertical lines."""
    tl = _timeline(as_rundir(run))
    actors = _ttc_actors(tl)
    if not actors or not tl.t:
        return None
    plt = pyplot()
    t = np.asarray(tl.t)
    fig, axes = plt.subplots(len(actors), 1, figsize=(9.0, 1.9 * len(actors) + 0.6), sharex=True, squeeze=False)
    for ax, actor in zip(axes[:, 0], actors, strict=True):
        series = np.full(len(t), np.nan)
        for f, v in tl.true_ttc[actor].items():
            series[f] = v
        for f in sorted(tl.danger.get(actor, ())):
            ax.axvspan(t[f] - 0.05, t[f] + 0.05, color="#fde0dc", lw=0)
        ax.plot(t, np.clip(series, 0, TTC_PLOT_MAX_S), color="black", lw=1.5, label="true TTC")
        if tl.pred.get(actor):
            pf, pv = zip(*tl.pred[actor], strict=True)
            ax.scatter(t[list(pf)], np.clip(pv, 0, TTC_PLOT_MAX_S), s=12, color="#1a73e8", zorder=3,
                       label="predicted TTC (matched track)")
        seen: set[str] = set()
        for a in tl.alerts:
            owner = tl.owner(int(a["track_id"]))
            if owner not in (actor, None):
                continue
            level = int(a.get("level", 0))
            name = a.get("level_name") or _LEVEL_NAMES.get(level, str(level))
            tag = f"alert {a.get('kind', '')} {name}" + (" (unassociated)" if owner is None else "")
            ax.axvline(float(a["t"]), color=_LEVEL_COLOURS.get(level, "#9aa0a6"), lw=1.4,
                       ls=":" if owner is None else "--" if level == 0 else
                       "-." if a.get("kind") == "downgrade" else "-",
                       label=None if tag in seen else tag)
            seen.add(tag)
        for c in tl.collisions:
            if c.get("name") == tl.names[actor]:
                ax.axvline(float(c["t"]), color="black", lw=2.0, label="collision")
        ax.set_ylim(0, TTC_PLOT_MAX_S)
        ax.set_ylabel("TTC (s)")
        ax.set_title(f"{tl.names[actor]} (id {actor}); shaded: ground-truth danger", fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    axes[-1, 0].set_xlabel("t (s)")
    axes[-1, 0].set_xlim(0, float(t[-1]) + 0.1)
    fig.suptitle(f"time to collision per actor (capped at {TTC_PLOT_MAX_S:.0f} s)", fontsize=11)
    return png_b64(fig)


def timing_figure(timing: dict) -> str | None:
    """Horizontal bars of per-stage median and p95 ms."""
    stages = [s for s in _STAGE_ORDER if s in timing] + sorted(set(timing) - set(_STAGE_ORDER))
    if not stages:
        return None
    plt = pyplot()
    y = np.arange(len(stages))
    med = [timing[s].get("median") or 0.0 for s in stages]
    p95 = [timing[s].get("p95") or 0.0 for s in stages]
    fig, ax = plt.subplots(figsize=(6.4, 0.35 * len(stages) + 1.2))
    ax.barh(y - 0.2, med, 0.4, color="#1a73e8", label="median")
    ax.barh(y + 0.2, p95, 0.4, color="#f4b400", label="p95")
    ax.set_yticks(y, stages)
    ax.invert_yaxis()
    ax.set_xlabel("ms per camera frame")
    ax.set_title("per-stage timing")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(axis="x", alpha=0.3)
    return png_b64(fig)


# --------------------------------------------------------------------------- HTML pieces












def _section_tables(name: str, sec: dict) -> str:
    """A key/value table of a section's scalars plus tables of its nested parts."""
    scalars = [[k, v] for k, v in sec.items() if not isinstance(v, dict | list)]
    out = [f'<div class="sec"><h3>{escape(name)}</h3>', table(["metric", "value"], scalars) if scalars else ""]
    per_class = sec.get("per_class")
    if isinstance(per_class, dict) and per_class:
        cols = list(dict.fromkeys(k for v in per_class.values() if isinstance(v, dict) for k in v))
        rows = [[c, *[(v or {}).get(k) for k in cols]] for c, v in per_class.items()]
        out.append(table(["class", *cols], rows))
    for key in ("event_list", "onset_list"):  # danger events, AEB brake onsets
        events = sec.get(key)
        if isinstance(events, list) and events:
            cols = list(dict.fromkeys(k for e in events for k in e))
            out.append(table(cols, [[e.get(k) for k in cols] for e in events]))
    out.append("</div>")
    return "".join(out)


def _cards(metrics: dict) -> str:
    d, t, e = metrics.get("detection", {}), metrics.get("tracking", {}), metrics.get("estimation", {})
    i, dg, cl = metrics.get("intent", {}), metrics.get("danger", {}), metrics.get("closed_loop", {})
    exp, aeb = metrics.get("expectations") or [], metrics.get("aeb") or {}
    items = [
        ("detection recall", d.get("recall")), ("detection precision", d.get("precision")),
        ("MOTA", t.get("mota")), ("IDF1", t.get("idf1")),
        ("range rel. error (median)", e.get("range_rel_err_median")),
        ("intent accuracy", i.get("accuracy")), ("intent macro F1", i.get("macro_f1")),
        ("danger events missed", f"{dg.get('missed', '—')} / {dg.get('events', '—')}"),
        ("false alarms / alerts", f"{dg.get('false_alarms', '—')} / {dg.get('alerts', '—')}"),
        ("warning lead time (median s)", dg.get("lead_time_s_median")),
        ("false AEB activations / brake onsets",
         f"{aeb.get('false_activations', '—')} / {aeb.get('brake_onsets', '—')}"),
        *_behaviour_cards(metrics),
        *_outcome_cards(cl, exp),
    ]
    cards = "".join(f'<div class="card"><div class="v">{escape(fmt(v))}</div><div class="k">{escape(k)}</div></div>'
                    for k, v in items)
    return f'<div class="cards">{cards}</div>'


def _behaviour_cards(metrics: dict) -> list[tuple[str, object]]:
    """Behaviour macro-F1, risk accuracy and the CIPV correct-target rate, where scored."""
    b, c = metrics.get("behaviour"), metrics.get("cipv")
    out: list[tuple[str, object]] = []
    if isinstance(b, dict):
        risk = b.get("risk") if isinstance(b.get("risk"), dict) else {}
        out += [("behaviour macro F1", b.get("macro_f1")), ("behaviour accuracy", b.get("accuracy")),
                ("risk-level accuracy", risk.get("accuracy"))]
    if isinstance(c, dict):
        out.append(("CIPV correct target", c.get("correct_rate")))
    return out


def behaviour_html(metrics: dict) -> str:
    """The behaviour section: per class group the behaviour confusion matrix (rows truth), the
    risk-level confusion, the worst behaviours, and the primary target's (CIPV) counts."""
    b, c = metrics.get("behaviour"), metrics.get("cipv")
    if not isinstance(b, dict) and not isinstance(c, dict):
        return ""
    out = ["<h2>Behaviours, risk and the primary target</h2>"]
    if isinstance(b, dict):
        groups = b.get("per_group") if isinstance(b.get("per_group"), dict) else {}
        out.append('<div class="grid">')
        for g, block in groups.items():
            if isinstance(block, dict):
                title = f"{g}: accuracy {fmt(block.get('accuracy'))}, macro F1 {fmt(block.get('macro_f1'))}"
                out.append(confusion_table(block.get("confusion"), title))
        risk = b.get("risk") if isinstance(b.get("risk"), dict) else {}
        out.append(confusion_table(risk.get("confusion"), f"risk level: accuracy {fmt(risk.get('accuracy'))}"))
        out.append("</div>")
        worst = b.get("worst")
        if isinstance(worst, list) and worst and all(isinstance(w, dict) for w in worst):
            out.append("<h3>worst behaviours (F1)</h3>" + table(
                ["group", "behaviour", "f1", "support"],
                [[w.get("group"), w.get("behaviour"), w.get("f1"), w.get("support")] for w in worst]))
    if isinstance(c, dict):
        out.append("<h3>primary target (CIPV)</h3>" + table(
            ["metric", "value"], [[k, v] for k, v in c.items() if not isinstance(v, dict | list)]))
    return "".join(out)


def _outcome_cards(cl: dict, exp: list | dict) -> list[tuple[str, object]]:
    """Collision and expectation cards of a run, or of suite totals (counts)."""
    if "runs" in cl:  # suite totals
        passed = f"{exp.get('total', 0) - exp.get('failed', 0)} / {exp.get('total', 0)}" if exp else None
        return [("runs with a collision", f"{cl.get('collisions')} / {cl.get('runs')}"),
                ("max impact speed (m/s)", cl.get("impact_speed_max")), ("expectations passed", passed)]
    coll = (f"yes, {fmt(cl.get('impact_speed'))} m/s" if cl.get("collision") else "no") if cl else None
    passed = f"{sum(bool(x.get('passed')) for x in exp)} / {len(exp)}" if exp else None
    return [("collision", coll), ("expectations passed", passed)]


def _expectations(exp: list[dict]) -> str:
    if not exp:
        return '<p class="muted">the scenario has no expectations</p>'
    rows = [["PASS" if x["passed"] else "FAIL", fmt(x["expectation"]), x.get("detail", "")] for x in exp]
    classes = ["pass" if x["passed"] else "fail" for x in exp]
    return table(["result", "expectation", "detail"], rows, classes)




def _saved_key_frames(run_dir: Path, records: list[dict]) -> list[str]:
    """Figures of the PNGs in ``frames/`` (captions: file, t, and why from ``key_frames.json``)."""
    paths = sorted((run_dir / "frames").glob("*.png"))[:MAX_KEY_FRAMES]
    if not paths:
        return []
    index = run_dir / "frames" / KEY_FRAMES_INDEX
    try:
        reasons = json.loads(index.read_text(encoding="utf-8")) if index.is_file() else {}
    except (OSError, json.JSONDecodeError):
        reasons = {}
    times = {int(r.get("frame", k)): r["t"] for k, r in enumerate(records)}
    figs = []
    for p in paths:
        digits = "".join(ch for ch in p.stem if ch.isdigit())
        cap = p.name + (f" — t = {times[int(digits)]:.2f} s" if digits and int(digits) in times else "")
        if isinstance(reasons, dict) and reasons.get(p.name):
            cap += f" — {reasons[p.name]}"
        figs.append(figure(p.name, "image/png", p.read_bytes(), cap))
    return figs


def video_key_frames(run_dir: Path, records: list[dict]) -> list[tuple[int, str, bytes]]:
    """(frame index, why, JPEG bytes) of the key frames of ``run_dir/annotated.mp4``, read
    with OpenCV; [] when there is no video or it cannot be read (logged)."""
    path = run_dir / VIDEO_FILE
    if not path.is_file():
        return []
    seen: set[str] = set()
    want: dict[int, str] = {}
    for k, r in enumerate(records):
        kinds = {a.get("kind") for a in r.get("alerts") or []}
        why = key_frame_reason(k, len(records), kinds, bool(r.get("collisions")), seen)
        if why and len(want) < MAX_KEY_FRAMES:
            want[k] = why
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        log.warning("%s: OpenCV cannot read the video; no key frames from it", path)
        return []
    out = []
    try:
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        if n and n != len(records):
            log.warning("%s: %d frames for %d records; key frames may be off", path, n, len(records))
        last = max(want, default=-1)
        k = 0
        while k <= last and cap.grab():
            if k in want:
                ok, img = cap.retrieve()
                enc, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, KEY_FRAME_JPEG_QUALITY]) if ok else (False, None)
                if enc:
                    out.append((int(records[k].get("frame", k)), want[k], buf.tobytes()))
            k += 1
    finally:
        cap.release()
    return out


def _key_frames(run_dir: Path, records: list[dict]) -> str:
    figs = _saved_key_frames(run_dir, records)
    if not figs:
        times = {int(r.get("frame", k)): r["t"] for k, r in enumerate(records)}
        figs = [figure(f"{VIDEO_FILE} frame {f}", "image/jpeg", data,
                        f"{VIDEO_FILE} frame {f}" + (f" — t = {times[f]:.2f} s" if f in times else "") + f" — {why}")
                for f, why, data in video_key_frames(run_dir, records)]
    if not figs:
        return ('<p class="muted">no key frames (frames/*.png from rendered demo runs, or frames of '
                f"{VIDEO_FILE} from a rendered run with --video)</p>")
    return f'<div class="frames">{"".join(figs)}</div>'


def cooperative_section(run_dir: Path, metrics: dict) -> str:
    """The cooperative perception part of a run page ("" for a run without one): the key frame's
    two pictures (``cooperative/panels.png``, ``map.png`` from ``lookahead run --coop-video``,
    ``tools.sinks.cooperative_view``) and ``metrics["cooperative"]`` as tables of whatever keys
    it holds (``html.nested_tables``)."""
    folder = run_dir / COOP_DIR
    pngs = [(folder / name, alt) for name, alt in ((COOP_PANELS, "own / received / fused / matches"),
                                                    (COOP_MAP, "global map")) if (folder / name).is_file()]
    sec = metrics.get("cooperative")
    if not pngs and not isinstance(sec, dict):
        return ""
    out = ["<h2>Cooperative perception</h2>"]
    if pngs:
        why = ""
        try:
            key = json.loads((folder / COOP_KEY_FRAME).read_text())
            why = f"frame {key.get('frame')}, t {fmt(key.get('t'))} s: {key.get('why')}"
        except (OSError, ValueError, AttributeError):
            pass
        out.append('<div class="grid">' + "".join(figure(p.name, "image/png", p.read_bytes(), f"{alt}; {why}")
                                                  for p, alt in pngs) + "</div>")
    else:
        out.append('<p class="muted">no pictures (lookahead run --coop-video draws them)</p>')
    if isinstance(sec, dict) and sec:
        out.append(nested_tables(sec))
    return "".join(out)


def _timing_table(timing: dict) -> str:
    stages = [s for s in _STAGE_ORDER if s in timing] + sorted(set(timing) - set(_STAGE_ORDER))
    rows = [[s, timing[s].get("median"), timing[s].get("p95")] for s in stages]
    return table(["stage", "median ms", "p95 ms"], rows) if rows else ""




# --------------------------------------------------------------------------- run and suite pages


#: metrics.json sections the report reads as mappings
_METRIC_SECTIONS = ("detection", "tracking", "estimation", "intent", "danger", "closed_loop", "aeb", "timing",
                    "behaviour", "cipv")


def check_metrics(path: Path, metrics: dict) -> dict:
    """``metrics`` as read from ``path``, checked for the shapes the report reads; ``ReportError``
    naming the file and the key for another (a hand-edited or foreign ``metrics.json``)."""
    def bad(key: str, what: str, value: object) -> ReportError:
        return ReportError(f"{path}: {key}: expected {what}, got {type(value).__name__}")

    for key in _METRIC_SECTIONS:
        sec = metrics.get(key)
        if sec is not None and not isinstance(sec, dict):
            raise bad(key, "a mapping", sec)
        for sub, val in (sec or {}).items():
            if sub in ("event_list", "onset_list") and val is not None and not (
                    isinstance(val, list) and all(isinstance(e, dict) for e in val)):
                raise bad(f"{key}.{sub}", "a list of mappings", val)
            if sub == "per_class" and val is not None and not (
                    isinstance(val, dict) and all(v is None or isinstance(v, dict) for v in val.values())):
                raise bad(f"{key}.{sub}", "a mapping of mappings", val)
    for stage, val in (metrics.get("timing") or {}).items():
        if not isinstance(val, dict):
            raise bad(f"timing.{stage}", "a mapping", val)
    conf = (metrics.get("intent") or {}).get("confusion")
    if conf is not None:
        if not isinstance(conf, dict):
            raise bad("intent.confusion", "a mapping", conf)
        labels, matrix = conf.get("labels") or [], conf.get("matrix") or []
        n = len(labels) if isinstance(labels, list) else -1
        if n < 0 or not isinstance(matrix, list) or (labels and matrix and not (
                len(matrix) == n and all(isinstance(r, list) and len(r) == n and
                                         all(isinstance(v, int | float) and not isinstance(v, bool) for v in r)
                                         for r in matrix))):
            raise ReportError(f"{path}: intent.confusion: expected labels and a square matrix of counts")
    exp = metrics.get("expectations")
    if exp is not None and not (isinstance(exp, list) and all(isinstance(x, dict) and "passed" in x and "expectation" in x for x in exp)
                                or isinstance(exp, dict)):
        raise bad("expectations", "a list of results (each with passed and expectation)", exp)
    return metrics


def _ensure_metrics(rd: RunDir) -> dict:
    if not rd.has(METRICS_FILE):
        log.info("%s: no metrics.json, scoring first", rd.path)
        return score_run(rd)
    check_text(rd.path / METRICS_FILE)  # a binary one: one line naming it
    return check_metrics(rd.path / METRICS_FILE, rd.read_metrics())


def build_run_report(run: RunDir | Path) -> Path:
    """Write ``report.html`` into a run directory; returns its path. The run's files are
    parsed once (one ``RunDir`` for the scoring, when needed, and every figure)."""
    rd = as_rundir(run)
    run_dir = rd.path
    metrics = _ensure_metrics(rd)
    run = run_record(rd)
    records = ticks_records(rd)
    sc = run.get("scenario") or {}
    summ = run.get("summary") or {}
    name = sc.get("name", run_dir.name)
    sub = (f"seed {run.get('seed', '—')} · {summ.get('frames', len(records))} frames · "
           f"t end {fmt(summ.get('t_end'))} s · renderer {run.get('renderer') or 'none'} · "
           f"config {run.get('config_hash', '—')}")
    order = ("detection", "tracking", "estimation", "intent", "danger", "closed_loop", "aeb", "timing")
    sections = [k for k in order if isinstance(metrics.get(k), dict) and k != "timing"]
    sections += [k for k, v in metrics.items() if isinstance(v, dict) and k not in order
                 and k not in ("cooperative", "behaviour", "cipv")]  # those have their own sections
    body = [
        f"<h1>{escape(name)}</h1>",
        f'<p class="sub">{escape(sc.get("description", ""))}</p><p class="sub">{escape(sub)}</p>',
        _cards(metrics),
        "<h2>Expectations</h2>", _expectations(metrics.get("expectations") or []),
        "<h2>Time to collision</h2>", img(ttc_figure(rd), "TTC over time"),
        "<h2>Intent</h2>", '<div class="grid">',
        img(confusion_figure((metrics.get("intent") or {}).get("confusion") or {}), "intent confusion matrix"),
        "</div>",
        behaviour_html(metrics),
        "<h2>Range estimation</h2>", img(range_error_figure(rd), "range error vs distance"),
        "<h2>Timing</h2>", '<div class="grid">',
        img(timing_figure(metrics.get("timing") or {}), "per-stage timing"),
        _timing_table(metrics.get("timing") or {}),
        "</div>",
        "<h2>Key frames</h2>", _key_frames(run_dir, records),
        cooperative_section(run_dir, metrics),
        "<h2>Metrics</h2>", '<div class="grid">', *[_section_tables(k, metrics[k]) for k in sections], "</div>",
    ]
    out = run_dir / REPORT_FILE
    out.write_text(page(f"lookahead report: {name}", "".join(body)), encoding="utf-8")
    log.info("report written: %s", out)
    return out


_SUITE_COLS = (
    ("recall", "detection", "recall"), ("precision", "detection", "precision"),
    ("MOTA", "tracking", "mota"), ("IDF1", "tracking", "idf1"),
    ("range rel err", "estimation", "range_rel_err_median"), ("speed err m/s", "estimation", "speed_err_median"),
    ("intent acc", "intent", "accuracy"), ("macro F1", "intent", "macro_f1"),
    ("danger events", "danger", "events"), ("missed", "danger", "missed"),
    ("false alarms", "danger", "false_alarms"), ("lead time s", "danger", "lead_time_s_median"),
    ("AEB onsets", "aeb", "brake_onsets"), ("false AEB", "aeb", "false_activations"),
    ("behaviour F1", "behaviour", "macro_f1"), ("CIPV correct", "cipv", "correct_rate"),
)


def _suite_cells(metrics: dict) -> list[tuple[object, str]]:
    """(value, CSS class) cells of one scenario row after the name."""
    cells: list[tuple[object, str]] = [(metrics.get(s, {}).get(k), "") for _, s, k in _SUITE_COLS]
    cl = metrics.get("closed_loop") or {}
    if cl.get("collision"):
        cells.append((f"{cl.get('collided_with')} at {fmt(cl.get('impact_speed'))} m/s", "fail l"))
    else:
        cells.append(("no", "pass l"))
    exp = metrics.get("expectations") or []
    passed = sum(bool(x.get("passed")) for x in exp)
    state = "" if not exp else "pass" if passed == len(exp) else "fail"
    cells.append((f"{passed}/{len(exp)}" if exp else "—", state))
    return cells


def _suite_totals_cells(totals: dict) -> list[tuple[object, str]]:
    cells: list[tuple[object, str]] = [(totals.get(s, {}).get(k), "") for _, s, k in _SUITE_COLS]
    cl, exp = totals.get("closed_loop") or {}, totals.get("expectations") or {}
    cells.append((f"{cl.get('collisions', '—')} of {cl.get('runs', '—')} runs", "l"))
    if isinstance(exp, dict) and exp.get("total"):
        cells.append((f"{exp['total'] - exp.get('failed', 0)}/{exp['total']}", ""))
    else:
        cells.append(("—", ""))
    return cells




def build_suite_report(suite_dir: Path) -> Path:
    """Write each run's report and ``suite_dir/report.html`` (one row per scenario)."""
    suite_dir = Path(suite_dir)
    summary = _read_summary(suite_dir)
    runs = summary.get("runs") or {}
    if not isinstance(runs, dict):
        raise ReportError(f"{suite_dir / SUMMARY_FILE}: runs: expected a mapping, got {type(runs).__name__}")
    rows = []
    for name, entry in runs.items():
        rel = str((entry or {}).get("dir") or name) if isinstance(entry, dict) else str(name)
        target = (suite_dir / rel).resolve()
        if target == suite_dir.resolve() or suite_dir.resolve() not in target.parents:
            raise ReportError(f"{suite_dir / SUMMARY_FILE}: runs.{name}.dir {rel!r:.80} is not a directory inside "
                              f"{suite_dir}; refusing to write a report there")
        rd = RunDir(suite_dir / rel)
        if not rd.has(TICKS_FILE):
            log.warning("%s: run directory missing, skipped", rd.path)
            continue
        build_run_report(rd)
        href = escape(f"{rel}/{REPORT_FILE}")
        cells = _suite_cells(_ensure_metrics(rd))
        rows.append(row(f'<a href="{href}">{escape(name)}</a>', cells, f'<a href="{href}">report</a>'))
    totals = summary.get("totals") or {}
    if totals:
        rows.append(row("TOTAL", _suite_totals_cells(totals), style=' style="font-weight:600"'))
    header = ["scenario", *[c[0] for c in _SUITE_COLS], "collision", "expectations", "report"]
    head = "".join(f'<th class="{"l" if h in ("scenario", "report") else ""}">{escape(h)}</th>' for h in header)
    title = f"suite {summary.get('suite', suite_dir.name)}"
    body = (f"<h1>{escape(title)}</h1><p class=\"sub\">{len(rows) - bool(totals)} scenarios · rendered: "
            f"{escape(fmt(summary.get('render')))} · red: a collision or a failed expectation; "
            "click a scenario for its report</p>"
            f'<table class="suite"><tr>{head}</tr>{"".join(rows)}</table>')
    if totals:
        body += "<h2>Suite totals</h2>" + _cards(totals)
        body += '<div class="grid">' + img(
            confusion_figure((totals.get("intent") or {}).get("confusion") or {}), "suite intent confusion matrix"
        ) + img(timing_figure(totals.get("timing") or {}), "suite per-stage timing") + "</div>"
        body += behaviour_html(totals)
    out = suite_dir / REPORT_FILE
    out.write_text(page(f"lookahead {title}", body), encoding="utf-8")
    log.info("suite report written: %s", out)
    return out


def _read_summary(out_dir: Path) -> dict:
    """``summary.json`` (``read_summary``), a binary one a ``ReportError`` naming it."""
    try:
        return read_summary(out_dir)
    except UnicodeDecodeError:
        raise ReportError(f"{Path(out_dir) / SUMMARY_FILE}: not UTF-8 text (a binary file?)") from None


def build_report(path: Path) -> Path:
    """``report.html`` for a run directory (``ticks.jsonl``) or a suite directory
    (``summary.json``); returns its path. Raises ``ReportError`` for anything else."""
    path = Path(path)
    if not path.is_dir():
        raise ReportError(f"{path}: no such directory")
    if (path / TICKS_FILE).is_file():
        return build_run_report(path)
    if (path / SUMMARY_FILE).is_file():
        _read_summary(path)  # a binary or non-object file: one line naming it, whichever report reads it
        return build_sweep_report(path) if is_sweep_dir(path) else build_suite_report(path)
    raise ReportError(f"{path}: not a run directory (no ticks.jsonl) or a suite directory (no summary.json)")
