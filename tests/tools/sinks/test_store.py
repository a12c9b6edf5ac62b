"""SqliteStore and `lookahead query`: row counts against the run directory, schema, crash safety, bad files."""

from __future__ import annotations

import csv
import io
import json
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.reports.query import WHATS
from lookahead.tools.sinks.rundir import RunDirWriter
from lookahead.tools.sinks.store import APPLICATION_ID, SCHEMA_VERSION, SqliteStore, StoreError

ROOT = Path(__file__).resolve().parents[3]
PED = ROOT / "scenarios" / "ped_crossing_nearside.yaml"


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> tuple[Path, Path]:
    """Two runs of the same scenario in one DB; the first alongside a RunDirWriter."""
    tmp = tmp_path_factory.mktemp("store")
    path, run_dir = tmp / "runs.sqlite", tmp / "run"
    sc = load_scenario(PED)
    Runner(sc, sinks=[RunDirWriter(run_dir, sc), SqliteStore(path, sc, run_dir=run_dir, batch_frames=7)],
           render=False).run()
    Runner(sc, sinks=[SqliteStore(path, sc)], render=False).run()
    return path, run_dir


def count(conn: sqlite3.Connection, table: str, run: int) -> int:
    return conn.execute(f"SELECT COUNT(*) FROM {table} WHERE run_id = ?", (run,)).fetchone()[0]


def test_rows_match_the_run_directory(db):
    path, run_dir = db
    ticks = [json.loads(line) for line in (run_dir / "ticks.jsonl").read_text().splitlines()]
    timings = [json.loads(line) for line in (run_dir / "timings.jsonl").read_text().splitlines()]
    conn = sqlite3.connect(path)
    for run in (1, 2):
        assert count(conn, "frames", run) == len(ticks) > 30
        assert count(conn, "ground_truth", run) == sum(len(t["ground_truth"]["actor_id"]) for t in ticks)
        assert count(conn, "detections", run) == sum(len(t["detections"]["score"]) for t in ticks)
        assert count(conn, "tracks", run) == sum(len(t["tracks"]["track_id"]) for t in ticks) > 0
        assert count(conn, "alerts", run) == sum(len(t["alerts"]) for t in ticks) > 0
        assert count(conn, "collisions", run) == sum(len(t["collisions"]) for t in ticks) == 1
        assert count(conn, "timings", run) == sum(len(t) for t in timings)
    ts = [r[0] for r in conn.execute("SELECT t FROM frames WHERE run_id = 1 ORDER BY frame")]
    assert ts == pytest.approx([t["t"] for t in ticks])
    levels = [r[0] for r in conn.execute("SELECT level FROM alerts WHERE run_id = 1 ORDER BY frame, track_id")]
    assert levels == [a["level"] for t in ticks for a in t["alerts"]]
    ranges = conn.execute("SELECT range FROM tracks WHERE run_id = 1 ORDER BY frame, rowid").fetchall()
    assert [r[0] for r in ranges] == pytest.approx(
        [v for t in ticks for v in t["tracks"]["range"]], abs=1e-3, nan_ok=True)
    runs = conn.execute("SELECT id, complete, seed, run_dir IS NOT NULL, ended IS NOT NULL FROM runs").fetchall()
    assert runs == [(1, 1, 7, 1, 1), (2, 1, 7, 0, 1)]
    summary = json.loads(conn.execute("SELECT summary FROM runs WHERE id = 1").fetchone()[0])
    assert summary["frames"] == len(ticks)


