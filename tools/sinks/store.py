"""``SqliteStore``: a sink that writes runs into one SQLite database (a whole suite can share it).

One row per camera frame in ``frames``, per actor per frame in ``ground_truth``
(with the GT label, behaviour, risk, TTC and in-path flag), per detection / track
per frame in ``detections`` / ``tracks`` (tracks: box, state and the estimator's
kinematics -- range, lateral offset, their rates, ground velocity, TTC), per
track per frame in ``assessments`` (intent's output: label, behaviour, risk,
TTC, in-path flag and the English reason text, ``intent.alerts.reason_text``;
join with ``tracks`` on run_id, frame, track_id), per event in ``alerts`` /
``collisions``, per stage per frame in ``timings`` (ms). SI units (m, s, m/s,
rad), boxes in float pixels xyxy. NaN is stored as NULL, a TTC of "not
closing" as +inf (SQLite REAL ``Inf``). ``risk`` and alert ``level`` are
``intent.labels.Risk`` integers (0 SAFE .. 4 CRITICAL; table ``risk_levels``
names them) so they order; labels, behaviours and classes are text.

Schema versions: 1 had label/behaviour/risk/in_path as ``tracks`` columns and no
``assessments`` table; 2 moved them to ``assessments``; 3 (current) appends
``assessments.behaviour_confidence`` (``intent.labels.behaviour_confidence``, in [0, 1]).
Files of versions 2..3 (``READABLE_VERSIONS``) are read (``open_db(create=False)``,
``lookahead query``: a version-2 file simply has no confidence column); the sink writes only
the current version, refusing an older file (one line: use a new file) -- files are never
migrated in place. Other versions are refused for reading too.

Durability: WAL journal, ``synchronous=NORMAL``, one transaction per frame. A
frame's rows are committed at the next ``on_tick`` (the runner completes a frame's
timings after the sinks return) and at ``on_end``, so a killed process (SIGKILL)
loses at most one frame, the last one received; an OS crash or power cut may also
lose the last commits (WAL is only fsynced at checkpoints), never consistency.
``batch_frames`` > 1 commits every that many frames instead (fewer commits, up to
``batch_frames`` frames lost). ``runs.complete`` becomes 1 only in ``on_end`` and
only when the run summary carries no ``error`` (an exception that ended the run).

The schema version is ``PRAGMA user_version`` (``SCHEMA_VERSION``) and the file
is tagged with ``PRAGMA application_id`` (``APPLICATION_ID``); any other file
raises ``StoreError`` before anything is written.
"""

from __future__ import annotations

import json
import logging
import os
import sqlite3
from datetime import UTC, datetime
from itertools import repeat
from pathlib import Path
from urllib.parse import quote

import numpy as np

from lookahead.intent.alerts import reason_text
from lookahead.intent.labels import BEHAVIOUR_NAMES, LABEL_NAMES, Risk
from lookahead.perception.detections import CLASSES
from lookahead.sim.records import TickRecord, jsonable
from lookahead.sim.scenario import Scenario
from lookahead.tools.sinks.rundir import config_hash, versions

log = logging.getLogger(__name__)

SCHEMA_VERSION = 3
READABLE_VERSIONS = (2, 3)  # versions open_db(create=False) reads; the sink writes only SCHEMA_VERSION
APPLICATION_ID = 0x4C4B4844  # "LKHD"
BUSY_TIMEOUT_S = 30.0  # wait this long for another writer (parallel suite workers share a DB)

_LABELS = np.array([LABEL_NAMES[k] for k in sorted(LABEL_NAMES)], dtype=object)
_BEHAVIOURS = np.array([BEHAVIOUR_NAMES[k] for k in sorted(BEHAVIOUR_NAMES)], dtype=object)
_CLASSES = np.array([*CLASSES, "obstacle"], dtype=object)  # index -1 (obstacles in older runs) -> "obstacle"

_BOX = "{p}_x1 REAL, {p}_y1 REAL, {p}_x2 REAL, {p}_y2 REAL"
_EST = "range REAL, lateral REAL, range_rate REAL, lateral_rate REAL, ttc REAL"
_KIN = f"{_EST}, in_path INTEGER, label TEXT, behaviour TEXT, risk INTEGER"

