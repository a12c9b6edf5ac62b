"""Single-frame range measurement (``perception.ranging``) on its own, its class-prior
table, and its contract with the per-track estimator (which measures through it).

The measurement model's accuracy cases live in test_estimator.py ("one frame"), where
boxes are rendered through the camera model as the simulator does.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import CLASS_ID, CLASSES
from lookahead.perception.estimator import Estimator, EstimatorConfig, Measurement
from lookahead.perception.estimator_config import ClassPrior, PriorTable
from lookahead.perception.geometry import clip_boxes
from lookahead.perception.ranging import BoxRanger

CAM = CameraModel.from_fov(640, 360, 90.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-2.0)
PED, CAR = CLASS_ID["pedestrian"], CLASS_ID["car"]


def test_a_pedestrian_on_the_road_ahead_is_measured_at_its_distance() -> None:
    near = 12.0
    foot, head = CAM.project(np.array([[near, 0.0, 0.0], [near, 0.0, 1.6]]))
    box = np.array([[foot[0] - 8.0, head[1], foot[0] + 8.0, foot[1]]])
    m = BoxRanger(CAM).measure(box, [PED])
    assert isinstance(m, Measurement) and m.valid.tolist() == [True]
    assert abs(m.x[0] - near) < 0.05 * near
    assert abs(m.lateral[0]) < 0.1
    assert m.cov.shape == (1, 2, 2) and np.all(np.linalg.eigvalsh(m.cov[0]) > 0)


def test_the_estimator_measures_through_a_ranger_with_its_own_settings() -> None:
    rng = np.random.default_rng(1)
    n = 300
    x1, y1 = rng.uniform(-20, 640, n), rng.uniform(150, 360, n)
    boxes = np.column_stack([x1, y1, x1 + rng.uniform(1, 300, n), y1 + rng.uniform(1, 200, n)])
    cls = rng.integers(-1, len(CLASSES) + 1, n)
    cos_h = rng.uniform(0.0, 1.0, n)
    cfg = EstimatorConfig(edge_sigma_rel=0.08, side_cut_min_extent=2.0)
    est = Estimator(CAM, cfg)
    assert est.ranger.config is est.config and est.ranger.priors is est.priors
    a, b = est.measure(boxes, cls, cos_h), BoxRanger(CAM, cfg).measure(boxes, cls, cos_h)
    for f in dataclasses.fields(Measurement):
        np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name), err_msg=f.name)


def test_prior_table_looks_classes_up_and_falls_back_to_the_default() -> None:
    cfg = EstimatorConfig(priors={"car": ClassPrior(height=1.4, height_sigma=0.1, width=1.7, width_sigma=0.1)})
    table = PriorTable(cfg)
    h = table.of(np.array([CAR, PED, -1, len(CLASSES), 99]), "height")
    assert h.tolist() == [1.4, cfg.default_prior.height, cfg.default_prior.height,
                          cfg.default_prior.height, cfg.default_prior.height]  # no pedestrian prior given
    assert table.of(np.array([[CAR]]), "width").shape == (1, 1)
    assert Estimator(CAM, cfg).prior_of(np.array([CAR]), "width_cue").tolist() == [False]


def test_position_covariance_follows_the_bearing() -> None:
    r = BoxRanger(CAM)
    cov = r.position_cov(np.array([10.0]), np.array([0.5]), np.array([0.2]), np.array([0.0]), np.array([0.0]))[0]
    floor2 = r.config.position_sigma_floor**2
    np.testing.assert_allclose(cov, [[0.25 + floor2, 0.2 * 0.25], [0.2 * 0.25, 0.04 * 0.25 + floor2]])


def test_an_objects_own_height_replaces_the_class_prior() -> None:
    """A 1.24 m child 20 m ahead: the pedestrian prior (1.60 m) puts the height cue ~29 % too far;
    ranged with its own height the height cue is right. NaN heights keep the prior."""
    near, h = 20.0, 1.24
    foot, head = CAM.project(np.array([[near, 0.0, 0.0], [near, 0.0, h]]))
    box = np.array([[foot[0] - 4.0, head[1], foot[0] + 4.0, foot[1]]] * 2)
    r = BoxRanger(CAM)
    prior = r.measure(box, [PED, PED])
    own = r.measure(box, [PED, PED], height=np.array([h, np.nan]), height_sigma=np.array([0.02, np.nan]))
    assert prior.x_height[0] > 1.2 * near
    assert own.x_height[0] == pytest.approx(near, rel=0.02)
    assert own.sigma_height[0] < prior.sigma_height[0]
    assert own.x_height[1] == prior.x_height[1] and own.x[1] == prior.x[1]  # NaN: the prior
    # the height evidence: the ground cue's height at the face, its std from the box's noise only
    assert own.height_ground[0] == pytest.approx(h, rel=0.02)
    assert 0.0 < own.height_rel_sigma[0] < 0.15


def test_a_car_alongside_cut_at_the_bottom_bounds_its_face_by_its_length() -> None:
    """A car in the next lane left, its rear beside the camera: its box is cut at the left and the
    bottom and shows the front inner corner, a length deeper than its face (``bearing_depth``); any
    other box's bearing point is its face's."""
    corners = np.array([[[x, y, z] for x in (-1.0, 3.5) for y in (2.6, 4.4) for z in (0.0, 1.5)]])
    box = clip_boxes(CAM.project_boxes(corners), CAM.width, CAM.height)
    m = BoxRanger(CAM).measure(box, [CAR])
    assert m.cut_bottom[0] and m.valid[0]
    assert m.bearing_depth[0] == pytest.approx(4.5)
    ahead = BoxRanger(CAM).measure(np.array([[300.0, 170.0, 340.0, 200.0]]), [CAR])
    assert ahead.bearing_depth[0] == 0.0
