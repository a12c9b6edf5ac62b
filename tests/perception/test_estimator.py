"""Range / velocity / TTC estimator: analytic cases from boxes projected through the camera model.

Boxes are rendered exactly as the simulator does (``geometry.box_corners`` +
``CameraModel.project_boxes``, clipped to the image like a detector), from an
object placed in the ego frame with its nearest face at x = ``near``. Given a
vehicle class, the object is a body on wheels: the body starts at ``near``,
``CLEARANCE`` above the road, and the wheels touch the road ``OVERHANG``
further in, as the simulator's cars and trucks do, so the box bottom is the
wheels' contact (or, very close, the bumper).
Motion cases integrate the ego exactly (constant speed and yaw rate: a
circle) and feed 10 Hz frames.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.estimator import Estimates, Estimator, EstimatorConfig
from lookahead.perception.frame import EgoOdometry
from lookahead.perception.geometry import box_corners, clip_boxes
from lookahead.perception.tracker import Tracks, TrackState

CAM = CameraModel.from_fov(640, 360, 90.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-2.0)
# Narrow and tilted up: the image bottom row meets the road 4.57 m ahead, so close objects are cut.
CAM_UP = CameraModel.from_fov(640, 360, 60.0, mount=(-1.5, 0.0, 1.4), pitch_deg=5.0)
PED, CYC, CAR, TRUCK = (CLASS_ID[k] for k in ("pedestrian", "cyclist", "car", "truck"))
ADULT = (0.4, 0.6, 1.70)  # length, width, height (m)
SEDAN = (4.5, 1.8, 1.50)
RATE = 10.0
#: Rear overhang (face to wheel contact, m) and the face's lower edge above the road (m):
#: the simulator's sedans (0.21 L, bumper 0.17 m) and trucks (under-run bar 0.55 m).
OVERHANG = {CAR: 0.21 * SEDAN[0], TRUCK: 1.6}
CLEARANCE = {CAR: 0.17, TRUCK: 0.55}


def render(
    near: float, y: float, size: tuple[float, float, float], cam: CameraModel = CAM, cls: int | None = None
) -> np.ndarray:
    """xyxy box (clipped to the image) of an axis-aligned object, nearest face at x = near, centre y.

    With a vehicle ``cls`` (``OVERHANG``), a body from ``CLEARANCE`` up and wheels set in by the overhang.
    """
    length, width, height = size
    ov = OVERHANG.get(cls, 0.0) if cls is not None else 0.0
    if ov <= 0.0:
        corners = box_corners([[near + length / 2, y, height / 2]], [size], [0.0])
        return clip_boxes(cam.project_boxes(corners), cam.width, cam.height)[0]
    clearance = CLEARANCE[cls]
    body = box_corners([[near + length / 2, y, (clearance + height) / 2]], [(length, width, height - clearance)], [0.0])
    wheels = box_corners([[near + length / 2, y, clearance / 2]], [(length - 2 * ov, width, clearance)], [0.0])
    b = cam.project_boxes(np.concatenate([body, wheels]))
    box = np.concatenate([b[:, :2].min(axis=0), b[:, 2:].max(axis=0)])[None]
    return clip_boxes(box, cam.width, cam.height)[0]


def one_track(box: np.ndarray, cls: int, track_id: int = 1, state: int = TrackState.CONFIRMED) -> Tracks:
    return Tracks(
        track_id=[track_id],
        xyxy=box[None],
        class_id=[cls],
        score=[0.9],
        age=[0],
        hits=[1],
        state=[state],
        det_index=[0],
        velocity_px=np.zeros((1, 4)),
    )


def drive(
    start: tuple[float, float],
    size: tuple[float, float, float],
    cls: int,
    ego_speed: float,
    duration: float,
    ego_yaw_rate: float = 0.0,
    obj_velocity: tuple[float, float] = (0.0, 0.0),
    obj_accel: tuple[float, float] = (0.0, 0.0),
    odometry_yaw_rate: float | None = None,
    cam: CameraModel = CAM,
    config: EstimatorConfig | None = None,
) -> list[tuple[float, np.ndarray, Estimates]]:
    """Run the estimator on 10 Hz frames; returns (t, true (near, y) in the ego frame, estimates).

    The object moves in the world frame = the ego frame at t = 0; ``start`` is
    its nearest-face x and centre y there.
    """
    est = Estimator(cam, config)
    w = ego_yaw_rate
    out = []
    for k in range(round(duration * RATE) + 1):
        t = k / RATE
        th = w * t
        ego = (
            np.array([ego_speed / w * np.sin(th), ego_speed / w * (1 - np.cos(th))])
            if abs(w) > 1e-12
            else np.array([ego_speed * t, 0.0])
        )
        p = np.asarray(start) + np.asarray(obj_velocity) * t + 0.5 * np.asarray(obj_accel) * t * t
        c, s = np.cos(th), np.sin(th)
        rel = np.array([[c, s], [-s, c]]) @ (p - ego)
        odo_w = w if odometry_yaw_rate is None else odometry_yaw_rate
        box = render(rel[0], rel[1], size, cam, cls)
        e = est.update(one_track(box, cls), EgoOdometry(speed=ego_speed, yaw_rate=odo_w), t)
        out.append((t, rel, e))
    return out


# ---------------------------------------------------------------- one frame
@pytest.mark.parametrize("r", [5.0, 10.0, 20.0, 40.0])
@pytest.mark.parametrize(("size", "cls"), [(ADULT, PED), (SEDAN, CAR)])
def test_ground_contact_range_within_2_percent(r, size, cls):
    m = Estimator(CAM).measure(render(r, 0.0, size, cls=cls)[None], [cls])
    # the box bottom is where the wheels touch the road; the class's contact offset is removed
    assert m.x_ground[0] == pytest.approx(r + OVERHANG.get(cls, 0.0), rel=0.02)
    assert m.x[0] == pytest.approx(r, rel=0.03)  # fused with a (slightly wrong) height prior


@pytest.mark.parametrize("r", [5.0, 10.0, 20.0, 40.0])
def test_height_prior_alone_within_the_priors_error(r):
    est = Estimator(CAM)
    prior = est.config.priors["pedestrian"]
    m = est.measure(render(r, 0.0, ADULT)[None], [PED])
    xc = r - CAM.mount[0]  # camera-forward distance
    err = (m.x_height[0] - r) / xc
    assert abs(err) <= prior.height_sigma / prior.height  # 1.6 +- 0.25 m for a 1.70 m adult: -6 %
    assert abs(m.x_height[0] - r) <= m.sigma_height[0]
    # a car of exactly the prior's height: the height cue alone is exact
    m = est.measure(render(r, 0.0, SEDAN)[None], [CAR])
    assert m.x_height[0] == pytest.approx(r, rel=0.01)


def test_fusion_beats_the_worse_of_the_two_cues():
    """Monte Carlo: pedestrians of random height, box edges with the configured pixel noise."""
    cfg = EstimatorConfig()
    cfg.priors["pedestrian"].contact_height_sigma = 0.0  # these boxes stand on the road plane, no kerb
    est = Estimator(CAM, cfg)
    rng = np.random.default_rng(0)
    n = 400
    for r in (5.0, 10.0, 20.0, 40.0):
        h = np.clip(rng.normal(1.6, 0.25, n), 0.9, 2.1)
        corners = box_corners(
            np.column_stack([np.full(n, r + 0.2), np.zeros(n), h / 2]),
            np.column_stack([np.full(n, 0.4), np.full(n, 0.6), h]),
            np.zeros(n),
        )
        b = CAM.project_boxes(corners)
        sv = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * (b[:, 3] - b[:, 1]))
        b += rng.normal(size=b.shape) * sv[:, None]
        b[:, [1, 3]] += rng.normal(size=(n, 1)) * CAM.fy * cfg.pitch_sigma  # pitching moves both edges
        m = est.measure(b, np.full(n, PED))

        g, hp, f = (float(np.sqrt(np.nanmean((x - r) ** 2))) for x in (m.x_ground, m.x_height, m.x))
        assert f < max(g, hp), (r, g, hp, f)
        assert f <= 1.02 * min(g, hp), (r, g, hp, f)
        covered = np.mean(np.abs(m.x - r) < 2 * m.sigma)
        assert 0.88 < covered < 0.99, (r, covered)  # the reported std is honest


@pytest.mark.parametrize("r", [5.0, 10.0, 20.0, 40.0])
@pytest.mark.parametrize("y", [3.0, -3.0])
def test_lateral_offset_of_an_object_to_the_side(r, y):
    m = Estimator(CAM).measure(render(r, y, ADULT)[None], [PED])
    assert m.lateral[0] == pytest.approx(y, rel=0.05)
    assert m.half_width[0] == pytest.approx(0.3, abs=0.1)


def test_lateral_of_a_car_off_to_the_side_is_unbiased():
    """The box's outer edge is the rear face's corner; its inner edge the front's, 4.5 m deeper."""
    est = Estimator(CAM)
    m = est.measure(render(10.0, 0.5, SEDAN, cls=CAR)[None], [CAR])  # the rear face spans the axis
    assert m.lateral[0] == pytest.approx(0.5, abs=0.02)
    assert m.half_width[0] == pytest.approx(0.9, abs=0.02)
    for r in (5.0, 10.0, 20.0, 40.0):
        for y in (3.0, -3.0, 1.6):  # wholly to one side (1.6: the inner edge 0.7 m off the axis)
            m = est.measure(render(r, y, SEDAN, cls=CAR)[None], [CAR])
            assert m.lateral[0] == pytest.approx(y, abs=0.05), (r, y)
            assert m.half_width[0] == pytest.approx(0.9, abs=0.02), (r, y)
    # The bottom-centre ray, taken at the face's depth, had put the inner edge of a car
    # parked 3 m aside 0.2-0.5 m nearer the ego's path: an "in path" parked car.
    m = est.measure(render(10.0, -3.0, SEDAN, cls=CAR)[None], [CAR])
    assert abs(m.lateral[0]) - m.half_width[0] == pytest.approx(2.1, abs=0.05)
    # Not for classes whose footprint is not known end-on (a pedestrian): the ray, as before.
    m = est.measure(render(10.0, 3.0, ADULT)[None], [PED])
    assert m.lateral[0] == pytest.approx(3.0, abs=0.1)


