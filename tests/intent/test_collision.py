"""Enhanced TTC and the required deceleration against hand-computed cases."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.intent.collision import enhanced_ttc, required_decel
from lookahead.intent.labels import time_to_collision


def test_without_accelerations_it_is_the_constant_velocity_ttc():
    r, vo = np.array([20.0, 30.0, 5.0, 12.0]), np.array([0.0, 5.0, 12.0, -4.0])
    ve = 10.0
    np.testing.assert_allclose(enhanced_ttc(r, vo, np.zeros(4), ve, 0.0), time_to_collision(r, vo - ve))


def test_ccrb_lead_braking_6_ms2_from_50_kmh_at_12_m():
    # gap 12 - 3 t^2 = 0 at 2.0 s, before the lead stops (13.9 / 6 = 2.3 s); constant-velocity TTC: never
    assert enhanced_ttc(np.array([12.0]), np.array([13.9]), np.array([-6.0]), 13.9, 0.0)[0] == pytest.approx(2.0)
    assert np.isinf(time_to_collision(np.array([12.0]), np.array([0.0]))[0])


def test_a_lead_that_stops_first_is_met_at_its_stopping_point():
    # lead stops after 13.9^2 / 12 = 16.1 m; the ego at 10 m/s covers 12 + 16.1 m in 2.81 s
    t = enhanced_ttc(np.array([12.0]), np.array([13.9]), np.array([-6.0]), 10.0, 0.0)[0]
    assert t == pytest.approx((12.0 + 13.9**2 / 12.0) / 10.0, rel=1e-9)


def test_an_ego_that_stops_short_never_collides():
    assert np.isinf(enhanced_ttc(np.array([20.0]), np.array([0.0]), np.array([0.0]), 10.0, -3.0)[0])  # 16.7 m
    assert enhanced_ttc(np.array([15.0]), np.array([0.0]), np.array([0.0]), 10.0, -3.0)[0] < np.inf


def test_behind_the_ego_front_is_zero_and_nan_stays_nan():
    out = enhanced_ttc(np.array([-0.5, np.nan]), np.array([0.0, 0.0]), np.array([0.0, 0.0]), 10.0, 0.0)
    assert out[0] == 0.0 and np.isnan(out[1])


def test_required_deceleration_for_a_stationary_object_is_v2_over_2r():
    assert required_decel(np.array([20.0]), np.array([0.0]), np.array([0.0]), 10.0)[0] == pytest.approx(2.5)


def test_required_deceleration_behind_a_braking_lead():
    # CCRb 12 m, -6 m/s^2, both 13.9 m/s: the lead stops first; the ego must stop within 12 + 16.1 m
    d = required_decel(np.array([12.0]), np.array([13.9]), np.array([-6.0]), 13.9)[0]
    assert d == pytest.approx(13.9**2 / (2 * (12.0 + 13.9**2 / 12.0)))
    # a slower lead still moving when the speeds match: v_c^2 / 2r - a_o
    assert required_decel(np.array([20.0]), np.array([10.0]), np.array([0.0]), 20.0)[0] == pytest.approx(2.5)
    assert required_decel(np.array([20.0]), np.array([15.0]), np.array([0.0]), 10.0)[0] == 0.0  # opening


def test_required_deceleration_brakes_exactly_enough():
    """Braking at the required deceleration from now ends with the gap at zero, not below."""
    r, vo, ao, ve = 25.0, 8.0, -2.0, 16.0
    d = required_decel(np.array([r]), np.array([vo]), np.array([ao]), ve)[0]
    t_hit = enhanced_ttc(np.array([r]), np.array([vo]), np.array([ao]), ve, -d * 1.001)[0]
    assert np.isinf(t_hit)
    assert enhanced_ttc(np.array([r]), np.array([vo]), np.array([ao]), ve, -d * 0.98)[0] < np.inf
