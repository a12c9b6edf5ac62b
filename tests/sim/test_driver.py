"""A driver who brakes for the first in-path forward-collision warning (sim.driver), in closed loop."""

from __future__ import annotations

from pathlib import Path

import pytest

from lookahead.intent.labels import Risk
from lookahead.intent.stack import alert_in_path
from lookahead.sim.driver import Driver, DriverConfig, combine_brakes
from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import Scenario, ScenarioError, load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parents[2]


def stationary_car(driver: DriverConfig | None, kmh: float | None = None, aeb: bool = False) -> Scenario:
    sc = load_scenario(ROOT / "scenarios" / "stationary_car.yaml").model_copy(deep=True)
    sc.ego.driver = driver
    sc.ego.aeb = aeb
    if kmh is not None:
        sc.ego.speed = kmh / 3.6
    return sc


def run(sc: Scenario) -> tuple[Runner, RecordCollector, list[tuple[float, float | None]]]:
    """Run without rendering (gt detector); also the brake command of every sim tick: (t, m/s^2)."""
    rc = RecordCollector()
    r = Runner(sc, sinks=[rc], render=False)
    ticks: list[tuple[float, float | None]] = []
    world_step = r.world.step

    def step():
        ticks.append((r.world.t, r.world.ego.brake_command))
        return world_step()

    r.world.step = step
    r.summary = r.run()
    return r, rc, ticks


def first_fcw(rc: RecordCollector) -> float:
    return min(a.t for rec in rc.records for a in rec.alerts if a.kind in ("fcw", "critical"))


def test_driver_unit():
    d = Driver(DriverConfig(reaction_s=1.2, decel=4.0))
    d.decide(0.5, fcw=False)
    assert d.command(5.0) is None and not d.braking
    d.decide(1.0, fcw=True)
    assert d.command(2.1) is None and d.command(2.2) == 4.0
    d.decide(3.0, fcw=True)  # a later warning changes nothing
    d.decide(4.0, fcw=False)  # nor does the warning clearing: braking to a standstill, held
    assert d.warned_at == 1.0 and d.command(100.0) == 4.0
    assert combine_brakes(None, None) is None
    assert combine_brakes(6.0, None) == 6.0 and combine_brakes(None, 4.0) == 4.0 and combine_brakes(6.0, 4.0) == 6.0
    assert alert_in_path({3: 3, 4: 4}, [3, 4], [False, False], Risk.HIGH) is False  # alerts, but none in path
    assert alert_in_path({3: 3}, [3, 4], [False, True], Risk.HIGH) is False  # in path, but no alert on it
    assert alert_in_path({4: 3}, [3, 4], [False, True], Risk.HIGH) is True  # HIGH (3) in path
    assert alert_in_path({4: 4}, [4], [True], Risk.HIGH) is True  # CRITICAL is above HIGH


def test_driver_field_parses_with_bounds():
    base = "name: x\nroad: {kind: straight}\n"
    assert parse_scenario(base).ego.driver is None
    sc = parse_scenario(base + "ego: {driver: {reaction_s: 1.2, decel: 4.0}}\n")
    assert sc.ego.driver == DriverConfig(reaction_s=1.2, decel=4.0)
    assert parse_scenario(base + "ego: {driver: {}}\n").ego.driver == DriverConfig()  # 1.2 s, 4 m/s^2
    for bad in ("{reaction_s: -1}", "{decel: 0}", "{decel: 20}", "{reaction_s: 11}", "{reacton_s: 1}"):
        with pytest.raises(ScenarioError, match="driver"):
            parse_scenario(base + f"ego: {{driver: {bad}}}\n")


def test_driver_brakes_reaction_time_after_first_fcw_and_avoids_the_collision():
    """Euro NCAP's FCW driver (1.2 s, 4 m/s^2) on the shipped stationary car (40 km/h): it collides
    without the driver (at full speed, 11.1 m/s) and not with one."""
    off_r, off_rc, _ = run(stationary_car(None))
    assert off_r.summary.collisions and off_r.summary.collisions[0].ego_speed == pytest.approx(11.1, abs=0.1)
    assert all("driver_brake" not in rec.ego for rec in off_rc.records)

    r, rc, ticks = run(stationary_car(DriverConfig(reaction_s=1.2, decel=4.0)))
    fcw = first_fcw(rc)
    assert fcw == pytest.approx(first_fcw(off_rc))  # same warning: nothing differs before the driver acts
    assert r.driver.warned_at == pytest.approx(fcw)
    dt = 1.0 / r.scenario.rate
    braking = [t for t, b in ticks if b is not None]
    assert braking and fcw + 1.2 - 1e-9 <= braking[0] < fcw + 1.2 + dt  # 1.2 s later, at sim-tick resolution
    assert all(b == 4.0 for t, b in ticks if t >= braking[0])  # and on to the end (a standstill, held)
    assert [rec.ego["driver_brake"] for rec in rc.records if rec.t <= braking[0]] == [None] * sum(
        rec.t <= braking[0] for rec in rc.records)
    assert all(rec.ego["driver_brake"] == 4.0 == rec.ego["brake"] for rec in rc.records if rec.t > braking[0])
    assert not r.summary.collisions
    assert rc.records[-1].ego["speed"] == 0.0