def test_car_alongside_cut_at_the_image_edge():
    """Overtaking on the left, front 3 m ahead: only its inner edge (the front's corner) is seen."""
    est = Estimator(CAM)
    box = render(-1.5, 3.5, SEDAN, cls=CAR)  # rear 1.5 m behind the bumper
    m = est.measure(box[None], [CAR])
    assert m.cut_bottom[0] or box[1] > 0
    assert box[0] == 0.0  # cut at the left image edge
    # At the true face depth the lateral is right; the far corner is L = 4.5 m deeper.
    mt = est.measure(render(3.0, 3.5, (0.1, 1.8, 1.5))[None], [CAR])  # a thin plate at the front
    assert np.isfinite(mt.lateral[0])
    lat = m.lateral[0]
    assert lat > 2.5, lat  # not pulled into the ego's corridor (|y| < 1.4 + 0.9)
    # a noisy detector edge 6 px inside the border still counts as cut
    noisy = box + np.array([6.0, 0.0, 0.0, 0.0])
    m2 = est.measure(noisy[None], [CAR])
    assert m2.lateral[0] == pytest.approx(lat, abs=0.3)


def render_visible(near: float, y: float, size: tuple[float, float, float], cam: CameraModel = CAM) -> np.ndarray:
    """Box of the object's surface points that land in the image, as a segmentation mask gives it
    (the amodal box clipped to the image keeps rows of parts outside it; this one does not)."""
    length, width, height = size
    g = np.linspace(0.0, 1.0, 60)
    a, b = (v.ravel() for v in np.meshgrid(g, g, indexing="ij"))
    x0, y0 = near, y - width / 2
    faces = [np.stack([x0 + length * a, y0 + width * b, np.full_like(a, z)], -1) for z in (0.0, height)]
    faces += [np.stack([x0 + length * a, np.full_like(a, s), height * b], -1) for s in (y0, y0 + width)]
    faces += [np.stack([np.full_like(a, s), y0 + width * a, height * b], -1) for s in (x0, x0 + length)]
    uv = cam.project(np.concatenate(faces))
    ok = np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] <= cam.width)
    ok &= (uv[:, 1] >= 0) & (uv[:, 1] <= cam.height)
    uv = uv[ok]
    return np.concatenate([uv.min(axis=0), uv.max(axis=0)])


