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
    METRICS_FILE,
    RUN_FILE,
    TICKS_FILE,
    TIMINGS_FILE,
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
    class_id: np.ndarray  # (N,) int, -1 = no detection class (obstacles in runs recorded before they were one)
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


def _not_text(path: Path) -> RunDirError:
    """The error for a file that is not UTF-8 text: its first such line named (``file:line``)."""
    try:
        with path.open("rb") as fh:
            for lineno, line in enumerate(fh, start=1):
                try:
                    line.decode("utf-8")
                except UnicodeDecodeError:
                    return RunDirError(f"{path}:{lineno}: not UTF-8 text (a binary file?)")
    except OSError:
        pass
    return RunDirError(f"{path}: not UTF-8 text (a binary file?)")


def ticks_records(run: RunDir | Path) -> list[dict]:
    """``RunDir.ticks``, with a binary ``ticks.jsonl`` a ``RunDirError`` naming the file and line."""
    rd = as_rundir(run)
    try:
        return rd.ticks
    except UnicodeDecodeError:
        raise _not_text(rd.path / TICKS_FILE) from None


def check_text(path: Path) -> None:
    """``RunDirError`` naming ``path`` and its first such line when it exists and is not UTF-8 text
    (for the small files of a run directory read elsewhere: ``metrics.json``, ``timings.jsonl``)."""
    try:
        data = Path(path).read_bytes()
    except (FileNotFoundError, IsADirectoryError, NotADirectoryError):
        return
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        raise _not_text(Path(path)) from None


#: run.json's keys read as mappings (``scenario.ego``: a key of ``scenario``), and lists
_RUN_MAPPINGS = ("scenario", "summary", "replay")
_SCENARIO_MAPPINGS = ("ego", "camera", "perception")
_SCENARIO_LISTS = ("expect", "actors")
_SCENARIO_TEXT = ("name", "description")


def run_record(run: RunDir | Path) -> dict:
    """``run.json`` of a run directory ({} when it has none), checked for the shape its readers
    (scoring, reports) expect: one-line ``RunDirError`` naming the file and the key for a file
    that is binary, not a JSON object, or whose ``scenario`` / ``summary`` / ``scenario.ego``
    is not a mapping (``scenario.expect`` not a list, ``scenario.name`` not text)."""
    rd = as_rundir(run)
    if not rd.has(RUN_FILE):
        return {}
    path = rd.path / RUN_FILE
    try:
        data = rd.run
    except UnicodeDecodeError:
        raise _not_text(path) from None
    except RecursionError:
        raise RunDirError(f"{path}: nested too deeply") from None

    def check(obj: dict, key: str, kind: type | tuple[type, ...], what: str, where: str) -> None:
        value = obj.get(key)
        if value is not None and not isinstance(value, kind):
            raise RunDirError(f"{path}: {where}{key}: expected {what}, got {type(value).__name__}")

    for key in _RUN_MAPPINGS:
        check(data, key, dict, "a mapping", "")
    scenario = data.get("scenario") or {}
    for key in _SCENARIO_MAPPINGS:
        check(scenario, key, dict, "a mapping", "scenario.")
    for key in _SCENARIO_LISTS:
        check(scenario, key, list, "a list", "scenario.")
    for key in _SCENARIO_TEXT:
        check(scenario, key, str, "text", "scenario.")
    for i, e in enumerate(scenario.get("expect") or []):
        if not isinstance(e, dict):
            raise RunDirError(f"{path}: scenario.expect[{i}]: expected a mapping, got {type(e).__name__}")
    return data


def load_run(run: RunDir | Path) -> RunData:
    """The frames of a run directory's ``ticks.jsonl`` (kept on the ``RunDir``: built once).

    ``run.json``, when there is one, is checked too (``run_record``), and ``timings.jsonl`` and
    ``metrics.json`` are checked to be text (``check_text``): the scorers after this one read them.

    Raises:
        FileNotFoundError / NotADirectoryError: no such run directory or no ticks file.
        RunDirError: a line that is not a JSON object (or not text) or whose arrays are malformed
            (message ``<file>:<line>: ...``); a malformed ``run.json`` (``run_record``).
    """
    rd = as_rundir(run)
    data = rd.derived("scoring.RunData", _build_run)
    run_record(rd)
    for name in (TIMINGS_FILE, METRICS_FILE):  # read after this by the scorers, as text
        check_text(rd.path / name)
    return data


#: Largest ``tick`` / ``frame`` number of a record (a day at 100 ticks/s): readers that index by
#: them (replay, report key frames) never see one that would ask for gigabytes.
MAX_TICK = 10**7


def check_counters(rec: dict, where: str) -> None:
    """``RunDirError`` at ``where`` when a record's ``tick`` or ``frame`` is not an integer in 0..``MAX_TICK``
    (absent or null is fine)."""
    for key in ("tick", "frame"):
        v = rec.get(key)
        if v is not None and not (isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= MAX_TICK):
            raise RunDirError(f"{where}: {key}: expected an integer 0..{MAX_TICK}, got {v!r:.40}")


def _build_run(rd: RunDir) -> RunData:
    gts: list[GTFrame] = []
    dets: list[DetFrame] = []
    tracks: list[TrackFrame | None] = []
    for i, rec in enumerate(ticks_records(rd)):
        where = rd.where(i)
        check_counters(rec, where)
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