def test_schema_indices_wal_and_version(db):
    conn = sqlite3.connect(db[0])
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    assert conn.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID
    assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    names = {t: {r[1] for r in conn.execute(f"PRAGMA index_list({t})")} for t in ("ground_truth", "tracks", "alerts")}
    assert {"gt_actor", "gt_frame"} <= names["ground_truth"]
    assert {"tracks_track", "tracks_cls", "tracks_frame"} <= names["tracks"]
    assert "alerts_level" in names["alerts"]
    for sql, index in [
        ("SELECT * FROM alerts WHERE run_id = 1 AND level = 3", "alerts_level"),
        ("SELECT * FROM tracks WHERE cls = 'pedestrian'", "tracks_cls"),
        ("SELECT * FROM ground_truth WHERE run_id = 1 AND actor_id = 1 ORDER BY frame", "gt_actor"),
        ("SELECT * FROM tracks WHERE run_id = 1 AND track_id = 1 ORDER BY frame", "tracks_track"),
    ]:
        plan = " ".join(str(r) for r in conn.execute("EXPLAIN QUERY PLAN " + sql))
        assert index in plan, (sql, plan)


def query_command(lookahead, db: Path, what: str, run: int | None, fmt: str) -> int:
    """``lookahead query DB WHAT [--run RUN] --format FMT``: its exit code."""
    return lookahead("query", db, what, *(["--run", run] if run is not None else []), "--format", fmt)


def run_query(capsys, lookahead, path: Path, what: str, run: int | None, fmt: str) -> str:
    assert query_command(lookahead, path, what, run, fmt) == 0
    out = capsys.readouterr()
    assert out.err == ""
    return out.out


def test_query_every_report_in_every_format(db, capsys, lookahead):
    path = db[0]
    conn = sqlite3.connect(path)
    expected = {
        "alerts": conn.execute("SELECT COUNT(*) FROM alerts").fetchone()[0],
        "tracks": conn.execute("SELECT COUNT(DISTINCT run_id || ':' || track_id) FROM tracks").fetchone()[0],
        "objects": conn.execute("SELECT COUNT(DISTINCT run_id || ':' || actor_id) FROM ground_truth").fetchone()[0],
        "summary": 2,
    }
    for what in WHATS:
        rows = json.loads(run_query(capsys, lookahead, path, what, None, "json"))
        assert len(rows) == expected[what] > 0, what
        parsed = list(csv.DictReader(io.StringIO(run_query(capsys, lookahead, path, what, None, "csv"))))
        assert len(parsed) == len(rows) and list(parsed[0]) == list(rows[0])
        assert [r["run"] for r in parsed] == [str(r["run"]) for r in rows]
        only2 = json.loads(run_query(capsys, lookahead, path, what, 2, "json"))
        assert only2 == [r for r in rows if r["run"] == 2] and only2
        table = run_query(capsys, lookahead, path, what, 1, "table")
        assert all(name in table for name in list(rows[0])[:3])
    summary = json.loads(run_query(capsys, lookahead, path, "summary", None, "json"))
    assert [(s["run"], s["complete"], s["collisions"]) for s in summary] == [(1, 1, 1), (2, 1, 1)]
    assert summary[0]["alerts_high"] + summary[0]["alerts_critical"] > 0
    objects = list(csv.DictReader(io.StringIO(run_query(capsys, lookahead, path, "objects", 1, "csv"))))
    ped = objects[0]
    assert ped["name"] == "ped1" and ped["cls"] == "pedestrian" and ped["max_risk"] == "CRITICAL"
    assert float(ped["first_seen"]) <= float(ped["first_tracked"]) <= float(ped["first_alert"])
    alerts = json.loads(run_query(capsys, lookahead, path, "alerts", 1, "json"))
    assert {a["level"] for a in alerts} <= {"NONE", "HIGH", "CRITICAL"} and alerts[0]["actor_id"] == 1


def test_query_bad_input_is_one_error_line(db, tmp_path, capsys, lookahead):
    path = db[0]
    junk = tmp_path / "junk.db"
    junk.write_text("not a database, just text " * 10)
    for args in [(path, "nope", None, "json"), (path, "alerts", None, "xml"), (path, "alerts", 99, "json"),
                 (tmp_path / "missing.db", "summary", None, "table"), (junk, "summary", None, "csv")]:
        assert query_command(lookahead, *args) == 2, args
        err = capsys.readouterr()
        assert err.out == "" and err.err.startswith("error: ") and err.err.count("\n") == 1, err.err