def test_car_alongside_seen_only_in_part_bounds_its_range():
    """A car overtaking on the left, rear beside the ego: the mask's box shows its front part only,
    cut at the left border, its bottom the lowest visible pixel there, not the nearest contact."""
    est = Estimator(CAM)
    box = render_visible(-1.55, 3.5, SEDAN)
    assert box[0] < 0.5 and box[3] < CAM.height - 20  # cut at the side (sampled surface), not the bottom
    m = est.measure(box[None], [CAR])
    assert m.side_bound[0] and not m.cut_bottom[0]
    assert m.x[0] > -1.55 + 1.0  # the visible part's face: an upper bound ...
    assert m.sigma[0] >= 0.9 * SEDAN[0] / np.sqrt(12.0)  # ... as uncertain as the hidden length
    # its nearest face in view (fully, or cut at the border with its rear face partly in view): measured
    for b in (render_visible(3.0, 2.8, SEDAN), render(1.0, 3.0, SEDAN, cls=CAR), render(2.0, 2.9, SEDAN, cls=CAR)):
        m = est.measure(b[None], [CAR])
        assert not m.side_bound[0], b
    # a short footprint (a pedestrian at the border) hides nothing worth a bound
    m = est.measure(render_visible(2.0, 3.2, ADULT)[None], [PED])
    assert not m.side_bound[0]


def test_no_settling_on_boxes_that_only_bound_the_range():
    """The overtaking car slides into view at +4 m/s relative: while its box only bounds the range
    the track stays unsettled (so 'initializing', no alert), then settles on the whole box with a
    range rate near the truth."""
    est = Estimator(CAM)
    settled, bound, rr = [], [], []
    for k in range(25):
        t = k / RATE
        near = -1.55 + 4.0 * t
        box = render_visible(near, 3.5 - 0.3 * max(t - 0.5, 0.0), SEDAN)
        m = est.measure(box[None], [CAR])
        e = est.update(one_track(box, CAR), EgoOdometry(speed=22.0), t)
        settled.append(e.settled[0])
        bound.append(bool(m.side_bound[0] or m.cut_bottom[0]))
        rr.append(e.range_rate[0])
    settled, bound = np.array(settled), np.array(bound)
    assert bound[:4].all() and not bound[-5:].any()
    first = int(np.argmax(settled == 1.0))
    assert not settled[bound & (np.arange(25) < first + 1)].any()  # never settles on a bound-only frame
    assert np.all(settled[first:] == 1.0) and first <= round(est.config.settle_max_s * RATE)
    assert rr[-1] == pytest.approx(4.0, abs=1.5)


