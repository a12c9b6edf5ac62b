"""``lookahead bench all``: every benchmark in one process, one JSON, one table.

Runs ``bench sim``, ``bench track``, ``bench detect``, ``bench sinks``, ``bench env``
(``ForwardTracks-v0`` vs bare highway-env), ``bench sweep`` (16 variants on 1 vs 2
workers), ``bench watch`` (the watch pipeline vs its slowest stage), ``bench appearance``
(the tracker with and without appearance re-identification at 30 objects) and the full loop (rendered, gt detector, every stage) on the same
machine in one run; cases are prefixed with their benchmark's name and all
ratios are gathered.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import STAGES, Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.bench.appearance import bench_appearance
from lookahead.tools.bench.common import bench_sim, case, machine
from lookahead.tools.bench.detect import bench_detect
from lookahead.tools.bench.env import bench_env
from lookahead.tools.bench.sinks import bench_sinks
from lookahead.tools.bench.sweep import bench_sweep
from lookahead.tools.bench.track import bench_track
from lookahead.tools.bench.watch import bench_watch


def bench_loop(scenario_path: Path) -> dict:
    """Per-stage ms of the full rendered loop over one scenario."""
    probe = RecordCollector()
    Runner(load_scenario(scenario_path), sinks=[probe], render=True).run()
    cases = {}
    for stage in STAGES:
        values = [r.timings[stage] for r in probe.records if stage in r.timings]
        if values:
            cases[stage] = case(values)
    tick = np.median([r.timings["tick"] for r in probe.records])
    return {"cases": cases, "fps": round(float(1000.0 / tick), 2)}


def bench_all(repeats: int = 3) -> dict:
    scen = SCENARIOS
    parts = {
        "sim": bench_sim(scen / "highway_traffic.yaml"),
        "track": bench_track(None, repeats=repeats),
        "detect": bench_detect(repeats=repeats),
        "sinks": bench_sinks(scen / "ped_crossing_nearside.yaml", repeats=repeats),
        "env": bench_env(scen / "highway_traffic.yaml"),
        "sweep": bench_sweep(scen / "sweeps" / "aeb_stationary_car.yaml"),
        "loop": bench_loop(scen / "urban_mix.yaml"),
        "watch": bench_watch(scen / "ped_crossing_nearside.yaml", repeats=repeats),
        "appearance": bench_appearance(objects=30),
    }
    cases, ratios = {}, {}
    for name, part in parts.items():
        for k, v in part["cases"].items():
            cases[f"{name}/{k}"] = {key: v[key] for key in ("ms_median", "ms_p95", "n") if key in v}
        ratios.update(part.get("ratios", {}))
    track = {k: parts["track"][k] for k in ("accuracy", "accuracy_pooled", "sort_reference") if k in parts["track"]}
    return {"machine": machine(), "cases": cases, "ratios": ratios, "loop_fps": parts["loop"]["fps"],
            "detect_fps": parts["detect"]["fps"], "track_accuracy": track, "watch_fps": parts["watch"]["fps"],
            "watch_latency_ms": parts["watch"]["latency_ms"]}
