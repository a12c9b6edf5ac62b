"""The ``timing`` section: per-stage milliseconds (median, p95) from ``timings.jsonl``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

TIMINGS_FILE = "timings.jsonl"


def load_timings(run_dir: Path) -> dict[str, list[float]]:
    """Per-stage lists of ms; empty when the run has no timings file."""
    path = Path(run_dir) / TIMINGS_FILE
    stages: dict[str, list[float]] = {}
    if not path.is_file():
        return stages
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.strip():
            for k, v in json.loads(line).items():
                stages.setdefault(k, []).append(float(v))
    return stages


def timing_section(stages: dict[str, list[float]]) -> dict[str, dict]:
    return {
        k: {"median": round(float(np.median(v)), 3), "p95": round(float(np.percentile(v, 95)), 3)}
        for k, v in sorted(stages.items()) if v
    }