def test_edges_within_their_noise_of_the_border_count_as_cut():
    est = Estimator(CAM)
    big = np.array([[5.0, 150.0, 205.0, 300.0]])  # 200 px wide: 5 % edge noise is 10 px
    small = np.array([[5.0, 150.0, 25.0, 170.0]])  # 20 px wide: 1 px
    cfg = est.config
    assert 5.0 <= cfg.edge_margin_px + cfg.edge_cut_sigmas * cfg.edge_sigma_rel * 200.0
    m = est.measure(np.concatenate([big, small]), [CAR, PED])
    assert m.half_width[0] >= 0.9 - 1e-9  # cut: the visible edge plus the prior half-width
    # the small box is not cut: its own width
    assert m.half_width[1] == pytest.approx(0.5 * (m.x[1] - CAM.mount[0]) * 20.0 / CAM.fx, rel=0.2)


@pytest.mark.parametrize("r", [10.0, 20.0, 40.0])
def test_width_cue_of_a_car_ahead(r):
    est = Estimator(CAM)
    m = est.measure(render(r, 0.3, SEDAN, cls=CAR)[None], [CAR])
    assert m.x_width[0] == pytest.approx(r, rel=0.01)  # the prior's width: exact
    assert m.x[0] == pytest.approx(r, rel=0.01)
    # not when a side face is in the box (wholly to one side), nor for a pedestrian
    m = est.measure(np.stack([render(r, 3.0, SEDAN, cls=CAR), render(r, 0.0, ADULT)]), [CAR, PED])
    assert np.all(np.isnan(m.x_width))
    # nor when the car is seen obliquely
    m = est.measure(render(r, 0.3, SEDAN, cls=CAR)[None], [CAR], cos_heading=np.array([0.9]))
    assert np.isnan(m.x_width[0])


def test_width_cue_lowers_the_noise_of_a_car_ahead():
    """Monte Carlo, cars of random width and height, box edges with the detector's 5 % noise."""
    cfg = EstimatorConfig()
    no_w = EstimatorConfig()
    for k in ("car",):
        no_w.priors[k] = no_w.priors[k].model_copy(update={"width_cue": False})
    rng = np.random.default_rng(1)
    n = 300
    for r in (15.0, 30.0):
        boxes = []
        for _ in range(n):
            size = (4.5, rng.uniform(1.7, 1.9), rng.uniform(1.4, 1.6))
            boxes.append(render(r, rng.uniform(-0.5, 0.5), size, cls=CAR))
        b = np.array(boxes)
        w, h = b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]
        b = b + rng.normal(size=b.shape) * cfg.edge_sigma_rel * np.stack([w, h, w, h], axis=1)
        m1 = Estimator(CAM, cfg).measure(b, np.full(n, CAR))
        m0 = Estimator(CAM, no_w).measure(b, np.full(n, CAR))
        e1, e0 = (float(np.sqrt(np.mean((m.x - r) ** 2))) for m in (m1, m0))
        assert e1 < 0.92 * e0, (r, e1, e0)
        covered = np.mean(np.abs(m1.x - r) < 2 * m1.sigma)
        assert 0.88 < covered < 0.995, (r, covered)  # the reported std is honest


def test_box_cut_at_the_bottom_uses_the_height_prior():
    est = Estimator(CAM_UP)
    x_row = CAM_UP.ground_points(np.array([[320.0, 360.0]]))[0, 0]
    # A truck of the prior's height 4 m ahead: its wheels are below the image. The
    # top ray on z = 3.2 m is exact; the single-frame range is that Gaussian (std
    # from the height prior) truncated to [0, x_row], as the foot is below the image.
    truck = (8.0, 2.5, 3.2)
    box = render(4.0, 0.0, truck, CAM_UP)
    assert box[3] == CAM_UP.height
    m = est.measure(box[None], [TRUCK])
    assert m.cut_bottom[0] and np.isnan(m.x_ground[0]) and m.x_max[0] == pytest.approx(x_row)
    assert m.x_height[0] == pytest.approx(4.0, rel=1e-6)
    assert 0.0 < m.x[0] <= x_row and abs(m.x[0] - 4.0) <= m.sigma[0]
    # A taller truck than the prior: within the prior's error.
    m = est.measure(render(4.0, 0.0, (8.0, 2.5, 3.4), CAM_UP)[None], [TRUCK])
    assert abs(m.x_height[0] - 4.0) <= m.sigma_height[0]
    # A 1.70 m adult: the top ray is near the camera's height and says little; the bound decides.
    for near in (1.0, 3.0):
        m = est.measure(render(near, 0.0, ADULT, CAM_UP)[None], [PED])
        assert m.cut_bottom[0] and np.isnan(m.x_ground[0])
        assert 0.0 <= m.x[0] <= x_row and abs(m.x[0] - near) <= 2 * m.sigma[0]
    # With the default camera an adult's feet leave the image only within 0.8 m.
    m = Estimator(CAM).measure(render(0.3, 0.0, ADULT)[None], [PED])
    assert m.cut_bottom[0] and 0.0 <= m.x[0] <= 0.8


