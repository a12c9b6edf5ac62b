"""``start.ref`` / ``start.impact``: where an actor's given start position puts its footprint."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.intent.config import IntentConfig
from lookahead.sim.groundtruth import compute_ground_truth
from lookahead.sim.runner import camera_from_scenario
from lookahead.sim.scenario import ScenarioError, parse_scenario
from lookahead.sim.world import World


def world_with(start: str, heading: float = 0.0, type_: str = "car", ego: str = "{lane: 1, speed: 10.0}") -> World:
    text = f"""
name: placement
duration: 2
road: {{kind: straight, lanes: 2, lane_width: 3.5}}
ego: {ego}
actors:
  - {{id: t, type: {type_}, start: {start}, heading: {heading}}}
"""
    return World(parse_scenario(text, "x.yaml"))


def gt_row(w: World):
    sc = w.scenario
    gt = compute_ground_truth(w, camera_from_scenario(sc), IntentConfig())
    return gt, gt.name.index("t")


def ego_rel(w: World) -> np.ndarray:
    """The target's centre in the ego frame at t=0 (the ego starts heading along +x)."""
    ox, oy, _ = w.ego_pose()
    return w.by_name["t"].xy - np.array([ox, oy])


def test_ref_rear_puts_the_rear_bumper_at_x():
    w = world_with("{x: 20, y: 0, ref: rear}")
    gt, i = gt_row(w)
    length = w.by_name["t"].LENGTH
    assert gt.range[i] == pytest.approx(20.0, abs=1e-3)
    assert ego_rel(w) == pytest.approx([20.0 + length / 2, 0.0])


def test_ref_centre_is_the_default_and_puts_the_centre_at_x():
    w = world_with("{x: 20, y: 0, ref: centre}")
    gt, i = gt_row(w)
    length = w.by_name["t"].LENGTH
    assert gt.range[i] == pytest.approx(20.0 - length / 2, abs=1e-3)
    assert ego_rel(w) == pytest.approx([20.0, 0.0])
    assert world_with("{x: 20, y: 0}").by_name["t"].xy.tolist() == w.by_name["t"].xy.tolist()


def test_ref_front_and_nearest():
    w = world_with("{x: 20, y: 1, ref: front}")
    assert ego_rel(w) == pytest.approx([20.0 - w.by_name["t"].LENGTH / 2, 1.0])
    # a target heading towards the ego: its front is the nearest point
    w = world_with("{x: 20, y: 0, ref: front}", heading=180)
    assert gt_row(w)[0].range[gt_row(w)[1]] == pytest.approx(20.0, abs=1e-3)
    # nearest: x is the ground-truth range whatever the heading (a pedestrian crossing: half its width)
    for heading in (0, 90, 180, 30):
        w = world_with("{x: 15, y: -2, ref: nearest}", heading=heading)
        gt, i = gt_row(w)
        assert gt.range[i] == pytest.approx(15.0, abs=1e-3)
        assert ego_rel(w)[1] == pytest.approx(-2.0)


def test_ref_moves_along_the_heading_for_a_crossing_target():
    w = world_with("{x: 20, y: -3, ref: rear}", heading=90, type_="cyclist")
    assert ego_rel(w) == pytest.approx([20.0, -3.0 + w.by_name["t"].LENGTH / 2])


def test_ref_on_lane_form():
    a, b = world_with("{lane: 1, s: 20}"), world_with("{lane: 1, s: 20, ref: rear}")
    assert b.by_name["t"].xy - a.by_name["t"].xy == pytest.approx([a.by_name["t"].LENGTH / 2, 0.0])


@pytest.mark.parametrize("ego_width", [1.85, 2.0])
def test_impact_25_and_75_are_opposite_sides_of_the_centreline(ego_width):
    ego = f"{{lane: 1, speed: 10.0, width: {ego_width}}}"
    left = ego_rel(world_with("{x: 20, impact: 25, ref: rear}", ego=ego))
    right = ego_rel(world_with("{x: 20, impact: 75, ref: rear}", ego=ego))
    centre = ego_rel(world_with("{x: 20, impact: 50}", ego=ego))
    assert left[1] == pytest.approx(0.25 * ego_width)  # 25 % of the width from the left side
    assert right[1] == pytest.approx(-0.25 * ego_width)
    assert centre[1] == pytest.approx(0.0)
    assert ego_rel(world_with("{x: 20, impact: 0}", ego=ego))[1] == pytest.approx(ego_width / 2)
    assert ego_rel(world_with("{x: 20, impact: 100}", ego=ego))[1] == pytest.approx(-ego_width / 2)
    assert left[0] == pytest.approx(right[0])
    # heading 180 (oncoming) is along the road too
    assert ego_rel(world_with("{x: 40, impact: 25}", heading=180, ego=ego))[1] == pytest.approx(0.25 * ego_width)


@pytest.mark.parametrize(
    ("start", "heading", "expected"),
    [
        ("{x: 20, y: 0, ref: back}", 0, ["x.yaml:7", "actors[0].start.ref", "'back'"]),
        ("{x: 20, impact: 120}", 0, ["x.yaml:7", "actors[0].start.impact", "less than or equal to 100"]),
        ("{x: 20, impact: -5}", 0, ["x.yaml:7", "actors[0].start.impact", "greater than or equal to 0"]),
        ("{x: 20, y: 1, impact: 25}", 0, ["x.yaml:7", "actors[0].start", "without y"]),
        ("{lane: 1, s: 20, impact: 25}", 0, ["x.yaml:7", "actors[0].start", "without y, lane"]),
        ("{impact: 25}", 0, ["x.yaml:7", "actors[0].start", "impact needs x"]),
        ("{x: 20, impact: 25}", 90, ["x.yaml:7", "actors[0]", "heading along the road"]),
    ],
)
def test_bad_values_are_one_line_located_errors(start, heading, expected):
    with pytest.raises(ScenarioError) as e:
        world_with(start, heading=heading)
    msg = str(e.value)
    assert "\n" not in msg
    for part in expected:
        assert part in msg
