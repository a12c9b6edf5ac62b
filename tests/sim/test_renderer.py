"""PyBullet renderer: image contract, geometry agreement with ``CameraModel``, depth,
silhouettes, windowed scenery and both backends."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from lookahead.perception.camera import CameraModel
from lookahead.perception.geometry import box_corners, iou_matrix, mask_boxes
from lookahead.sim.layout import Marking, Rect, RoadLayout
from lookahead.sim.renderer import Renderer, RenderResult
from lookahead.sim.shapes import ActorShape, Part, make_shape

# A two-lane road with a pavement on the right (y < -3.5) and roadside zones.
ROAD = RoadLayout(
    asphalt=(Rect(0.0, -3.5, 10_000.0, 3.5),),
    sidewalks=(Rect(0.0, -6.5, 10_000.0, -3.5), Rect(0.0, 3.5, 10_000.0, 6.5)),
    markings=(
        Marking((0.0, 0.0), (10_000.0, 0.0), dashed=True),
        Marking((0.0, -3.3), (10_000.0, -3.3)),
    ),
    structure_zones=(Rect(0.0, 7.5, 10_000.0, 21.5), Rect(0.0, -21.5, 10_000.0, -7.5)),
)
# Open asphalt with a raised pavement island straight ahead (x 115..125 m, |y| < 2 m).
PLAIN = RoadLayout(
    asphalt=(Rect(-50.0, -10.0, 400.0, 10.0),), sidewalks=(Rect(115.0, -2.0, 125.0, 2.0),)
)
EGO = (100.0, 0.0, 0.0)


def _egl_available() -> bool:
    try:
        Renderer(CameraModel.from_fov(64, 48, 60), PLAIN, seed=0, backend="egl").close()
    except RuntimeError:
        return False
    return True


BACKENDS = [
    "tiny",
    pytest.param("egl", marks=pytest.mark.skipif(not _egl_available(), reason="no EGL")),
]


# ---------------------------------------------------------------------- helpers
def world_to_ego_box(
    shape: ActorShape,
    pose: tuple[float, float, float, float],
    ego: tuple[float, float, float],
    z0: float,
) -> np.ndarray:
    """Corners (8, 3) in the ego frame of the actor's tight local box at its gait phase."""
    x, y, h, g = pose
    ex, ey, eh = ego
    centre, size = shape.local_box(g)
    c, s = np.cos(h), np.sin(h)
    cw = np.array(
        [x + c * centre[0] - s * centre[1], y + s * centre[0] + c * centre[1], z0 + centre[2]]
    )
    d = cw - np.array([ex, ey, 0.0])
    ce, se = np.cos(-eh), np.sin(-eh)
    ego_c = np.array([ce * d[0] - se * d[1], se * d[0] + ce * d[1], d[2]])
    return box_corners(ego_c[None], size[None], np.array([h - eh]))[0]


def projected_box(cam: CameraModel, corners: np.ndarray) -> np.ndarray:
    return cam.project_boxes(corners[None])[0]


def mask_box(seg: np.ndarray, actor_id: int) -> tuple[np.ndarray, int]:
    boxes, counts = mask_boxes(seg, np.array([actor_id]))
    return boxes[0], int(counts[0])


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float(iou_matrix(a[None], b[None])[0, 0])


# ---------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def tele() -> CameraModel:
    """A narrow camera so test actors span 40+ pixels (rasterisation error << 5 %)."""
    return CameraModel.from_fov(320, 240, 14.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-3.0)


@pytest.fixture(scope="module", params=BACKENDS)
def tele_renderer(request, tele: CameraModel):
    gc.collect()  # renderers leaked by other tests give back the single EGL slot
    try:
        r = Renderer(tele, PLAIN, seed=1, backend=request.param)
    except RuntimeError as exc:
        pytest.skip(str(exc))
    yield r
    r.close()