SCHEMA: tuple[str, ...] = (
    """CREATE TABLE runs (
        id INTEGER PRIMARY KEY AUTOINCREMENT, name TEXT NOT NULL, scenario TEXT NOT NULL,
        scenario_file TEXT, seed INTEGER, config_hash TEXT, versions TEXT, renderer TEXT, run_dir TEXT,
        started TEXT NOT NULL, ended TEXT, complete INTEGER NOT NULL DEFAULT 0, error TEXT, summary TEXT)""",
    """CREATE TABLE frames (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, tick INTEGER NOT NULL,
        t REAL NOT NULL, ego_x REAL, ego_y REAL, ego_yaw REAL, ego_speed REAL, ego_accel REAL,
        ego_yaw_rate REAL, ego_brake REAL, n_gt INTEGER, n_detections INTEGER, n_tracks INTEGER,
        PRIMARY KEY (run_id, frame)) WITHOUT ROWID""",
    f"""CREATE TABLE ground_truth (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, t REAL NOT NULL,
        actor_id INTEGER NOT NULL, name TEXT, cls TEXT, subtype TEXT, class_id INTEGER,
        x REAL, y REAL, z REAL, length REAL, width REAL, height REAL, yaw REAL, vx REAL, vy REAL,
        {_BOX.format(p="amodal")}, {_BOX.format(p="visible")}, visible_fraction REAL, truncation REAL,
        {_KIN})""",
    f"""CREATE TABLE detections (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, det INTEGER NOT NULL,
        {_BOX.format(p="box")}, score REAL, class_id INTEGER, cls TEXT, source_id INTEGER,
        PRIMARY KEY (run_id, frame, det)) WITHOUT ROWID""",
    f"""CREATE TABLE tracks (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, t REAL NOT NULL,
        track_id INTEGER NOT NULL, class_id INTEGER, cls TEXT, score REAL, age INTEGER, hits INTEGER,
        state INTEGER, {_BOX.format(p="box")}, det_index INTEGER, source_id INTEGER,
        range_sigma REAL, half_width REAL, ground_vx REAL, ground_vy REAL, accel REAL, yaw_rate REAL,
        {_EST})""",
    """CREATE TABLE assessments (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, t REAL NOT NULL,
        track_id INTEGER NOT NULL, label TEXT, behaviour TEXT, risk INTEGER, ttc REAL, in_path INTEGER,
        reason TEXT, behaviour_confidence REAL)""",
    """CREATE TABLE alerts (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, t REAL NOT NULL,
        track_id INTEGER, actor_id INTEGER, cls TEXT, kind TEXT, level INTEGER, range REAL, ttc REAL,
        label TEXT, behaviour TEXT, reason TEXT, reason_zh TEXT)""",
    """CREATE TABLE collisions (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, t REAL NOT NULL,
        tick INTEGER, actor_id INTEGER, name TEXT, cls TEXT, ego_speed REAL, relative_speed REAL)""",
    """CREATE TABLE timings (
        run_id INTEGER NOT NULL REFERENCES runs(id), frame INTEGER NOT NULL, stage TEXT NOT NULL,
        ms REAL, PRIMARY KEY (run_id, frame, stage)) WITHOUT ROWID""",
    "CREATE TABLE risk_levels (level INTEGER PRIMARY KEY, name TEXT NOT NULL)",
    "CREATE INDEX gt_actor ON ground_truth (run_id, actor_id, frame)",
    "CREATE INDEX gt_frame ON ground_truth (run_id, frame)",
    "CREATE INDEX tracks_track ON tracks (run_id, track_id, frame)",
    "CREATE INDEX tracks_frame ON tracks (run_id, frame)",
    "CREATE INDEX tracks_cls ON tracks (cls, run_id)",
    "CREATE INDEX assessments_track ON assessments (run_id, track_id, frame)",
    "CREATE INDEX assessments_risk ON assessments (run_id, risk)",
    "CREATE INDEX alerts_level ON alerts (run_id, level)",
    "CREATE INDEX collisions_run ON collisions (run_id)",
)

#: Tables written per frame, in insertion order.
_TABLES = ("frames", "ground_truth", "detections", "tracks", "assessments", "alerts", "collisions", "timings")


class StoreError(ValueError):
    """A database file that cannot be used (not SQLite, another schema, unwritable); ``str()`` is one line."""