CRASH = """
import os, signal, sys
from pathlib import Path
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.sinks.store import SqliteStore

class Killer:
    def __init__(self, n): self.n, self.seen = n, 0
    def on_start(self, info): pass
    def on_tick(self, record):
        self.seen += 1
        if self.seen == self.n:
            os.kill(os.getpid(), signal.SIGKILL)
    def on_end(self, summary): pass

sc = load_scenario(sys.argv[1])
Runner(sc, sinks=[SqliteStore(Path(sys.argv[2]), sc, batch_frames=int(sys.argv[3])), Killer(int(sys.argv[4]))],
       render=False).run()
"""


def test_killed_run_leaves_a_consistent_incomplete_db(tmp_path, capsys, lookahead):
    path, batch, n = tmp_path / "crash.sqlite", 10, 25
    proc = subprocess.run([sys.executable, "-c", CRASH, str(PED), str(path), str(batch), str(n)],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    frames = [r[0] for r in conn.execute("SELECT frame FROM frames ORDER BY frame")]
    # rows are committed when the next frame arrives after a full batch: frames 0..19 here
    assert len(frames) == batch * ((n - 1) // batch) == 20 and frames == list(range(20))
    assert conn.execute("SELECT MAX(frame) FROM ground_truth").fetchone()[0] == 19
    assert conn.execute("SELECT complete, ended FROM runs").fetchall() == [(0, None)]
    conn.close()
    assert query_command(lookahead, path, "summary", None, "json") == 0
    assert json.loads(capsys.readouterr().out)[0]["complete"] == 0


def test_a_run_that_raises_is_not_complete(tmp_path):
    class Boom:
        def on_start(self, info): ...
        def on_tick(self, record):
            if record.frame_index == 3:
                raise RuntimeError("boom")
        def on_end(self, summary): ...

    from lookahead.tools.sinks.rundir import RunDirWriter

    path = tmp_path / "boom.sqlite"
    sc = load_scenario(PED)
    with pytest.raises(RuntimeError):
        Runner(sc, sinks=[RunDirWriter(tmp_path / "run", sc), SqliteStore(path, sc), Boom()], render=False).run()
    conn = sqlite3.connect(path)
    assert conn.execute("SELECT complete, error FROM runs").fetchone() == (0, "RuntimeError: boom")
    run = json.loads((tmp_path / "run" / "run.json").read_text())
    assert run["complete"] is False and run["summary"]["error"] == "RuntimeError: boom"
    assert conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0] == 4


_OTHER_PROCESS = """
import sqlite3, sys
c = sqlite3.connect(sys.argv[1], isolation_level=None, timeout=30)
c.execute("INSERT INTO t VALUES (?)", (sys.argv[2],))
if sys.argv[3] == "hold":
    print("ready", flush=True)
    sys.stdin.readline()
c.close()
"""


def test_a_second_open_in_one_process_keeps_the_first_ones_writes_safe(tmp_path):
    # Two stores on one file in one process (a pool worker whose failed variant's store was
    # not yet collected) while other processes open and close theirs: nothing is lost.
    # Reading the file with a plain open() here used to drop this process's SQLite locks, so
    # another process closing its last connection checkpointed and deleted a WAL still in use.
    from lookahead.tools.sinks.store import open_db

    path = tmp_path / "shared.sqlite"
    first = open_db(path)
    first.execute("CREATE TABLE t (v TEXT)")
    second = open_db(path)

    def other(value: str, hold: bool = False):
        args = [sys.executable, "-c", _OTHER_PROCESS, str(path), value, "hold" if hold else "go"]
        if not hold:
            return subprocess.run(args, check=True, timeout=60)
        proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        return proc

    other("a")  # opens, writes, closes: not the last connection, so leaves the WAL alone
    assert (tmp_path / "shared.sqlite-wal").exists()
    held = other("b", hold=True)
    second.execute("INSERT INTO t VALUES ('ours')")
    second.close()
    first.close()
    held.communicate("\n", timeout=60)
    assert held.returncode == 0
    with sqlite3.connect(path) as conn:
        assert sorted(r[0] for r in conn.execute("SELECT v FROM t")) == ["a", "b", "ours"]


def test_foreign_files_raise_and_stay_untouched(tmp_path):
    sc = load_scenario(PED)
    text = tmp_path / "notes.db"
    text.write_bytes(b"hello, this is not sqlite\n" * 8)
    foreign = tmp_path / "foreign.db"
    with sqlite3.connect(foreign) as c:
        c.execute("CREATE TABLE things (x)")
    future = tmp_path / "future.db"
    with sqlite3.connect(future) as c:
        c.execute("CREATE TABLE runs (id)")
        c.execute(f"PRAGMA application_id={APPLICATION_ID}")
        c.execute("PRAGMA user_version=99")
    cases = [(text, "not a SQLite database"), (foreign, "not a lookahead store"), (future, "schema version 99")]
    for path, needle in cases:
        before = path.read_bytes()
        with pytest.raises(StoreError) as e:
            SqliteStore(path, sc)
        msg = str(e.value)
        assert needle in msg and str(path) in msg and "\n" not in msg
        assert path.read_bytes() == before
        assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(path.name)) == [path.name]