def test_tracking_through_bottom_truncation_keeps_the_range():
    """Approaching at 5 m/s; below 4.57 m the box is cut and only bearing and bound are measured."""
    # the truck is 0.2 m taller than the prior and its wheels 0.1 m further in: 0.3 m
    for size, cls, tol in ((SEDAN, CAR, 0.2), (ADULT, PED, 0.2), ((8.0, 2.5, 3.4), TRUCK, 0.3)):
        out = drive((12.0, 0.0), size, cls, ego_speed=5.0, duration=2.2, cam=CAM_UP)
        for t, rel, e in out[12:]:
            assert e.range[0] == pytest.approx(rel[0], abs=tol), (cls, t)
            assert e.range_rate[0] == pytest.approx(-5.0, abs=0.2), (cls, t)


def test_box_cut_at_the_top_uses_the_ground_contact_only():
    est = Estimator(CAM)
    m = est.measure(render(1.5, 0.0, (8.0, 2.5, 3.4), cls=TRUCK)[None], [TRUCK])
    assert m.cut_top[0] and np.isnan(m.x_height[0])
    assert m.x_ground[0] == pytest.approx(1.5 + OVERHANG[TRUCK], rel=1e-6)  # the rear wheels
    assert m.x[0] == pytest.approx(1.5, abs=0.15)  # less the prior's overhang (1.5 m)


# ---------------------------------------------------------------- motion
def test_pedestrian_crossing_while_the_ego_drives():
    # 20 m ahead, 3 m to the right, walking left at 1.5 m/s; ego at 10 m/s.
    out = drive((20.0, -3.0), ADULT, PED, ego_speed=10.0, duration=1.0, obj_velocity=(0.0, 1.5))
    _, rel, e = out[-1]
    assert e.range_rate[0] == pytest.approx(-10.0, abs=0.5)
    assert e.ground_vy[0] == pytest.approx(1.5, abs=0.3)
    assert e.ground_vx[0] == pytest.approx(0.0, abs=0.5)
    assert e.lateral_rate[0] == pytest.approx(1.5, abs=0.3)
    assert e.range[0] == pytest.approx(rel[0], rel=0.02)
    assert e.lateral[0] == pytest.approx(rel[1], rel=0.05)


def test_stationary_object_ttc_is_range_over_ego_speed():
    out = drive((30.0, 0.0), SEDAN, CAR, ego_speed=10.0, duration=1.5)
    for _, rel, e in out[-3:]:
        assert e.ttc[0] == pytest.approx(rel[0] / 10.0, rel=0.10)
        assert np.isnan(e.yaw_rate[0])  # not moving: no heading


def test_constant_velocity_model_too():
    cfg = EstimatorConfig(motion_model="cv")
    _, rel, e = drive((30.0, 0.0), SEDAN, CAR, ego_speed=10.0, duration=1.5, config=cfg)[-1]
    assert e.ttc[0] == pytest.approx(rel[0] / 10.0, rel=0.10)


def test_opening_object_has_infinite_ttc():
    out = drive((15.0, 0.0), SEDAN, CAR, ego_speed=10.0, duration=1.5, obj_velocity=(15.0, 0.0))
    _, _, e = out[-1]
    assert e.range_rate[0] == pytest.approx(5.0, abs=0.5)
    assert e.ground_vx[0] == pytest.approx(15.0, abs=0.5)
    assert np.isinf(e.ttc[0])


def test_ego_yaw_rate_is_compensated():
    # Ego turning left at 0.2 rad/s and 10 m/s past a stationary pedestrian.
    kw = dict(start=(25.0, 4.0), size=ADULT, cls=PED, ego_speed=10.0, duration=2.0, ego_yaw_rate=0.2)
    for t, rel, e in drive(**kw)[10:]:
        assert np.hypot(e.ground_vx[0], e.ground_vy[0]) < 0.3, t
        # relative motion in the rotating ego frame, as the ground truth defines it
        assert e.range_rate[0] == pytest.approx(-10.0 + 0.2 * rel[1], abs=0.5)
        assert e.lateral_rate[0] == pytest.approx(-0.2 * rel[0], abs=0.5)
    # Sanity: the same run with the yaw rate withheld from the estimator sees a moving object.
    _, _, e = drive(**kw, odometry_yaw_rate=0.0)[-1]
    assert np.hypot(e.ground_vx[0], e.ground_vy[0]) > 1.0


def test_braking_lead_vehicle_acceleration():
    # Lead car 15 m ahead at 12 m/s braking at 4 m/s^2; ego at 10 m/s.
    kw = dict(start=(15.0, 0.0), size=SEDAN, cls=CAR, ego_speed=10.0, duration=2.8,
              obj_velocity=(12.0, 0.0), obj_accel=(-4.0, 0.0))  # fmt: skip
    # The constant-acceleration model (the IMM's manoeuvre model) follows it closely.
    out = drive(**kw, config=EstimatorConfig(motion_model="ca"))
    for t, _, e in out[20:]:
        assert e.accel[0] == pytest.approx(-4.0, abs=1.0), t
        assert e.ground_vx[0] == pytest.approx(12.0 - 4.0 * t, abs=0.8), t
    assert np.isnan(out[3][2].accel[0])  # not before the filter settles
    # The default IMM, tuned for the detector's box noise (5 % per edge), weighs a
    # deceleration against that noise: it has switched to braking within 2.4 s.
    for t, _, e in drive(**kw)[24:]:
        assert e.accel[0] < -2.0, t
        assert e.ground_vx[0] == pytest.approx(12.0 - 4.0 * t, abs=1.5), t


