"""Where the ego speed comes from when the frames are real video.

An ``EgoSpeedSource`` answers ``at(t)``: the ego speed (m/s) at frame time ``t`` (s, on the
video's clock: 0 at its first frame), or ``None`` when it is not known. Three kinds:

* ``FixedSpeed(v)``: always ``v`` (a drive at a known, steady speed);
* ``SpeedLog``: samples read from a file (``load_speed_log``), linearly interpolated between
  samples; within ``hold`` seconds (default 0.5 s) outside the log the nearest end sample is
  held, further out the speed is ``None``;
* ``NoSpeed()``: always ``None``.

A speed log is CSV or JSON (chosen by the ``.json`` suffix; anything else is read as CSV):

* CSV: a header line with the columns ``t`` (s) and ``speed`` (m/s), in any order, any case; other
  columns are ignored, as are blank lines and lines starting with ``#``::

      t,speed
      0.0,13.9
      0.5,14.1

* JSON: a list of objects ``{"t": 0.0, "speed": 13.9}`` (other keys are refused).

Times must be finite and strictly increasing; speeds finite and within 0..100 m/s. The file's
size is checked (``MAX_SPEED_LOG_BYTES``) before it is read. Anything wrong is an
``EgoSpeedError`` whose ``str()`` is one line ``file[:line]: problem``.

``open_ego_speed(spec)`` turns a command-line value into a source: a number -> fixed speed,
``None``/``"none"``/``""`` -> no speed, anything else -> the path of a speed log.
"""

from __future__ import annotations

import bisect
import json
import logging
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

log = logging.getLogger(__name__)

MAX_SPEED_LOG_BYTES = 64 * 2**20
MAX_SPEED = 100.0  # m/s
DEFAULT_HOLD = 0.5  # s


class EgoSpeedError(ValueError):
    """A speed source that cannot be used; ``str()`` is one line ``file[:line]: problem``."""


@runtime_checkable
class EgoSpeedSource(Protocol):
    """The ego speed (m/s) at a frame time (s), or ``None`` when unknown."""

    def at(self, t: float) -> float | None: ...


