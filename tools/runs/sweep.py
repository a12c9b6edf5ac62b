"""Scenario sweeps: one scenario expanded over parameter grids and random samples.

A sweep file (YAML, validated by ``SweepSpec``; paths relative to the file)::

    name: aeb_stationary_car            # default: the file's stem
    scenario: ../stationary_car.yaml    # the base scenario
    set: {duration: 6.0}                # fixed overrides for every variant (not part of the id)
    grid:                               # Cartesian product of value lists
      ego.speed: [8.3, 11.1, 13.9, 16.7]
      ego.aeb: [false, true]
    samples:                            # n random draws, combined with every grid point
      n: 4
      seed: 1
      params:
        actors[target].impact_offset: {uniform: [-0.9, 0.9]}
        weather.kind: {choice: [clear, fog]}
        seed: {randint: [0, 1000]}
    report: {x: [ego.speed], split: ego.aeb, metrics: [closed_loop.impact_speed]}

Parameter paths are dotted scenario field paths; list items are selected by id
(``actors[ped1].speed``) or index (``actors.0.speed`` / ``actors[0].speed``);
free-form mappings (``perception.detector.noise``, ``perception.tracker``,
``intent``...) accept new keys. ``actors[ID].impact_offset`` is a convenience
(see ``place_impact_offset``). Each variant is the base scenario with ``set``
then its parameters applied and validated again, so a bad path or value is one
``SweepError`` line naming the sweep file and the parameter.

Variant id = readable slug of the parameter values + 8 hex of the SHA-1 of the
canonical JSON of ``{path: value}``: it depends on the values only, not on the
order of expansion, the file's key order or the worker count. Sampled floats
are rounded to 6 decimals; every parameter draws from its own generator
(``default_rng([seed, crc32(path)])``), so adding a parameter leaves the others'
draws unchanged.

``run_sweep`` writes ``OUT/runs/<id>/`` (the variant's ``scenario.yaml``,
``variant.json`` and a normal run directory), one SQLite store for all
variants (``OUT/sweep.sqlite``, one run per variant), ``OUT/summary.json``
(per-variant parameters, status, key metrics; ``totals`` pooled from the
variants' metrics by ``tools.scoring.totals.sweep_totals``) and ``OUT/report.html``
(``tools.reports.sweep``). A variant is done when its ``run.json`` says
``complete: true`` with the variant's ``config_hash``, its ``metrics.json`` exists
and the store holds a complete run of it (its run directory, the same config hash);
a re-run skips done variants and re-runs the rest (their directories and store rows
are removed first). A variant that raises is ``failed`` with a one-line error and
does not stop the others.

Workers and loaded models are reused across variants, none is started, imported or loaded
per variant: a pool (``new_pool``, ``spawn``) starts its workers once per sweep, they import
the loop in their initializer (``warm_worker``) and run variant after variant; on Ray
(``--ray``, ``start_ray``: ``local`` starts a new local instance with ``workers`` CPUs) each
variant is a task (``ray_task``) without a ``max_calls`` limit, so Ray's worker processes run
task after task too (the first variant on each imports the loop). Inside a worker the ONNX
sessions (detector, appearance embedder) are loaded once per model file version and options
(``perception.detectors.onnx_detector.load_session``); each variant still builds its own
stack, as the detector, tracker and alerts hold per-run state. ``summary.json`` records the
pid each variant ran on (``variants.*.pid``) and the sweep's ``worker_pids``, which is how the
reuse is checked (``lookahead bench sweep``).

Killed sweeps and resumes: the store keeps exactly one run per variant directory.
``settle_store`` deletes every other one (half-written by a killed sweep, written
twice by a late worker, rows that outlived their run) in one transaction, before
the variants run and again after the last one has finished. Pool workers end with
the sweep's main process, also when it is SIGKILLed (``die_with_parent``: Linux's
parent-death signal plus a parent-pid poll), so none is left running or writing;
multiprocessing's resource tracker then sees its pipe close and exits too.
"""