def test_unwritable_path_raises(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(StoreError, match="cannot create the directory"):
        SqliteStore(blocker / "sub" / "runs.sqlite", load_scenario(PED))
    with pytest.raises(StoreError, match="is a directory"):
        SqliteStore(tmp_path, load_scenario(PED))


def test_assessments_table_matches_the_run_directory(db):
    """One assessments row per reported track per frame: label, behaviour, risk, TTC, in-path, reason."""
    from lookahead.intent.labels import BEHAVIOUR_NAMES, LABEL_NAMES

    path, run_dir = db
    ticks = [json.loads(line) for line in (run_dir / "ticks.jsonl").read_text().splitlines()]
    conn = sqlite3.connect(path)
    cols = [r[1] for r in conn.execute("PRAGMA table_info(assessments)")]
    assert cols == ["run_id", "frame", "t", "track_id", "label", "behaviour", "risk", "ttc", "in_path", "reason",
                    "behaviour_confidence"]
    assert not {"label", "behaviour", "risk", "in_path"} & {r[1] for r in conn.execute("PRAGMA table_info(tracks)")}
    assert count(conn, "assessments", 1) == count(conn, "tracks", 1) == sum(len(t["tracks"]["track_id"]) for t in ticks)
    rows = conn.execute("SELECT frame, track_id, label, behaviour, risk, ttc, in_path, reason FROM assessments "
                        "WHERE run_id = 1 ORDER BY frame, rowid").fetchall()
    want = [(t["frame"], tid, LABEL_NAMES[a["label"][i]], BEHAVIOUR_NAMES[a["behaviour"][i]], a["risk"][i],
             a["ttc"][i], int(a["in_path"][i]))
            for t in ticks if (a := t["assessments"]) for i, tid in enumerate(t["tracks"]["track_id"])]
    assert [r[:5] for r in rows] == [w[:5] for w in want]
    assert [min(r[5], 1e9) for r in rows] == pytest.approx([w[5] for w in want], abs=1e-3)
    assert [r[6] for r in rows] == [w[6] for w in want]
    assert all(r[7] and r[7].startswith(("SAFE", "LOW", "MEDIUM", "HIGH", "CRITICAL")) for r in rows)
    crit = conn.execute("SELECT reason FROM assessments WHERE run_id = 1 AND risk = 4 LIMIT 1").fetchone()[0]
    assert crit.startswith("CRITICAL: ") and "range" in crit
    # every alert's track has an assessment at that frame with the alert's reason (same words, same numbers)
    for fr, tid, reason in conn.execute("SELECT frame, track_id, reason FROM alerts WHERE run_id = 1 AND level > 0"):
        got = conn.execute("SELECT reason FROM assessments WHERE run_id = 1 AND frame = ? AND track_id = ?",
                           (fr, tid)).fetchone()
        assert got is not None and got[0].split(":", 1)[1] == reason.split(":", 1)[1]
    names = {r[1] for r in conn.execute("PRAGMA index_list(assessments)")}
    assert {"assessments_track", "assessments_risk"} <= names
    for sql, index in [
        ("SELECT * FROM assessments WHERE run_id = 1 AND track_id = 1 ORDER BY frame", "assessments_track"),
        ("SELECT * FROM assessments WHERE run_id = 1 AND risk >= 3", "assessments_risk"),
    ]:
        plan = " ".join(str(r) for r in conn.execute("EXPLAIN QUERY PLAN " + sql))
        assert index in plan, (sql, plan)


def test_tracks_report_uses_assessments(db, capsys, lookahead):
    rows = json.loads(run_query(capsys, lookahead, db[0], "tracks", 1, "json"))
    worst = max(rows, key=lambda r: ["SAFE", "LOW", "MEDIUM", "HIGH", "CRITICAL"].index(r["max_risk"]))
    assert worst["max_risk"] == "CRITICAL" and worst["reason"].startswith("CRITICAL: ")


def test_an_old_schema_version_is_one_line_and_untouched(tmp_path, capsys, lookahead):
    """A version-1 store (label/risk in tracks, no assessments) is refused by the sink and by query."""
    old = tmp_path / "v1.sqlite"
    with sqlite3.connect(old) as c:
        c.execute("CREATE TABLE runs (id INTEGER PRIMARY KEY, name TEXT)")
        c.execute("CREATE TABLE tracks (run_id INTEGER, frame INTEGER, label TEXT, risk INTEGER)")
        c.execute(f"PRAGMA application_id={APPLICATION_ID}")
        c.execute("PRAGMA user_version=1")
    before = old.read_bytes()
    with pytest.raises(StoreError) as e:
        SqliteStore(old, load_scenario(PED))
    msg = str(e.value)
    assert "schema version 1" in msg and "reads only versions 2-3" in msg and "\n" not in msg
    assert query_command(lookahead, old, "summary", None, "table") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "schema version 1" in err
    assert old.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v1.sqlite"]


def test_behaviour_confidence_is_stored(db):
    """assessments.behaviour_confidence: the record's, per track per frame, in [0, 1]."""
    path, run_dir = db
    ticks = [json.loads(line) for line in (run_dir / "ticks.jsonl").read_text().splitlines()]
    want = [c for t in ticks if (a := t["assessments"]) for c in a["behaviour_confidence"]]
    conn = sqlite3.connect(path)
    got = [r[0] for r in conn.execute("SELECT behaviour_confidence FROM assessments WHERE run_id = 1 ORDER BY frame, rowid")]
    assert len(want) > 0 and got == pytest.approx(want, abs=1e-3)
    assert all(0.0 <= c <= 1.0 for c in got)


def test_a_version_2_store_is_read_but_not_written(tmp_path, capsys, lookahead):
    """A version-2 store (assessments without behaviour_confidence) stays readable by query;
    the sink refuses to append to it (one line) and leaves it untouched."""
    old = tmp_path / "v2.sqlite"
    with sqlite3.connect(old) as c:
        c.execute("CREATE TABLE runs (id INTEGER PRIMARY KEY, name TEXT, scenario TEXT, seed INTEGER, "
                  "started TEXT, ended TEXT, complete INTEGER, error TEXT)")
        c.execute(f"PRAGMA application_id={APPLICATION_ID}")
        c.execute("PRAGMA user_version=2")
    before = old.read_bytes()
    with pytest.raises(StoreError) as e:
        SqliteStore(old, load_scenario(PED))
    msg = str(e.value)
    assert "schema version 2" in msg and f"writes only {SCHEMA_VERSION}" in msg and "\n" not in msg
    from lookahead.tools.sinks.store import open_db
    conn = open_db(old, create=False)  # readable
    assert conn.execute("SELECT COUNT(*) FROM runs").fetchone()[0] == 0
    conn.close()
    assert old.read_bytes() == before