def _not_a_database(path: Path, exc: sqlite3.Error) -> str:
    """The one-line error for a file SQLite refuses, with its size and first bytes when readable.

    Only called once SQLite has refused the file: reading it with a plain ``open`` while this
    process holds a SQLite connection to it would drop that connection's POSIX locks (closing
    any descriptor of a file releases all of a process's locks on it), and another process
    closing its last connection could then checkpoint and delete a WAL still being written.
    """
    try:
        with path.open("rb") as f:
            head = f.read(16)
        size = path.stat().st_size
    except OSError:
        return f"{path}: not a SQLite database ({exc})"
    return f"{path}: not a SQLite database (found {size} bytes starting {head!r})"


def open_db(path: str | Path, create: bool = True) -> sqlite3.Connection:
    """Open (and with ``create`` initialise) a lookahead store; ``StoreError`` for anything else.

    Nothing is written to a file that fails the checks. ``create=False`` opens read-only
    (``_open_readonly``: also in a directory this process cannot write). The connection is in
    autocommit mode (explicit ``BEGIN``/``COMMIT``). The file is only ever read through SQLite
    (see ``_not_a_database`` for why).
    """
    path = Path(path)
    if path.is_dir():
        raise StoreError(f"{path}: is a directory, not a SQLite database")
    if not path.exists():
        if not create:
            raise StoreError(f"{path}: no such database file")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise StoreError(f"{path}: cannot create the directory ({e.strerror or e})") from None
    try:
        if create:
            conn = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        else:
            conn = _open_readonly(path)  # reads the header: a non-database fails here (closed)
    except sqlite3.Error as e:
        if getattr(e, "sqlite_errorcode", None) == sqlite3.SQLITE_NOTADB or "not a database" in str(e):
            raise StoreError(_not_a_database(path, e)) from None
        raise StoreError(f"{path}: cannot open ({e})") from None
    try:
        _check_schema(conn, path, create)
        if create:
            conn.execute("PRAGMA synchronous=NORMAL")
            _probe_write(conn, path)
    except sqlite3.Error as e:
        conn.close()
        if getattr(e, "sqlite_errorcode", None) == sqlite3.SQLITE_NOTADB or "not a database" in str(e):
            raise StoreError(_not_a_database(path, e)) from None
        raise StoreError(f"{path}: cannot use as a database ({e})") from None
    except StoreError:
        conn.close()
        raise
    return conn


def _connect_ro(path: Path, immutable: bool = False) -> sqlite3.Connection:
    uri = f"file:{quote(str(path.resolve()))}?mode=ro" + ("&immutable=1" if immutable else "")
    conn = sqlite3.connect(uri, uri=True, timeout=BUSY_TIMEOUT_S, isolation_level=None)
    try:
        conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()  # opens the file (and the WAL)
    except sqlite3.Error:
        conn.close()
        raise
    return conn


def _open_readonly(path: Path) -> sqlite3.Connection:
    """A read-only connection (``mode=ro``). Reading a WAL database needs its ``-shm`` file, which
    SQLite creates beside it: in a directory this process cannot write (a read-only mount, another
    user's run) with no ``-shm`` there, ``mode=ro`` fails, and the file is opened ``immutable=1``
    (no locks, no WAL) -- only when nothing can be writing it nor be left in a journal: no
    non-empty ``-wal`` and no ``-journal`` beside it (a writer needs one; a killed writer leaves
    committed frames in the ``-wal`` that ``immutable`` would silently skip). Otherwise a
    ``StoreError`` says why."""
    try:
        return _connect_ro(path)
    except sqlite3.OperationalError as e:
        if getattr(e, "sqlite_errorcode", None) == sqlite3.SQLITE_NOTADB or os.access(path.parent, os.W_OK):
            raise
        first = e
    wal, journal = Path(f"{path}-wal"), Path(f"{path}-journal")
    try:
        pending = wal if wal.exists() and wal.stat().st_size > 0 else journal if journal.exists() else None
    except OSError:
        pending = wal
    if pending is not None:
        raise StoreError(
            f"{path}: cannot open read-only ({first}): its directory is not writable and {pending.name} "
            "holds changes not yet in the database (a writer is running or was killed); read a copy in "
            "a writable directory"
        )
    return _connect_ro(path, immutable=True)


