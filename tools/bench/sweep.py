"""``lookahead bench sweep``: one sweep on 1 worker, then on 2 workers, in one process.

The sweep (default ``scenarios/sweeps/aeb_stationary_car.yaml``, 16 variants,
rendering off, gt detector) runs through ``tools.runs.sweep.run_sweep`` exactly as
``lookahead sweep`` does (run directories, scoring, one SQLite store,
``summary.json`` with totals; no HTML report), each time into a fresh directory.
Both pools are created once, before timing, and warmed: their workers import the
loop in the pool initializer and each runs one short warm-up scenario; the
main process is warmed by one untimed 2-variant sweep (scoring, totals). So the
timed wall time is the sweep itself, not process start-up or imports.

Cases: ``sweep_1_worker`` / ``sweep_2_workers`` (wall ms per whole sweep, one
sample per repeat), ``variant_1_worker`` / ``variant_2_workers`` (wall ms per
variant inside a worker) and ``variant_cpu_*`` (CPU ms of the worker process per
variant: equal CPU but longer wall with 2 workers means the workers were starved
of CPU by other load, not slowed by each other). Ratio ``two_workers_over_one`` = median wall(2) / median wall(1).
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.bench.common import case, machine
from lookahead.tools.runs.sweep import load_sweep, new_pool, run_sweep

WARM_SCENARIO = SCENARIOS / "stationary_car.yaml"


def _warm_task(run_dir: str, hold_s: float) -> int:
    """Run a 1-s scenario in this worker (first-run caches), then hold so the next
    warm-up task lands on another worker; returns the worker's pid."""
    t0 = time.perf_counter()
    sc = load_scenario(WARM_SCENARIO).model_copy(update={"duration": 1.0})
    Runner(sc, render=False).run()
    time.sleep(max(0.0, hold_s - (time.perf_counter() - t0)))
    return os.getpid()


def warm_pool(pool, workers: int, tmp: str, rounds: int = 5) -> set[int]:
    """Until every one of ``workers`` processes has run a warm-up task (or ``rounds`` ran out)."""
    seen: set[int] = set()
    for _ in range(rounds):
        futures = [pool.submit(_warm_task, tmp, 0.3) for _ in range(workers)]
        seen |= {f.result() for f in futures}
        if len(seen) >= workers:
            break
    return seen


def bench_sweep(sweep_path: Path, variants: int | None = None, repeats: int = 1, worker_counts=(1, 2)) -> dict:
    sweep_path = Path(sweep_path)
    _, _, expanded = load_sweep(sweep_path)
    chosen = expanded if variants is None else expanded[:variants]
    walls: dict[int, list[float]] = {n: [] for n in worker_counts}
    per_variant: dict[int, list[float]] = {n: [] for n in worker_counts}
    cpu: dict[int, list[float]] = {n: [] for n in worker_counts}
    failed = 0
    with tempfile.TemporaryDirectory(prefix="lookahead-bench-sweep-") as tmp:
        pools = {n: new_pool(n) for n in worker_counts}
        try:
            pids = {n: sorted(warm_pool(pools[n], n, tmp)) for n in worker_counts}
            # the main process: scoring and totals imported and run once, untimed
            run_sweep(sweep_path, Path(tmp) / "warm", executor=pools[worker_counts[0]], report=False,
                      variants=chosen[:2])
            for rep in range(repeats):
                order = worker_counts if rep % 2 == 0 else tuple(reversed(worker_counts))
                for n in order:
                    t0 = time.perf_counter()
                    s = run_sweep(sweep_path, Path(tmp) / f"w{n}-{rep}", executor=pools[n], report=False,
                                  variants=chosen)
                    walls[n].append((time.perf_counter() - t0) * 1e3)
                    per_variant[n] += [v["seconds"] * 1e3 for v in s["variants"].values() if v.get("seconds")]
                    cpu[n] += [v["cpu_seconds"] * 1e3 for v in s["variants"].values() if v.get("cpu_seconds")]
                    failed += s["counts"]["failed"]
        finally:
            for p in pools.values():
                p.shutdown(wait=True, cancel_futures=True)
    name = {1: "1_worker"}
    cases = {}
    for n in worker_counts:
        label = name.get(n, f"{n}_workers")
        cases[f"sweep_{label}"] = case(walls[n])
        cases[f"variant_{label}"] = case(per_variant[n])
        cases[f"variant_cpu_{label}"] = case(cpu[n])
    ratios = {}
    if 1 in walls and 2 in walls:
        ratios["two_workers_over_one"] = round(statistics.median(walls[2]) / statistics.median(walls[1]), 4)
    return {
        "machine": machine(),
        "sweep": str(sweep_path),
        "variants": len(chosen),
        "repeats": repeats,
        "render": False,
        "failed_variants": failed,
        "worker_pids": {str(n): p for n, p in pids.items()},
        "cases": cases,
        "ratios": ratios,
    }
