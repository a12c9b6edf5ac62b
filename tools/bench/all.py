"""``lookahead bench all``: every benchmark in one process, one JSON, one table.

Runs ``bench sim``, ``bench track``, ``bench detect``, ``bench sinks``, ``bench env``
(``ForwardTracks-v0`` vs bare highway-env), ``bench sweep`` (16 variants on 1 and 2
workers and on a local Ray instance; ``sweep_ray_same_results``), ``bench watch`` (the watch pipeline vs its slowest stage), ``bench appearance``
(the tracker with and without appearance re-identification at 30 objects), ``bench fusion``
(cooperative fusion of 3 senders x 30 objects per tick) and the full
rendered loop (``urban_mix``, 640x360, the shipped ONNX detector; ``bench_loop``) on the
same machine in one run; cases are prefixed with their benchmark's name and all ratios
are gathered.
"""

from __future__ import annotations

import time
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
from lookahead.tools.bench.fusion import bench_fusion
from lookahead.tools.bench.sinks import bench_sinks
from lookahead.tools.bench.sweep import bench_sweep
from lookahead.tools.bench.track import bench_track
from lookahead.tools.bench.watch import bench_watch


class _FrameClock(RecordCollector):
    """Keeps every record and when it reached the sinks (perf_counter s)."""

    def __init__(self) -> None:
        super().__init__()
        self.stamps: list[float] = []

    def on_tick(self, record) -> None:
        super().on_tick(record)
        self.stamps.append(time.perf_counter())


def _loop_run(scenario, overlap: bool) -> _FrameClock:
    """One run of ``scenario``, configured as the overlapped loop is (one inference thread, one
    GL thread in the render worker); ``overlap`` False runs it stage after stage."""
    clock = _FrameClock()
    runner = Runner(scenario, sinks=[clock], render=True, overlap=True)
    runner.overlap = overlap
    runner.run()
    return clock


def bench_loop(scenario_path: Path) -> dict:
    """The full rendered loop over one scenario (its detector: the shipped ONNX model by default).

    Run twice in this process, both configured as ``lookahead run`` runs it (one inference
    thread, one GL thread in the render worker): stage by stage (every stage alone, the
    per-stage cases), then overlapped (frame k+1 rendered while frame k is perceived).
    Stage groups: ``render`` (the render worker's: render, weather) and ``perceive`` (the
    rest of a frame: world step, ground truth, detect, track, estimate, intent, sinks). Frame rates count frames after the first (no
    start-up). Ratios: ``loop_over_slowest_stage`` = overlapped fps / (1000 / the slower
    group's median ms alone); ``gt_over_render`` = median ground truth / median render ms.
    """
    scenario = load_scenario(scenario_path)
    alone = _loop_run(scenario, overlap=False)
    looped = _loop_run(scenario, overlap=True)
    cases = {}
    for stage in STAGES:
        values = [r.timings[stage] for r in alone.records if stage in r.timings]
        if values:
            cases[stage] = case(values)
    cases["perceive"] = case([r.timings["tick"] - r.timings["render"] for r in alone.records])
    render, perceive = cases["render"]["ms_median"], cases["perceive"]["ms_median"]
    intervals = np.diff(looped.stamps) * 1e3
    cases["loop_frame"] = case(intervals.tolist())
    fps = float(1000.0 / np.mean(intervals))
    fps_alone = float(1000.0 / np.mean(np.diff(alone.stamps) * 1e3))
    slowest = max(render, perceive)
    return {
        "cases": cases,
        "fps": round(fps, 2),
        "fps_sequential": round(fps_alone, 2),
        "renderer": looped.info.get("renderer"),
        "slowest_stage_group": "render" if render >= perceive else "perceive",
        "ratios": {
            "loop_over_slowest_stage": round(fps / (1000.0 / slowest), 4),
            "gt_over_render": round(cases["gt"]["ms_median"] / cases["render"]["ms_median"], 4),
        },
    }


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
        "fusion": bench_fusion(senders=3, objects=30),
    }
    cases, ratios = {}, {}
    for name, part in parts.items():
        for k, v in part["cases"].items():
            cases[f"{name}/{k}"] = {key: v[key] for key in ("ms_median", "ms_p95", "n") if key in v}
        ratios.update(part.get("ratios", {}))
    track = {k: parts["track"][k] for k in ("accuracy", "accuracy_pooled", "sort_reference") if k in parts["track"]}
    return {"machine": machine(), "cases": cases, "ratios": ratios, "loop_fps": parts["loop"]["fps"],
            "loop_fps_sequential": parts["loop"]["fps_sequential"], "renderer": parts["loop"]["renderer"],
            "loop_slowest_stage_group": parts["loop"]["slowest_stage_group"],
            "sweep_ray_same_results": parts["sweep"].get("ray_same_results"),
            "detect_fps": parts["detect"]["fps"], "track_accuracy": track, "watch_fps": parts["watch"]["fps"],
            "watch_latency_ms": parts["watch"]["latency_ms"],
            "fusion_matching": {k: parts["fusion"][k] for k in ("matching_precision", "matching_recall")}}