def test_range_rate_std_shrinks_and_settled_latches_through_a_manoeuvre():
    """A lead car followed at 16.7 m/s, 22 m ahead, then braking at 8 m/s^2 (``lead_brake``).

    Noisy boxes (the detector's 5 % edge noise): the filter starts from the class's
    broad velocity prior, so its range-rate std starts at 12 m/s and shrinks; the track
    settles once it is below 1 m/s (or after ``settle_max_s``) and stays settled while
    the std grows again in the manoeuvre.
    """
    cfg = EstimatorConfig()
    est = Estimator(CAM, cfg)
    rng = np.random.default_rng(3)
    sig, settled, errs = [], [], []
    for k in range(46):
        t = k / RATE
        tb = max(t - 3.0, 0.0)
        gap = 22.0 - 0.5 * 8.0 * tb**2  # the lead brakes from t = 3 s; the ego keeps 16.7 m/s
        box = render(gap, 0.0, SEDAN, cls=CAR)
        w, h = box[2] - box[0], box[3] - box[1]
        box = box + rng.normal(size=4) * cfg.edge_sigma_rel * np.array([w, h, w, h])
        e = est.update(one_track(box, CAR), EgoOdometry(speed=16.7), t)
        sig.append(e.range_rate_sigma[0])
        settled.append(e.settled[0])
        errs.append(e.range_rate[0] - (-8.0 * tb))
    sig, settled = np.array(sig), np.array(settled)
    assert sig[0] == pytest.approx(12.0)  # the prior: N(0, 12^2) ground velocity per axis
    assert sig[20] < 0.2 * sig[0]
    first = int(np.argmax(settled == 1.0))
    assert settled[0] == 0.0 and 5 <= first <= round(cfg.settle_max_s * RATE)
    assert np.all(settled[first:] == 1.0)  # latched ...
    assert sig[40:].max() > sig[25:30].min()  # ... though the std grows in the braking
    assert np.all(np.abs(errs[first:30]) < 1.5)  # settled and steady: good to the deadband (1 m/s)


def noisy(box: np.ndarray, rng: np.random.Generator, cfg: EstimatorConfig) -> np.ndarray:
    """``box`` with the detector's edge noise (``edge_sigma_rel`` of its size per edge)."""
    w, h = box[2] - box[0], box[3] - box[1]
    return box + rng.normal(size=4) * cfg.edge_sigma_rel * np.array([w, h, w, h])


@pytest.mark.parametrize("seed", range(4))
def test_a_converging_velocity_is_no_acceleration_nor_turn(seed):
    """An oncoming car (14 m/s, 60 m ahead, the ego at 10 m/s) seen through noisy boxes: its filter
    starts from the broad velocity prior and converges over the first second or two. That drift of
    the filtered velocity is no acceleration, nor its heading's a turn: accel and yaw rate are
    unknown (NaN) or small -- no sudden brake (4 m/s^2) nor sudden turn (0.35 rad/s) from them."""
    cfg = EstimatorConfig()
    est, rng = Estimator(CAM, cfg), np.random.default_rng(seed)
    for k in range(31):
        t = k / RATE
        box = noisy(render(60.0 - 24.0 * t, 3.0, SEDAN, cls=CAR), rng, cfg)
        e = est.update(one_track(box, CAR), EgoOdometry(speed=10.0), t)
        assert not abs(e.accel[0]) > 3.0, t
        assert not abs(e.yaw_rate[0]) > 0.2, t


@pytest.mark.parametrize("seed", range(4))
def test_a_braking_lead_through_noisy_boxes(seed):
    """``lead_brake``: a lead car 22 m ahead at the ego's 16.7 m/s brakes at 8 m/s^2 from 3 s.
    Before, the converging and steady velocity reads no acceleration beyond 3 m/s^2 (no sudden
    brake); after, a deceleration beyond 4 m/s^2 within 1.5 s."""
    cfg = EstimatorConfig()
    est, rng = Estimator(CAM, cfg), np.random.default_rng(seed)
    first = None
    for k in range(46):
        t = k / RATE
        tb = max(t - 3.0, 0.0)
        box = noisy(render(22.0 - 4.0 * tb**2, 0.0, SEDAN, cls=CAR), rng, cfg)
        a = est.update(one_track(box, CAR), EgoOdometry(speed=16.7), t).accel[0]
        if t < 3.0:
            assert not abs(a) > 3.0, t
        elif first is None and a < -4.0:
            first = t
    assert first is not None and first <= 4.5


def test_turning_cyclist_yaw_rate():
    est = Estimator(CAM)
    w, v = 0.3, 5.0
    for k in range(31):
        t = k / RATE
        p = np.array([15.0 + v / w * np.sin(w * t) - 5.0 * t, v / w * (1 - np.cos(w * t))])
        e = est.update(one_track(render(p[0], p[1], (0.6, 0.6, 1.75)), CYC), EgoOdometry(speed=5.0), t)
    assert e.yaw_rate[0] == pytest.approx(w, abs=0.1)
    assert e.ground_vx[0] == pytest.approx(v * np.cos(w * 3.0), abs=0.5)
    assert e.ground_vy[0] == pytest.approx(v * np.sin(w * 3.0), abs=0.5)


