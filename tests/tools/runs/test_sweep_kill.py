"""A sweep whose main process is SIGKILLed leaves no process behind (its pool workers and
multiprocessing's resource tracker end with it), and a resumed sweep has exactly one store run
per variant, whatever a killed or late worker wrote."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from lookahead.sim.runner import Runner
from lookahead.tools.runs.sweep import load_sweep, run_sweep, todo_variants
from lookahead.tools.sinks.rundir import RunDirWriter
from lookahead.tools.sinks.store import SqliteStore

ROOT = Path(__file__).resolve().parents[3]
CAR = ROOT / "scenarios" / "stationary_car.yaml"
EXE = Path(sys.executable).parent / "lookahead"
GONE_WITHIN_S = 5.0

needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")


def session_processes(sid: int) -> dict[int, tuple[int, str]]:
    """Live (not zombie) processes of session ``sid``: pid -> (ppid, command line)."""
    found = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
            cmd = Path(f"/proc/{entry}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:  # gone meanwhile
            continue
        state, ppid, _pgrp, session = stat.rsplit(")", 1)[1].split()[:4]
        if int(session) == sid and state not in ("Z", "X"):
            found[int(entry)] = (int(ppid), cmd.strip())
    return found


def wait_until_gone(sid: int, within: float = GONE_WITHIN_S) -> dict[int, tuple[int, str]]:
    """The session's processes still alive ``within`` s from now (empty as soon as there are none)."""
    deadline = time.monotonic() + within
    while (left := session_processes(sid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    return left


def store_runs(db: Path) -> list[tuple[str, int]]:
    with sqlite3.connect(db, timeout=30) as conn:
        return conn.execute("SELECT run_dir, complete FROM runs ORDER BY run_dir, id").fetchall()


def dangling_frames(db: Path) -> int:
    with sqlite3.connect(db, timeout=30) as conn:
        return conn.execute("SELECT count(*) FROM frames WHERE run_id NOT IN (SELECT id FROM runs)").fetchone()[0]


@needs_proc
def test_a_sigkilled_sweep_leaves_no_process_and_resumes_to_one_run_per_variant(tmp_path):
    if not EXE.exists():
        pytest.skip("console script not installed")
    sw = tmp_path / "k.yaml"
    sw.write_text(f"scenario: {CAR}\nset: {{duration: 4.0, perception.detector.kind: gt}}\n"
                  "grid:\n  ego.speed: [6, 7, 8, 9, 10, 11]\n")
    out = tmp_path / "out"
    db = out / "sweep.sqlite"
    _, _, variants = load_sweep(sw)
    cmd = [str(EXE), "sweep", str(sw), "--out", str(out), "--workers", "2", "--no-report"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        rows: list[tuple[str, int]] = []
        while time.monotonic() < deadline and proc.poll() is None:  # one run stored, another in flight
            try:
                rows = store_runs(db) if db.exists() else []
            except sqlite3.Error:
                rows = []
            if any(c for _, c in rows) and any(not c for _, c in rows):
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the sweep ended before it could be killed mid-run"
        before = session_processes(proc.pid)
        workers = [pid for pid, (ppid, c) in before.items() if ppid == proc.pid and "spawn_main" in c]
        assert len(workers) == 2, before
        os.kill(proc.pid, signal.SIGKILL)  # the main process only: its workers must follow by themselves
        proc.wait()
        left = wait_until_gone(proc.pid)
        assert not left, f"still running {GONE_WITHIN_S} s after the sweep was killed: {left}"
    finally:
        if session_processes(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    assert 1 <= sum(c for _, c in rows) < len(variants)

    # resumed in this process (no second pool start-up: the store is settled before anything runs)
    c = run_sweep(sw, out, workers=1, report=False)["counts"]
    assert c["done"] == c["variants"] == len(variants) and c["ran"] + c["skipped"] == len(variants)
    assert store_runs(db) == sorted((str(out / "runs" / v.id), 1) for v in variants)  # one each, complete
    assert dangling_frames(db) == 0


@needs_proc
def test_pool_workers_end_with_their_parent_without_the_parent_death_signal(tmp_path):
    """The portable fallback alone (``pdeathsig=False``): the workers poll their parent's pid.
    (``fork`` here only to spare the workers the imports; the sweep's pool is ``spawn``.)"""
    started = tmp_path / "started"
    started.mkdir()
    script = tmp_path / "parent.py"
    script.write_text(textwrap.dedent(f"""
        import os, time
        from concurrent.futures import ProcessPoolExecutor
        from multiprocessing import get_context

        from lookahead.tools.runs.sweep import die_with_parent

        def job(d):
            open(os.path.join(d, str(os.getpid())), "w").close()
            time.sleep(120)

        if __name__ == "__main__":
            pool = ProcessPoolExecutor(2, mp_context=get_context("fork"), initializer=die_with_parent,
                                       initargs=(os.getpid(), False))
            for _ in range(2):
                pool.submit(job, {str(started)!r})
            time.sleep(120)
    """))
    proc = subprocess.Popen([sys.executable, str(script)], start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while len(list(started.iterdir())) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        workers = {int(p.name) for p in started.iterdir()}
        assert len(workers) == 2 and workers <= set(session_processes(proc.pid))
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        left = wait_until_gone(proc.pid)
        assert not left, left
    finally:
        if session_processes(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)


def test_a_resumed_sweep_keeps_one_store_run_per_variant_whatever_was_written_late(tmp_path):
    sw = tmp_path / "s.yaml"
    sw.write_text(f"scenario: {CAR}\nset: {{duration: 1.0}}\ngrid:\n  ego.speed: [8, 10, 12]\n")
    out = tmp_path / "out"
    db = out / "sweep.sqlite"
    first = run_sweep(sw, out, workers=1, report=False)
    assert first["counts"]["done"] == 3
    _, _, (a, b, c) = load_sweep(sw)
    runs = out / "runs"
    # a late worker writes a second, complete run of a (into a scratch dir: the store row names a's),
    # another one dies half-way through b, and a killed one's frames outlived their deleted run
    Runner(a.scenario, sinks=[RunDirWriter(tmp_path / "late", a.scenario),
                              SqliteStore(db, a.scenario, run_dir=runs / a.id)], render=False).run()
    store = SqliteStore(db, b.scenario, run_dir=runs / b.id)
    store.on_start({})
    store.close()
    with sqlite3.connect(db) as conn:
        conn.execute("INSERT INTO frames (run_id, frame, tick, t) VALUES (999999, 0, 0, 0.0)")
        # and c's store run is lost: its run directory alone does not make it done
        conn.execute("DELETE FROM frames WHERE run_id IN (SELECT id FROM runs WHERE run_dir = ?)", (str(runs / c.id),))
        conn.execute("DELETE FROM runs WHERE run_dir = ?", (str(runs / c.id),))
    assert len(store_runs(db)) == 4 and dangling_frames(db) == 1
    assert [v.id for v in todo_variants(out, [a, b, c])] == [c.id]  # read-only: what a resume will run
    assert len(store_runs(db)) == 4
    again = run_sweep(sw, out, workers=1, report=False)
    assert again["counts"] == {"variants": 3, "done": 3, "failed": 0, "ran": 1, "skipped": 2}
    assert not again["variants"][c.id]["skipped"]
    assert store_runs(db) == sorted((str(runs / v.id), 1) for v in (a, b, c))
    assert dangling_frames(db) == 0
