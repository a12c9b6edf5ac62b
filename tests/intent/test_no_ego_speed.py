"""Issue 32: without ego speed the stack assesses relative motion only, and nothing from a guess.

``EgoOdometry(speed_known=False)``: range, range rate, TTC, labels, in-path and risk still work
(relative quantities); the object's ground velocity along x, its accelerations, the enhanced
TTC's stop model, the required deceleration and the behaviours are unavailable (NaN / UNKNOWN).
"""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Behaviour, Kinematics, Label, Risk, assess
from lookahead.intent.stack import build_stack
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import PerceptionSpec
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.estimator import Estimator
from lookahead.perception.frame import EgoOdometry, Frame

CAMERA = CameraModel.from_fov(640, 360, 90.0)
EXACT_GT = {"miss_rate": 0.0, "miss_occlusion": 0.0, "miss_truncation": 0.0, "box_sigma": 0.0, "fp_rate": 0.0,
            "class_confusion": 0.0}  # the gt detector without noise
EGO_SPEED = 10.0  # m/s
START = 50.0  # m, a parked car's rear ahead at t = 0
RATE = 10.0  # Hz


def _car_box(range_m: float, lateral: float = 0.0) -> list[float]:
    """xyxy (px) of a 1.8 m wide, 1.5 m high car ahead, its rear at ``range_m``."""
    x, y, z = np.meshgrid([range_m, range_m + 4.5], [lateral - 0.9, lateral + 0.9], [0.0, 1.5], indexing="ij")
    uv = CAMERA.project(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1))
    return [*uv.min(axis=0), *uv.max(axis=0)]


def _run(known, n: int = 44):
    """The stack over n frames of the ego at EGO_SPEED closing on a parked car; ``known(i)`` says
    whether frame i has the ego speed. Per frame: (true range, estimates, assessment, alerts, known)."""
    stack = build_stack(PerceptionSpec.model_validate({"detector": {"kind": "gt", "noise": EXACT_GT}}), CAMERA, RATE,
                        render=False)
    out = []
    for i in range(n):
        t = i / RATE
        r = START - EGO_SPEED * t
        truth = DetectorTruth(width=640, height=360, xyxy=[_car_box(r)], class_id=[CLASS_ID["car"]],
                              source_id=[7], range_m=[r])
        k = bool(known(i))
        odo = EgoOdometry(speed=EGO_SPEED if k else 0.0, speed_known=k)
        _, tracks, est, a, alerts = stack.process(Frame(tick=i, t=t, camera=CAMERA, odometry=odo, index=i), truth, {})
        out.append((r, est, a, alerts, k))
    return out


def _settled(run):
    return [(r, e, a, al, k) for r, e, a, al, k in run if len(e) == 1 and e.settled[0] == 1.0]


def _first_alert(run):
    return next((al[0] for *_, al, _ in run if al), None)


def test_relative_quantities_work_without_ego_speed_and_ground_ones_are_unavailable():
    run = _run(lambda i: False)
    rows = _settled(run)
    assert len(rows) >= 15
    for r, e, a, _, _ in rows:
        assert e.range[0] == pytest.approx(r, abs=1.0)  # (the box model's bias, as with ego speed)
        assert e.range_rate[0] == pytest.approx(-EGO_SPEED, abs=1.0)  # closing at the ego's speed
        assert e.ttc[0] == pytest.approx(r / EGO_SPEED, abs=0.15)
        assert np.isfinite(e.lateral[0]) and abs(e.lateral[0]) < 0.5
        assert np.isfinite(e.ground_vy[0]) and abs(e.ground_vy[0]) < 1.0  # lateral: the same over the ground
        for name in Estimator.NEEDS_EGO_SPEED:  # over-ground quantities: unavailable, not guessed
            assert np.isnan(getattr(e, name)[0]), name
        assert a.ttc[0] == pytest.approx(e.ttc[0])
        assert a.ettc[0] == pytest.approx(a.ttc[0])  # no enhanced model without ground speeds
        assert np.isnan(a.decel_req[0])
        assert a.behaviour[0] == Behaviour.UNKNOWN  # not 'wrong_way' from a guessed ego speed of 0
        assert bool(a.in_path[0])  # straight ahead, in the (straight) corridor
        assert a.label[0] in (Label.APPROACHING, Label.DANGER)
    # a risk from range and closing speed only, so the warning still comes, on the relative TTC
    assert max(int(a.risk[0]) for _, _, a, _, _ in rows) >= Risk.HIGH
    first = _first_alert(run)
    assert first is not None and first.kind in ("fcw", "critical")
    assert first.ttc < IntentConfig().risk["vehicle"].high_ttc + 0.5
    assert "unknown" in first.reason  # its behaviour, unavailable


