"""The primary target (CIPV, *closest in-path vehicle/object*): the one object forward-collision
warning and ACC act on in single-target mode (the CARLA study's).

Definition (one pure function, ``select_cipv``, for predictions and ground truth alike):
among the given objects, those flagged in path (``Assessment.in_path``: in the ego corridor now
or within the prediction window, ``intent.labels.in_path``) with a finite range (the nearest
point's x, m); the one with the smallest range; ties by the smaller id. None when no object
qualifies.

Predictions: the ego camera's reported tracks (the tracker's output: confirmed and briefly
coasting tracks; tentative ones are never output), their estimated range and the assessment's
in-path flag; ``initializing`` tracks count (the AEB's nearest in-path range uses them too).
Ground truth (``sim.runner``): actors of a detection class (``class_id`` >= 0) with a visible
box, their true ``range`` and ``in_path``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Cipv:
    """The primary target: its id (track id or actor id) and range (m); both None without one."""

    id: int | None = None
    range: float | None = None


def select_cipv(ids: np.ndarray, ranges: np.ndarray, in_path: np.ndarray,
                eligible: np.ndarray | None = None) -> Cipv:
    """The closest in-path object of ``ids`` (N,) with ``ranges`` (N,) m and ``in_path`` (N,) bool;
    ``eligible`` (N,) bool restricts the candidates further (default all). Smallest finite range
    wins, ties by the smaller id; ``Cipv()`` when none qualifies."""
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    r = np.asarray(ranges, dtype=np.float64).reshape(-1)
    ok = np.asarray(in_path, dtype=bool).reshape(-1) & np.isfinite(r)
    if eligible is not None:
        ok &= np.asarray(eligible, dtype=bool).reshape(-1)
    if not ok.any():
        return Cipv()
    rows = np.flatnonzero(ok)
    best = rows[np.lexsort((ids[rows], r[rows]))[0]]  # by range, then id
    return Cipv(int(ids[best]), float(r[best]))
