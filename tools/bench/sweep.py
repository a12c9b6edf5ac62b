"""``lookahead bench sweep``: one sweep on 1 worker, on 2 workers and on a local Ray cluster, in one process.

The sweep (default ``scenarios/sweeps/aeb_stationary_car.yaml``, 16 variants,
rendering off, gt detector) runs through ``tools.runs.sweep.run_sweep`` exactly as
``lookahead sweep`` does (run directories, scoring, one SQLite store,
``summary.json`` with totals; no HTML report), each time into a fresh directory.

What is reused, and so not timed: both process pools, then (once the pools are shut
down, so that Ray's daemons, a few % of a CPU, stay out of the pools' timing) the Ray
instance (``ray.init(address="local", num_cpus=2)`` by ``tools.runs.sweep.start_ray``,
the ``--ray local`` path) are started once, before their timed sweeps, and warmed:
their workers import the loop (pools: in the initializer; Ray: in the warm-up task)
and each runs one short warm-up scenario; the main process is warmed by one untimed
2-variant sweep (scoring, totals). Every timed sweep then runs its variants on those
same worker processes (Ray tasks have no ``max_calls`` limit), and a worker loads
each ONNX model once (``perception.detectors.onnx_detector.load_session``; none with
the gt detector). So the timed wall time is the sweep itself, not process start-up,
imports or model loads. Checked, not assumed: ``variant_worker_pids`` holds the pids
the variants ran on (from ``summary.json``), ``worker_pids`` the warmed ones, and
``workers_reused`` is true when every variant of every case ran on a warmed worker,
on no more processes than the case's workers.

Cases: ``sweep_1_worker`` / ``sweep_2_workers`` (their order alternating between
repeats) / ``sweep_ray`` (wall ms per whole sweep, one sample per repeat),
``variant_*`` (wall ms per variant inside a worker) and ``variant_cpu_*`` (CPU ms of
the worker process per variant: equal CPU but longer wall with 2 workers means the
workers were starved of CPU by other load, not slowed by each other). Ratios
``two_workers_over_one`` = median wall(2) / median wall(1) and ``ray_over_two_workers``
= median wall(Ray) / median wall(2). ``ray_same_results``: every variant's status and
key metrics in each Ray run's ``summary.json`` equal the 2-worker run's of the same
repeat (``ray_differing_variants``: the ids that do not). Ray is optional: without
it (``import ray`` fails) or when it cannot start, the Ray case is skipped, the
reason logged and stored as ``ray_skipped``.
"""

from __future__ import annotations

import json
import logging
import os
import statistics
import tempfile
import time
from pathlib import Path

from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.bench.common import case, machine
from lookahead.tools.runs.sweep import (
    SweepError,
    import_ray,
    load_sweep,
    new_pool,
    ray_task,
    run_sweep,
    start_ray,
    warm_worker,
)
from lookahead.tools.sinks.rundir import SUMMARY_FILE

log = logging.getLogger(__name__)

WARM_SCENARIO = SCENARIOS / "stationary_car.yaml"
RAY = "ray"  # the Ray backend's key among the worker counts
RAY_CPUS = 2


def _warm_task(run_dir: str, hold_s: float) -> int:
    """Import the loop (``warm_worker``), run a 1-s scenario in this worker (first-run caches),
    then hold so the next warm-up task lands on another worker; returns the worker's pid."""
    t0 = time.perf_counter()
    warm_worker()
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


def warm_ray(workers: int, tmp: str, rounds: int = 5) -> set[int]:
    """``warm_pool`` for the connected Ray instance: warm-up tasks until ``workers`` worker processes ran one."""
    ray = import_ray()
    task = ray_task(_warm_task)
    seen: set[int] = set()
    for _ in range(rounds):
        seen |= set(ray.get([task.remote(tmp, 0.3) for _ in range(workers)]))
        if len(seen) >= workers:
            break
    return seen


def _ray_up() -> tuple[bool, str | None]:
    """Connect to Ray for the benchmark: (whether this call started it, None) or (False, why not)."""
    try:
        return start_ray("local", RAY_CPUS), None
    except SweepError as e:
        log.warning("bench sweep: Ray case skipped: %s", e)
        return False, str(e)


def _label(n: int | str) -> str:
    return {1: "1_worker", RAY: RAY}.get(n, f"{n}_workers")


def differing_variants(a: dict, b: dict) -> list[str]:
    """Ids of the variants whose status or key metrics differ between two ``summary.json``
    contents (or that only one holds); NaN equals NaN."""
    va, vb = a.get("variants", {}), b.get("variants", {})

    def key(v: dict | None) -> str:
        return json.dumps(None if v is None else [v.get("status"), v.get("metrics")], sort_keys=True)

    return sorted(k for k in va.keys() | vb.keys() if key(va.get(k)) != key(vb.get(k)))


