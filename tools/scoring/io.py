"""The scorer's typed view of a run directory: ``ticks.jsonl`` as per-frame arrays.

The run directory is read by ``tools.sinks.rundir.RunDir`` (parsed once per ``RunDir``);
``load_run`` turns its records into ``RunData`` and keeps that on the ``RunDir``, so
every scorer (and the report) given the same ``RunDir`` shares one parse. Numbers
are decoded by ``rundir.decode_array``: ``null`` is NaN, the "never" sentinel
(``abs(v) >= NEVER``, e.g. a TTC of never) is +-inf -- consumers that want it as a
large finite number clip to ``NEVER`` themselves. A missing visible box (``null``
or four ``null`` s) becomes a NaN row. Frames are numbered by their position in the
file (0-based), blank lines are skipped.

``metrics.json`` is read, merged and written atomically by ``tools.sinks.rundir``
(``read_metrics``, ``merge_sections``, ``write_metrics``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Label
from lookahead.perception.tracker import TrackState
from lookahead.tools.sinks.rundir import (
    RunDir,
    RunDirError,
    as_rundir,
    decode_array,
)

_CONFIRMED = (TrackState.CONFIRMED.name.lower(), int(TrackState.CONFIRMED))
_LOST = (TrackState.LOST.name.lower(), int(TrackState.LOST))
#: ``intent.labels.Label.INITIALIZING`` (tools may import intent; the value is the contract).
LABEL_INITIALIZING = int(Label.INITIALIZING)
#: Fallback when a run has no assessments: tracks younger than this are initializing.
INIT_FRAMES = IntentConfig().init_frames


@dataclass(frozen=True)
class GTFrame:
    """Ground truth of one frame (N actors), ego frame, SI units."""

    actor_id: np.ndarray  # (N,) int
    class_id: np.ndarray  # (N,) int, -1 = static obstacle
    visible: np.ndarray  # (N, 4) xyxy px, NaN when not visible
    visible_fraction: np.ndarray  # (N,) in [0, 1]
    truncation: np.ndarray  # (N,) share of the amodal box outside the image
    range: np.ndarray  # (N,) m, nearest point's x
    velocity: np.ndarray  # (N, 2) m/s, ground velocity in ego axes
    ttc: np.ndarray  # (N,) s, inf = never
    ettc: np.ndarray | None = None  # (N,) s, enhanced (constant-acceleration) TTC, NaN if not recorded
    decel_req: np.ndarray | None = None  # (N,) m/s^2, the ego's required deceleration, NaN if not recorded


@dataclass(frozen=True)
class DetFrame:
    """Detections of one frame (M rows)."""

    xyxy: np.ndarray  # (M, 4) px
    score: np.ndarray  # (M,)
    class_id: np.ndarray  # (M,) int


@dataclass(frozen=True)
class TrackFrame:
    """Tracks of one frame (K rows); kinematics are NaN when the run has none."""

    track_id: np.ndarray  # (K,) int
    xyxy: np.ndarray  # (K, 4) px
    class_id: np.ndarray  # (K,) int
    score: np.ndarray  # (K,)
    confirmed: np.ndarray  # (K,) bool, state == confirmed
    range: np.ndarray  # (K,) m
    ground_velocity: np.ndarray  # (K, 2) m/s, ground_vx, ground_vy
    ttc: np.ndarray  # (K,) s, inf = never
    reported: np.ndarray  # (K,) bool, state confirmed or lost (coasting): what the system outputs
    initializing: np.ndarray  # (K,) bool, intent label ``initializing`` (or age < init_frames)
    ettc: np.ndarray | None = None  # (K,) s, the assessment's enhanced TTC, NaN if not recorded
    decel_req: np.ndarray | None = None  # (K,) m/s^2, the assessment's required deceleration

    def __getitem__(self, index: np.ndarray) -> TrackFrame:
        return TrackFrame(**{k: None if v is None else v[index] for k, v in self.__dict__.items()})


@dataclass(frozen=True)
class RunData:
    """All frames of a run; ``tracks`` is None when no frame carries tracks."""

    gt: list[GTFrame]
    dets: list[DetFrame]
    tracks: list[TrackFrame] | None

    def __len__(self) -> int:
        return len(self.gt)


def _array(obj: dict, key: str, n: int, cols: int | None, where: str, required: bool) -> np.ndarray:
    """``obj[key]`` as a float array of shape (n,) or (n, cols); NaN-filled if optional and absent."""
    shape = (n,) if cols is None else (n, cols)
    value = obj.get(key)
    if value is None:
        if required:
            raise RunDirError(f"{where}.{key}: missing")
        return np.full(shape, np.nan)
    if not isinstance(value, list):
        raise RunDirError(f"{where}.{key}: expected a list, got {type(value).__name__}")
    if cols is not None:
        value = [[None] * cols if row is None else row for row in value]
    try:
        arr = decode_array(value)
    except (TypeError, ValueError):
        raise RunDirError(f"{where}.{key}: expected numbers (null allowed)") from None
    if arr.size == 0 and n == 0:
        return np.zeros(shape)
    if arr.shape != shape:
        what = f"{n}" if cols is None else f"{n}x{cols}"
        raise RunDirError(f"{where}.{key}: expected {what} values, got shape {arr.shape}")
    return arr


def _length(obj: dict, key: str, where: str) -> int:
    value = obj.get(key)
    if not isinstance(value, list):
        raise RunDirError(f"{where}.{key}: missing or not a list")
    return len(value)


def _ints(arr: np.ndarray, where: str) -> np.ndarray:
    if not np.all(np.isfinite(arr)):
        raise RunDirError(f"{where}: expected integers, found null")
    return arr.astype(np.int64)


def _parse_gt(obj: Any, where: str) -> GTFrame:
    if not isinstance(obj, dict):
        raise RunDirError(f"{where}: expected an object")
    n = _length(obj, "actor_id", where)

    def a(key: str, cols: int | None = None, req: bool = False) -> np.ndarray:
        return _array(obj, key, n, cols, where, req)

    return GTFrame(
        actor_id=_ints(a("actor_id", req=True), f"{where}.actor_id"),
        class_id=_ints(a("class_id", req=True), f"{where}.class_id"),
        visible=a("visible", 4, req=True),
        visible_fraction=a("visible_fraction", req=True),
        truncation=a("truncation"),
        range=a("range"),
        velocity=a("velocity", 2),
        ttc=a("ttc"),
        ettc=a("ettc"),
        decel_req=a("decel_req"),
    )


def _parse_dets(obj: Any, where: str) -> DetFrame:
    if obj is None:
        return DetFrame(np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=np.int64))
    if not isinstance(obj, dict):
        raise RunDirError(f"{where}: expected an object or null")
    n = _length(obj, "xyxy", where)
    return DetFrame(
        xyxy=_array(obj, "xyxy", n, 4, where, True),
        score=_array(obj, "score", n, None, where, True),
        class_id=_ints(_array(obj, "class_id", n, None, where, True), f"{where}.class_id"),
    )


def _initializing(assessments: Any, age: np.ndarray, n: int) -> np.ndarray:
    """Rows labelled ``initializing`` by the run's intent stage; ``age < INIT_FRAMES`` without one."""
    label = assessments.get("label") if isinstance(assessments, dict) else None
    if isinstance(label, list) and len(label) == n:
        try:
            lab = np.array([np.nan if v is None else v for v in label], dtype=np.float64)
        except (TypeError, ValueError):
            lab = None
        if lab is not None:
            return lab == LABEL_INITIALIZING
    return age < INIT_FRAMES


