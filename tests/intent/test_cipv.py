"""The primary target (``intent.cipv.select_cipv``) and the behaviour confidence of ``assess``."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.intent.cipv import Cipv, select_cipv
from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Behaviour, Kinematics, assess, behaviour_confidence, behaviours


def test_closest_in_path_wins_ties_by_id_and_nothing_gives_none():
    ids = np.array([7, 3, 5, 9])
    r = np.array([20.0, 12.0, 12.0, 5.0])
    path = np.array([True, True, True, False])  # the nearest (9) is beside the lane
    assert select_cipv(ids, r, path) == Cipv(3, 12.0)  # 3 and 5 tie at 12 m: the smaller id
    assert select_cipv(ids, np.array([20.0, np.nan, np.inf, 5.0]), path) == Cipv(7, 20.0)  # no finite range: out
    assert select_cipv(ids, r, path, eligible=np.array([True, False, True, True])) == Cipv(5, 12.0)
    assert select_cipv(ids, r, np.zeros(4, dtype=bool)) == Cipv()
    assert select_cipv(np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool)) == Cipv(None, None)


def _kin(n: int, rng: np.random.Generator, sigmas: bool) -> Kinematics:
    f = lambda lo, hi: rng.uniform(lo, hi, n)  # noqa: E731
    k = Kinematics(
        class_id=rng.integers(0, 8, n), range=f(2, 60), lateral=f(-8, 8), half_width=f(0.2, 1.0),
        range_rate=f(-15, 5), lateral_rate=f(-3, 3), ground_vx=f(-12, 15), ground_vy=f(-3, 3),
        accel=np.where(rng.random(n) < 0.2, f(-8, 0), f(-1, 1)), yaw_rate=f(-0.6, 0.6),
        height=f(0.5, 1.6),
    )
    if sigmas:
        k.ground_vx_sigma, k.ground_vy_sigma, k.lateral_sigma = f(0.05, 2), f(0.05, 1), f(0.05, 0.5)
        k.ground_vx_sigma[::17] = np.nan  # unknown stds: margin 0
    return k


def test_confidence_follows_the_behaviour_decision():
    """The confidence's priority chain reproduces ``behaviours`` (so it rates the decision made);
    exact kinematics are sure; with stds it lies in [0.5, 1], lower near a threshold."""
    cfg = IntentConfig()
    rng = np.random.default_rng(3)
    exact = _kin(2000, rng, sigmas=False)
    assert np.all(behaviour_confidence(exact, cfg) == 1.0)
    noisy = _kin(2000, rng, sigmas=True)
    c = behaviour_confidence(noisy, cfg)
    assert c.shape == (2000,) and np.all((c >= 0.5) & (c <= 1.0))
    assert np.all(c[::17] == 0.5)  # an unknown std: as likely one side as the other
    assert 0.5 < c.mean() < 1.0
    a = assess(noisy, cfg, ego_speed=10.0)
    assert np.array_equal(a.behaviour, behaviours(noisy, cfg))
    assert np.allclose(a.behaviour_confidence, c)
    assert "behaviour_confidence" in a.to_dict() and len(a.to_dict()["behaviour_confidence"]) == 2000


def _one_ped(speed: float, sigma: float) -> Kinematics:
    one = lambda v: np.array([v], dtype=np.float64)  # noqa: E731
    return Kinematics(class_id=np.array([0]), range=one(20), lateral=one(6), half_width=one(0.3),
                      range_rate=one(speed - 10), lateral_rate=one(0), ground_vx=one(speed), ground_vy=one(0),
                      accel=one(0), yaw_rate=one(0), ground_vx_sigma=one(sigma), ground_vy_sigma=one(sigma))


def test_confidence_is_the_margin_to_the_threshold_in_stds():
    """A pedestrian walking along the pavement: Phi((speed - still) / sigma) near the
    still threshold, sure far from every threshold."""
    from scipy.special import ndtr

    cfg = IntentConfig()
    th = cfg.behaviour["pedestrian"]
    v = th.still_speed + 0.2
    k = _one_ped(v, 0.2)
    assert behaviours(k, cfg)[0] == Behaviour.WALKING
    want = ndtr(min(0.2 / 0.2, (th.fast_speed - v) / 0.2))
    assert behaviour_confidence(k, cfg)[0] == pytest.approx(want, abs=1e-9)
    mid = 0.5 * (th.still_speed + th.fast_speed)
    sure = behaviour_confidence(_one_ped(mid, 0.01), cfg)[0]
    assert sure == pytest.approx(1.0, abs=1e-6)
    assert assess(k, cfg, ego_speed=float("nan")).behaviour_confidence[0] == 0.0  # no ego speed: unknown