from __future__ import annotations

import ctypes
import json
import logging
import os
import re
import shutil
import signal
import sqlite3
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import yaml

from lookahead.sim.scenario import Scenario
from lookahead.tools.reports.sweep import build_sweep_report
from lookahead.tools.runs.suite import run_one
from lookahead.tools.runs.sweep_spec import (  # noqa: F401 (the sweep file's spec, re-exported)
    MAX_VARIANTS,
    SweepError,
    SweepSpec,
    Variant,
    aeb_variants,
    load_sweep,
    variant_id,
)
from lookahead.tools.scoring.totals import metric_at, sweep_totals
from lookahead.tools.sinks.rundir import (
    METRICS_FILE,
    RunDir,
    as_rundir,
    config_hash,
    prepare_dir,
    write_summary,
)
from lookahead.tools.sinks.store import open_db

log = logging.getLogger(__name__)

RUNS_DIR = "runs"
DB_FILE = "sweep.sqlite"
#: Metrics copied (flat, dotted) into summary.json for every variant.
KEY_METRICS: tuple[str, ...] = (
    "closed_loop.collision", "closed_loop.impact_speed", "closed_loop.min_ttc", "closed_loop.aeb_active_s",
    "detection.recall", "detection.precision", "tracking.mota", "tracking.idf1",
    "estimation.range_rel_err_median", "estimation.speed_err_median",
    "intent.accuracy", "intent.macro_f1",
    "danger.events", "danger.missed", "danger.false_alarms", "danger.lead_time_s_median",
)


# --------------------------------------------------------------------------- running


def one_line(exc: BaseException) -> str:
    text = re.sub(r"\s*For further information visit \S+", "", " ".join(str(exc).split()))
    text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text if len(text) <= 400 else text[:397] + "..."


#: How often (s) a pool worker checks that the process that started it is still alive.
PARENT_POLL_S = 0.5
_PR_SET_PDEATHSIG = 1  # linux/prctl.h


