"""Roll out two longitudinal policies in the lookahead gymnasium environment.

- ``ttc_brake``: keep the speed (zero acceleration), brake at -8 m/s^2 while the
  nearest in-path perception track's time to collision is below 2 s.
- ``aeb``: the AEB baseline, the built-in ``sim.aeb.Aeb`` (``aeb=True``) with a
  zero-acceleration action.

Prints the collision rate and the mean ego speed per scenario and policy::

    .venv/bin/python examples/policy_rollout.py [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np

import lookahead.sim  # noqa: F401  (registers lookahead/ForwardTracks-v0)

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ("stationary_car.yaml", "ped_crossing_nearside.yaml")
TTC_BRAKE_S = 2.0
# Observation column indices of obs["tracks"].
RANGE, RANGE_RATE, VALID = 0, 2, 7


def nearest_in_path_ttc(tracks: np.ndarray, half_lane: float = 1.75) -> float:
    """TTC (s) of the nearest valid, closing track within ``half_lane`` of the ego's centre line."""
    m = (tracks[:, VALID] > 0) & (np.abs(tracks[:, 1]) < half_lane) & (tracks[:, RANGE_RATE] < -0.1)
    if not m.any():
        return float("inf")
    t = tracks[m]
    return float(np.min(np.maximum(t[:, RANGE], 0.0) / -t[:, RANGE_RATE]))


def ttc_brake_policy(obs: dict) -> np.ndarray:
    brake = nearest_in_path_ttc(obs["tracks"]) < TTC_BRAKE_S
    return np.array([-8.0 if brake else 0.0], np.float32)


def zero_policy(obs: dict) -> np.ndarray:
    return np.zeros(1, np.float32)


def episode(scenario: Path, seed: int, policy, aeb: bool) -> tuple[bool, float]:
    env = gym.make("lookahead/ForwardTracks-v0", scenario=scenario, aeb=aeb)
    obs, _ = env.reset(seed=seed)
    speeds = [float(obs["ego"][0])]
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, _ = env.step(policy(obs))
        speeds.append(float(obs["ego"][0]))
    env.close()
    return bool(terminated), float(np.mean(speeds))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = ap.parse_args()
    policies = {"ttc_brake": (ttc_brake_policy, False), "aeb": (zero_policy, True)}
    print(f"{'scenario':28s} {'policy':10s} {'collision rate':>14s} {'mean speed m/s':>15s}")
    for name in SCENARIOS:
        for pname, (policy, aeb) in policies.items():
            res = [episode(ROOT / "scenarios" / name, s, policy, aeb) for s in args.seeds]
            rate = np.mean([c for c, _ in res])
            speed = np.mean([v for _, v in res])
            print(f"{name:28s} {pname:10s} {rate:14.2f} {speed:15.2f}")


if __name__ == "__main__":
    main()