def _parse_tracks(obj: Any, where: str, assessments: Any = None) -> TrackFrame | None:
    if obj is None:
        return None
    if not isinstance(obj, dict):
        raise RunDirError(f"{where}: expected an object or null")
    n = _length(obj, "track_id", where)

    def a(key: str, cols: int | None = None, req: bool = False) -> np.ndarray:
        return _array(obj, key, n, cols, where, req)

    state = obj.get("state")
    if not isinstance(state, list) or len(state) != n:
        raise RunDirError(f"{where}.state: expected {n} values")
    age = a("age")
    confirmed = np.array([s in _CONFIRMED for s in state], dtype=bool)
    return TrackFrame(
        track_id=_ints(a("track_id", req=True), f"{where}.track_id"),
        xyxy=a("xyxy", 4, req=True),
        class_id=_ints(a("class_id", req=True), f"{where}.class_id"),
        score=a("score"),
        confirmed=confirmed,
        range=a("range"),
        ground_velocity=np.column_stack([a("ground_vx"), a("ground_vy")]),
        ttc=a("ttc"),
        reported=confirmed | np.array([s in _LOST for s in state], dtype=bool),
        initializing=_initializing(assessments, age, n),
        ettc=_assessed(assessments, "ettc", n, where),
        decel_req=_assessed(assessments, "decel_req", n, where),
    )