def _arm_parent_death_signal() -> bool:
    """Linux: have the kernel SIGKILL this process when the thread that started it exits."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, ctypes.c_ulong(signal.SIGKILL), ctypes.c_ulong(0),
                          ctypes.c_ulong(0), ctypes.c_ulong(0)) == 0
    except (OSError, AttributeError):  # no libc symbols (static or exotic builds): the poll still works
        return False


def die_with_parent(parent_pid: int, pdeathsig: bool = True) -> None:
    """Make this (worker) process end when ``parent_pid``, the process that started it, ends.

    ``pdeathsig`` (Linux only): ``prctl(PR_SET_PDEATHSIG, SIGKILL)``, immediate, even in C code.
    The kernel sends it when the *thread* that forked this process exits, so it may only be armed
    when that thread lives as long as the process (``new_pool`` arms it when it runs on the main
    thread and starts its workers there). Everywhere: a daemon thread compares ``os.getppid()``
    with ``parent_pid`` every ``PARENT_POLL_S`` s (a dead parent's children are re-parented) and
    ends the process with ``os._exit``. Checked once now too: the parent may already be gone.
    """
    if pdeathsig:
        _arm_parent_death_signal()
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="lookahead-parent-watch", daemon=True).start()


def init_worker(parent_pid: int | None = None, pdeathsig: bool = False) -> None:
    """Pool initializer: end with the parent process (``die_with_parent``), then ``warm_worker``."""
    if parent_pid is not None:
        die_with_parent(parent_pid, pdeathsig)
    warm_worker()


def warm_worker() -> None:
    """Import the loop and the scorer before the first variant arrives."""
    # lazy on purpose: importing these in each worker, before its first variant, is this function's job
    import lookahead.sim.runner  # noqa: F401
    import lookahead.tools.runs.suite  # noqa: F401
    import lookahead.tools.scoring.intent  # noqa: F401
    import lookahead.tools.scoring.run  # noqa: F401
    import lookahead.tools.sinks.store  # noqa: F401


def run_variant(vid: str, scenario_path: str, run_dir: str, render: bool = False, db: str | None = None) -> dict:
    """Run and score one variant (a worker's job); never raises: failures come back as data."""
    t0, c0 = time.perf_counter(), time.process_time()
    result: dict[str, Any] = {"id": vid, "ok": True}
    try:
        run_one(scenario_path, run_dir, render, db)
    except Exception as e:  # one variant must not stop the sweep
        log.info("variant %s failed: %s", vid, one_line(e))
        result.update(ok=False, error=one_line(e))
    result.update(seconds=round(time.perf_counter() - t0, 4), cpu_seconds=round(time.process_time() - c0, 4),
                  pid=os.getpid())
    return result


def _failed(vid: str, exc: BaseException) -> dict:
    return {"id": vid, "ok": False, "error": one_line(exc), "seconds": None, "pid": None}


def is_complete(run_dir: Path | RunDir, scenario: Scenario) -> bool:
    """``run.json`` complete for this very scenario (config hash) and ``metrics.json`` written."""
    rd = as_rundir(run_dir)
    try:
        run = rd.run
    except (OSError, ValueError):
        return False
    return bool(run.get("complete")) and run.get("config_hash") == config_hash(scenario) and rd.has(METRICS_FILE)


#: What ``settle_store`` keeps of a variant directory's store runs.
KEEP_NONE = "none"  # nothing: the variant is to run (again)
KEEP_LATEST = "latest"  # the newest run, complete or not (a failed variant's record)
_CHUNK = 500  # ids per DELETE ... IN (...) (SQLite's variable limit is 999 in old builds)


def _run_tables(conn: sqlite3.Connection) -> list[str]:
    """The store's tables with a ``run_id`` column (rows belonging to a run)."""
    tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
    return [t for t in tables if t != "runs"
            and "run_id" in {c[1] for c in conn.execute(f"PRAGMA table_info({t})")}]


def _delete_runs(conn: sqlite3.Connection, ids: list[int], tables: list[str]) -> None:
    for i in range(0, len(ids), _CHUNK):
        part = ids[i: i + _CHUNK]
        marks = ",".join("?" * len(part))
        for t in tables:
            conn.execute(f"DELETE FROM {t} WHERE run_id IN ({marks})", part)
        conn.execute(f"DELETE FROM runs WHERE id IN ({marks})", part)


def settle_store(db: Path, keep: dict[Path, str]) -> dict[Path, int | None]:
    """Leave at most one store run per variant directory; returns the run id kept for each.

    ``keep[run_dir]``: ``KEEP_NONE`` (delete every run written into it), ``KEEP_LATEST`` (keep the
    newest), or a config hash (keep the newest *complete* run of that scenario, delete the
    rest). Runs of other directories are left alone, except rows of runs that no longer exist
    (a killed or late worker that went on writing after its run was deleted), which are deleted.
    One ``BEGIN IMMEDIATE`` transaction: nothing is half-deleted, and a worker's commit lands
    before or after it, never in between. Only call it while no worker of this sweep runs.
    """
    conn = open_db(db)
    try:
        conn.execute("BEGIN IMMEDIATE")
        try:
            rows: dict[str, list[tuple[int, int, str | None]]] = {}
            wanted = {str(d) for d in keep}
            for rid, run_dir, complete, chash in conn.execute(
                    "SELECT id, run_dir, complete, config_hash FROM runs ORDER BY id"):
                if run_dir in wanted:
                    rows.setdefault(run_dir, []).append((int(rid), int(complete), chash))
            kept: dict[Path, int | None] = {}
            drop: list[int] = []
            for d, rule in keep.items():
                have = rows.get(str(d), [])
                if rule == KEEP_NONE:
                    good = []
                elif rule == KEEP_LATEST:
                    good = have[-1:]
                else:
                    good = [r for r in have if r[1] and r[2] == rule][-1:]
                kept[d] = good[0][0] if good else None
                drop += [r[0] for r in have if r[0] != kept[d]]
            tables = _run_tables(conn)
            if "frames" in tables:  # every batch writes frames: runs whose rows outlived them
                drop += [r[0] for r in conn.execute(
                    "SELECT DISTINCT run_id FROM frames WHERE run_id NOT IN (SELECT id FROM runs)")]
            if drop:
                _delete_runs(conn, sorted(set(drop)), tables)
            conn.execute("COMMIT")
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        if drop:
            log.info("%s: deleted %d stale, duplicate or orphaned run(s)", db, len(set(drop)))
        return kept
    finally:
        conn.close()


def todo_variants(out: Path, variants: list[Variant], db: Path | None = None) -> list[Variant]:
    """The variants a (re-)run of the sweep in ``out`` would run, as ``run_sweep`` decides it, but
    read-only (for listings such as ``--dry-run``): not done = no complete run directory of this
    scenario, or no complete store run of it (``db``, default ``out/sweep.sqlite``)."""
    out = Path(out).resolve()
    db = (Path(db) if db is not None else out / DB_FILE).resolve()
    stored: set[tuple[str, str]] = set()
    if db.is_file():
        conn = open_db(db, create=False)
        try:
            stored = {(r[0], r[1]) for r in conn.execute(
                "SELECT run_dir, config_hash FROM runs WHERE complete = 1 AND run_dir IS NOT NULL")}
        finally:
            conn.close()
    todo = []
    for v in variants:
        d = out / RUNS_DIR / v.id
        if not (is_complete(d, v.scenario) and (str(d), config_hash(v.scenario)) in stored):
            todo.append(v)
    return todo


def forget_runs(db: Path, run_dirs: list[Path]) -> int:
    """Delete the store's rows of runs written into ``run_dirs`` (stale or killed runs)."""
    if not run_dirs:
        return 0
    conn = open_db(db)
    try:
        dirs = {str(d) for d in run_dirs}
        ids = [int(r[0]) for r in conn.execute("SELECT id, run_dir FROM runs") if r[1] in dirs]
    finally:
        conn.close()
    settle_store(db, dict.fromkeys(run_dirs, KEEP_NONE))
    return len(ids)


def _run_pool(pool, jobs: list[dict], on_result: Callable[[dict], None]) -> None:
    futures = {pool.submit(run_variant, **job): job["vid"] for job in jobs}
    for f in as_completed(futures):
        try:
            r = f.result()
        except Exception as e:  # a worker process died (BrokenProcessPool) or the job did not pickle
            r = _failed(futures[f], e)
        on_result(r)


def new_pool(workers: int):
    """A ``spawn`` pool of ``workers`` processes, started now, that import the loop up front and
    end with this process (``die_with_parent``: also after a SIGKILL, which runs no cleanup).

    The workers are started here, by this thread (one no-op job each: a spawn pool starts a
    process per job submitted while none is idle), so that the Linux parent-death signal, armed
    when this is the main thread, follows the process, not a thread that may end before it."""
    main = threading.current_thread() is threading.main_thread()
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"), initializer=init_worker,
                               initargs=(os.getpid(), main))
    for _ in range(workers):
        pool.submit(os.getpid)
    return pool


def import_ray():
    try:
        import ray  # lazy: ray is the optional extra 'distributed'
    except ImportError:
        raise SweepError("--ray needs the 'distributed' extra: pip install 'lookahead[distributed]'") from None
    return ray


def start_ray(address: str, workers: int) -> bool:
    """Connect to Ray unless it is initialised already (e.g. by the caller); True when this call
    did (the caller then ends it with ``ray.shutdown``). ``address``: ``auto``, ``ray://...``,
    ``HOST:PORT``, or ``local``: a new local instance with ``workers`` CPUs, never one started
    with ``ray start``."""
    ray = import_ray()
    if ray.is_initialized():
        return False
    try:
        if address == "local":
            ray.init(address="local", num_cpus=max(1, workers), include_dashboard=False,
                     logging_level=logging.WARNING)
        else:
            ray.init(address=address, logging_level=logging.WARNING)
    except Exception as e:
        raise SweepError(f"--ray {address}: cannot start or reach a Ray cluster ({one_line(e)})") from None
    return True


def ray_task(fn: Callable):
    """``fn`` as a Ray task needing 1 CPU, never retried, run by reused workers: ``max_calls=0``
    (no limit; Ray's default for CPU tasks, stated so nothing defeats it), so a worker process
    imports the loop and loads its models once and runs task after task."""
    return import_ray().remote(num_cpus=1, max_retries=0, max_calls=0)(fn)


def _run_ray(jobs: list[dict], address: str, workers: int, on_result: Callable[[dict], None]) -> None:
    """One Ray task per variant (``ray_task``); Ray connected by ``start_ray`` (an already
    initialised Ray is used as it is and left running)."""
    ray = import_ray()
    started = start_ray(address, workers)
    try:
        task = ray_task(run_variant)
        refs = {task.remote(**job): job["vid"] for job in jobs}
        pending = list(refs)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for ref in ready:
                try:
                    r = ray.get(ref)
                except Exception as e:  # worker crash, task error
                    r = _failed(refs[ref], e)
                on_result(r)
    finally:
        if started:
            ray.shutdown()


def key_metrics(metrics: dict, extra: list[str] | None = None) -> dict[str, Any]:
    out = {k: metric_at(metrics, k) for k in (*KEY_METRICS, *(extra or []))}
    exp = metrics.get("expectations") or []
    out["expectations.passed"] = sum(bool(e.get("passed")) for e in exp)
    out["expectations.total"] = len(exp)
    return out


def _write_variant(v: Variant, run_dir: Path) -> Path:
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / "scenario.yaml"
    data = v.scenario.model_dump(mode="json", exclude_unset=True)
    data["name"] = v.scenario.name
    path.write_text(f"# variant {v.id} of a sweep; parameters: {json.dumps(v.params)}\n"
                    + yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    (run_dir / "variant.json").write_text(json.dumps({"id": v.id, "params": v.params}, indent=2) + "\n")
    return path


def run_sweep(
    sweep_path: str | Path, out: Path, workers: int = 1, ray_address: str | None = None, render: bool = False,
    db: Path | None = None, progress: Callable[[dict], None] | None = None, executor=None, report: bool = True,
    variants: list[Variant] | None = None, aeb: str | None = None,
) -> dict:
    """Run the missing variants of a sweep and write ``summary.json`` (and the report).

    ``executor``: an existing ``concurrent.futures`` pool to use (benchmarks keep one warm);
    else ``ray_address`` (Ray), else a ``spawn`` pool of ``workers`` processes (in this
    process when ``workers`` <= 1). ``progress(result)`` is called once per variant run.
    ``variants`` overrides the sweep file's (a subset, e.g. in benchmarks). ``aeb`` (on | off)
    switches every variant's AEB (``aeb_variants``); recorded in the summary (None: as written).
    """
    sweep_path = Path(sweep_path)
    spec, base_path, expanded = load_sweep(sweep_path)  # aeb: applied below, to these or the given variants
    variants = aeb_variants(expanded if variants is None else variants, aeb)
    out = prepare_dir(Path(out).resolve())
    runs = out / RUNS_DIR
    db = (Path(db) if db is not None else out / DB_FILE).resolve()
    open_db(db).close()  # fail before running anything; creates the schema once
    # done = complete run directory and its complete store run; everything else runs again, and
    # the store keeps no other run of a variant (a killed sweep's half-written or late runs)
    keep = {runs / v.id: config_hash(v.scenario) if is_complete(runs / v.id, v.scenario) else KEEP_NONE
            for v in variants}
    kept = settle_store(db, keep)
    pending = [v for v in variants if kept[runs / v.id] is None]
    jobs = []
    for v in pending:
        d = runs / v.id
        shutil.rmtree(d, ignore_errors=True)
        jobs.append({"vid": v.id, "scenario_path": str(_write_variant(v, d)), "run_dir": str(d),
                     "render": render, "db": str(db)})
    results: dict[str, dict] = {}

    def on_result(r: dict) -> None:
        results[r["id"]] = r
        if progress is not None:
            progress(r)

    t0 = time.perf_counter()
    if not jobs:
        backend = "none"
    elif executor is not None:
        backend = "pool"
        _run_pool(executor, jobs, on_result)
    elif ray_address:
        backend = "ray"
        _run_ray(jobs, ray_address, workers, on_result)
    elif workers <= 1:
        backend = "inline"
        for job in jobs:
            on_result(run_variant(**job))
    else:
        backend = "pool"
        with new_pool(min(workers, len(jobs))) as pool:
            _run_pool(pool, jobs, on_result)
    elapsed = time.perf_counter() - t0
    if jobs:  # every worker is done: one store run per variant whatever was written twice
        settle_store(db, {runs / v.id: config_hash(v.scenario) if is_complete(runs / v.id, v.scenario)
                          else KEEP_LATEST for v in variants})
    summary = gather(out, spec, sweep_path, base_path, variants, results, render=render, db=db, aeb=aeb)
    summary.update(backend=backend, workers=workers, elapsed_s=round(elapsed, 3))
    write_summary(out, summary)
    if report:
        build_sweep_report(out)
    return summary


def gather(
    out: Path, spec: SweepSpec, sweep_path: Path, base_path: Path, variants: list[Variant],
    results: dict[str, dict], render: bool, db: Path, aeb: str | None = None,
) -> dict:
    """``summary.json`` content from the run directories on disk (done now or earlier)."""
    entries: dict[str, dict] = {}
    done: list[dict] = []  # the done variants' metrics
    extra = spec.report.metrics or []
    for v in variants:
        d = RunDir(out / RUNS_DIR / v.id)
        r = results.get(v.id)
        entry: dict[str, Any] = {"dir": f"{RUNS_DIR}/{v.id}", "params": v.params, "skipped": r is None,
                                 "seconds": None if r is None else r.get("seconds"),
                                 "cpu_seconds": None if r is None else r.get("cpu_seconds"),
                                 "pid": None if r is None else r.get("pid")}
        if is_complete(d, v.scenario):
            metrics = d.read_metrics()
            entry.update(status="done", summary=d.run.get("summary"), metrics=key_metrics(metrics, extra))
            done.append(metrics)
        else:
            error = (r or {}).get("error") or ("the run ended without a complete run directory" if r else
                                               "not run")
            entry.update(status="failed", error=error)
        entries[v.id] = entry
    failed = [k for k, e in entries.items() if e["status"] == "failed"]
    totals = sweep_totals(done, KEY_METRICS) if done else {}

    def rel(p: Path) -> str:
        try:
            return str(p.relative_to(out))
        except ValueError:
            return str(p)

    return {
        "sweep": spec.name or sweep_path.stem,
        "description": spec.description,
        "sweep_file": str(sweep_path),
        "scenario": str(base_path),
        "parameters": spec.parameters(),
        "set": spec.set,
        "report": spec.report.model_dump(),
        "render": render,
        "aeb": aeb,
        "db": rel(db),
        "counts": {"variants": len(variants), "done": len(done), "failed": len(failed),
                   "ran": len(results), "skipped": len(variants) - len(results)},
        "worker_pids": sorted({r["pid"] for r in results.values() if r.get("pid") is not None}),
        "failed": {k: entries[k]["error"] for k in failed},
        "variants": entries,
        "totals": totals,
    }