def _state(conn: sqlite3.Connection) -> tuple[int, int, list[str]]:
    app = conn.execute("PRAGMA application_id").fetchone()[0]
    version = conn.execute("PRAGMA user_version").fetchone()[0]
    tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table' ORDER BY name")]
    return app, version, tables


def _check_schema(conn: sqlite3.Connection, path: Path, create: bool) -> None:
    app, version, tables = _state(conn)
    if app == APPLICATION_ID and (version == SCHEMA_VERSION or (not create and version in READABLE_VERSIONS)):
        return
    if app == 0 and version == 0 and not tables:
        if not create:
            raise StoreError(f"{path}: empty database, no lookahead runs in it")
        _initialise(conn, path)
        return
    if app != APPLICATION_ID:
        shown = ", ".join(tables[:5]) + (", ..." if len(tables) > 5 else "") or "none"
        raise StoreError(
            f"{path}: not a lookahead store (application_id {app}, user_version {version}, tables: {shown})"
        )
    if version in READABLE_VERSIONS:  # an older store, opened to write: readable, never migrated
        raise StoreError(
            f"{path}: lookahead store schema version {version}, this version writes only {SCHEMA_VERSION} "
            "(use a new file; old stores stay readable, they are not migrated)"
        )
    raise StoreError(
        f"{path}: lookahead store schema version {version}, this version reads only versions "
        f"{READABLE_VERSIONS[0]}-{READABLE_VERSIONS[-1]} (use a new file; old stores are not migrated)"
    )