def _check_speed(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise EgoSpeedError(f"{where}: speed must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v) or not 0.0 <= v <= MAX_SPEED:
        raise EgoSpeedError(f"{where}: speed must be finite and within 0..{MAX_SPEED:g} m/s, got {v!r}")
    return v


class FixedSpeed:
    """Always the same speed (m/s)."""

    def __init__(self, speed: float) -> None:
        self.speed = _check_speed(speed, "fixed ego speed")

    def at(self, t: float) -> float | None:
        return self.speed

    def __repr__(self) -> str:
        return f"FixedSpeed({self.speed!r})"


class NoSpeed:
    """The ego speed is not known."""

    def at(self, t: float) -> float | None:
        return None

    def __repr__(self) -> str:
        return "NoSpeed()"


class SpeedLog:
    """Speed samples: linear interpolation inside the log, the nearest end held within ``hold``
    seconds outside it, ``None`` further out.

    Args:
        t: sample times (s), finite and strictly increasing (at least one).
        speed: speeds (m/s), finite, 0..100.
        source: the file it came from, for messages.
        hold: how far (s) outside the log its end samples are held.
    """

    def __init__(self, t: Any, speed: Any, source: str = "<speed log>", hold: float = DEFAULT_HOLD) -> None:
        tt = np.asarray(t, dtype=np.float64).ravel()
        vv = np.asarray(speed, dtype=np.float64).ravel()
        if tt.size == 0 or tt.size != vv.size:
            raise EgoSpeedError(f"{source}: needs at least one sample and as many speeds as times")
        if not (np.all(np.isfinite(tt)) and np.all(np.isfinite(vv))):
            raise EgoSpeedError(f"{source}: times and speeds must be finite")
        if np.any(np.diff(tt) <= 0.0):
            i = int(np.argmax(np.diff(tt) <= 0.0)) + 1
            raise EgoSpeedError(f"{source}: sample {i}: t {tt[i]!r} is not after {tt[i - 1]!r}")
        if np.any((vv < 0.0) | (vv > MAX_SPEED)):
            i = int(np.argmax((vv < 0.0) | (vv > MAX_SPEED)))
            raise EgoSpeedError(f"{source}: sample {i}: speed {vv[i]!r} is outside 0..{MAX_SPEED:g} m/s")
        if not (math.isfinite(hold) and hold >= 0.0):
            raise EgoSpeedError(f"{source}: hold must be a finite number >= 0, got {hold!r}")
        self.t, self.speed, self.source, self.hold = tt, vv, source, float(hold)
        self._times = tt.tolist()

    def __len__(self) -> int:
        return int(self.t.size)

    def at(self, t: float) -> float | None:
        t = float(t)
        if not math.isfinite(t):
            return None
        t0, t1 = self._times[0], self._times[-1]
        if t < t0:
            return float(self.speed[0]) if t0 - t <= self.hold else None
        if t > t1:
            return float(self.speed[-1]) if t - t1 <= self.hold else None
        i = bisect.bisect_right(self._times, t)
        if i >= len(self._times):
            return float(self.speed[-1])
        ta, tb = self._times[i - 1], self._times[i]
        va, vb = float(self.speed[i - 1]), float(self.speed[i])
        return va + (vb - va) * (t - ta) / (tb - ta)

    def __repr__(self) -> str:
        return f"SpeedLog({self.source!r}, {len(self)} samples, t {self._times[0]:g}..{self._times[-1]:g} s)"


# ---------------------------------------------------------------------------- files
def _read_text(p: Path) -> str:
    if not p.is_file():
        raise EgoSpeedError(f"{p}: no such speed log file")
    try:
        size = p.stat().st_size
        if size > MAX_SPEED_LOG_BYTES:
            raise EgoSpeedError(f"{p}: {size} bytes, more than the {MAX_SPEED_LOG_BYTES} a speed log may have")
        data = p.read_bytes()
    except OSError as e:
        raise EgoSpeedError(f"{p}: cannot read: {e.strerror or e}") from None
    nul = data.find(b"\x00")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        raise EgoSpeedError(f"{p}:{line}: not text (a NUL byte at byte {nul})")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise EgoSpeedError(f"{p}:{line}: not UTF-8 text (byte {e.start})") from None


def _number(cell: str, what: str, where: str) -> float:
    try:
        v = float(cell)
    except ValueError:
        raise EgoSpeedError(f"{where}: {what} is not a number: {cell.strip()[:40]!r}") from None
    if not math.isfinite(v):
        raise EgoSpeedError(f"{where}: {what} must be finite, got {cell.strip()!r}")
    return v


def _check_row(t: float, v: float, prev_t: float | None, where: str) -> None:
    if prev_t is not None and t <= prev_t:
        raise EgoSpeedError(f"{where}: t {t!r} is not after the previous sample's {prev_t!r}")
    if not 0.0 <= v <= MAX_SPEED:
        raise EgoSpeedError(f"{where}: speed {v!r} is outside 0..{MAX_SPEED:g} m/s")


def _parse_csv(text: str, source: str) -> tuple[list[float], list[float]]:
    ts: list[float] = []
    vs: list[float] = []
    cols: tuple[int, int, int] | None = None  # t index, speed index, column count
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c.strip() for c in line.split(",")]
        where = f"{source}:{n}"
        if cols is None:
            names = [c.lower() for c in cells]
            missing = [c for c in ("t", "speed") if c not in names]
            if missing:
                raise EgoSpeedError(
                    f"{where}: the header needs the columns t and speed, missing {' and '.join(missing)}"
                    f" (got {line[:80]!r})"
                )
            cols = (names.index("t"), names.index("speed"), len(cells))
            continue
        if len(cells) != cols[2]:
            raise EgoSpeedError(f"{where}: {len(cells)} columns, the header has {cols[2]}")
        t = _number(cells[cols[0]], "t", where)
        v = _number(cells[cols[1]], "speed", where)
        _check_row(t, v, ts[-1] if ts else None, where)
        ts.append(t)
        vs.append(v)
    if cols is None:
        raise EgoSpeedError(f"{source}: empty; expected a header line 't,speed' and samples")
    return ts, vs


_WS = re.compile(r"[ \t\n\r]*")
NL = "\n"


def _json_items(text: str, source: str) -> Iterator[tuple[Any, int]]:
    """(element, line) of a top-level JSON list, each element decoded on its own."""
    dec = json.JSONDecoder()
    line, pos = 1, 0

    def skip(i: int) -> int:
        nonlocal line, pos
        j = _WS.match(text, i).end()  # type: ignore[union-attr]
        line += text.count("\n", pos, j)
        pos = j
        return j

    def bad(i: int, problem: str) -> EgoSpeedError:
        return EgoSpeedError(f"{source}:{text.count(NL, 0, i) + 1}: {problem}")

    i = skip(0)
    if text[i : i + 1] != "[":
        raise bad(i, "expected a JSON list of {\"t\": s, \"speed\": m/s} objects")
    i = skip(i + 1)
    if text[i : i + 1] == "]":
        i = skip(i + 1)
    else:
        while True:
            try:
                obj, end = dec.raw_decode(text, i)
            except json.JSONDecodeError as e:
                raise EgoSpeedError(f"{source}:{e.lineno}: malformed JSON: {e.msg}") from None
            yield obj, line
            line += text.count("\n", pos, end)
            pos = end
            i = skip(end)
            c = text[i : i + 1]
            if c == ",":
                i = skip(i + 1)
            elif c == "]":
                i = skip(i + 1)
                break
            else:
                raise bad(i, "malformed JSON: expected ',' or ']' after a list element")
    if i != len(text):
        raise bad(i, "malformed JSON: extra data after the list")


def _parse_json(text: str, source: str) -> tuple[list[float], list[float]]:
    ts: list[float] = []
    vs: list[float] = []
    for k, (obj, n) in enumerate(_json_items(text, source)):
        where = f"{source}:{n}: [{k}]"
        if not isinstance(obj, dict):
            raise EgoSpeedError(f"{where}: expected an object {{\"t\": s, \"speed\": m/s}}, got {type(obj).__name__}")
        extra = sorted(set(obj) - {"t", "speed"})
        if extra:
            raise EgoSpeedError(f"{where}: unknown field {extra[0]!r}")
        vals = []
        for key in ("t", "speed"):
            if key not in obj:
                raise EgoSpeedError(f"{where}: missing field {key!r}")
            v = obj[key]
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise EgoSpeedError(f"{where}.{key}: expected a number, got {v!r}")
            if not math.isfinite(v):
                raise EgoSpeedError(f"{where}.{key}: expected a finite number, got {v!r}")
            vals.append(float(v))
        _check_row(vals[0], vals[1], ts[-1] if ts else None, where)
        ts.append(vals[0])
        vs.append(vals[1])
    return ts, vs


def load_speed_log(path: str | Path, hold: float = DEFAULT_HOLD) -> SpeedLog:
    """Read a CSV or JSON speed log (see the module docstring); ``EgoSpeedError`` when unusable."""
    p = Path(path)
    text = _read_text(p)
    ts, vs = (_parse_json if p.suffix.lower() == ".json" else _parse_csv)(text, str(p))
    if not ts:
        raise EgoSpeedError(f"{p}: no samples")
    speed_log = SpeedLog(ts, vs, str(p), hold)
    log.info("speed log %s: %d samples, t %.3f..%.3f s", p, len(ts), ts[0], ts[-1])
    return speed_log


def open_ego_speed(spec: str | Path | float | None, hold: float = DEFAULT_HOLD) -> EgoSpeedSource:
    """A speed source from a command-line value: a number (m/s) -> ``FixedSpeed``;
    ``None``, ``"none"`` or ``""`` -> ``NoSpeed``; another string or a path -> ``load_speed_log``.
    A string that parses as a number is a speed, never a file name."""
    if spec is None:
        return NoSpeed()
    if isinstance(spec, bool):
        raise EgoSpeedError(f"ego speed: expected a number, a speed log path or 'none', got {spec!r}")
    if isinstance(spec, int | float):
        return FixedSpeed(spec)
    if isinstance(spec, str):
        s = spec.strip()
        if s.lower() in ("", "none"):
            return NoSpeed()
        try:
            v = float(s)
        except ValueError:
            return load_speed_log(s, hold)
        return FixedSpeed(v)
    return load_speed_log(spec, hold)
