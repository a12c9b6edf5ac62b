"""Closed loop matters: AEB avoids the collisions that happen without it."""

from __future__ import annotations

from pathlib import Path

import pytest

from lookahead.sim.aeb import Aeb, AebConfig
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[2]
CROSS_TIME_S = 2.85  # pedestrian: 0.35 s to reach 1.4 m/s, then 3.5 m to the ego's centre line


def variant(name: str, speed: float, aeb: bool) -> Scenario:
    sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    sc = sc.model_copy(deep=True)
    sc.ego.speed = speed
    sc.ego.aeb = aeb
    if name == "ped_crossing_nearside":  # time the crossing so the ego would hit mid-front
        sc.actors[0].script[0].when.ego_range_lt = CROSS_TIME_S * speed
    return sc


@pytest.mark.parametrize("name", ["stationary_car", "ped_crossing_nearside", "barrier_in_lane"])
@pytest.mark.parametrize("kmh", [30, 40])
def test_aeb_avoids_what_happens_without_it(name, kmh):
    speed = kmh / 3.6
    off = Runner(variant(name, speed, aeb=False), render=False).run()
    assert off.collisions, f"{name} at {kmh} km/h without AEB should collide"
    assert off.collisions[0].ego_speed == pytest.approx(speed, abs=0.3)
    on = Runner(variant(name, speed, aeb=True), render=False).run()
    assert not on.collisions, f"{name} at {kmh} km/h with AEB collided: {on.collisions[0]}"


def test_aeb_at_least_halves_the_impact_on_a_deer_at_60_kmh():
    """A deer is a large animal (by its estimated height): braked for like an obstacle."""
    speed = 60 / 3.6
    off = Runner(variant("deer_entering", speed, aeb=False), render=False).run()
    assert off.collisions and off.collisions[0].ego_speed == pytest.approx(speed, abs=0.3)
    on = Runner(variant("deer_entering", speed, aeb=True), render=False).run()
    assert not on.collisions or on.collisions[0].ego_speed <= 0.5 * speed


def test_aeb_latency_release_and_standstill_hold():
    aeb = Aeb(AebConfig(latency=0.2, decel=6.0, release_s=0.5, hold_range=15.0))
    assert aeb.command(0.0) is None
    aeb.decide(1.0, critical_in_path=True, nearest_in_path=10.0, ego_speed=10.0)
    assert aeb.command(1.1) is None and aeb.command(1.2) == 6.0
    aeb.decide(1.3, critical_in_path=False, nearest_in_path=10.0, ego_speed=5.0)
    assert aeb.command(1.3) == 6.0  # not yet 0.5 s without a critical object
    aeb.decide(1.9, critical_in_path=False, nearest_in_path=9.0, ego_speed=0.0)
    assert aeb.command(1.9) == 6.0  # standing still with the object 9 m ahead: hold
    aeb.decide(2.5, critical_in_path=False, nearest_in_path=float("inf"), ego_speed=0.0)
    assert aeb.command(2.5) is None  # the path cleared: release
    assert aeb.activations == [1.0]
