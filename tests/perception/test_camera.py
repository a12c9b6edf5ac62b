"""The one camera model: projection, near-plane clipping and ground back-projection."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lookahead.perception.camera import CameraModel, truncation
from lookahead.perception.geometry import box_corners, iou_matrix, mask_boxes

CAM = CameraModel.from_fov(640, 360, 90.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-2.0)


def test_point_on_the_optical_axis_hits_the_principal_point():
    cam = CameraModel.from_fov(640, 360, 90.0, mount=(0.0, 0.0, 1.0))
    np.testing.assert_allclose(cam.project(np.array([[10.0, 0.0, 1.0]])), [[320.0, 180.0]])
    # 90 deg horizontal FOV: a point 45 deg to the left lands on the left edge.
    np.testing.assert_allclose(cam.project(np.array([[10.0, 10.0, 1.0]])), [[0.0, 180.0]], atol=1e-9)


def test_left_is_left_and_up_is_up():
    uv = CAM.project(np.array([[20.0, 3.0, 0.0], [20.0, -3.0, 0.0], [20.0, 0.0, 3.0]]))
    assert uv[0, 0] < 320 < uv[1, 0]
    assert uv[2, 1] < uv[0, 1]


def test_pitch_down_moves_the_horizon_up():
    assert CAM.horizon_v() < 180.0
    far = CAM.project(np.array([[1e6, 0.0, 1.4]]))[0]
    assert far[1] == pytest.approx(CAM.horizon_v(), abs=0.01)


@given(st.floats(2.0, 80.0), st.floats(-10.0, 10.0))
def test_ground_back_projection_inverts_projection(x, y):
    p = np.array([[x, y, 0.0]])
    back = CAM.ground_points(CAM.project(p))
    np.testing.assert_allclose(back, p, atol=1e-6 * max(1.0, x))


def test_points_above_the_horizon_do_not_meet_the_ground():
    assert np.all(np.isnan(CAM.ground_points(np.array([[320.0, 10.0]]))))


def test_distortion_round_trip():
    cam = CameraModel(640, 360, CAM.K, dist=np.array([-0.2, 0.05, 0.001, -0.001, 0.0]), mount=CAM.mount, pitch=CAM.pitch)
    p = np.array([[15.0, 3.0, 0.0], [8.0, -2.0, 0.0]])
    np.testing.assert_allclose(cam.ground_points(cam.project(p)), p, atol=1e-3)


def test_box_projection_equals_corner_extremes_in_front():
    corners = box_corners([[20.0, 1.0, 0.75]], [[4.5, 1.8, 1.5]], [0.3])
    uv = CAM.project(corners[0])
    np.testing.assert_allclose(CAM.project_boxes(corners)[0], [*uv.min(0), *uv.max(0)])


def test_box_partly_behind_the_camera_is_clipped_at_the_near_plane():
    # A long truck beside and ahead: its rear corners are behind the camera.
    corners = box_corners([[1.0, 3.0, 1.5]], [[12.0, 2.5, 3.0]], [0.0])
    box = CAM.project_boxes(corners, near=0.1)[0]
    assert np.all(np.isfinite(box))
    assert box[0] < 0 and box[2] > 0  # extends off the left edge, as it must
    assert truncation(box[None], 640, 360)[0] > 0.5
    # Wholly behind: NaN.
    behind = box_corners([[-10.0, 0.0, 0.75]], [[4.0, 1.8, 1.5]], [0.0])
    assert np.all(np.isnan(CAM.project_boxes(behind)))


def test_mask_boxes_are_tight():
    lab = np.full((10, 12), -1)
    lab[2:5, 3:7] = 4
    lab[8, 11] = 9
    boxes, counts = mask_boxes(lab, np.array([9, 4, 7]))
    np.testing.assert_array_equal(boxes[:2], [[11, 8, 12, 9], [3, 2, 7, 5]])
    assert np.all(np.isnan(boxes[2]))
    np.testing.assert_array_equal(counts, [1, 12, 0])


def test_iou_matrix_hand_computed():
    a = np.array([[0, 0, 2, 2]])
    b = np.array([[1, 1, 3, 3], [0, 0, 2, 2], [5, 5, 6, 6]])
    np.testing.assert_allclose(iou_matrix(a, b), [[1 / 7, 1.0, 0.0]])