def _probe_write(conn: sqlite3.Connection, path: Path) -> None:
    """Fail now, not at the first frame, if the file cannot be written (rolled back: no change)."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        conn.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
    except sqlite3.Error as e:
        raise StoreError(f"{path}: cannot write ({e})") from None
    finally:
        conn.execute("ROLLBACK")


def _initialise(conn: sqlite3.Connection, path: Path) -> None:
    """Create the schema in one transaction (safe against a concurrent creator)."""
    try:
        mode = conn.execute("PRAGMA journal_mode=WAL").fetchone()[0]
    except sqlite3.OperationalError as e:
        raise StoreError(f"{path}: cannot write ({e})") from None
    if mode != "wal":
        log.warning("%s: WAL journal not available here (journal_mode %s)", path, mode)
    conn.execute("BEGIN IMMEDIATE")
    try:
        app, version, tables = _state(conn)
        created = app == 0 and version == 0 and not tables
        if created:
            for ddl in SCHEMA:
                conn.execute(ddl)
            conn.executemany("INSERT INTO risk_levels VALUES (?, ?)", [(int(r), r.name) for r in Risk])
            conn.execute(f"PRAGMA application_id={APPLICATION_ID}")
            conn.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        conn.execute("COMMIT")
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    if not created:  # another process got there first: check what it made
        _check_schema(conn, path, create=False)


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


def _names(table: np.ndarray, codes: np.ndarray | None, n: int) -> list:
    if codes is None:
        return [None] * n
    return table[np.asarray(codes, dtype=np.int64)].tolist()


def _ids(a: np.ndarray) -> list:
    """Integer ids as a list with negatives (= none) as None."""
    return [v if v >= 0 else None for v in np.asarray(a, dtype=np.int64).tolist()]


def _cols(a: np.ndarray) -> list[list]:
    """Columns of a 2-D array as Python lists."""
    return np.asarray(a, dtype=np.float64).T.tolist()


class SqliteStore:
    """Sink writing one run per ``on_start``..``on_end`` into ``db_path`` (created if missing).

    ``run_id`` is set in ``on_start``. Commits every ``batch_frames`` frames (default 1: each
    frame at the next ``on_tick``, so a kill loses at most one frame) and at the end.
    """

    def __init__(
        self, db_path: Path, scenario: Scenario, run_dir: Path | None = None, batch_frames: int = 1,
        source: str | None = None,
    ) -> None:
        if batch_frames < 1:
            raise ValueError(f"batch_frames must be >= 1, got {batch_frames}")
        self.path = Path(db_path)
        self.scenario = scenario
        self.run_dir = run_dir
        self.source = source
        self.batch_frames = batch_frames
        self.conn: sqlite3.Connection | None = open_db(self.path, create=True)
        self.run_id: int | None = None
        self.frames = 0  # frames received
        self.committed_frames = 0
        self._rows: dict[str, list[tuple]] = {k: [] for k in _TABLES}
        self._timings: list[tuple[int, dict[str, float]]] = []
        self._track_actor: dict[int, int] = {}
        self._sql = {k: self._insert_sql(k) for k in _TABLES}

    # --- sink protocol -------------------------------------------------------------------
    def on_start(self, info: dict) -> None:
        sc = self.scenario
        row = (
            sc.name, json.dumps(jsonable(sc.model_dump(mode="json")), sort_keys=True), self.source,
            sc.seed, config_hash(sc), json.dumps(versions(), sort_keys=True), info.get("renderer"),
            None if self.run_dir is None else str(self.run_dir), _now(),
        )
        try:
            cur = self._conn().execute(
                "INSERT INTO runs (name, scenario, scenario_file, seed, config_hash, versions, renderer, "
                "run_dir, started) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", row,
            )
        except sqlite3.Error as e:
            raise StoreError(f"{self.path}: cannot add a run ({e})") from None
        self.run_id = int(cur.lastrowid)
        log.info("%s: run %d (%s)", self.path, self.run_id, sc.name)

    def on_tick(self, record: TickRecord) -> None:
        if len(self._timings) >= self.batch_frames:
            self.flush()
        self._add(record)
        self.frames += 1

    def on_end(self, summary: dict) -> None:
        """Flush, then mark the run complete (unless an exception is propagating) and close."""
        if self.run_id is None:
            self.close()
            return
        error = summary.get("error")
        try:
            self.flush()
            self._conn().execute(
                "UPDATE runs SET ended = ?, complete = ?, error = ?, summary = ? WHERE id = ?",
                (_now(), int(error is None), error, json.dumps(jsonable(summary), sort_keys=True), self.run_id),
            )
        finally:
            self.close()

    # --- writing -------------------------------------------------------------------------
    def flush(self) -> None:
        """Write the buffered frames in one transaction."""
        if not self._timings:
            return
        rows = self._rows
        rows["timings"] = [
            (self.run_id, f, stage, float(ms)) for f, tim in self._timings for stage, ms in tim.items()
        ]
        conn = self._conn()
        try:
            conn.execute("BEGIN")
            for table, data in rows.items():
                if data:
                    conn.executemany(self._sql[table], data)
            conn.execute("COMMIT")
        except sqlite3.Error as e:
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            raise StoreError(f"{self.path}: cannot write run {self.run_id} ({e})") from None
        self.committed_frames += len(self._timings)
        self._rows = {k: [] for k in _TABLES}
        self._timings = []

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
            self.conn = None

    def _insert_sql(self, table: str) -> str:
        n = len(self._conn().execute(f"PRAGMA table_info({table})").fetchall())
        return f"INSERT INTO {table} VALUES ({', '.join('?' * n)})"

    def _conn(self) -> sqlite3.Connection:
        if self.conn is None:
            raise StoreError(f"{self.path}: the store is closed")
        return self.conn

    def _add(self, r: TickRecord) -> None:
        """Turn one record into row tuples (column-wise from the numpy arrays)."""
        run, f, t = self.run_id, r.frame_index, round(float(r.t), 4)
        rows = self._rows
        gt, dets, tr = r.ground_truth, r.detections, r.tracks
        n_tr = 0 if tr is None else len(tr)
        e = r.ego
        rows["frames"].append((
            run, f, r.tick, t, e.get("x"), e.get("y"), e.get("yaw"), e.get("speed"), e.get("accel"),
            e.get("yaw_rate"), e.get("brake"), len(gt), len(dets), n_tr,
        ))
        if n := len(gt):
            rows["ground_truth"].extend(zip(
                repeat(run, n), repeat(f), repeat(t), gt.actor_id.tolist(), gt.name, gt.cls, gt.subtype,
                gt.class_id.tolist(), *_cols(gt.box3d), *_cols(gt.velocity), *_cols(gt.amodal),
                *_cols(gt.visible), gt.visible_fraction.tolist(), gt.truncation.tolist(),
                gt.range.tolist(), gt.lateral.tolist(), gt.range_rate.tolist(), gt.lateral_rate.tolist(),
                gt.ttc.tolist(), np.asarray(gt.in_path, dtype=np.int64).tolist(),
                _names(_LABELS, gt.label, n), _names(_BEHAVIOURS, gt.behaviour, n),
                np.asarray(gt.risk, dtype=np.int64).tolist(), strict=False,
            ))
        if n := len(dets):
            rows["detections"].extend(zip(
                repeat(run, n), repeat(f), range(n), *_cols(dets.xyxy), dets.score.tolist(),
                dets.class_id.tolist(), _names(_CLASSES, dets.class_id, n), _ids(dets.source_id),
                strict=False,
            ))
        source = np.zeros(0, dtype=np.int64)
        if n_tr:
            di = tr.det_index
            source = np.where(di >= 0, dets.source_id[np.clip(di, 0, None)], -1) if len(dets) else np.full(n_tr, -1)
            rows["tracks"].extend(zip(
                repeat(run, n_tr), repeat(f), repeat(t), *self._track_cols(r, source), strict=False,
            ))
            if r.assessments is not None and len(r.assessments) == n_tr:
                rows["assessments"].extend(zip(
                    repeat(run, n_tr), repeat(f), repeat(t), tr.track_id.tolist(),
                    *self._assessment_cols(r), strict=False,
                ))
        if n_tr:  # last known GT actor of each track (a coasting track keeps it), for alerts
            known = source >= 0
            self._track_actor.update(zip(tr.track_id[known].tolist(), source[known].tolist(), strict=True))
        for a in r.alerts:
            d = a if isinstance(a, dict) else a.__dict__
            rows["alerts"].append((
                run, f, round(float(d["t"]), 4), int(d["track_id"]), self._track_actor.get(int(d["track_id"])),
                _CLASSES[int(d["class_id"])], d["kind"], int(d["level"]), float(d["range"]),
                float(d["ttc"]), LABEL_NAMES.get(d["label"]), BEHAVIOUR_NAMES.get(d["behaviour"]),
                d["reason"], d["reason_zh"],
            ))
        for c in r.collisions:
            rows["collisions"].append(
                (run, f, round(float(c.t), 4), c.tick, c.actor_id, c.name, c.cls, float(c.ego_speed), float(c.relative_speed))
            )
        self._timings.append((f, r.timings))  # the runner completes this dict after the sinks return

    @staticmethod
    def _track_cols(r: TickRecord, source: np.ndarray) -> list[list]:
        tr, est = r.tracks, r.estimates
        n = len(tr)
        nan = [float("nan")] * n
        def e(name: str) -> list:
            return nan if est is None else getattr(est, name).tolist()

        return [
            tr.track_id.tolist(), tr.class_id.tolist(), _names(_CLASSES, tr.class_id, n), tr.score.tolist(),
            tr.age.tolist(), tr.hits.tolist(), tr.state.tolist(), *_cols(tr.xyxy), tr.det_index.tolist(),
            _ids(source), e("range_sigma"), e("half_width"), e("ground_vx"), e("ground_vy"), e("accel"),
            e("yaw_rate"), e("range"), e("lateral"), e("range_rate"), e("lateral_rate"), e("ttc"),
        ]

    @staticmethod
    def _assessment_cols(r: TickRecord) -> list[list]:
        """label, behaviour, risk, ttc (constant velocity), in_path, reason (with the enhanced TTC, as
        alerts give it), behaviour_confidence (NULL when not assessed) of each track (``r.assessments``
        row order)."""
        a, n = r.assessments, len(r.assessments)
        rng = r.estimates.range.tolist() if r.estimates is not None else [float("nan")] * n
        ttc, beh, lab, risk = a.ttc.tolist(), a.behaviour.tolist(), a.label.tolist(), a.risk.tolist()
        decided = ttc if a.ettc is None else a.ettc.tolist()  # the reason gives the TTC risk decided on
        reasons = [reason_text(rg, tc, b, lb, rk)[0]
                   for rg, tc, b, lb, rk in zip(rng, decided, beh, lab, risk, strict=True)]
        return [
            _names(_LABELS, a.label, n), _names(_BEHAVIOURS, a.behaviour, n),
            np.asarray(a.risk, dtype=np.int64).tolist(), ttc, np.asarray(a.in_path, dtype=np.int64).tolist(),
            reasons,
            [None] * n if a.behaviour_confidence is None else np.asarray(a.behaviour_confidence, dtype=np.float64).tolist(),
        ]