def _assessed(assessments: Any, key: str, n: int, where: str) -> np.ndarray:
    """The assessment field ``key`` of a frame's n track rows (NaN when not recorded)."""
    if not isinstance(assessments, dict) or not isinstance(assessments.get(key), list):
        return np.full(n, np.nan)
    return _array(assessments, key, n, None, f"{where}.assessments", False)


def _empty_tracks() -> TrackFrame:
    z = np.zeros(0)
    zi = np.zeros(0, dtype=np.int64)
    zb = np.zeros(0, dtype=bool)
    return TrackFrame(zi, np.zeros((0, 4)), zi, z, zb, z, np.zeros((0, 2)), z, zb, zb)


def load_run(run: RunDir | Path) -> RunData:
    """The frames of a run directory's ``ticks.jsonl`` (kept on the ``RunDir``: built once).

    Raises:
        FileNotFoundError / NotADirectoryError: no such run directory or no ticks file.
        RunDirError: a line that is not a JSON object or whose arrays are malformed
            (message ``<file>:<line>: ...``).
    """
    return as_rundir(run).derived("scoring.RunData", _build_run)


def _build_run(rd: RunDir) -> RunData:
    gts: list[GTFrame] = []
    dets: list[DetFrame] = []
    tracks: list[TrackFrame | None] = []
    for i, rec in enumerate(rd.ticks):
        where = rd.where(i)
        gts.append(_parse_gt(rec.get("ground_truth"), f"{where}: ground_truth"))
        dets.append(_parse_dets(rec.get("detections"), f"{where}: detections"))
        tracks.append(_parse_tracks(rec.get("tracks"), f"{where}: tracks", rec.get("assessments")))
    has_tracks = any(t is not None for t in tracks)
    return RunData(
        gt=gts,
        dets=dets,
        tracks=[t if t is not None else _empty_tracks() for t in tracks] if has_tracks else None,
    )


def concat_runs(runs: list[RunData]) -> RunData:
    """One long run made of several, with actor and track ids kept apart (offset per run).

    Scoring the concatenation gives suite totals whose counts are the sums over
    the runs and whose rates and medians are recomputed over all frames.
    """
    offset = 10**6

    def shift_gt(g: GTFrame, k: int) -> GTFrame:
        return GTFrame(**{**g.__dict__, "actor_id": g.actor_id + k * offset})

    def shift_tracks(t: TrackFrame, k: int) -> TrackFrame:
        return TrackFrame(**{**t.__dict__, "track_id": t.track_id + k * offset})

    any_tracks = any(r.tracks is not None for r in runs)
    gts, dets, tracks = [], [], []
    for k, r in enumerate(runs):
        gts += [shift_gt(g, k) for g in r.gt]
        dets += r.dets
        if any_tracks:
            frames = r.tracks if r.tracks is not None else [_empty_tracks() for _ in r.gt]
            tracks += [shift_tracks(t, k) for t in frames]
    return RunData(gt=gts, dets=dets, tracks=tracks if any_tracks else None)
