"""Cooperative perception (``perception.cooperative``): time alignment, matching, fusion weights."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.cooperative import (
    ObjectList,
    SharedObjects,
    fuse,
    match,
    range_covariance,
    to_frame,
)
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
    own = objects([[20, 0], [20, 3.5], [45, -2]], np.zeros((3, 2)), class_id=[2, 0, 2])
    other = objects([[20.3, 3.3], [20.2, 0.1], [45, -2], [90, 0]], np.zeros((4, 2)), class_id=[0, 2, 1, 2])
    i, j = match(own, other)
    assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == [(0, 1), (1, 0)]  # (2, 2): other class
    fused = fuse(own, other, (i, j))
    assert sorted(fused.source.tolist()) == [0, 1, 1, 2, 2]  # 2 both, 1 own only, 2 other only
    assert len(fuse(own, ObjectList.empty(), match(own, ObjectList.empty()))) == 3


@pytest.mark.parametrize("n", [0, 1])
def test_empty_lists_pass_through(n):
    own = objects(np.zeros((n, 2)) + 10, np.zeros((n, 2)))
    assert len(fuse(own, ObjectList.empty(), match(own, ObjectList.empty()))) == n
