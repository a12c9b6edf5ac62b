"""MOTChallenge text files: read, write, group by frame, convert to/from Detections.

One row per box: ``frame, id, x, y, w, h, conf, x, y, z`` -- 1-based frame,
id (-1 for detections), top-left corner and size in px, confidence, and three
trailing columns: world x/y/z (-1) in det and tracker files, or
``class, visibility`` in MOT16+ ground truth (``gt.txt``: ``conf`` is then the
"consider" flag, 0 = ignore). Rows need at least the 6 first columns; missing
ones default to ``conf = 1`` and ``-1`` for the trailing three.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lookahead.perception.detections import Detections

_MIN_COLS, _MAX_COLS = 6, 10
#: Largest frame number read or iterated (an hour at 25 fps; MOT sequences have a few thousand).
#: Scoring and tracking walk every frame up to the last one (0.4 GB and ~10 s at this bound),
#: so a bigger one would only ever mean a broken file asking for gigabytes.
MAX_FRAME = 100_000
#: Largest magnitude of an id, and of any other value of a row (px, scores, world coordinates).
MAX_ID = 10**9
MAX_VALUE = 1e9


class MotFileError(ValueError):
    """A MOT file that cannot be read: one line naming the file and line."""


@dataclass
class MotRecords:
    """N rows of a MOT file, struct of arrays.

    Attributes:
        frame: (N,) int, 1-based frame number.
        track_id: (N,) int, object/track id (-1 for detections).
        xywh: (N, 4) float, top-left x, y and width, height in px.
        conf: (N,) float, detection score, or the GT "consider" flag.
        extra: (N, 3) float, trailing columns 8-10 (world xyz, or GT class and visibility).
    """

    frame: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    track_id: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    xywh: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    conf: np.ndarray | None = None
    extra: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.frame = np.asarray(self.frame, dtype=np.int64).reshape(-1)
        n = len(self.frame)
        self.track_id = np.asarray(self.track_id, dtype=np.int64).reshape(-1)
        self.xywh = np.asarray(self.xywh, dtype=np.float64).reshape(-1, 4)
        self.conf = np.ones(n) if self.conf is None else np.asarray(self.conf, dtype=np.float64)
        self.conf = self.conf.reshape(-1)
        self.extra = (
            np.full((n, 3), -1.0)
            if self.extra is None
            else np.asarray(self.extra, dtype=np.float64).reshape(-1, 3)
        )
        lengths = [len(self.track_id), len(self.xywh), len(self.conf), len(self.extra)]
        if any(m != n for m in lengths):
            raise ValueError(f"MotRecords arrays disagree in length: frame {n}, others {lengths}")

    def __len__(self) -> int:
        return len(self.frame)

    def __getitem__(self, index: np.ndarray | slice) -> MotRecords:
        return MotRecords(
            frame=self.frame[index],
            track_id=self.track_id[index],
            xywh=self.xywh[index],
            conf=self.conf[index],
            extra=self.extra[index],
        )

    @property
    def xyxy(self) -> np.ndarray:
        """(N, 4) boxes as x1, y1, x2, y2 (px)."""
        return np.concatenate([self.xywh[:, :2], self.xywh[:, :2] + self.xywh[:, 2:]], axis=1)

    @property
    def num_frames(self) -> int:
        """Last frame number (0 when empty)."""
        return int(self.frame.max()) if len(self) else 0

    def to_array(self) -> np.ndarray:
        """(N, 10) float array in file column order."""
        return np.column_stack([self.frame, self.track_id, self.xywh, self.conf, self.extra])

    @classmethod
    def from_array(cls, rows: np.ndarray) -> MotRecords:
        """Records from an (N, 6..10) array in file column order."""
        a = np.asarray(rows, dtype=np.float64)
        if a.ndim != 2 or not (_MIN_COLS <= a.shape[1] <= _MAX_COLS):
            if a.size == 0:
                return cls()
            raise ValueError(f"MOT array must be (N, 6..10), got shape {a.shape}")
        full = np.full((len(a), _MAX_COLS), -1.0)
        full[:, 6] = 1.0
        full[:, : a.shape[1]] = a
        return cls(
            frame=full[:, 0].astype(np.int64),
            track_id=full[:, 1].astype(np.int64),
            xywh=full[:, 2:6],
            conf=full[:, 6],
            extra=full[:, 7:10],
        )

    @classmethod
    def concat(cls, parts: list[MotRecords]) -> MotRecords:
        if not parts:
            return cls()
        return cls.from_array(np.concatenate([p.to_array() for p in parts], axis=0))


def read_mot(path: str | Path) -> MotRecords:
    """Read a MOT file (det.txt, gt.txt or tracker output).

    Blank lines and lines starting with ``#`` are skipped. Raises ``FileNotFoundError``
    if the file is missing and ``MotFileError`` (a ``ValueError``) naming the file and line
    for a malformed row (not text, wrong column count, non-numeric or non-finite value,
    non-integer frame or one outside 1..``MAX_FRAME``, non-integer id or one beyond
    ``MAX_ID``, a value beyond ``MAX_VALUE``).
    """
    path = Path(path)
    rows: list[list[float]] = []
    with path.open("rb") as fh:
        for lineno, raw in enumerate(fh, start=1):
            try:
                line = raw.decode("utf-8")
            except UnicodeDecodeError:
                raise MotFileError(f"{path}:{lineno}: not UTF-8 text (a binary file?)") from None
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            rows.append(_parse_row(text, path, lineno))
    if not rows:
        return MotRecords()
    return MotRecords.from_array(np.array(rows))


def _parse_row(text: str, path: Path, lineno: int) -> list[float]:
    parts = [p.strip() for p in text.split(",")]
    where = f"{path}:{lineno}"
    shown = text if len(text) <= 80 else text[:77] + "..."
    if not (_MIN_COLS <= len(parts) <= _MAX_COLS):
        raise MotFileError(
            f"{where}: expected 6 to 10 comma-separated values "
            f"(frame,id,x,y,w,h,conf,x,y,z), got {len(parts)}: {shown!r}"
        )
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise MotFileError(f"{where}: non-numeric value in {shown!r}") from None
    if not all(np.isfinite(values)):
        raise MotFileError(f"{where}: non-finite value in {shown!r}")
    frame, track_id = values[0], values[1]
    if frame != int(frame) or not 1 <= frame <= MAX_FRAME:
        raise MotFileError(f"{where}: frame must be an integer >= 1 and <= {MAX_FRAME} (1-based), got {parts[0]!r:.40}")
    if track_id != int(track_id) or abs(track_id) > MAX_ID:
        raise MotFileError(f"{where}: id must be an integer within +-{MAX_ID}, got {parts[1]!r:.40}")
    if any(abs(v) > MAX_VALUE for v in values[2:]):
        raise MotFileError(f"{where}: a value beyond +-{MAX_VALUE:g} in {shown!r}")
    if values[4] < 0 or values[5] < 0:
        raise MotFileError(f"{where}: width and height must be >= 0, got {parts[4]!r:.20} {parts[5]!r:.20}")
    if len(values) == _MIN_COLS:
        values.append(1.0)  # conf
    return values + [-1.0] * (_MAX_COLS - len(values))


def write_mot(path: str | Path, records: MotRecords) -> None:
    """Write records as a 10-column MOT file, sorted by frame then id."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    order = np.lexsort((records.track_id, records.frame))
    r = records[order]
    lines = [
        f"{f},{i},{x:.3f},{y:.3f},{w:.3f},{h:.3f},{c:.6g},{e0:.6g},{e1:.6g},{e2:.6g}\n"
        for f, i, (x, y, w, h), c, (e0, e1, e2) in zip(
            r.frame, r.track_id, r.xywh, r.conf, r.extra, strict=True
        )
    ]
    with path.open("w", encoding="utf-8") as fh:
        fh.writelines(lines)


