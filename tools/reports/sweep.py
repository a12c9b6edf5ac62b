"""The sweep page: ``SWEEP_DIR/report.html`` with metric-vs-parameter plots and a variant table.

Built by ``lookahead sweep`` at the end and by ``lookahead report SWEEP_DIR``, from
``summary.json`` alone (the key metrics of every done variant; nothing is re-scored).
One figure per x parameter (the sweep file's ``report.x``, default every parameter
with at least two distinct numeric values), one panel per metric (``report.metrics``,
default ``DEFAULT_METRICS`` that have data); the variants are points, split into
series by ``report.split`` (default: the first other parameter with bool values,
else with at most ``MAX_SERIES`` distinct values), and each series' line joins its
mean per x value (solid), or, for more than ``MAX_LINE_VALUES`` distinct values
(random samples), its mean per bin of ``TREND_BINS`` equal-width bins (dashed).
The figures are also written as ``plots/<x>.png``. Same self-contained style and
helpers as ``tools.reports.report``.
"""

from __future__ import annotations

import base64
import json
import logging
import math
import re
from pathlib import Path
from typing import Any

from lookahead.tools.reports.html import REPORT_FILE, escape, fmt, img, page, png_b64, pyplot, row
from lookahead.tools.sinks.rundir import is_number, read_summary

log = logging.getLogger(__name__)

DEFAULT_METRICS = (
    "closed_loop.impact_speed", "closed_loop.min_ttc", "danger.lead_time_s_median",
    "detection.recall", "tracking.mota", "intent.macro_f1",
)
UNITS = {"closed_loop.impact_speed": "m/s", "closed_loop.min_ttc": "s", "danger.lead_time_s_median": "s",
         "closed_loop.aeb_active_s": "s", "estimation.speed_err_median": "m/s"}
TABLE_METRICS = ("closed_loop.collision", "closed_loop.impact_speed", "closed_loop.min_ttc",
                 "danger.lead_time_s_median", "detection.recall", "tracking.mota")
MAX_SERIES = 6
MAX_LINE_VALUES = 8  # more distinct x values than this: a binned trend (dashed) instead
TREND_BINS = 5
_COLOURS = ("#1a73e8", "#d93025", "#188038", "#f29900", "#a142f4", "#5f6368")


def is_sweep_dir(path: Path) -> bool:
    try:
        data = read_summary(Path(path))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and "sweep" in data and "variants" in data


def _num(v: Any) -> float | None:
    if isinstance(v, bool):
        return float(v)
    if is_number(v):  # finite, not the "never" sentinel
        return float(v)
    return None


def _key(v: Any) -> str:
    return json.dumps(v, sort_keys=True)


def numeric_params(params: list[str], done: list[dict]) -> list[str]:
    out = []
    for p in params:
        vals = [v["params"].get(p) for v in done]
        if all(isinstance(x, int | float) and not isinstance(x, bool) for x in vals) and len(set(vals)) >= 2:
            out.append(p)
    return out


def default_split(params: list[str], done: list[dict], x: str) -> str | None:
    others = [p for p in params if p != x]
    distinct = {p: {_key(v["params"].get(p)) for v in done} for p in others}
    for p in others:
        if all(isinstance(v["params"].get(p), bool) for v in done) and len(distinct[p]) > 1:
            return p
    for p in others:
        if 1 < len(distinct[p]) <= MAX_SERIES:
            return p
    return None


def _label(value: Any) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    return fmt(value)


def _trend(pts: list[tuple[float, float]]) -> tuple[list[float], list[float]]:
    """Mean per x value; with more than ``MAX_LINE_VALUES`` distinct x (random samples),
    the mean per bin of ``TREND_BINS`` equal-width bins at the bins' mean x."""
    xs = sorted({a for a, _ in pts})
    if len(xs) <= MAX_LINE_VALUES:
        return xs, [sum(b for a, b in pts if a == x) / sum(1 for a, _ in pts if a == x) for x in xs]
    lo, hi = xs[0], xs[-1]
    width = (hi - lo) / TREND_BINS
    bins: dict[int, list[tuple[float, float]]] = {}
    for a, b in pts:
        bins.setdefault(min(TREND_BINS - 1, int((a - lo) / width)), []).append((a, b))
    keys = sorted(bins)
    return ([sum(a for a, _ in bins[k]) / len(bins[k]) for k in keys],
            [sum(b for _, b in bins[k]) / len(bins[k]) for k in keys])


