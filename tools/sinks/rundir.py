"""The run directory, written and read here only: ``run.json``, ``ticks.jsonl``,
``timings.jsonl``, ``metrics.json`` (and a suite's or sweep's ``summary.json``).

``ticks.jsonl`` holds one TickRecord per line (images and timings excluded, so
it is byte-identical for the same scenario, seed and version);
``timings.jsonl`` holds the per-stage timings (ms) of each line.

Writing: ``RunDirWriter`` (the loop's sink) and, for tools that write run files
themselves (replay), the encoders ``tick_line`` / ``timings_line`` /
``write_run_json``; ``write_metrics`` (atomic) and ``write_summary``.

Reading: ``RunDir(path)``. Its ``run`` (``run.json``), ``ticks`` (the records of
``ticks.jsonl``, one dict per non-blank line, as written) and ``timings`` are
parsed once, on first use, and kept; a corrupt line is a ``RunDirError`` naming
``file:line``, a missing directory or file a one-line ``FileNotFoundError`` /
``NotADirectoryError``. Numbers are decoded in one place, ``decode`` /
``decode_array``: ``null`` is NaN and ``abs(v) >= NEVER`` (how ``sim.records.jsonable``
writes +-inf) is +-inf. Readers that derive something from a run (the scorer's
typed frames) keep it on the ``RunDir`` with ``derived``, so a command that
passes one ``RunDir`` along parses each file once.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import platform
import tempfile
from collections.abc import Callable
from functools import cached_property
from importlib import metadata
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from lookahead.intent.labels import NEVER
from lookahead.perception.calibration import CalibrationError, CameraCalibration, write_calibration
from lookahead.sim.records import TickRecord, jsonable
from lookahead.sim.scenario import Scenario
from lookahead.tools.sinks.paths import MAX_STEM, OutputError, inside, safe_file_stem  # noqa: F401 (re-exported)

RUN_FILE = "run.json"
TICKS_FILE = "ticks.jsonl"
TIMINGS_FILE = "timings.jsonl"
METRICS_FILE = "metrics.json"
CALIBRATION_FILE = "camera.yaml"  # the run's camera as a calibration file (perception.calibration)
EGO_SPEED_FILE = "ego_speed.csv"  # t (s, 0 at the first frame), speed (m/s): `lookahead watch --ego-speed`
SUMMARY_FILE = "summary.json"  # a suite's (or sweep's) directory

T = TypeVar("T")


log = logging.getLogger(__name__)


class RunDirError(ValueError):
    """Malformed run-directory content; ``str()`` is one line naming the file (and line)."""


# --------------------------------------------------------------------------- numbers


def decode(value: Any) -> float:
    """A number of a run file as a float: ``null`` -> NaN, ``abs(v) >= NEVER`` -> +-inf."""
    if value is None:
        return math.nan
    v = float(value)
    return math.copysign(math.inf, v) if abs(v) >= NEVER else v


def decode_array(values: Any) -> np.ndarray:
    """A (nested) list of numbers as a float array, decoded as ``decode`` does.

    Raises ``TypeError`` / ``ValueError`` for non-numbers or ragged lists (callers add where).
    """
    arr = np.array(values, dtype=np.float64)
    never = np.abs(arr) >= NEVER
    if never.any():
        arr[never] = np.copysign(np.inf, arr[never])
    return arr


def is_number(value: Any) -> bool:
    """A finite number as run and summary files carry it (bools count; the sentinel does not)."""
    if isinstance(value, bool):
        return True
    return isinstance(value, int | float) and math.isfinite(decode(value))


# --------------------------------------------------------------------------- writing


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for pkg in ("lookahead", "highway-env", "pybullet", "numpy", "onnxruntime"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out


def config_hash(scenario: Scenario) -> str:
    text = json.dumps(scenario.model_dump(mode="json"), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def prepare_dir(path: Path) -> Path:
    """Create ``path`` (and parents); one clear error if it cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".write-test-{os.getpid()}"  # per process: workers share dirs
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise OutputError(f"{path}: cannot write the output directory ({e.strerror or e})") from None
    return path


def tick_line(record: dict) -> str:
    """One ``ticks.jsonl`` line, compact, of a JSON-ready record (``sim.records.jsonable``:
    NaN -> null, +-inf -> +-NEVER; ``TickRecord.to_dict()`` already is)."""
    return json.dumps(record, separators=(",", ":")) + "\n"


def timings_line(timings: dict[str, float]) -> str:
    """One ``timings.jsonl`` line: the stages' ms rounded to 1 us."""
    return json.dumps({k: round(v, 3) for k, v in timings.items()}) + "\n"


def write_run_json(run_dir: Path, run: dict) -> Path:
    path = Path(run_dir) / RUN_FILE
    path.write_text(json.dumps(jsonable(run), indent=2, sort_keys=True) + "\n")
    return path


