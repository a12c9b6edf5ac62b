"""The ``timing`` section: per-stage milliseconds (median, p95) from ``timings.jsonl``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lookahead.tools.sinks.rundir import TIMINGS_FILE as TIMINGS_FILE  # re-exported
from lookahead.tools.sinks.rundir import RunDir, as_rundir


def load_timings(run: RunDir | Path) -> dict[str, list[float]]:
    """Per-stage lists of ms (``RunDir.timings``); empty when the run has no timings file."""
    stages: dict[str, list[float]] = {}
    for line in as_rundir(run).timings:
        for k, v in line.items():
            stages.setdefault(k, []).append(v)
    return stages


def timing_section(stages: dict[str, list[float]]) -> dict[str, dict]:
    return {
        k: {"median": round(float(np.median(v)), 3), "p95": round(float(np.percentile(v, 95)), 3)}
        for k, v in sorted(stages.items()) if v
    }