def iter_frames(
    records: MotRecords, num_frames: int | None = None
) -> Iterator[tuple[int, MotRecords]]:
    """Yield ``(frame, rows)`` for every frame 1..num_frames, empty frames included.

    ``num_frames`` defaults to the last frame present in ``records``; more than ``MAX_FRAME``
    (e.g. a seqinfo.ini's seqLength) is a ``ValueError``, raised before anything is allocated.
    """
    n = records.num_frames if num_frames is None else int(num_frames)
    if n > MAX_FRAME:
        raise ValueError(f"{n} frames: more than {MAX_FRAME} (a broken sequence length?)")
    order = np.argsort(records.frame, kind="stable")
    sorted_frames = records.frame[order]
    starts = np.searchsorted(sorted_frames, np.arange(1, n + 2))
    for f in range(1, n + 1):
        yield f, records[order[starts[f - 1] : starts[f]]]


def group_by_frame(records: MotRecords) -> dict[int, MotRecords]:
    """``{frame: rows}`` for the frames present in ``records``."""
    return {f: r for f, r in iter_frames(records) if len(r)}


def to_detections(records: MotRecords, class_id: int = 0) -> Detections:
    """Detections from MOT rows (all one frame): boxes, ``conf`` as score.

    MOT files carry no class; every row gets ``class_id`` (default 0, pedestrian).
    """
    n = len(records)
    return Detections(
        xyxy=records.xyxy,
        score=records.conf,
        class_id=np.full(n, class_id, dtype=np.int64),
        source_id=np.where(records.track_id >= 0, records.track_id, -1),
    )


def from_boxes(
    frame: int,
    ids: np.ndarray,
    xyxy: np.ndarray,
    conf: np.ndarray | None = None,
) -> MotRecords:
    """MOT rows for one frame from ids (N,), xyxy boxes (N, 4) px and optional scores (N,)."""
    xyxy = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    n = len(xyxy)
    return MotRecords(
        frame=np.full(n, frame, dtype=np.int64),
        track_id=np.asarray(ids, dtype=np.int64).reshape(-1),
        xywh=np.concatenate([xyxy[:, :2], xyxy[:, 2:] - xyxy[:, :2]], axis=1),
        conf=None if conf is None else np.asarray(conf, dtype=np.float64).reshape(-1),
    )


def from_detections(frame: int, dets: Detections) -> MotRecords:
    """det.txt rows (id -1) for one frame of detections."""
    return from_boxes(frame, np.full(len(dets), -1), dets.xyxy, dets.score)