def bench_sweep(
    sweep_path: Path, variants: int | None = None, repeats: int = 1, worker_counts=(1, 2), ray: bool = True,
) -> dict:
    """Time the sweep on each of ``worker_counts`` (warm process pools) and, with ``ray``, on a
    local Ray instance of ``RAY_CPUS`` CPUs; see the module docstring for what is measured."""
    sweep_path = Path(sweep_path)
    _, _, expanded = load_sweep(sweep_path)
    chosen = expanded if variants is None else expanded[:variants]
    walls: dict[int | str, list[float]] = {}
    per_variant: dict[int | str, list[float]] = {}
    cpu: dict[int | str, list[float]] = {}
    used_pids: dict[int | str, set[int]] = {}
    summaries: dict[int | str, list[dict]] = {}
    pids: dict[int | str, list[int]] = {}
    failed = 0

    def timed(n: int | str, out: Path, **backend) -> None:
        nonlocal failed
        t0 = time.perf_counter()
        run_sweep(sweep_path, out, report=False, variants=chosen, **backend)
        walls.setdefault(n, []).append((time.perf_counter() - t0) * 1e3)
        s = json.loads((out / SUMMARY_FILE).read_text())
        summaries.setdefault(n, []).append(s)
        entries = s["variants"].values()
        per_variant.setdefault(n, []).extend(v["seconds"] * 1e3 for v in entries if v.get("seconds"))
        cpu.setdefault(n, []).extend(v["cpu_seconds"] * 1e3 for v in entries if v.get("cpu_seconds"))
        used_pids.setdefault(n, set()).update(s["worker_pids"])
        failed += s["counts"]["failed"]

    with tempfile.TemporaryDirectory(prefix="lookahead-bench-sweep-") as tmp:
        pools = {n: new_pool(n) for n in worker_counts}
        try:
            pids.update({n: sorted(warm_pool(pools[n], n, tmp)) for n in worker_counts})
            # the main process: scoring and totals imported and run once, untimed
            run_sweep(sweep_path, Path(tmp) / "warm", executor=pools[worker_counts[0]], report=False,
                      variants=chosen[:2])
            for rep in range(repeats):
                for n in worker_counts if rep % 2 == 0 else tuple(reversed(worker_counts)):
                    timed(n, Path(tmp) / f"{_label(n)}-{rep}", executor=pools[n])
        finally:
            for p in pools.values():
                p.shutdown(wait=True, cancel_futures=True)
        # Ray after the pools are gone (its daemons' few % of a CPU stay out of their timing)
        ray_started, ray_skipped = _ray_up() if ray else (False, "not asked for")
        if ray_skipped is None:
            try:
                pids[RAY] = sorted(warm_ray(RAY_CPUS, tmp))
                for rep in range(repeats):
                    timed(RAY, Path(tmp) / f"{RAY}-{rep}", ray_address="local", workers=RAY_CPUS)
            finally:
                if ray_started:
                    import_ray().shutdown()
    backends = [n for n in (*worker_counts, RAY) if n in walls]
    cases = {}
    for n in backends:
        cases[f"sweep_{_label(n)}"] = case(walls[n])
        cases[f"variant_{_label(n)}"] = case(per_variant[n])
        cases[f"variant_cpu_{_label(n)}"] = case(cpu[n])
    size = {n: RAY_CPUS if n == RAY else n for n in backends}
    result: dict = {
        "machine": machine(),
        "sweep": str(sweep_path),
        "variants": len(chosen),
        "repeats": repeats,
        "render": False,
        "failed_variants": failed,
        "worker_pids": {str(n): p for n, p in pids.items()},
        "variant_worker_pids": {str(n): sorted(p) for n, p in used_pids.items()},
        "workers_reused": all(used_pids[n] <= set(pids[n]) and len(used_pids[n]) <= size[n] for n in backends),
        "cases": cases,
        "ratios": {},
    }
    median = {n: statistics.median(walls[n]) for n in backends}
    if 1 in median and 2 in median:
        result["ratios"]["two_workers_over_one"] = round(median[2] / median[1], 4)
    if RAY in median:
        ref = 2 if 2 in median else max(worker_counts)
        name = "ray_over_two_workers" if ref == 2 else f"ray_over_{_label(ref)}"
        result["ratios"][name] = round(median[RAY] / median[ref], 4)
        differing = sorted({vid for a, b in zip(summaries[RAY], summaries[ref], strict=True)
                            for vid in differing_variants(a, b)})
        result.update(ray_same_results=not differing, ray_differing_variants=differing)
    else:
        result["ray_skipped"] = ray_skipped
    return result