def metric_figure(done: list[dict], x: str, metrics: list[str], split: str | None):
    """Matplotlib figure: one panel per metric vs parameter ``x``, series by ``split``."""
    plt = pyplot()
    cols = 2 if len(metrics) in (2, 4) else min(3, len(metrics))
    rows = math.ceil(len(metrics) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 3.4 * rows), squeeze=False)
    series: dict[str, list[dict]] = {}
    for v in done:
        series.setdefault(_key(v["params"].get(split)) if split else "", []).append(v)
    def rank(k: str) -> tuple:
        v = json.loads(k) if k else None
        return (v is None, not isinstance(v, int | float), v if isinstance(v, int | float) else str(v))

    order = sorted(series, key=rank)
    binned = False
    for i, m in enumerate(metrics):
        ax = axes[i // cols][i % cols]
        for j, k in enumerate(order):
            colour = _COLOURS[j % len(_COLOURS)]
            pts = [(float(v["params"][x]), _num(v["metrics"].get(m))) for v in series[k]]
            pts = [(a, b) for a, b in pts if b is not None]
            if not pts:
                continue
            label = f"{split} = {_label(json.loads(k))}" if split else None
            ax.scatter([a for a, _ in pts], [b for _, b in pts], s=22, alpha=0.55, color=colour, label=label)
            xs, means = _trend(pts)
            per_value = len(xs) == len({a for a, _ in pts})
            binned |= not per_value
            if len(xs) > 1:
                ax.plot(xs, means, color=colour, lw=1.6, ls="-" if per_value else "--")
        unit = UNITS.get(m)
        ax.set_title(m, fontsize=10)
        ax.set_xlabel(x)
        ax.set_ylabel(f"{m.split('.')[-1]}" + (f" ({unit})" if unit else ""))
        ax.grid(alpha=0.3)
        if split and i == 0:
            ax.legend(fontsize=8)
    for i in range(len(metrics), rows * cols):
        axes[i // cols][i % cols].axis("off")
    fig.suptitle(f"metrics vs {x}" + (f", split by {split}" if split else "")
                 + (" (dashed: mean per x bin)" if binned else " (lines: mean per value)"), fontsize=11)
    fig.tight_layout()
    return fig


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_") or "param"


def build_sweep_report(sweep_dir: Path) -> Path:
    """Write ``sweep_dir/report.html`` (and ``plots/*.png``); returns the page's path."""
    sweep_dir = Path(sweep_dir)
    summary = read_summary(sweep_dir)
    variants: dict[str, dict] = summary.get("variants") or {}
    params: list[str] = summary.get("parameters") or []
    rep = summary.get("report") or {}
    done = [v for v in variants.values() if v.get("status") == "done"]
    metrics = rep.get("metrics") or [m for m in DEFAULT_METRICS
                                     if any(_num(v["metrics"].get(m)) is not None for v in done)]
    xs = [x for x in (rep.get("x") or numeric_params(params, done)) if x in params]
    figs = []
    plots = sweep_dir / "plots"
    for x in xs:
        pts = [v for v in done if _num(v["params"].get(x)) is not None]
        if not pts or not metrics:
            figs.append(img(None, f"metrics vs {x}"))
            continue
        split = rep.get("split") if rep.get("split") in params and rep.get("split") != x else None
        split = split or default_split(params, pts, x)
        b64 = png_b64(metric_figure(pts, x, metrics, split))
        plots.mkdir(exist_ok=True)
        (plots / f"{_safe(x)}.png").write_bytes(base64.b64decode(b64))
        figs.append(img(b64, f"metrics vs {x}"))

    counts = summary.get("counts") or {}
    cl = (summary.get("totals") or {}).get("closed_loop") or {}
    cards = [("variants", counts.get("variants")), ("done", counts.get("done")), ("failed", counts.get("failed")),
             ("ran this time", counts.get("ran")), ("skipped (already done)", counts.get("skipped")),
             ("runs with a collision", f"{cl.get('collisions', '—')} / {cl.get('runs', '—')}"),
             ("max impact speed (m/s)", cl.get("impact_speed_max"))]
    card_html = "".join(f'<div class="card"><div class="v">{escape(fmt(v))}</div><div class="k">{escape(k)}</div></div>'
                        for k, v in cards)
    header = ["variant", *params, *TABLE_METRICS, "status"]
    head = "".join(f'<th class="{"l" if h in ("variant", "status") else ""}">{escape(h)}</th>' for h in header)
    rows = []
    for vid, v in variants.items():
        href = escape(f"{v.get('dir', vid)}/")
        cells: list[tuple[object, str]] = [(v["params"].get(p), "" if _num(v["params"].get(p)) is not None else "l")
                                           for p in params]
        m = v.get("metrics") or {}
        cells += [(m.get(k), "") for k in TABLE_METRICS]
        if v.get("status") == "done":
            last = "done" + (" (earlier run)" if v.get("skipped") else "")
            style = ""
        else:
            last = f"failed: {escape(v.get('error', ''))}"
            style = ' class="fail"'
        rows.append(row(f'<a href="{href}">{escape(vid)}</a>', cells, last, style))
    title = f"sweep {summary.get('sweep', sweep_dir.name)}"
    sub = (f"{escape(summary.get('description', ''))}<br>base scenario {escape(summary.get('scenario', ''))} · "
           f"parameters: {escape(', '.join(params) or 'none')} · rendered: {escape(fmt(summary.get('render')))} · "
           f"backend {escape(summary.get('backend', '—'))}, {escape(summary.get('workers', '—'))} worker(s), "
           f"{escape(fmt(summary.get('elapsed_s')))} s · store {escape(summary.get('db', ''))}")
    body = (f"<h1>{escape(title)}</h1><p class=\"sub\">{sub}</p><div class=\"cards\">{card_html}</div>"
            "<h2>Metrics vs parameters</h2>" + ("".join(figs) or '<p class="muted">no numeric parameter to plot</p>')
            + "<h2>Variants</h2><p class=\"sub\">click a variant for its run directory "
            "(<code>lookahead report</code> it for the run page)</p>"
            f'<table class="suite"><tr>{head}</tr>{"".join(rows)}</table>')
    out = sweep_dir / REPORT_FILE
    out.write_text(page(f"lookahead {title}", body), encoding="utf-8")
    log.info("sweep report written: %s", out)
    return out
