"""Static obstacles (cones, barriers, debris) in intent: a car's risk thresholds, always stationary."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Behaviour, Kinematics, Label, Risk, assess, behaviour_confidence
from lookahead.perception.detections import CLASS_ID

CFG = IntentConfig()


def obstacle(r: float, y: float = 0.0, vx: float = 0.0, vy: float = 0.0, ego_speed: float = 11.1,
             sigma: float | None = None) -> Kinematics:
    a = lambda v: np.atleast_1d(np.asarray(v, dtype=np.float64))  # noqa: E731
    s = None if sigma is None else a(sigma)
    return Kinematics(
        class_id=np.array([CLASS_ID["obstacle"]]), range=a(r), lateral=a(y), half_width=a(0.9),
        range_rate=a(vx - ego_speed), lateral_rate=a(vy), ground_vx=a(vx), ground_vy=a(vy),
        accel=a(0.0), yaw_rate=a(0.0), ground_vx_sigma=s, ground_vy_sigma=s,
    )


@pytest.mark.parametrize(("r", "risk"), [(60.0, Risk.MEDIUM), (40.0, Risk.HIGH), (20.0, Risk.CRITICAL)])
def test_a_barrier_in_the_lane_at_40_kmh_is_ranked_as_a_stopped_car_would_be(r, risk):
    # 11.1 m/s: TTC 5.4 s (under 2 x 4 s), 3.6 s (under 4 s), 1.8 s (under 2 s)
    a = assess(obstacle(r), CFG, ego_speed=11.1)
    assert a.in_path[0] and a.risk[0] == risk
    car = assess(Kinematics(**{**obstacle(r).__dict__, "class_id": np.array([CLASS_ID["car"]])}), CFG, ego_speed=11.1)
    assert car.risk[0] == risk
    if risk == Risk.CRITICAL:
        assert a.label[0] == Label.DANGER


def test_a_cone_beside_the_lane_is_not_in_path():
    a = assess(obstacle(15.0, y=-3.5), CFG, ego_speed=11.1)
    assert not a.in_path[0] and a.risk[0] <= Risk.MEDIUM


def test_an_obstacle_is_stationary_whatever_motion_its_estimate_shows_and_surely_so():
    # an estimate's noise (1.5 m/s sideways toward the lane) would make a car "crossing"
    k = obstacle(20.0, y=-2.5, vx=0.4, vy=1.5, sigma=0.5)
    assert assess(k, CFG, ego_speed=11.1).behaviour[0] == Behaviour.STATIONARY
    assert behaviour_confidence(k, CFG)[0] == pytest.approx(1.0)
    car = Kinematics(**{**k.__dict__, "class_id": np.array([CLASS_ID["car"]])})
    assert assess(car, CFG, ego_speed=11.1).behaviour[0] == Behaviour.CROSSING
