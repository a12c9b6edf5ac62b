"""`lookahead query` reads a store read-only, also in a directory it cannot write (no ``-shm``
can be created there), and never skips committed frames left in a killed writer's ``-wal``."""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import tempfile
from pathlib import Path

import pytest

from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.reports.query import query
from lookahead.tools.sinks import store
from lookahead.tools.sinks.store import SqliteStore, StoreError

ROOT = Path(__file__).resolve().parents[3]
PED = ROOT / "scenarios" / "ped_crossing_nearside.yaml"


def _permissions_enforced() -> bool:
    """Whether this process is refused a file in a 0o555 directory (root, or CAP_DAC_OVERRIDE, is
    not: ``os.geteuid() == 0`` alone would also skip a root without that capability)."""
    if os.name != "posix":
        return False
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "ro"
        d.mkdir(mode=0o555)
        try:
            (d / "probe").write_bytes(b"")
        except PermissionError:
            return True
        finally:
            d.chmod(0o755)
        return False


permissions = pytest.mark.skipif(not _permissions_enforced(), reason="directory permissions are not enforced (root)")


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> Path:
    """A store with one short run (no rendering), closed: no -wal or -shm left beside it."""
    path = tmp_path_factory.mktemp("store") / "runs.sqlite"
    sc = load_scenario(PED).model_copy(update={"duration": 2.0})
    Runner(sc, sinks=[SqliteStore(path, sc)], render=False).run()
    assert not Path(f"{path}-wal").exists()
    return path


@pytest.fixture
def read_only(tmp_path):
    """``read_only(*files)``: copies ``files`` into a fresh directory made 0o555; returns it."""
    made = []

    def make(*files: Path) -> Path:
        d = tmp_path / f"ro{len(made)}"
        d.mkdir()
        for f in files:
            shutil.copy2(f, d / f.name)
        d.chmod(0o555)
        made.append(d)
        return d

    yield make
    for d in made:
        d.chmod(0o755)


def add_run(conn: sqlite3.Connection, name: str) -> None:
    conn.execute("INSERT INTO runs (name, scenario, started) VALUES (?, '{}', '2026-01-01')", (name,))


@permissions
def test_query_reads_a_store_in_a_read_only_directory(db, read_only, lookahead, capsys):
    ro = read_only(db)
    copy = ro / db.name
    before = sorted(os.listdir(ro))
    for what in ("summary", "alerts", "tracks", "objects"):
        assert query(copy, what) == query(db, what), what
    assert query(copy, "summary")[0]["frames"] == 20
    assert lookahead("query", copy, "summary", "--format", "json") == 0
    assert json.loads(capsys.readouterr().out)[0]["frames"] == 20
    assert sorted(os.listdir(ro)) == before  # nothing created (no -shm, no -wal)


@permissions
def test_a_killed_writers_wal_is_read_or_refused_never_skipped(db, read_only, tmp_path):
    """Committed rows still in the -wal (a writer killed, or running): with its -shm beside it
    the read-only directory is read with them; without, it is refused (immutable would skip them)."""
    work = tmp_path / "w"
    work.mkdir()
    live = work / db.name
    shutil.copy2(db, live)
    writer = sqlite3.connect(live, isolation_level=None)
    writer.execute("PRAGMA wal_autocheckpoint=0")
    add_run(writer, "in-the-wal")
    assert Path(f"{live}-wal").stat().st_size > 0
    try:
        with_shm = read_only(live, Path(f"{live}-wal"), Path(f"{live}-shm"))
        assert [r["scenario"] for r in query(with_shm / db.name, "summary")][-1] == "in-the-wal"
        without_shm = read_only(live, Path(f"{live}-wal"))
        with pytest.raises(StoreError, match="runs.sqlite-wal holds changes") as e:
            query(without_shm / db.name, "summary")
        assert "\n" not in str(e.value)
    finally:
        writer.close()


def test_immutable_only_when_nothing_can_be_pending(db, tmp_path, monkeypatch):
    """The fallback's decision, as any user: ``mode=ro`` fails in an unwritable directory ->
    ``immutable=1`` unless a non-empty -wal or a -journal lies beside the file."""
    expected = query(db, "summary")
    real = store._connect_ro
    opened = []

    def connect(path, immutable=False):
        if not immutable:
            raise sqlite3.OperationalError("unable to open database file")
        opened.append(path)
        return real(path, immutable=True)

    monkeypatch.setattr(store, "_connect_ro", connect)
    monkeypatch.setattr(store.os, "access", lambda p, mode: False)
    copy = tmp_path / db.name
    shutil.copy2(db, copy)
    assert query(copy, "summary") == expected and opened == [copy]
    Path(f"{copy}-wal").write_bytes(b"x" * 32)
    with pytest.raises(StoreError, match="not writable and runs.sqlite-wal holds changes"):
        query(copy, "summary")
    Path(f"{copy}-wal").write_bytes(b"")  # an empty -wal: nothing pending
    assert query(copy, "summary") == expected
    Path(f"{copy}-journal").write_bytes(b"x")
    with pytest.raises(StoreError, match="runs.sqlite-journal holds changes"):
        query(copy, "summary")
