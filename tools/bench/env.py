"""``lookahead bench env``: the ``ForwardTracks-v0`` gymnasium env against bare highway-env.

``gymnasium.make("lookahead/ForwardTracks-v0", scenario=...)`` with a traffic
scenario (``traffic.count: 10`` in ``scenarios/highway_traffic.yaml``) steps with
a constant zero-acceleration action; one env step is one camera frame
(``frame_every`` world ticks + ground truth + the perception stack, no rendering).
The same simulated time of bare highway-env (``tools.bench.common.bare_highway``: its
``Road``, the same IDM traffic and an IDM ego) is stepped in interleaved blocks in
the same process; both restart when the episode ends (env resets are timed
separately). Ratios: ``tracks_env_realtime_factor`` = simulated seconds per wall
second of the env (median step), ``highway_env_realtime_factor`` likewise for bare
highway-env, ``tracks_env_over_highway`` = env step / bare step (ms).
"""

from __future__ import annotations

import time
from pathlib import Path

import gymnasium
import numpy as np

import lookahead.sim  # noqa: F401  (registers the lookahead/ environments)
from lookahead.sim.scenario import load_scenario
from lookahead.tools.bench.common import bare_highway, case, machine

ENV_ID = "lookahead/ForwardTracks-v0"


def bench_env(scenario_path: Path, steps: int = 600, block: int = 10) -> dict:
    scenario = load_scenario(scenario_path)
    env = gymnasium.make(ENV_ID, scenario=scenario)
    action = np.zeros(1, dtype=np.float32)
    t0 = time.perf_counter()
    env.reset(seed=scenario.seed)
    reset_ms = [(time.perf_counter() - t0) * 1e3]
    runner = env.unwrapped.runner
    ticks = runner.frame_every
    dt = 1.0 / scenario.rate
    step_s = ticks * dt
    vehicles = len(runner.world.road.vehicles) - 1 - len(scenario.actors)  # traffic only
    road = bare_highway(scenario)
    env_ms: list[float] = []
    bare_ms: list[float] = []
    episodes = 1
    while len(env_ms) < steps:
        for _ in range(min(block, steps - len(env_ms))):
            t0 = time.perf_counter()
            _, _, terminated, truncated, _ = env.step(action)
            env_ms.append((time.perf_counter() - t0) * 1e3)
            if terminated or truncated:
                t0 = time.perf_counter()
                env.reset(seed=scenario.seed + episodes)
                reset_ms.append((time.perf_counter() - t0) * 1e3)
                road = bare_highway(scenario.model_copy(update={"seed": scenario.seed + episodes}))
                episodes += 1
        for _ in range(block):
            t0 = time.perf_counter()
            for _ in range(ticks):
                road.act()
                road.step(dt)
            bare_ms.append((time.perf_counter() - t0) * 1e3)
    env.close()
    cases = {"tracks_env_step": case(env_ms), "highway_env_step": case(bare_ms), "tracks_env_reset": case(reset_ms)}
    env_med, bare_med = cases["tracks_env_step"]["ms_median"], cases["highway_env_step"]["ms_median"]
    return {
        "machine": machine(),
        "scenario": str(scenario_path),
        "env": ENV_ID,
        "traffic_vehicles": vehicles,
        "simulated_s_per_step": step_s,
        "episodes": episodes,
        "cases": cases,
        "ratios": {
            "tracks_env_realtime_factor": round(step_s * 1e3 / env_med, 3),
            "highway_env_realtime_factor": round(step_s * 1e3 / bare_med, 3),
            "tracks_env_over_highway": round(env_med / bare_med, 3),
        },
    }
