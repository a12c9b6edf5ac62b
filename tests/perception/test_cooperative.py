"""Cooperative perception (``perception.cooperative``): time alignment, matching, fusion weights."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.cooperative import (
    REMOTE_ID_BASE,
    FusionNode,
    ObjectList,
    SharedObjects,
    fuse,
    match,
    objects_from_estimates,
    range_covariance,
    to_frame,
)
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.estimator import Estimates
from lookahead.sim.layout import ego_frame


def world_to_ego(p: np.ndarray, pose) -> np.ndarray:
    return ego_frame(np.asarray(pose[:2]), pose[2], p)[0]


def objects(xy, velocity, class_id=None, cov=None) -> ObjectList:
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    n = len(xy)
    return ObjectList(xy, np.asarray(velocity, dtype=float).reshape(-1, 2),
                      range_covariance(xy) if cov is None else np.asarray(cov, dtype=float),
                      np.zeros(n, dtype=np.int64) if class_id is None else np.asarray(class_id),
                      np.full(n, 0.8), np.arange(n))


def test_a_message_of_age_dt_lands_where_the_object_is_now():
    # a cyclist at world (50, 3) riding at (4, -1) m/s; an oncoming car (heading pi) sees it at t0
    v_world = np.array([4.0, -1.0])
    p0 = np.array([50.0, 3.0])
    sender = (80.0, 3.5, np.pi)
    seen = world_to_ego(p0, sender)
    c, s = np.cos(sender[2]), np.sin(sender[2])
    v_sender = np.array([c * v_world[0] + s * v_world[1], -s * v_world[0] + c * v_world[1]])
    msg = SharedObjects("oncoming", 10.0, sender, objects([seen], [v_sender]))
    for age in (0.0, 0.2, 0.5):
        ego = (20.0 + 13.9 * age, 0.0, 0.05)  # the ego moved and turned meanwhile
        got = to_frame(msg, ego, 10.0 + age)
        np.testing.assert_allclose(got.xy[0], world_to_ego(p0 + v_world * age, ego), atol=1e-9)
        ce, se = np.cos(ego[2]), np.sin(ego[2])
        np.testing.assert_allclose(got.velocity[0], [ce * 4.0 - se * 1.0, -se * 4.0 - ce * 1.0], atol=1e-9)
        assert got.source[0] == 1  # other
    # the older the message, the less it is trusted
    covs = [np.trace(to_frame(msg, (20.0, 0.0, 0.0), 10.0 + a).cov[0]) for a in (0.0, 0.3, 0.6)]
    assert covs[0] < covs[1] < covs[2]


def test_camera_uncertainty_grows_with_range_and_lies_along_the_line_of_sight():
    cov = range_covariance(np.array([[10.0, 0.0], [60.0, 0.0], [40.0, 40.0]]))
    assert cov[1, 0, 0] > cov[0, 0, 0] and cov[1, 0, 0] > 10 * cov[1, 1, 1]  # range >> bearing error
    w, v = np.linalg.eigh(cov[2])
    np.testing.assert_allclose(np.abs(v[:, 1]), [np.sqrt(0.5)] * 2, atol=1e-9)  # longest axis: the diagonal


def test_the_lower_variance_source_dominates_the_fusion():
    near = objects([[10.0, 1.0]], [[0.0, 0.0]])  # the ego sees it close
    far = objects([[10.8, 1.4]], [[1.0, 0.0]], cov=range_covariance(np.array([[70.0, 0.0]])))  # seen from afar
    fused = fuse(near, far, match(near, far))
    assert len(fused) == 1 and fused.source[0] == 2  # both
    d_near, d_far = np.linalg.norm(fused.xy[0] - near.xy[0]), np.linalg.norm(fused.xy[0] - far.xy[0])
    assert d_near < 0.2 * d_far
    assert np.linalg.det(fused.cov[0]) < np.linalg.det(near.cov[0])  # fusing never loses information
    # equal uncertainties: the midpoint
    a, b = objects([[20.0, 0.0]], [[0, 0]]), objects([[20.4, 0.2]], [[0, 0]], cov=range_covariance(np.array([[20.0, 0.0]])))
    np.testing.assert_allclose(fuse(a, b, match(a, b)).xy[0], [20.2, 0.1], atol=1e-9)


def test_matching_is_one_to_one_gated_and_class_aware():
    car, truck, ped = CLASS_ID["car"], CLASS_ID["truck"], CLASS_ID["pedestrian"]
    own = objects([[20, 0], [20, 3.5], [45, -2]], np.zeros((3, 2)), class_id=[car, ped, car])
    other = objects([[20.3, 3.3], [20.2, 0.1], [45, -2], [90, 0]], np.zeros((4, 2)), class_id=[ped, truck, ped, car])
    i, j = match(own, other)
    # (2, 2): a pedestrian is no car; (0, 1): a car read as a truck is still the same vehicle
    assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == [(0, 1), (1, 0)]
    fused = fuse(own, other, (i, j))
    assert sorted(fused.source.tolist()) == [0, 1, 1, 2, 2]  # 2 both, 1 own only, 2 other only
    assert len(fuse(own, ObjectList.empty(), match(own, ObjectList.empty()))) == 3


@pytest.mark.parametrize("n", [0, 1])
def test_empty_lists_pass_through(n):
    own = objects(np.zeros((n, 2)) + 10, np.zeros((n, 2)))
    assert len(fuse(own, ObjectList.empty(), match(own, ObjectList.empty()))) == n


# ---------------------------------------------------------------------- the fusion node
def message(sender: str, xy, ids, class_id=None, t: float = 0.0, pose=(0.0, 0.0, 0.0)) -> SharedObjects:
    o = objects(xy, np.zeros((len(xy), 2)), class_id=class_id)
    o.object_id = np.asarray(ids)
    return SharedObjects(sender, t, pose, o)


def test_others_detection_of_the_receiver_is_dropped_but_a_car_beside_it_stays():
    car = CLASS_ID["car"]
    node = FusionNode(length=4.6, width=1.9)
    # the sender sees the ego (centre 2.3 m behind its front) and a car parked 2.4 m to its right
    msg = message("oncoming", [[-2.0, 0.2], [-2.3, -2.4]], [7, 8], class_id=[car, car])
    r = node.update(ObjectList.empty(), [msg], (0.0, 0.0, 0.0), 0.0)
    assert r.senders[0].fused_id.tolist() == [-1, REMOTE_ID_BASE]  # the nearest is the ego, the other stays
    assert len(r.objects) == 1 and r.objects.xy[0].tolist() == [-2.3, -2.4]
    # a pedestrian at the ego's bumper is never the ego
    ped = message("oncoming", [[-1.0, 0.0]], [9], class_id=[CLASS_ID["pedestrian"]])
    assert node.update(ObjectList.empty(), [ped], (0.0, 0.0, 0.0), 0.0).senders[0].fused_id[0] >= REMOTE_ID_BASE


def test_remote_ids_are_stable_and_a_second_sender_joins_the_first_senders_object():
    ped = CLASS_ID["pedestrian"]
    node = FusionNode()
    own = objects([[20.0, 0.0]], [[0.0, 0.0]], class_id=[ped])
    own.object_id = np.array([3])
    a = message("a_car", [[30.0, -4.0], [20.2, 0.1]], [11, 12], class_id=[ped, ped])
    b = message("b_rsu", [[30.3, -4.1]], [5], class_id=[ped])
    first = node.update(own, [b, a], (0.0, 0.0, 0.0), 0.0)  # fused in sender name order: a, then b
    ra, rb = first.senders
    assert (ra.sender, rb.sender) == ("a_car", "b_rsu")
    assert ra.fused_id.tolist() == [REMOTE_ID_BASE, 3] and ra.matched.tolist() == [False, True]
    assert ra.matched_source.tolist() == [-1, 0]  # joined an own object
    assert rb.fused_id.tolist() == [REMOTE_ID_BASE] and rb.matched_source.tolist() == [1]  # joined a's object
    src = dict(zip(first.objects.object_id.tolist(), first.objects.source.tolist(), strict=True))
    assert src == {3: 2, REMOTE_ID_BASE: 1}  # own+a: both; a+b: still only others'
    assert dict(zip(first.objects.object_id.tolist(), first.own_row.tolist(), strict=True)) == {3: 0, REMOTE_ID_BASE: -1}
    again = node.update(own, [a], (0.0, 0.0, 0.0), 0.1)
    assert again.senders[0].fused_id.tolist() == [REMOTE_ID_BASE, 3]  # the same id next frame


def test_pose_noise_widens_the_covariance_across_the_line_of_sight():
    msg = message("rsu", [[40.0, 0.0]], [1], pose=(0.0, 0.0, 0.0))
    base = to_frame(msg, (0.0, 0.0, 0.0), 0.0).cov[0]
    noisy = to_frame(SharedObjects("rsu", 0.0, msg.pose, msg.objects, (0.0, np.radians(1.0))),
                     (0.0, 0.0, 0.0), 0.0).cov[0]
    assert noisy[1, 1] - base[1, 1] == pytest.approx((40.0 * np.radians(1.0)) ** 2)  # heading x distance
    assert noisy[0, 0] == pytest.approx(base[0, 0])


def test_estimates_become_centres_with_a_systematic_range_error():
    n = 2
    est = Estimates.empty(n)
    est.range[:] = [10.0, 40.0]
    est.lateral[:] = [0.0, 2.0]
    est.range_sigma[:] = 0.2
    est.lateral_sigma[:] = 0.1
    est.ground_vx[:], est.ground_vy[:] = [5.0, 0.0], [0.0, 0.0]  # the first drives along x, the second stands
    est.ground_vx_sigma[:], est.ground_vy_sigma[:] = 0.5, 0.5
    est.settled[:] = [1.0, np.nan]
    o = objects_from_estimates(np.array([4, 5]), np.array([CLASS_ID["car"]] * n), np.array([0.9, 0.8]), est,
                               np.array([4.5, 4.5]), np.array([1.8, 1.8]), np.array([0.3, 0.3]))
    # driving: half a car length beyond the face; standing: it may lie any way, so half way between
    # its half length and half width, with a quarter of their difference as std
    np.testing.assert_allclose(o.xy, [[12.25, 0.0], [40.0 + (4.5 + 1.8) / 4, 2.0]])
    assert o.settled.tolist() == [1.0, 0.0]
    assert o.cov[1, 0, 0] > 4 * o.cov[0, 0, 0]  # the systematic part grows with range
    # range 0.2^2 + prior length (0.3 / 2)^2 + lying any way ((4.5 - 1.8) / 4)^2 + 5 % of the range along x
    assert o.cov[1, 0, 0] == pytest.approx(0.04 + 0.0225 + ((4.5 - 1.8) / 4) ** 2 + (0.05 * o.xy[1, 0]) ** 2)
    est.range[1] = np.nan
    assert objects_from_estimates(np.array([4, 5]), np.array([4, 4]), np.array([0.9, 0.8]), est, np.array([4.5, 4.5]),
                                  np.array([1.8, 1.8]), np.array([0.3, 0.3])).object_id.tolist() == [4]


def test_sizes_fuse_by_confidence_and_image_boxes_stay_with_their_camera():
    a = objects([[20.0, 0.0]], [[0.0, 0.0]], class_id=[CLASS_ID["car"]])
    a.size, a.score, a.xyxy = np.array([[4.0, 1.8, 1.5]]), np.array([0.9]), np.array([[300.0, 170.0, 340.0, 200.0]])
    b = objects([[20.3, 0.1]], [[0.0, 0.0]], class_id=[CLASS_ID["car"]])
    b.size, b.score = np.array([[5.0, 1.8, np.nan]]), np.array([0.3])
    b.xyxy = np.array([[10.0, 10.0, 20.0, 20.0]])  # in the sender's image
    moved = to_frame(SharedObjects("s", 0.0, (0.0, 0.0, 0.0), b), (0.0, 0.0, 0.0), 0.0)
    assert np.isnan(moved.xyxy).all()
    np.testing.assert_array_equal(moved.size, b.size)
    fused = fuse(a, moved, match(a, moved))
    np.testing.assert_allclose(fused.size[0], [(0.9 * 4.0 + 0.3 * 5.0) / 1.2, 1.8, 1.5])  # the unknown height: a's
    assert fused.xyxy[0].tolist() == a.xyxy[0].tolist()