def test_with_ego_speed_the_same_sequence_behaves_as_before():
    run = _run(lambda i: True)
    rows = _settled(run)
    assert len(rows) >= 15
    for r, e, a, _, _ in rows:
        assert e.range[0] == pytest.approx(r, abs=1.0)
        assert e.range_rate[0] == pytest.approx(-EGO_SPEED, abs=1.0)
        assert e.ground_vx[0] == pytest.approx(0.0, abs=1.0)  # parked
        assert np.isfinite(e.ground_vx_sigma[0]) and np.isfinite(e.accel_x[0])
        assert np.isfinite(a.decel_req[0])
        assert a.behaviour[0] == Behaviour.STOPPED
    known_first, unknown_first = _first_alert(run), _first_alert(_run(lambda i: False))
    assert known_first is not None and known_first.kind in ("fcw", "critical")
    # constant speeds: the relative TTC is the enhanced one, so the warning comes at about the same time
    assert unknown_first is not None and abs(unknown_first.t - known_first.t) <= 0.3


def test_default_odometry_is_speed_known_and_unchanged():
    """``speed_known`` defaults to True: simulated frames take the ground-velocity path as before."""
    a = _run(lambda i: True, n=20)
    stack = build_stack(PerceptionSpec.model_validate({"detector": {"kind": "gt", "noise": EXACT_GT}}), CAMERA, RATE,
                        render=False)
    for i, (r, e_ref, a_ref, _, _) in enumerate(a):
        truth = DetectorTruth(width=640, height=360, xyxy=[_car_box(r)], class_id=[CLASS_ID["car"]],
                              source_id=[7], range_m=[r])
        frame = Frame(tick=i, t=i / RATE, camera=CAMERA, odometry=EgoOdometry(speed=EGO_SPEED), index=i)
        _, _, e, asm, _ = stack.process(frame, truth, {})
        np.testing.assert_array_equal(e.ground_vx, e_ref.ground_vx)
        np.testing.assert_array_equal(e.range_rate, e_ref.range_rate)
        np.testing.assert_array_equal(asm.risk, a_ref.risk)


def test_the_speed_coming_and_going_converts_the_filters():
    """Known for 1 s, unknown for 1 s, known again: the track carries on; ground quantities are NaN
    exactly while the speed is unknown, and right again after."""
    run = _run(lambda i: not 10 <= i < 20)
    rows = _settled(run)
    assert all(e.range_rate[0] == pytest.approx(-EGO_SPEED, abs=1.5) for _, e, *_ in rows)
    for _, e, a, _, k in rows:
        assert np.isnan(e.ground_vx[0]) != k
        assert (a.behaviour[0] == Behaviour.UNKNOWN) != k
    after = [e for i, (_, e, *_rest) in enumerate(run) if i >= 22]
    assert all(e.ground_vx[0] == pytest.approx(0.0, abs=1.0) for e in after)


def _kin(**over) -> Kinematics:
    base = {"class_id": [CLASS_ID["car"]], "range": [12.0], "lateral": [0.0], "half_width": [0.9],
            "range_rate": [-2.0], "lateral_rate": [0.0], "ground_vx": [np.nan], "ground_vy": [0.0],
            "accel": [np.nan], "yaw_rate": [np.nan], "accel_x": [-3.0]}
    base.update(over)
    return Kinematics(**{k: np.asarray(v, dtype=np.float64) if k != "class_id" else np.asarray(v) for k, v in base.items()})


def test_assess_without_ego_speed_decides_on_relative_motion_only():
    """12 m ahead, closing at 2 m/s (TTC 6 s), with an acceleration of -3 m/s^2 that, without the
    ego's speed, cannot be told from the ego's own: taken as the object's (ego speed guessed 0) it
    makes an enhanced TTC of 2.2 s and a HIGH risk; with the speed unknown (NaN), MEDIUM."""
    cfg = IntentConfig()
    k = _kin()
    guessed = assess(k, cfg, 0.0)
    unknown = assess(k, cfg, float("nan"))
    assert guessed.risk[0] == Risk.HIGH and guessed.ettc[0] == pytest.approx(2.24, abs=0.05)
    assert unknown.risk[0] == Risk.MEDIUM
    assert unknown.ttc[0] == pytest.approx(6.0) and unknown.ettc[0] == pytest.approx(6.0)
    assert np.isnan(unknown.decel_req[0])
    assert unknown.label[0] == Label.APPROACHING and bool(unknown.in_path[0])
    assert unknown.behaviour[0] == Behaviour.UNKNOWN
    # a yaw rate bends the corridor only with a known speed: unknown, the corridor is straight
    side = _kin(lateral=[2.0], range=[20.0], accel_x=[0.0])  # 2 m left, in the straight corridor
    assert bool(assess(side, cfg, float("nan"), -0.2).in_path[0])
    assert not bool(assess(side, cfg, 10.0, -0.2).in_path[0])  # the ego turning right, away from it
    # closing fast, in path: HIGH and CRITICAL still come from the relative TTC
    close = _kin(range=[8.0], range_rate=[-8.0], accel_x=[np.nan])
    assert assess(close, cfg, float("nan")).risk[0] == Risk.CRITICAL
