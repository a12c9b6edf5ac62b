"""The world: ego control, scripted actors, triggers, traffic and collisions."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.sim.scenario import parse_scenario
from lookahead.sim.world import World

BASE = """
name: t
seed: 1
duration: 8
road: {kind: straight, lanes: 2, lane_width: 3.5, sidewalks: true}
ego: {lane: 1, speed: 10.0, controller: cruise}
"""


def world(extra: str = "") -> World:
    return World(parse_scenario(BASE + extra))


def run(w: World, seconds: float) -> list:
    hits = []
    for _ in range(int(round(seconds * w.scenario.rate))):
        hits += w.step()
    return hits


def test_cruise_holds_speed_and_lane():
    w = world()
    y0 = w.ego_pose()[1]
    run(w, 3.0)
    assert w.ego.speed == pytest.approx(10.0, abs=1e-6)
    assert w.ego_pose()[1] == pytest.approx(y0, abs=1e-6)
    assert w.odometry.speed == pytest.approx(10.0)
    assert w.odometry.accel == pytest.approx(0.0, abs=1e-9)


def test_profile_controller_tracks_the_profile():
    w = World(parse_scenario(BASE.replace("controller: cruise", "controller: profile, profile: [[0, 10], [2, 10], [4, 5], [8, 5]]")))
    run(w, 6.0)
    assert w.ego.speed == pytest.approx(5.0, abs=0.3)


def test_trigger_on_ego_range_starts_a_pedestrian():
    w = world("""
actors:
  - id: ped
    type: pedestrian
    start: {x: 40, y: -3.5}
    heading: 90
    script:
      - when: {ego_range_lt: 30}
        do: {speed: 1.4}
""")
    ped = w.by_name["ped"]
    run(w, 0.5)
    assert ped.speed == 0.0
    run(w, 1.0)  # ego covered ~15 m: range now < 30 m
    assert ped.speed > 0.5
    assert ped.yaw == pytest.approx(np.pi / 2)
    assert ped.xy[1] > w.to_world(np.array([0.0, -3.5]))[1]  # moved left


def test_time_trigger_delay_and_lane_change():
    w = world("""
actors:
  - id: car
    type: car
    start: {lane: 0, s: 20}
    speed: 10
    script:
      - when: {t: 1.0}
        delay: 0.5
        do: {lane: 1}
""")
    car = w.by_name["car"]
    run(w, 1.4)
    assert car.xy[1] == pytest.approx(0.0, abs=1e-6)
    run(w, 5.0)
    assert car.xy[1] == pytest.approx(-3.5, abs=0.06)
    assert abs(car.yaw) < 0.02


def test_waypoints_are_followed():
    w = world("""
actors:
  - id: dog
    type: animal
    subtype: dog
    start: {x: 30, y: -4}
    script:
      - do: {speed: 2.0, waypoints: [[30, 0], [34, 0]]}
""")
    run(w, 5.0)
    end = w.to_world(np.array([34.0, 0.0]))
    assert np.linalg.norm(w.by_name["dog"].xy - end) < 2.5


def test_collision_with_stationary_car_has_impact_speed():
    w = world("""
actors:
  - {id: target, type: car, start: {lane: 1, s: 20}}
""")
    hits = run(w, 4.0)
    assert len(hits) == 1
    assert hits[0].name == "target" and hits[0].cls == "car"
    assert hits[0].ego_speed == pytest.approx(10.0, abs=0.01)
    assert hits[0].relative_speed == pytest.approx(10.0, abs=0.01)
    gap = 20.0 - w.by_name["target"].LENGTH / 2  # its rear bumper, 20 m minus half its length
    assert hits[0].t == pytest.approx(gap / 10.0, abs=0.06)


def test_idm_traffic_brakes_for_a_pedestrian_in_its_lane():
    w = World(parse_scenario(BASE.replace("controller: cruise", "controller: idm") + """
actors:
  - {id: ped, type: pedestrian, start: {lane: 1, s: 30}}
"""))
    hits = run(w, 8.0)
    assert hits == []
    assert w.ego.speed < 0.5


def test_same_seed_same_traffic_and_shapes():
    text = BASE + "traffic: {count: 6, density: 1.0}\n"
    a, b = World(parse_scenario(text)), World(parse_scenario(text))
    run(a, 2.0)
    run(b, 2.0)
    sa, sb = a.agent_states(), b.agent_states()
    np.testing.assert_array_equal(sa.xy, sb.xy)
    np.testing.assert_array_equal(sa.length, sb.length)
    c = World(parse_scenario(text.replace("seed: 1", "seed: 2")))
    assert not np.array_equal(c.agent_states().xy, World(parse_scenario(text)).agent_states().xy)


@pytest.mark.parametrize("falls", [False, True])
def test_a_fallen_pedestrian_lies_in_the_path_it_fell_into(falls):
    """Standing beside the ego's path the pedestrian is passed; fallen towards it, the body on the
    road is hit (the collision footprint is the posed body's, not the standing one's)."""
    script = "\n    script:\n      - when: {t: 0.1}\n        do: {gesture: fall}" if falls else ""
    w = world(f"""
actors:
  - id: ped
    type: pedestrian
    start: {{x: 20, y: -1.5}}
    heading: 90
    speed: 0.0{script}
""")
    hits = run(w, 3.0)
    assert [h.name for h in hits] == (["ped"] if falls else [])
