"""AEB brakes to a standstill and holds: the ego never creeps into what it stopped for."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from lookahead.sim.aeb import Aeb, AebConfig
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[2]
STILL = 0.1  # m/s, AebConfig().standstill_speed


def closed_loop(sc: Scenario) -> tuple[list[tuple[float, float, float, float | None]], Aeb, list]:
    """Every frame's (t, ego speed, ground-truth gap to the nearest actor, brake command)."""
    r = Runner(sc, render=False)
    rows = []
    while True:
        res = r.step()
        w = r.world
        rows.append((w.t, w.ego.speed, min(w.relative(a)[0] for a in w.agents), w.ego.brake_command))
        if res.done:
            break
    aeb, collisions = r.aeb, list(r.world.collisions)
    r.close()
    return rows, aeb, collisions


def stationary_car(**update) -> Scenario:
    sc = load_scenario(ROOT / "scenarios" / "stationary_car.yaml")
    return Scenario.model_validate({**sc.model_dump(), "ego": {**sc.ego.model_dump(), "aeb": True}, **update})


def onsets(rows) -> int:
    brakes = [None] + [b for *_, b in rows]
    return sum(1 for prev, cur in zip(brakes, brakes[1:], strict=False) if cur is not None and prev is None)


def test_stops_once_and_holds_behind_the_stationary_car():
    rows, aeb, collisions = closed_loop(stationary_car())
    assert not collisions
    stop = next(i for i, r in enumerate(rows) if r[3] is not None and r[1] <= STILL)
    t_stop, _, gap_stop, _ = rows[stop]
    assert t_stop < rows[-1][0] - 2.0, "the stop should leave seconds of hold to check"
    after = rows[stop:]
    assert all(v <= 1e-6 for _, v, _, _ in after), "the ego moved after the AEB stop"
    assert all(g >= gap_stop - 1e-6 for _, _, g, _ in after), "the gap shrank after the stop"
    assert all(b is not None for *_, b in after), "the brake came off while held"
    assert onsets(rows) == 1 and len(aeb.activations) == 1
    assert [s for _, s in aeb.transitions] == ["braking", "holding"]
    assert gap_stop > 6.0  # one brake from 40 km/h: 7.5 m short (it used to creep to 4.6-5.1 m)


def test_hold_releases_when_the_car_drives_away():
    sc = stationary_car(duration=14.0)
    sc = Scenario.model_validate({**sc.model_dump(), "actors": [
        {**sc.actors[0].model_dump(), "script": [{"when": {"t": 7.0}, "do": {"speed": 8.0, "accel": 1.5}}]}]})
    rows, aeb, collisions = closed_loop(sc)
    assert not collisions
    states = [s for _, s in aeb.transitions]
    assert states == ["braking", "holding", "idle"]
    t_hold, t_release = aeb.transitions[1][0], aeb.transitions[2][0]
    assert t_release > 7.0  # not before the car moved
    held = [r for r in rows if t_hold <= r[0] <= t_release]
    assert all(v <= 1e-6 for _, v, _, _ in held)
    gap_at_release = next(g for t, _, g, _ in rows if t >= t_release - 1e-9)
    assert gap_at_release > AebConfig().hold_range  # released only with the path clear
    assert rows[-1][1] > 5.0  # and the ego drives on


def test_braking_continues_to_a_standstill_after_critical_clears():
    aeb = Aeb(AebConfig())  # latency 0.2, release 0.5, hold 15 m, clear time 4 s
    aeb.decide(1.0, critical_in_path=True, nearest_in_path=20.0, ego_speed=11.0)
    assert aeb.state == "braking" and aeb.command(1.2) == 6.0
    for k in range(1, 15):  # critical gone (TTC grew), the object still 10 m ahead
        aeb.decide(1.0 + 0.1 * k, critical_in_path=False, nearest_in_path=10.0, ego_speed=2.0)
    assert aeb.state == "braking" and aeb.command(2.4) == 6.0
    aeb.decide(2.5, critical_in_path=False, nearest_in_path=9.8, ego_speed=0.0)
    assert aeb.state == "holding" and aeb.command(2.5) == 6.0
    aeb.decide(2.6, critical_in_path=False, nearest_in_path=math.inf, ego_speed=0.0)  # one lost frame
    aeb.decide(2.7, critical_in_path=False, nearest_in_path=9.8, ego_speed=0.0)
    aeb.decide(3.3, critical_in_path=False, nearest_in_path=9.8, ego_speed=0.0)
    assert aeb.state == "holding" and aeb.command(3.3) == 6.0
    for k in range(1, 6):  # the object drives beyond the hold range: released after 0.5 s
        aeb.decide(3.3 + 0.1 * k, critical_in_path=False, nearest_in_path=16.0 + k, ego_speed=0.0)
    assert aeb.state == "idle" and aeb.command(3.8) is None
    assert aeb.activations == [1.0]


@pytest.mark.parametrize(("speed", "nearest", "released"), [
    (10.0, 30.0, False),  # 30 m < 4 s * 10 m/s: still braking
    (10.0, 45.0, True),  # beyond the clear range
    (3.0, 14.0, False),  # the clear range is never below hold_range
    (3.0, math.inf, True),  # the object left the path (a pedestrian crossed)
])
def test_release_while_moving_needs_the_clear_range(speed, nearest, released):
    aeb = Aeb(AebConfig())
    aeb.decide(0.0, critical_in_path=True, nearest_in_path=nearest, ego_speed=speed)
    for k in range(1, 7):
        aeb.decide(0.1 * k, critical_in_path=False, nearest_in_path=nearest, ego_speed=speed)
    assert (aeb.state == "idle") is released


def test_config_bounds():
    with pytest.raises(ValueError):
        AebConfig(clear_time=-1.0)
    with pytest.raises(ValueError):
        AebConfig(hold_range=-1.0)
    assert Aeb().clear_range(0.0) == 15.0 and Aeb().clear_range(10.0) == 40.0
