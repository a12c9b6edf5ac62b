"""The gymnasium wrapper: API conformance, seeding, vector envs, collisions."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import lookahead.sim  # noqa: F401  (registers the environments)
from lookahead.intent.labels import risk_colour
from lookahead.sim import birdseye
from lookahead.sim.gym_env import LookaheadEnv
from lookahead.sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
STATIONARY = ROOT / "scenarios" / "stationary_car.yaml"


def tiny_camera_scenario():
    sc = load_scenario(STATIONARY)
    cam = sc.camera.model_copy(update={"width": 160, "height": 96})
    return sc.model_copy(update={"camera": cam, "duration": 1.0})


def rollout(env, actions, seed):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for a in actions:
        obs, *_ = env.step(a)
        out.append(obs)
    return out


def test_check_env_tracks():
    env = gym.make("lookahead/ForwardTracks-v0")
    try:
        check_env(env.unwrapped)
    finally:
        env.close()


def test_check_env_camera_tiny():
    env = gym.make("lookahead/ForwardCamera-v0", scenario=tiny_camera_scenario(), render_mode="rgb_array")
    try:
        check_env(env.unwrapped)
        obs, _ = env.reset(seed=1)
        assert obs["image"].shape == (96, 160, 3) and obs["image"].dtype == np.uint8
        env.step(np.array([0.0], np.float32))
        img = env.render()
        assert img is not None and img.shape == (96, 160, 3)
    finally:
        env.close()


def test_render_without_camera_is_a_top_down_view_of_the_tracks():
    env = LookaheadEnv(render_mode="rgb_array")  # a stationary car ahead; no camera
    try:
        env.reset(seed=0)
        for _ in range(5):
            obs, *_ = env.step(np.array([0.0], np.float32))
        img = env.render()
        assert img.shape == (*birdseye.SIZE_PX, 3) and img.dtype == np.uint8
        rng, lat, risk, valid = obs["tracks"][0][[0, 1, 5, 7]]  # the nearest track
        assert valid == 1 and rng > 5
        col, row = birdseye.to_pixel(rng + 1.0, lat)  # inside its box
        assert tuple(img[int(row), int(col)]) == risk_colour(int(risk))
        assert LookaheadEnv().render() is None  # no render mode: nothing
    finally:
        env.close()


def test_a_normalised_action_space_is_gymnasiums_rescale_wrapper():
    env = gym.wrappers.RescaleAction(gym.make("lookahead/ForwardTracks-v0"), np.float32(-1), np.float32(1))
    try:
        assert env.action_space.low[0] == -1 and env.action_space.high[0] == 1
        env.reset(seed=0)
        env.step(np.array([-1.0], np.float32))
        assert env.unwrapped._accel_cmd == pytest.approx(-8.0, abs=1e-6)
        env.step(np.array([1.0], np.float32))
        assert env.unwrapped._accel_cmd == pytest.approx(3.0, abs=1e-6)
    finally:
        env.close()


def test_reset_seed_is_reproducible():
    env = LookaheadEnv(scenario=ROOT / "scenarios" / "ped_crossing_nearside.yaml")
    actions = [np.array([a], np.float32) for a in (0.0, -2.0, 1.0, 0.0, -4.0, 0.0, 0.0, 3.0)]
    a = rollout(env, actions, seed=11)
    b = rollout(env, actions, seed=11)
    env.close()
    for oa, ob in zip(a, b, strict=True):
        for k in oa:
            np.testing.assert_array_equal(oa[k], ob[k])


def test_discrete_actions():
    env = LookaheadEnv(discrete=True)
    env.reset(seed=0)
    for _ in range(5):
        obs, *_ = env.step(0)  # full braking
    assert obs["ego"][0] < 11.1 - 3.0
    env.close()


def test_zero_accel_hits_the_stationary_car():
    env = gym.make("lookahead/ForwardTracks-v0", scenario=STATIONARY)
    env.reset(seed=7)
    terminated = truncated = False
    steps = 0
    while not (terminated or truncated):
        _, reward, terminated, truncated, info = env.step(np.zeros(1, np.float32))
        steps += 1
    env.close()
    assert terminated and not truncated
    assert info["collisions"] and info["collisions"][0]["name"] == "target"
    assert reward < -5.0
    assert "ground_truth" in info and "assessment" in info and "alerts" in info


def test_truncated_at_duration_when_braking():
    env = LookaheadEnv(scenario=STATIONARY)
    env.reset(seed=7)
    n = 0
    while True:
        _, _, terminated, truncated, _ = env.step(np.array([-8.0], np.float32))
        n += 1
        if terminated or truncated:
            break
    env.close()
    assert truncated and not terminated
    assert n == 80  # 8 s at 10 frames/s


def test_sync_vector_env():
    envs = gym.vector.SyncVectorEnv([lambda: gym.make("lookahead/ForwardTracks-v0") for _ in range(2)])
    try:
        obs, _ = envs.reset(seed=[1, 2])
        assert obs["tracks"].shape == (2, 16, 8) and obs["ego"].shape == (2, 3)
        for _ in range(3):
            obs, rew, term, trunc, _ = envs.step(np.zeros((2, 1), np.float32))
        assert rew.shape == (2,) and term.shape == (2,)
    finally:
        envs.close()


def test_async_vector_env():
    envs = gym.vector.AsyncVectorEnv(
        [lambda: gym.make("lookahead/ForwardTracks-v0") for _ in range(2)], context="fork"
    )
    try:
        obs, _ = envs.reset(seed=[1, 2])
        obs, rew, *_ = envs.step(np.zeros((2, 1), np.float32))
        assert obs["tracks"].shape == (2, 16, 8) and rew.shape == (2,)
    finally:
        envs.close()


def test_weather_and_detector_choices_reach_the_scenario():
    env = LookaheadEnv(scenario=STATIONARY, weather={"kind": "fog", "visibility": 80})
    assert env.scenario.weather.kind == "fog" and env.scenario.weather.visibility == 80
    assert env.scenario.perception.detector.kind == "gt"
    cam = LookaheadEnv(scenario=tiny_camera_scenario(), render_camera=True, detector="onnx", weather="night")
    assert cam.scenario.perception.detector.kind == "onnx" and cam.scenario.weather.kind == "night"
    try:
        LookaheadEnv(detector="onnx")
    except ValueError as e:
        assert "render_camera" in str(e)
    else:
        raise AssertionError("onnx without the camera must be refused")


def _braking_flags(aeb: bool, decel: float) -> tuple[list[bool], float]:
    """``info["aeb_braking"]`` per step on the stationary car with a 1.2 s driver model braking at
    ``decel`` (m/s^2) and an agent that holds its speed; also the ego's final speed (m/s)."""
    from lookahead.sim.driver import DriverConfig

    sc = load_scenario(STATIONARY)
    sc = sc.model_copy(update={"ego": sc.ego.model_copy(update={"driver": DriverConfig(decel=decel)})})
    env = LookaheadEnv(scenario=sc, aeb=aeb)
    env.reset(seed=7)
    flags: list[bool] = []
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(np.zeros(1, np.float32))
        flags.append(info["aeb_braking"])
        done = terminated or truncated
    env.close()
    return flags, float(obs["ego"][0])


def test_aeb_braking_info_is_the_aebs_own_brake_not_the_drivers():
    flags, speed = _braking_flags(aeb=False, decel=4.0)
    assert speed < 0.1  # the driver braked the ego to a standstill
    assert not any(flags)  # ... and the AEB, which is off, never did
    # with the AEB on and a driver too gentle to avoid its CRITICAL alert, the AEB brakes too
    flags, _ = _braking_flags(aeb=True, decel=2.0)
    assert not flags[0] and any(flags)