@pytest.fixture(scope="module")
def road_renderer():
    cam = CameraModel.from_fov(320, 180, 90.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-2.0)
    r = Renderer(cam, ROAD, seed=7, backend="tiny")
    yield r
    r.close()


# ---------------------------------------------------------------------- tests
def test_render_returns_images_of_the_contracted_types(road_renderer: Renderer) -> None:
    r = road_renderer
    r.add_actor(1, make_shape("car", "sedan", np.random.default_rng(0)))
    try:
        out = r.render(EGO, {1: (EGO[0] + 15.0, -1.75, 0.0, 0.0)})
    finally:
        r.remove_actor(1)
    H, W = r.camera.height, r.camera.width
    assert isinstance(out, RenderResult)
    assert out.rgb.shape == (H, W, 3) and out.rgb.dtype == np.uint8
    assert out.depth.shape == (H, W) and out.depth.dtype == np.float32
    assert out.seg.shape == (H, W) and out.seg.dtype == np.int32
    assert set(np.unique(out.seg)) == {-1, 1}
    assert np.all(out.depth > 0) and np.all(out.depth <= r.far)
    assert out.depth[0, W // 2] == r.far  # sky at the top centre
    sky = out.rgb[0, W // 2].astype(int)
    assert sky[2] > sky[0]  # bluish
    assert r.backend == "tiny"


def test_actor_on_the_left_appears_left_of_centre(road_renderer: Renderer) -> None:
    r = road_renderer
    r.add_actor(5, make_shape("pedestrian", "adult", np.random.default_rng(0)))
    try:
        cols = {}
        for side, y in (("left", 2.0), ("right", -2.0)):
            seg = r.render(EGO, {5: (EGO[0] + 12.0, y, 0.0, 0.0)}).seg
            cols[side] = np.nonzero(seg == 5)[1].mean()
    finally:
        r.remove_actor(5)
    W = r.camera.width
    assert cols["left"] < W / 2 < cols["right"]


CASES = {  # actor, ego-frame (x, y) of the footprint centre, heading (rad), gait phase
    "car_behind_40m": (("car", "sedan"), (40.0, 0.0), 0.0, 0.0),
    "car_oblique_30m": (("car", "suv"), (30.0, 1.0), 0.5, 0.0),
    "car_side_22m": (("car", "hatchback"), (22.0, 0.0), np.pi / 2, 0.0),
    "pedestrian_mid_stride_25m": (("pedestrian", "adult"), (25.0, 0.0), np.pi / 2, np.pi / 2),
    "child_on_pavement_20m": (("pedestrian", "child"), (20.0, 0.0), -np.pi / 2, 1.0),
    "dog_trotting_14m": (("animal", "dog"), (14.0, 0.0), -np.pi / 2, np.pi / 2),
    "cyclist_crossing_25m": (("cyclist", "bicycle"), (25.0, 0.0), np.pi / 2, 2.0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_projected_box_matches_the_mask(
    tele_renderer: Renderer, tele: CameraModel, case: str
) -> None:
    (cls, subtype), (x, y), heading, phase = CASES[case]
    r = tele_renderer
    shape = make_shape(cls, subtype, np.random.default_rng(3))
    pose = (EGO[0] + x, EGO[1] + y, heading, phase)
    r.add_actor(9, shape)
    try:
        out = r.render(EGO, {9: pose})
    finally:
        r.remove_actor(9)
    z0 = float(PLAIN.surface_height(np.array([pose[:2]]))[0])
    corners = world_to_ego_box(shape, pose, EGO, z0)
    proj = projected_box(tele, corners)
    seen, n = mask_box(out.seg, 9)
    assert n > 400
    assert 0 <= proj[0] and proj[2] <= tele.width and 0 <= proj[1] and proj[3] <= tele.height
    assert iou(seen, proj) >= 0.95, (seen, proj)
    # depth at the actor's pixels lies within its box's camera-frame depth range
    z = tele.ego_to_camera(corners)[:, 2]
    d = out.depth[out.seg == 9]
    tol = 0.01 * z.max() + 0.02
    assert z.min() - tol <= d.min() and d.max() <= z.max() + tol
    if case == "car_behind_40m":  # its rear face is a plane at the box's nearest depth
        assert d.min() == pytest.approx(z.min(), abs=tol)


def test_swing_direction_agrees_with_part_poses(tele_renderer: Renderer, tele: CameraModel) -> None:
    """One asymmetric swinging leg: the rendered silhouette follows ``local_box``."""
    leg = Part(
        "box",
        (0.05, 0.1, 0.5),
        (0.0, 0.0, 0.5),
        (0.9, 0.2, 0.2, 1.0),
        swing=0.6,
        pivot=(0.0, 0.0, 1.0),
    )
    hip = Part("box", (0.1, 0.1, 0.1), (0.0, 0.0, 1.1), (0.2, 0.2, 0.9, 1.0))
    shape = ActorShape("test", "leg", (leg, hip), stride=1.0)
    r = tele_renderer
    r.add_actor(3, shape)
    try:
        for phase in (np.pi / 2, 3 * np.pi / 2):
            pose = (EGO[0] + 12.0, EGO[1], np.pi / 2, phase)  # seen side-on, x local = image left
            seg = r.render(EGO, {3: pose}).seg
            proj = projected_box(tele, world_to_ego_box(shape, pose, EGO, 0.0))
            assert iou(mask_box(seg, 3)[0], proj) >= 0.9, phase
    finally:
        r.remove_actor(3)


def test_silhouettes_show_an_occluded_actor_whole(
    tele_renderer: Renderer, tele: CameraModel
) -> None:
    r = tele_renderer
    truck = make_shape("truck", "truck", np.random.default_rng(0))
    car = make_shape("car", "hatchback", np.random.default_rng(0))
    r.add_actor(1, truck)
    r.add_actor(2, car)
    poses = {1: (EGO[0] + 14.0, 0.2, 0.0, 0.0), 2: (EGO[0] + 36.0, -0.3, 0.0, 0.0)}
    try:
        full = r.render(EGO, poses)
        alone = r.silhouettes(EGO, poses, [2])
        b = mask_box(alone, 2)[0]
        window = (int(b[0]) - 3, int(b[1]) - 3, int(b[2]) + 3, int(b[3]) + 3)
        windowed = r.silhouettes(EGO, poses, [2], window)
        again = r.render(EGO, poses)
    finally:
        r.remove_actor(1)
        r.remove_actor(2)
    assert not np.any(full.seg == 2)  # wholly behind the truck
    assert not np.any(alone == 1)
    assert alone.dtype == np.int32 and alone.shape == full.seg.shape
    proj = projected_box(tele, world_to_ego_box(car, poses[2], EGO, 0.0))
    assert iou(mask_box(alone, 2)[0], proj) >= 0.95
    # rendering only a window around the actor gives exactly the same pixels
    np.testing.assert_array_equal(windowed, alone)
    np.testing.assert_array_equal(again.seg, full.seg)  # the scene comes back afterwards
    np.testing.assert_array_equal(again.rgb, full.rgb)


def test_actors_hide_and_unknown_ids_are_rejected(road_renderer: Renderer) -> None:
    r = road_renderer
    r.add_actor(4, make_shape("animal", "cow", np.random.default_rng(0)))
    try:
        assert np.any(r.render(EGO, {4: (EGO[0] + 20.0, 0.0, 1.0, 0.5)}).seg == 4)
        assert not np.any(r.render(EGO, {}).seg == 4)
        with pytest.raises(KeyError):
            r.render(EGO, {77: (EGO[0] + 20.0, 0.0, 0.0, 0.0)})
        with pytest.raises(ValueError):
            r.add_actor(4, make_shape("animal", "cow", np.random.default_rng(0)))
    finally:
        r.remove_actor(4)
    r.remove_actor(4)  # idempotent


def test_scenery_is_deterministic_and_windowed_along_a_long_road(road_renderer: Renderer) -> None:
    r = road_renderer
    far_away = (9_000.0, 0.0, 0.0)
    a = r.render(EGO, {}).rgb
    b = r.render(far_away, {})
    c = r.render(EGO, {}).rgb
    np.testing.assert_array_equal(a, c)  # the same place always looks the same
    assert not np.array_equal(a, b.rgb)
    # the road and roadside are drawn at the far end of a 10 km road too
    H, W = b.rgb.shape[:2]
    assert b.depth[H - 1, W // 2] < 5.0  # road under the camera
    assert np.mean(b.depth[: H // 2] < r.far) > 0.05  # buildings/trees above the horizon


def test_same_seed_same_image_other_seed_other_scenery() -> None:
    cam = CameraModel.from_fov(160, 90, 90.0, pitch_deg=-2.0)
    imgs = []
    for seed in (3, 3, 4):
        with Renderer(cam, ROAD, seed=seed, backend="tiny") as r:
            imgs.append(r.render((500.0, 0.0, 0.0), {}).rgb)
    np.testing.assert_array_equal(imgs[0], imgs[1])
    assert not np.array_equal(imgs[0], imgs[2])


def test_surface_height_lifts_actors_onto_pavements() -> None:
    xy = np.array([[10.0, 0.0], [10.0, -5.0], [10.0, 5.0], [10.0, -30.0]])
    np.testing.assert_allclose(ROAD.surface_height(xy), [0.0, 0.15, 0.15, 0.0])


def test_bad_arguments_are_rejected() -> None:
    cam = CameraModel.from_fov(64, 48, 60)
    with pytest.raises(ValueError, match="backend"):
        Renderer(cam, PLAIN, seed=0, backend="vulkan")
    with pytest.raises(ValueError, match="near"):
        Renderer(cam, PLAIN, seed=0, near=5.0, far=1.0)


def test_backends_agree_on_geometry(tele_renderer: Renderer, tele: CameraModel) -> None:
    if tele_renderer.backend != "egl":
        pytest.skip("compares EGL with TinyRenderer")
    shape = make_shape("car", "sedan", np.random.default_rng(0))
    pose = (EGO[0] + 25.0, 0.8, 0.3, 0.0)
    with Renderer(tele, PLAIN, seed=0, backend="tiny") as tiny:
        tiny.add_actor(1, shape)
        tele_renderer.add_actor(1, shape)
        try:
            a, b = (r.render(EGO, {1: pose}) for r in (tele_renderer, tiny))
        finally:
            tele_renderer.remove_actor(1)
    assert iou(mask_box(a.seg, 1)[0], mask_box(b.seg, 1)[0]) >= 0.97
    both = (a.seg == 1) & (b.seg == 1)
    np.testing.assert_allclose(a.depth[both], b.depth[both], rtol=0.01)


def test_a_second_renderer_falls_back_to_tiny_while_egl_is_taken(
    tele_renderer: Renderer,
) -> None:
    if tele_renderer.backend != "egl":
        pytest.skip("needs a live EGL renderer")
    cam = CameraModel.from_fov(160, 90, 60.0)
    with pytest.raises(RuntimeError, match="EGL"):
        Renderer(cam, PLAIN, seed=0, backend="egl")
    shape = make_shape("car", "sedan", np.random.default_rng(0))
    with Renderer(tele_renderer.camera, PLAIN, seed=1, backend="auto") as second:
        assert second.backend == "tiny"
        second.add_actor(1, shape)
        tele_renderer.add_actor(1, shape)
        try:
            segs = [
                r.render(EGO, {1: (EGO[0] + 30.0, 0.0, 0.0, 0.0)}).seg
                for r in (tele_renderer, second)
            ]
        finally:
            tele_renderer.remove_actor(1)
    assert all(np.any(s == 1) for s in segs)  # the first (EGL) one still renders
    assert iou(mask_box(segs[0], 1)[0], mask_box(segs[1], 1)[0]) >= 0.95