# ---------------------------------------------------------------- bookkeeping and robustness
def test_invalid_boxes_give_nan_and_never_raise():
    est = Estimator(CAM)
    good = render(10.0, 0.0, ADULT)
    boxes = np.array(
        [
            good,
            [np.nan, 100.0, 120.0, 200.0],
            [100.0, 100.0, 100.0, 200.0],  # zero width
            [120.0, 200.0, 100.0, 100.0],  # inverted
            [np.inf, 0.0, 1.0, 1.0],
            [-1e12, -1e12, 1e12, 1e12],
        ]
    )
    n = len(boxes)
    tracks = Tracks(
        track_id=np.arange(1, n + 1),
        xyxy=boxes,
        class_id=[PED, PED, CAR, 99, -1, CAR],
        score=np.full(n, 0.9),
        age=np.zeros(n),
        hits=np.ones(n),
        state=np.ones(n),
        det_index=np.arange(n),
        velocity_px=np.full((n, 4), np.nan),
    )
    for k in range(3):
        e = est.update(tracks, EgoOdometry(speed=np.nan, yaw_rate=np.nan), 0.1 * k)
        assert len(e) == n
        assert np.isfinite(e.range[0]) and np.isfinite(e.range_rate[0])
        for name in ("range", "lateral", "range_rate", "ttc"):
            assert np.all(np.isnan(getattr(e, name)[1:])), name
    # unknown classes fall back to the default prior
    m = est.measure(np.array([good, good]), [-1, 99])
    assert np.all(np.isfinite(m.x))
    assert len(est.update(Tracks(), None, 1.0)) == 0
    assert len(est.update(Tracks(), EgoOdometry(), 0.5)) == 0  # time going back: reset, no raise
    assert est.num_filters == 0


def test_lost_tracks_coast_and_filters_drop_after_2_s():
    est = Estimator(CAM)
    odo = EgoOdometry(speed=10.0)
    t = 0.0
    for k in range(16):
        t = k / RATE
        est.update(one_track(render(30.0 - 10.0 * t, 0.0, SEDAN, cls=CAR), CAR), odo, t)
    # the tracker reports the track as lost (box = its prediction): prediction only
    e = est.update(one_track(np.array([0.0, 0.0, 10.0, 10.0]), CAR, state=TrackState.LOST), odo, t + 0.1)
    assert e.range[0] == pytest.approx(30.0 - 10.0 * (t + 0.1), abs=0.5)
    assert est.num_filters == 1
    t_last = t
    for k in range(1, 25):  # gone
        t = t_last + k / RATE
        est.update(Tracks(), odo, t)
        assert est.num_filters == (1 if t - t_last <= 2.0 + 1e-9 else 0), t
    est.reset()
    assert est.num_filters == 0


def test_raw_detection_boxes_are_measured_when_given():
    est = Estimator(CAM)
    box = render(10.0, 0.0, ADULT)
    tracks = one_track(box + np.array([0.0, 0.0, 0.0, 20.0]), PED)  # a lagging tracker box
    dets = Detections(xyxy=box[None], score=[0.9], class_id=[PED])
    e = est.update(tracks, EgoOdometry(), 0.0, detections=dets)
    assert e.range[0] == pytest.approx(10.0, rel=0.03)


def test_to_dict_and_kinematics_fields():
    out = drive((20.0, 1.0), SEDAN, CAR, ego_speed=10.0, duration=0.3)
    e = out[-1][2]
    d = e.to_dict()
    assert set(d) == {f.name for f in dataclasses.fields(Estimates)}
    assert all(len(v) == 1 for v in d.values())
    assert np.isnan(d["accel"][0])  # unknown this early, kept as NaN for the writer
    # The consumer's contract (perception itself never imports intent).
    from lookahead.intent.labels import Kinematics

    k = Kinematics(class_id=np.array([CAR]), age=np.array([3]), **e.kinematics_fields())
    assert k.range[0] == e.range[0]
    assert set(e.kinematics_fields()) == {f.name for f in dataclasses.fields(Kinematics)} - {"class_id", "age"}


@pytest.mark.parametrize(("size", "large"), [((1.5, 0.3, 1.2), True), ((1.0, 0.22, 0.65), False)])
def test_an_animals_height_comes_from_its_boxes_not_its_prior(size, large):
    """A deer (1.2 m) and a dog (0.65 m) standing 30 m ahead, the ego closing at 16.7 m/s: the
    animal prior (0.9 +- 0.45 m) gives way to the ground contact within a second, so the two
    land on either side of the large-animal height (0.9 m)."""
    out = drive((30.0, 0.0), size, CLASS_ID["animal"], ego_speed=16.7, duration=1.0)
    h = out[-1][2].height[0]
    assert h == pytest.approx(size[2], rel=0.08)
    assert (h >= 0.9) == large