def test_driver_lowers_the_impact_speed_where_it_cannot_avoid():
    """At 60 km/h the 1.2 s driver cannot stop in time, but hits slower than no driver does."""
    off, _, _ = run(stationary_car(None, kmh=60))
    on, _, _ = run(stationary_car(DriverConfig(reaction_s=1.2, decel=4.0), kmh=60))
    v_off, v_on = off.summary.collisions[0].ego_speed, on.summary.collisions[0].ego_speed
    assert v_off == pytest.approx(60 / 3.6, abs=0.1)
    assert 0.0 < v_on < v_off - 5.0


def test_very_late_driver_is_no_driver_up_to_the_impact():
    off_r, off_rc, off_ticks = run(stationary_car(None))
    r, rc, ticks = run(stationary_car(DriverConfig(reaction_s=5.0, decel=4.0)))
    assert r.driver.warned_at is not None and r.driver.brake_at > off_r.summary.collisions[0].t
    assert ticks == off_ticks  # no brake on any tick, the same ticks
    assert [c.to_dict() for c in r.summary.collisions] == [c.to_dict() for c in off_r.summary.collisions]
    assert len(rc.records) == len(off_rc.records)
    for a, b in zip(rc.records, off_rc.records, strict=True):
        assert a.ego.pop("driver_brake") is None
        assert a.t == b.t and a.ego == b.ego
        assert [x.to_dict() for x in a.alerts] == [x.to_dict() for x in b.alerts]


def test_driver_and_aeb_the_stronger_brake_wins():
    """With the AEB on (6 m/s^2) and a driver too gentle to avoid its CRITICAL alert (2 m/s^2), the
    driver alone brakes until the AEB engages, then the AEB's stronger brake is the command."""
    r, _, ticks = run(stationary_car(DriverConfig(reaction_s=1.2, decel=2.0), aeb=True))
    aeb_on = r.aeb.activations[0] + r.aeb.config.latency
    drv_on = r.driver.brake_at
    assert drv_on < aeb_on
    assert {b for t, b in ticks if t < drv_on - 1e-9} == {None}
    assert {b for t, b in ticks if drv_on + 1e-9 < t < aeb_on - 1e-9} == {2.0}
    assert {b for t, b in ticks if t > aeb_on + 1e-9} == {6.0}
    assert not r.summary.collisions


def test_the_aeb_brake_is_recorded_apart_from_the_driver_brake():
    """``ego.aeb_brake`` is the AEB's own command: null while only the driver brakes, 6 m/s^2
    once the AEB engages; runs without the AEB have no such field."""
    r, rc, _ = run(stationary_car(DriverConfig(reaction_s=1.2, decel=2.0), aeb=True))
    aeb_on = r.aeb.activations[0] + r.aeb.config.latency
    driver_only = [rec for rec in rc.records if r.driver.brake_at + 1e-9 < rec.t < aeb_on - 1e-9]
    assert driver_only  # frames where the driver alone brakes
    assert all(rec.ego["aeb_brake"] is None and rec.ego["driver_brake"] == 2.0 == rec.ego["brake"]
               for rec in driver_only)
    after = [rec for rec in rc.records if rec.t > aeb_on + 1e-9]
    assert after and all(rec.ego["aeb_brake"] == 6.0 == rec.ego["brake"] for rec in after)
    assert all(rec.ego["aeb_brake"] is None for rec in rc.records if rec.t < aeb_on - 1e-9)

    _, no_aeb, _ = run(stationary_car(DriverConfig(reaction_s=1.2, decel=4.0)))
    assert any(rec.ego["brake"] == 4.0 for rec in no_aeb.records)  # the driver brakes
    assert all("aeb_brake" not in rec.ego for rec in no_aeb.records)
