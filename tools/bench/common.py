"""Benchmarks. Each writes ``{"machine", "cases", "ratios"}`` JSON; all cases of
one file are measured in the same process run, interleaved where they are
compared, so ratios are robust to this machine's noise."""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

import numpy as np
from highway_env.road.road import Road
from highway_env.vehicle.behavior import IDMVehicle

from lookahead.sim.road import MAIN_FROM, MAIN_TO, build_road
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import Scenario, load_scenario
from lookahead.sim.world import World


def machine() -> dict:
    return {
        "platform": platform.platform(),
        "python": platform.python_version(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
    }


def case(samples_ms: list[float]) -> dict:
    a = np.asarray(samples_ms, dtype=np.float64)
    return {"ms_median": round(float(np.median(a)), 4), "ms_p95": round(float(np.percentile(a, 95)), 4), "n": len(a)}


def bare_highway(scenario: Scenario) -> Road:
    """highway-env alone with the scenario's traffic: its Road, IDM vehicles and an IDM ego."""
    net, _, _ = build_road(scenario.road)
    road = Road(network=net, np_random=np.random.RandomState(scenario.seed))
    lane = net.get_lane((MAIN_FROM, MAIN_TO, scenario.ego.lane))
    ego = IDMVehicle(road, lane.position(scenario.ego.s, 0.0), 0.0, scenario.ego.speed, enable_lane_change=False)
    road.vehicles.append(ego)
    rng = np.random.default_rng([scenario.seed, 2])
    t = scenario.traffic
    for _ in range(t.count):
        speed = None if t.speed is None else float(rng.uniform(*t.speed))
        rng.random()  # the class draw our world makes
        v = IDMVehicle.create_random(road, speed=speed, lane_from=MAIN_FROM, lane_to=MAIN_TO, spacing=1.0 / t.density)
        v.enable_lane_change = t.lane_change
        road.vehicles.append(v)
    return road


def bench_sim(scenario_path: Path, ticks: int = 400, frames: int = 30, block: int = 20) -> dict:
    """Bare highway-env vs our world step (no rendering), then rendering at two sizes."""
    scenario = load_scenario(scenario_path)
    dt = 1.0 / scenario.rate
    road, world = bare_highway(scenario), World(scenario)
    bare_ms, world_ms = [], []
    for _ in range(max(1, ticks // block)):  # interleaved blocks
        t0 = time.perf_counter()
        for _ in range(block):
            road.act()
            road.step(dt)
        t1 = time.perf_counter()
        for _ in range(block):
            world.step()
        t2 = time.perf_counter()
        bare_ms.append((t1 - t0) * 1e3 / block)
        world_ms.append((t2 - t1) * 1e3 / block)
    cases = {"highway_env_step": case(bare_ms), "world_step": case(world_ms)}
    for w, h in ((640, 360), (960, 540)):
        sc = scenario.model_copy(deep=True)
        sc.camera.width, sc.camera.height = w, h
        runner = Runner(sc, render=True)
        render_ms, gt_ms = [], []
        for _ in range(frames):
            for _ in range(runner.frame_every):
                runner.world.step()
            _, _, timings = runner.frame()
            render_ms.append(timings["render"])
            gt_ms.append(timings["gt"])
        cases[f"render_{w}x{h}"] = case(render_ms)
        cases[f"ground_truth_{w}x{h}"] = case(gt_ms)
        cases[f"render_{w}x{h}"]["backend"] = runner.renderer.backend
        runner.close()
    ratios = {"world_over_highway": round(cases["world_step"]["ms_median"] / cases["highway_env_step"]["ms_median"], 4)}
    return {
        "machine": machine(),
        "scenario": str(scenario_path),
        "traffic_vehicles": scenario.traffic.count,
        "cases": cases,
        "ratios": ratios,
    }
