"""Regression gate: a suite's totals against a committed baseline, metric by metric.

A metric *regresses* when it moves in its bad direction by more than its
tolerance; the gate prints a Markdown table of every metric that moved and
exits 1 on any regression. ``--update-baseline`` writes the current values.

A metric the baseline file does not name (a file written before the metric existed)
is compared with ``ASSUMED_BASELINE``'s value when it has one, and is otherwise listed
without a verdict: ``aeb.false_activations`` is assumed 0, so a baseline that predates
AEB scoring still fails on the first false AEB activation.

Metrics of an optional totals block (``OPTIONAL_SECTIONS``: ``cooperative``, present only
when some run of the suite has other cameras; ``behaviour`` and ``cipv``, absent from totals
pooled from metrics scored before they existed) are left out of ``flatten`` -- and so of a
baseline written with ``--update-baseline`` -- when the block is absent, so suites without
them flatten and write exactly as before; they are gated only when the baseline has them (a
baseline written before them lists them without a verdict).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

#: metric path -> (direction, tolerance): "up" = higher is better; the tolerance is absolute.
TOLERANCES: dict[str, tuple[str, float]] = {
    "detection.precision": ("up", 0.02),
    "detection.recall": ("up", 0.02),
    "detection.ap50": ("up", 0.02),
    "tracking.mota": ("up", 0.02),
    "tracking.idf1": ("up", 0.02),
    "tracking.id_switches": ("down", 2),
    "estimation.range_rel_err_median": ("down", 0.01),
    "estimation.speed_err_median": ("down", 0.1),
    "estimation.ttc_err_median": ("down", 0.02),
    "intent.accuracy": ("up", 0.02),
    "intent.macro_f1": ("up", 0.02),
    "danger.miss_rate": ("down", 0.0),
    "danger.false_alarm_rate": ("down", 0.02),
    "danger.lead_time_s_median": ("up", 0.2),
    "closed_loop.collisions": ("down", 0),
    "expectations.failed": ("down", 0),
    "aeb.false_activations": ("down", 0),
    "cooperative.matching_precision": ("up", 0.02),
    "cooperative.matching_recall": ("up", 0.02),
    "cooperative.occluded_recall_fused": ("up", 0.02),
    "cooperative.lead_time_median_s_fusion": ("up", 0.2),
    "cooperative.missed_fusion": ("down", 0),
    "behaviour.accuracy": ("up", 0.02),
    "behaviour.macro_f1": ("up", 0.02),
    "cipv.correct_rate": ("up", 0.01),
}

#: totals blocks that only some suites have: their metrics are not flattened when the block is absent.
OPTIONAL_SECTIONS = frozenset({"cooperative", "behaviour", "cipv"})

#: metric path -> the value a baseline that lacks the metric is taken to have.
ASSUMED_BASELINE: dict[str, float] = {"aeb.false_activations": 0}


def flatten(totals: dict) -> dict[str, float | None]:
    """The watched metrics of a suite's ``totals``."""
    out: dict[str, float | None] = {}
    for path in TOLERANCES:
        section, key = path.split(".", 1)
        if section in OPTIONAL_SECTIONS and not isinstance(totals.get(section), dict):
            continue
        out[path] = (totals.get(section) or {}).get(key)
    return out


def compare(current: dict[str, float | None], baseline: dict[str, float | None],
            tolerances: dict[str, tuple[str, float]] | None = None) -> list[dict]:
    """One row per metric: baseline, current, delta, and whether it regressed (a metric
    absent from ``baseline`` takes its ``ASSUMED_BASELINE`` value, row ``assumed``)."""
    tol = {**TOLERANCES, **(tolerances or {})}
    rows = []
    for path, (direction, limit) in tol.items():
        assumed = path not in baseline and path in ASSUMED_BASELINE
        base = ASSUMED_BASELINE[path] if assumed else baseline.get(path)
        cur = current.get(path)
        if base is None and cur is None:
            continue
        if base is None or cur is None:
            rows.append({"metric": path, "baseline": base, "current": cur, "delta": None,
                         "regressed": base is not None, "tolerance": limit, "direction": direction})
            continue
        delta = cur - base
        worse = -delta if direction == "up" else delta
        rows.append({"metric": path, "baseline": base, "current": cur, "delta": delta,
                     "regressed": worse > limit + 1e-12, "tolerance": limit, "direction": direction,
                     **({"assumed": True} if assumed else {})})
    return rows


def markdown(rows: list[dict], only_moved: bool = True) -> str:
    def f(v: object) -> str:
        return "—" if v is None else f"{v:.4g}" if isinstance(v, float) else str(v)

    lines = ["| metric | baseline | current | change | tolerance | verdict |", "|---|---|---|---|---|---|"]
    for r in rows:
        if only_moved and r["delta"] == 0 and not r["regressed"]:
            continue
        verdict = "**REGRESSED**" if r["regressed"] else "ok"
        sign = "" if r["delta"] is None else ("+" if r["delta"] >= 0 else "")
        better = "higher is better" if r["direction"] == "up" else "lower is better"
        base = f(r["baseline"]) + (" (assumed)" if r.get("assumed") else "")
        lines.append(f"| {r['metric']} | {base} | {f(r['current'])} | {sign}{f(r['delta'])} "
                     f"| {f(r['tolerance'])} ({better}) | {verdict} |")
    if len(lines) == 2:
        lines.append("| (nothing moved) | | | | | |")
    return "\n".join(lines)


class BaselineError(ValueError):
    """A baseline file that cannot be used; one line."""


MAX_BASELINE_BYTES = 16 * 2**20


def load_baseline(path: Path) -> dict:
    try:
        if Path(path).stat().st_size > MAX_BASELINE_BYTES:
            raise BaselineError(f"{path}: more than {MAX_BASELINE_BYTES} bytes, not a baseline")
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such baseline file (create it with --update-baseline)") from None
    except json.JSONDecodeError as e:
        raise BaselineError(f"{path}:{e.lineno}: baseline is not valid JSON ({e.msg})") from None
    except UnicodeDecodeError as e:
        raise BaselineError(f"{path}: baseline is not UTF-8 text (byte {e.start})") from None
    except RecursionError:
        raise BaselineError(f"{path}: baseline JSON is nested too deeply") from None
    if not isinstance(data, dict) or not isinstance(data.get("metrics"), dict):
        raise BaselineError(f"{path}: baseline needs a 'metrics' mapping")
    for key, v in data["metrics"].items():  # null: the metric had no value (no such objects)
        if v is not None and (isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)):
            raise BaselineError(f"{path}: metrics.{key}: expected a finite number or null, got {v!r:.40}")
    tolerances = data.get("tolerances", {})
    if not isinstance(tolerances, dict):
        raise BaselineError(f"{path}: tolerances: expected a mapping of metric -> [up|down, limit]")
    for key, v in tolerances.items():
        if not (isinstance(v, list) and len(v) == 2 and v[0] in ("up", "down") and isinstance(v[1], int | float)
                and not isinstance(v[1], bool) and math.isfinite(v[1]) and v[1] >= 0):
            raise BaselineError(f"{path}: tolerances.{key}: expected [up|down, limit >= 0], got {v!r:.40}")
    return data


def write_baseline(path: Path, suite: str, metrics: dict) -> None:
    tol = {k: list(v) for k, v in TOLERANCES.items()
           if k.split(".", 1)[0] not in OPTIONAL_SECTIONS or k in metrics}
    Path(path).write_text(json.dumps({"suite": suite, "metrics": metrics, "tolerances": tol}, indent=2) + "\n")