def test_relative_acceleration_of_a_braking_lead():
    """Following a lead car 15 m ahead at 13.9 m/s for 2 s, then it brakes at 6 m/s^2. Its ground
    acceleration along x reads ~0 while steady and the braking (over 3.5 m/s^2) 1.2 s after it
    began -- the measured lag of boxes good to 5 % per edge, which the filter is tuned for --,
    with a std that says the estimate is loose."""
    est = Estimator(CAM)
    acc = {}
    for k in range(33):
        t = k / RATE
        tb = max(t - 2.0, 0.0)
        gap = 15.0 - 0.5 * 6.0 * tb * tb  # the ego keeps 13.9 m/s
        e = est.update(one_track(render(gap, 0.0, SEDAN, CAM, CAR), CAR), EgoOdometry(speed=13.9), t)
        acc[k] = (e.accel_x[0], e.accel_x_sigma[0])
    assert max(abs(acc[k][0]) for k in range(15, 21)) < 0.5
    a, sig = acc[32]
    assert a < -3.5
    assert 1.0 < sig < 6.0


def _drive_raised(start, size, cls, ego_speed, duration, lift=0.0, config=None, obj_vx=0.0):
    """``drive`` for an object standing ``lift`` m above the road (a pavement): (t, near, estimates)."""
    est = Estimator(CAM, config)
    out = []
    length, width, height = size
    for k in range(round(duration * RATE) + 1):
        t = k / RATE
        near = start[0] + (obj_vx - ego_speed) * t
        corners = box_corners([[near + length / 2, start[1], lift + height / 2]], [size], [0.0])
        box = clip_boxes(CAM.project_boxes(corners), CAM.width, CAM.height)[0]
        out.append((t, near, est.update(one_track(box, cls), EgoOdometry(speed=ego_speed), t)))
    return out


@pytest.mark.parametrize(("height", "lift"), [(1.70, 0.0), (1.20, 0.0), (1.70, 0.15), (1.80, 0.15)])
def test_a_pedestrians_learned_height_tells_adults_from_children_and_discounts_a_pavement(height, lift):
    """Pedestrians standing 25 m ahead, the ego at 10 m/s: the learned height (``Estimates.height``)
    takes the adult or the child mode of the prior; on a 0.15 m pavement, whose contact the ground
    cue reads as the road (heights 11 % too tall), the contact height's prior takes part of it."""
    out = _drive_raised((25.0, 2.5), (0.4, 0.6, height), PED, ego_speed=10.0, duration=1.5, lift=lift)
    h = out[-1][2].height[0]
    seen = height * CAM.mount[2] / (CAM.mount[2] - lift)  # what the ground cue reads
    assert h == pytest.approx(height, rel=0.06)
    assert abs(h - height) < abs(seen - height) or lift == 0.0


@pytest.mark.parametrize("learned", [False, True])
def test_ranging_with_the_learned_height_is_an_option(learned):
    """A 1.2 m child on the road 30 m ahead, 15 m after 1.5 s: the class prior's height (1.60 m)
    ranges it 3 % too far; with ``range_learned_height`` its learned height does not."""
    cfg = EstimatorConfig(range_learned_height=learned)
    out = _drive_raised((30.0, 0.0), (0.3, 0.4, 1.2), PED, ego_speed=10.0, duration=1.5, config=cfg)
    _, near, e = out[-1]
    err = (e.range[0] - near) / near
    assert (abs(err) < 0.01) if learned else (err > 0.02)


def test_a_car_overtaking_alongside_restarts_once_carried_behind_its_bound():
    """A car in the next lane overtaking at +4 m/s, first seen with its rear beside the camera: its
    box is cut at the bottom and the left, the range unobservable, and the filter's velocity prior
    (0 over the ground, the ego at 22 m/s) carries it back, its lateral sliding along the bearing of
    the front inner corner (not off it: that bearing is taken at the corner's depth, even behind the
    camera). Once the prediction is more than the car's length behind the camera (the corner is in
    view) the pull-back fails the NIS gate: the filter coasts one frame and restarts on the next box
    (here the first one whose bottom is in view; without the bound that box was the first outlier)."""
    est = Estimator(CAM)
    x_min = CAM.mount[0] + 0.1 - 4.5  # the front inner corner is in front of the camera
    rows = []
    for k in range(10):
        t = k / RATE
        rear = -1.0 + 4.0 * t
        corners = box_corners([[rear + 2.25, 3.5, 0.75]], [(4.5, 1.8, 1.5)], [0.0])
        box = clip_boxes(CAM.project_boxes(corners), CAM.width, CAM.height)[0]
        assert est.measure(box[None], [CAR]).cut_bottom[0] == (k < 6)
        e = est.update(one_track(box, CAR), EgoOdometry(speed=22.0), t)
        rows.append((rear, e.range[0], e.lateral[0]))
    beyond = [k for k, (_, r, _) in enumerate(rows) if r < x_min]
    assert beyond and len(beyond) <= 1  # one coasting frame at most
    rear, r, lat = rows[beyond[0] + 1]
    assert abs(r - rear) < 1.0 and abs(lat - 3.5) < 0.5
    for _rear, r, lat in rows[beyond[0] + 1:]:
        assert r > x_min and abs(lat - 3.5) < 0.5
