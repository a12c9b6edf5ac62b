"""The fusion stage between the ego's estimator and its intent (``intent.cooperative``)."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.intent.config import IntentConfig
from lookahead.intent.cooperative import FusionStage
from lookahead.intent.labels import Kinematics, assess
from lookahead.perception.camera import CameraModel
from lookahead.perception.cooperative import REMOTE_ID_BASE, FusionNode, ObjectList, SharedObjects
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.estimator import Estimates, Estimator
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.tracker import Tracks

PED, CAR = CLASS_ID["pedestrian"], CLASS_ID["car"]


def own_tracks() -> tuple[Tracks, Estimates]:
    tracks = Tracks(track_id=[7, 9], xyxy=np.zeros((2, 4)), class_id=[CAR, PED], score=[0.9, 0.8], age=[20, 20],
                    hits=[20, 20], state=[1, 1], det_index=[0, 1], velocity_px=np.zeros((2, 4)))
    est = Estimates.empty(2)
    for name, v in dict(range=[30.0, np.nan], lateral=[0.0, 2.0], range_sigma=[0.5, 0.5], lateral_sigma=[0.1, 0.1],
                        half_width=[0.9, 0.3], range_rate=[-10.0, 0.0], lateral_rate=[0.0, 0.0], ground_vx=[0.0, 0.0],
                        ground_vy=[0.0, 0.0], ground_vx_sigma=[0.3, 0.3], ground_vy_sigma=[0.3, 0.3],
                        settled=[1.0, 1.0], accel=[0.0, 0.0], yaw_rate=[0.0, 0.0], accel_x=[0.0, 0.0],
                        range_rate_sigma=[0.3, 0.3], height=[1.5, 1.7]).items():
        getattr(est, name)[:] = v
    return tracks, est


def child_message() -> SharedObjects:
    """A child 12 m ahead, 3 m right, walking left at 1.5 m/s, seen by a unit standing at the ego."""
    o = ObjectList(np.array([[12.0, -3.0]]), np.array([[0.0, 1.5]]), np.eye(2)[None] * 0.04,
                   np.array([PED]), np.array([0.9]), np.array([4]), velocity_sigma=np.array([[0.2, 0.2]]))
    return SharedObjects("rsu", 1.0, (0.0, 0.0, 0.0), o)


def stage(enabled: bool = True) -> FusionStage:
    est = Estimator(CameraModel.from_fov(640, 360, 90.0))
    return FusionStage(FusionNode(), est.priors, enabled=enabled)


def frame() -> Frame:
    return Frame(tick=20, t=1.0, camera=CameraModel.from_fov(640, 360, 90.0), odometry=EgoOdometry(speed=10.0), index=10)


def test_intent_sees_the_ego_tracks_in_order_then_what_only_others_see():
    s = stage()
    tracks, est = own_tracks()
    kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
    s.receive([child_message()], (0.0, 0.0, 0.0))
    union, ids, classes = s(frame(), tracks, est, kin)
    assert ids.tolist() == [7, 9, REMOTE_ID_BASE] and classes.tolist() == [CAR, PED, PED]
    half = s.priors.of(np.array([PED]), "width")[0] / 2  # walking along y: its x extent is its width
    assert union.range[2] == pytest.approx(12.0 - half, abs=1e-9)
    assert union.range_rate[2] == pytest.approx(0.0 - 10.0)  # standing still in x; the ego closes at 10 m/s
    assert union.lateral_rate[2] == pytest.approx(1.5) and union.age[2] == 0
    assert union.range[0] == 30.0 and np.isnan(union.range[1])  # own rows as estimated (no match)
    a = assess(union, IntentConfig(), 10.0)
    own = s.split(a)
    assert len(own) == 2 and len(s.remote.assessment) == 1 and s.remote.ids.tolist() == [REMOTE_ID_BASE]
    assert s.remote.assessment.in_path[0]  # walking into the path at 1.5 m/s, TTC ~1.2 s


def test_with_fusion_off_intent_sees_the_ego_alone_but_the_fusion_is_kept():
    s = stage(enabled=False)
    tracks, est = own_tracks()
    kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
    s.receive([child_message()], (0.0, 0.0, 0.0))
    union, ids, _ = s(frame(), tracks, est, kin)
    assert union is kin and ids.tolist() == [7, 9]
    assert s.result.objects.object_id.tolist() == [7, REMOTE_ID_BASE] and s.remote is None


def test_an_object_both_see_takes_the_fused_position_and_the_others_settled_velocity():
    s = stage()
    tracks, est = own_tracks()
    est.settled[0] = 0.0  # the ego's own track of the car is new
    est.ground_vx_sigma[0] = est.ground_vy_sigma[0] = 5.0
    kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
    o = ObjectList(np.array([[32.5, 0.0]]), np.array([[-3.0, 0.0]]), np.eye(2)[None] * 0.25, np.array([CAR]),
                   np.array([0.9]), np.array([2]), velocity_sigma=np.array([[0.2, 0.2]]))
    s.receive([SharedObjects("oncoming", 1.0, (0.0, 0.0, 0.0), o)], (0.0, 0.0, 0.0))
    union, ids, _ = s(frame(), tracks, est, kin)
    assert ids.tolist() == [7, 9]  # matched: no remote row
    assert union.settled[0] == 1.0
    assert union.ground_vx[0] == pytest.approx(-3.0, abs=0.01)  # the others' velocity dominates
    assert union.range_rate[0] == pytest.approx(-13.0, abs=0.01)