def write_summary(out_dir: Path, summary: dict) -> Path:
    """A suite's or sweep's ``summary.json``."""
    path = Path(out_dir) / SUMMARY_FILE
    path.write_text(json.dumps(jsonable(summary), indent=2) + "\n")
    return path


def read_summary(out_dir: Path) -> dict:
    """A suite's or sweep's ``summary.json``; ``RunDirError`` (file:line) when it is not JSON."""
    return _read_json(Path(out_dir) / SUMMARY_FILE)


def write_metrics(run_dir: Path, metrics: dict) -> Path:
    """Write ``metrics.json`` atomically (temporary file + ``os.replace``; NaN -> null).

    ``metrics.json`` is shared by several scorers; concurrent read-modify-write by two of
    them is not locked: run them in turn.
    """
    path = Path(run_dir) / METRICS_FILE
    text = json.dumps(jsonable(metrics), indent=2, allow_nan=False) + "\n"
    mode = path.stat().st_mode & 0o777 if path.exists() else 0o644
    fd, tmp = tempfile.mkstemp(prefix=".metrics-", suffix=".json", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def merge_sections(existing: dict, sections: dict[str, dict | list]) -> dict:
    """``existing`` with each section's keys updated (foreign keys, also inside sections, kept)."""
    out = dict(existing)
    for name, values in sections.items():
        old = out.get(name)
        if isinstance(values, dict):
            out[name] = {**old, **values} if isinstance(old, dict) else dict(values)
        else:  # list sections (expectations) are replaced whole
            out[name] = values
    return out


class RunDirWriter:
    """A sink that writes the run directory of one scenario run.

    ``__init__`` only checks (creates the directory, probes a write, refuses run files that
    are directories or read-only); nothing is written or truncated before ``on_start``.
    """

    FILES = (RUN_FILE, TICKS_FILE, TIMINGS_FILE, EGO_SPEED_FILE)

    def __init__(self, out_dir: Path, scenario: Scenario, source: str | None = None) -> None:
        self.dir = prepare_dir(Path(out_dir))
        for name in self.FILES:
            f = self.dir / name
            if f.is_dir():
                raise OutputError(f"{f}: is a directory, cannot write the run file")
            if f.exists() and not os.access(f, os.W_OK):
                raise OutputError(f"{f}: the run file is not writable")
        self.scenario = scenario
        self.source = source
        self._ticks = None
        self._speeds = None
        self._t0: float | None = None
        self._timings: list[dict] = []
        self.frames = 0

    def on_start(self, info: dict) -> None:
        self._run = {
            "scenario": self.scenario.model_dump(mode="json"),
            "scenario_file": self.source,
            "seed": self.scenario.seed,
            "versions": versions(),
            "config_hash": config_hash(self.scenario),
            "renderer": info.get("renderer"),
            "complete": False,
        }
        write_run_json(self.dir, self._run)
        if info.get("camera") is not None:  # the same file `lookahead watch --calibration` reads
            try:
                write_calibration(CameraCalibration.from_camera(info["camera"]), self.dir / CALIBRATION_FILE)
            except CalibrationError as e:
                log.warning("%s: camera not written as a calibration file (%s)", self.dir, e)
        self._ticks = (self.dir / TICKS_FILE).open("w", encoding="utf-8")
        self._speeds = (self.dir / EGO_SPEED_FILE).open("w", encoding="utf-8")
        self._speeds.write("t,speed\n")  # the speed log `lookahead watch --ego-speed` reads (perception.ego_speed)

    def on_tick(self, record: TickRecord) -> None:
        self._ticks.write(tick_line(record.to_dict()))
        self._ticks.flush()  # one write per frame: a killed run keeps every whole line written
        if self._t0 is None:
            self._t0 = record.t
        speed = record.ego.get("speed")
        if record.ego.get("speed_known", True) and speed is not None and math.isfinite(speed):
            self._speeds.write(f"{record.t - self._t0:.6f},{speed:.6f}\n")
            self._speeds.flush()
        self._timings.append(record.timings)  # completed by the runner after the sinks return
        self.frames += 1

    def on_end(self, summary: dict) -> None:
        for f in (self._ticks, self._speeds):
            if f is not None:
                f.close()
        with (self.dir / TIMINGS_FILE).open("w", encoding="utf-8") as f:
            for t in self._timings:
                f.write(timings_line(t))
        run = {**jsonable(self._run), "complete": summary.get("error") is None, "summary": jsonable(summary)}
        write_run_json(self.dir, run)


# --------------------------------------------------------------------------- reading


def read_jsonl(path: Path) -> tuple[list[dict], list[int]]:
    """The objects of a JSON-lines file and their line numbers (blank lines skipped).

    The one parser of ``ticks.jsonl`` and ``timings.jsonl``. Raises ``RunDirError``
    ``<file>:<line>: ...`` for a line that is not UTF-8 or not a JSON object. An unterminated
    last line that does not parse is the torn end of a killed writer: it is dropped (logged).
    """
    records: list[dict] = []
    lines: list[int] = []
    with Path(path).open("rb") as fh:
        for lineno, raw in enumerate(fh, start=1):
            if not raw.strip():
                continue
            try:
                rec = json.loads(raw.decode("utf-8"))
            except UnicodeDecodeError as e:
                raise RunDirError(f"{path}:{lineno}: not UTF-8 text (byte {e.start})") from None
            except json.JSONDecodeError as e:
                if not raw.endswith(b"\n"):  # only the last line can lack one
                    log.warning("%s:%d: dropped an unterminated last line (a killed writer's)", path, lineno)
                    break
                raise RunDirError(f"{path}:{lineno}: not valid JSON ({e.msg}, column {e.colno})") from None
            except RecursionError:
                raise RunDirError(f"{path}:{lineno}: JSON nested too deeply") from None
            if not isinstance(rec, dict):
                raise RunDirError(f"{path}:{lineno}: expected a JSON object per line")
            records.append(rec)
            lines.append(lineno)
    return records, lines


def _read_json(path: Path, what: str = "") -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise RunDirError(f"{path}:{e.lineno}: not valid JSON ({e.msg}){what}") from None
    except UnicodeDecodeError as e:
        raise RunDirError(f"{path}: not UTF-8 text (byte {e.start}){what}") from None
    except RecursionError:
        raise RunDirError(f"{path}: JSON nested too deeply{what}") from None
    if not isinstance(data, dict):
        raise RunDirError(f"{path}: expected a JSON object")
    return data


def read_metrics(run_dir: Path) -> dict:
    """Existing ``metrics.json`` as a dict ({} if absent); RunDirError if it is not a JSON object."""
    path = Path(run_dir) / METRICS_FILE
    if not path.exists():
        return {}
    return _read_json(path, "; fix or delete it")


class RunDir:
    """A run directory to read; each file is parsed once, on first use (module docstring)."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        self._derived: dict[str, Any] = {}

    def __repr__(self) -> str:
        return f"RunDir({str(self.path)!r})"

    def file(self, name: str) -> Path:
        """``path/name``, checked: one-line ``FileNotFoundError`` / ``NotADirectoryError``."""
        if not self.path.exists():
            raise FileNotFoundError(f"{self.path}: no such run directory")
        if not self.path.is_dir():
            raise NotADirectoryError(f"{self.path}: not a directory")
        f = self.path / name
        if not f.is_file():
            raise FileNotFoundError(f"{f}: no such file (not a run directory?)")
        return f

    def has(self, name: str) -> bool:
        return (self.path / name).is_file()

    @cached_property
    def run(self) -> dict:
        """``run.json`` (FileNotFoundError when absent; test ``has(RUN_FILE)`` first if optional)."""
        return _read_json(self.file(RUN_FILE))

    @cached_property
    def _ticks(self) -> tuple[list[dict], list[int]]:
        return read_jsonl(self.file(TICKS_FILE))

    @property
    def ticks(self) -> list[dict]:
        """The records of ``ticks.jsonl`` as written (read them, do not change them)."""
        return self._ticks[0]

    def where(self, frame: int) -> str:
        """``<ticks file>:<line>`` of record ``frame`` (for error messages)."""
        return f"{self.path / TICKS_FILE}:{self._ticks[1][frame]}"

    @cached_property
    def timings(self) -> list[dict[str, float]]:
        """Per-line stage timings (ms) of ``timings.jsonl``; [] when the run has none."""
        if not self.has(TIMINGS_FILE):
            return []
        path = self.path / TIMINGS_FILE
        records, lines = read_jsonl(path)
        try:
            return [{k: float(v) for k, v in rec.items()} for rec in records]
        except (TypeError, ValueError):
            bad = next(i for i, rec in enumerate(records)
                       if not all(isinstance(v, int | float) for v in rec.values()))
            raise RunDirError(f"{path}:{lines[bad]}: expected stage: milliseconds") from None

    def read_metrics(self) -> dict:
        """``metrics.json`` now ({} if absent; not cached: scorers rewrite it)."""
        return read_metrics(self.path)

    def derived(self, key: str, build: Callable[[RunDir], T]) -> T:
        """``build(self)``, computed once per ``RunDir`` and kept under ``key``."""
        if key not in self._derived:
            self._derived[key] = build(self)
        return self._derived[key]


def as_rundir(run: RunDir | Path | str) -> RunDir:
    """``run`` itself when it is a ``RunDir``, else a new one on that path."""
    return run if isinstance(run, RunDir) else RunDir(run)
