"""CLI bodies for ``lookahead track`` and ``lookahead eval-mot`` (wired into typer by tools.cli).

Each returns a process exit code: 0 on success, 2 on bad input after printing
one ``error: ...`` line to stderr (no traceback).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rich.console import Console
from rich.table import Table

from lookahead.tools.scoring.mot_eval import evaluate_mot, resolve_frame_rate, run_tracker_on_mot

_FORMATS = ("table", "json")
_TABLE_KEYS = (
    ("hota", "HOTA", "{:.3f}"),
    ("mota", "MOTA", "{:.3f}"),
    ("motp", "MOTP", "{:.3f}"),
    ("idf1", "IDF1", "{:.3f}"),
    ("id_switches", "ID switches", "{}"),
    ("fp", "FP", "{}"),
    ("fn", "FN", "{}"),
    ("mostly_tracked", "Mostly tracked", "{}"),
    ("mostly_lost", "Mostly lost", "{}"),
    ("fragmentations", "Fragmentations", "{}"),
    ("num_gt_ids", "GT ids", "{}"),
    ("num_tracker_ids", "Tracker ids", "{}"),
)


def _fail(message: str) -> int:
    print(f"error: {message}", file=sys.stderr)
    return 2


def _describe(exc: Exception) -> str:
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"cannot read {exc.filename}: {exc.strerror or exc}"
    return str(exc)


def track_command(det: Path, out: Path, frame_rate: float | None = None) -> int:
    """Track a MOTChallenge det.txt into a tracks file; print the frame rate used and a summary.

    ``frame_rate`` None: ``frameRate`` of the sequence's ``seqinfo.ini`` (beside
    det.txt or one directory up, i.e. ``<seq>/det/det.txt`` -> ``<seq>/seqinfo.ini``),
    else ``DEFAULT_MOT_FRAME_RATE`` (30) with a ``warning:`` line on stderr.
    """
    if frame_rate is not None and not frame_rate > 0:
        return _fail(f"--frame-rate must be positive, got {frame_rate}")
    try:
        rate, source, info = resolve_frame_rate(det, frame_rate)
        if source == "default":
            where = "has no frameRate" if info is not None else "found beside or above it"
            what = f"{info.path} {where}" if info is not None else f"no seqinfo.ini {where}"
            print(
                f"warning: {det}: {what}; assuming {rate:g} fps (pass --frame-rate to set it)",
                file=sys.stderr,
            )
        elif source == "--frame-rate" and info is not None and info.frame_rate not in (None, rate):
            print(f"warning: --frame-rate {rate:g} overrides frameRate={info.frame_rate:g} of {info.path}",
                  file=sys.stderr)
        summary = run_tracker_on_mot(det, out, frame_rate=rate)
    except (OSError, ValueError) as exc:
        return _fail(_describe(exc))
    origin = {"--frame-rate": "from --frame-rate", "default": "default"}.get(source, f"from {source}")
    print(f"frame rate: {rate:g} fps ({origin})")
    print(
        f"wrote {out}: {summary['track_rows']} rows, {summary['tracks']} tracks over "
        f"{summary['frames']} frames ({summary['dropped_detections']} invalid detections dropped)"
    )
    return 0


def eval_mot_command(gt: Path, tracks: Path, fmt: str = "table") -> int:
    """Evaluate a tracks file against gt.txt; print a rich table or JSON."""
    if fmt not in _FORMATS:
        return _fail(f"--format must be one of {', '.join(_FORMATS)}, got {fmt!r}")
    try:
        metrics = evaluate_mot(gt, tracks)
    except (OSError, ValueError) as exc:
        return _fail(_describe(exc))
    if fmt == "json":
        print(json.dumps(metrics, indent=2, sort_keys=True))
        return 0
    table = Table(title=f"{tracks} vs {gt}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, label, spec in _TABLE_KEYS:
        table.add_row(label, spec.format(metrics[key]))
    Console().print(table)
    return 0
