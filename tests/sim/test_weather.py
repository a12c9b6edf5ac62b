"""Weather and light (``sim.weather``): the fog model's exact transmission, visibility
presets, night lighting, rain, determinism, the clear no-op, the spec's validation, the
lamp-head positions and the runner hook (image only, ground truth unchanged)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lookahead.perception.camera import CameraModel
from lookahead.sim.layout import Marking, Rect, RoadLayout
from lookahead.sim.renderer import Renderer
from lookahead.sim.scenario import FOG_PRESETS, ScenarioError, WeatherSpec, parse_scenario
from lookahead.sim.weather import (
    SKY_HORIZON_RGB,
    Weather,
    beta_from_visibility,
    decode,
    encode,
    lamp_heads,
    linear_to_srgb,
    srgb_to_linear,
)

# Wide asphalt (|y| < 12 m) with a centre line and lamp-post zones beyond it.
ROAD = RoadLayout(
    asphalt=(Rect(0.0, -12.0, 2_000.0, 12.0),),
    markings=(Marking((0.0, 0.0), (2_000.0, 0.0), dashed=True),),
    structure_zones=(Rect(0.0, 13.0, 2_000.0, 27.0), Rect(0.0, -27.0, 2_000.0, -13.0)),
)
EGO = (118.0, 0.0, 0.0)  # a lamp post stands 12 m ahead of the front bumper (x = 130)
FAR = 250.0


@pytest.fixture(scope="module")
def cam() -> CameraModel:
    return CameraModel.from_fov(320, 180, 90.0, mount=(-1.5, 0.0, 1.4), pitch_deg=-2.0)


@pytest.fixture(scope="module")
def scene(cam: CameraModel):
    """One real (TinyRenderer) frame of ROAD: (rgb, depth)."""
    r = Renderer(cam, ROAD, seed=3, backend="tiny", far=FAR)
    try:
        out = r.render(EGO, {})
    finally:
        r.close()
    return out.rgb, out.depth


def luma(rgb: np.ndarray) -> np.ndarray:
    return decode(rgb) @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


def ground_pixels(cam: CameraModel, xs, ys) -> tuple[np.ndarray, np.ndarray]:
    """Integer (rows, cols) of ego-frame ground points on a grid xs x ys."""
    gx, gy = np.meshgrid(xs, ys)
    uv = cam.project(np.stack([gx, gy, np.zeros_like(gx)], axis=-1).reshape(-1, 3))
    return uv[:, 1].astype(int), uv[:, 0].astype(int)


# ---------------------------------------------------------------------- fog
def test_visibility_presets_map_to_beta() -> None:
    assert beta_from_visibility(100.0) == pytest.approx(-math.log(0.05) / 100.0)
    assert beta_from_visibility(100.0) == pytest.approx(0.02996, rel=1e-3)
    for name, mor in FOG_PRESETS.items():
        spec = WeatherSpec(kind="fog", visibility=name)
        assert spec.visibility_m == mor
        assert Weather(spec, CameraModel.from_fov(32, 24, 60.0), 0).beta == pytest.approx(3.0 / mor, rel=2e-3)
    assert WeatherSpec(kind="fog").visibility_m == FOG_PRESETS["thick"] == 200.0
    assert WeatherSpec(kind="fog", visibility=80).visibility_m == 80.0
    assert WeatherSpec(kind="night").visibility_m is None  # clear air unless given
    assert WeatherSpec(kind="rain", intensity=1.0).visibility_m < WeatherSpec(kind="rain").visibility_m
    # the definition of MOR: transmission 5 % over that distance (along the ray)
    w = Weather(WeatherSpec(kind="fog", visibility=150, variation=0), CameraModel.from_fov(32, 24, 60.0), 0)
    assert float(w.transmission(np.full((24, 32), 150.0, np.float32))[12, 16]) == pytest.approx(
        0.05, rel=1e-3
    )


def test_fog_transmission_follows_exp_minus_beta_d_along_the_ray() -> None:
    """Synthetic frame: known J, known airlight A, depth z per pixel; the output is exactly
    A + (J - A) exp(-beta d) in linear light, d the ray (not optical-axis) distance."""
    cam = CameraModel.from_fov(64, 48, 90.0, pitch_deg=-5.0)
    mor = 120.0
    w = Weather(WeatherSpec(kind="fog", visibility=mor, variation=0), cam, seed=1, far=FAR)
    H, W = 48, 64
    z = np.tile(np.linspace(2.0, 240.0, W, dtype=np.float32), (H, 1))
    J = np.zeros((H, W, 3), np.uint8)
    J[...] = (30, 90, 160)
    v, u = np.mgrid[0:H, 0:W] + 0.5
    xn, yn = (u - cam.K[0, 2]) / cam.fx, (v - cam.K[1, 2]) / cam.fy
    d = z * np.sqrt(xn**2 + yn**2 + 1.0)  # ray length, independent of the module
    t = np.exp(-beta_from_visibility(mor) * d)
    np.testing.assert_allclose(w.transmission(z), t, rtol=2e-6, atol=1e-7)
    assert not np.allclose(np.exp(-beta_from_visibility(mor) * z), t, rtol=1e-3)  # ray != z
    A = srgb_to_linear(np.array(SKY_HORIZON_RGB) / 255.0)
    expected = A + (srgb_to_linear(J / 255.0) - A) * t[..., None]
    out = w.apply(J, z, frame_index=0)
    assert out.dtype == np.uint8 and out.shape == J.shape
    ref = np.round(255.0 * linear_to_srgb(expected))
    assert np.abs(out.astype(int) - ref).max() <= 1  # the 16-bit encoding table rounds
    # and t recovered from the image: (I - A) / (J - A), to 8-bit precision
    lin = decode(out).astype(np.float64)
    est = (lin[..., 2] - A[2]) / (srgb_to_linear(160 / 255.0) - A[2])
    assert np.abs(est - t)[t > 0.05].max() < 0.01


def test_fog_contrast_falls_with_distance_and_near_objects_stay_crisp() -> None:
    cam = CameraModel.from_fov(64, 48, 90.0)
    w = Weather(WeatherSpec(kind="fog", visibility=80), cam, seed=2)
    checker = np.where((np.indices((48, 64)).sum(0) // 4) % 2 == 0, 40, 220).astype(np.uint8)
    J = np.repeat(checker[..., None], 3, axis=2)
    contrast = []
    for z in (2.0, 10.0, 30.0, 60.0, 120.0):
        out = decode(w.apply(J, np.full((48, 64), z, np.float32), 0))  # linear light
        contrast.append(out[checker == 220].mean() - out[checker == 40].mean())
    j = decode(J)
    assert contrast[0] > 0.85 * (j[checker == 220].mean() - j[checker == 40].mean())  # 2 m: crisp
    assert all(a > b for a, b in zip(contrast, contrast[1:], strict=False))
    assert contrast[-1] < 0.1 * contrast[0]


def test_fog_density_varies_smoothly_and_is_anchored_in_the_world() -> None:
    cam = CameraModel.from_fov(64, 48, 90.0)
    w = Weather(WeatherSpec(kind="fog", visibility=100, variation=0.5, variation_scale=20), cam, 4)
    z = np.full((48, 64), 150.0, np.float32)
    t = w.transmission(z, (10.0, 0.0, 0.0))
    assert t.std() > 1e-3  # varies across the image
    # the mean density factor over many places is 1 (beta stays the visibility's)
    m = [w._density(np.full((48, 64), 1e-3, np.float32), (x, 3.0 * x, 0.3)) for x in range(0, 4000, 40)]
    assert np.mean(m) == pytest.approx(1.0, abs=0.1)
    # a ray of ~0 length samples the field at the camera centre, whatever the heading
    tiny = np.full((48, 64), 1e-3, np.float32)
    cx, cy = 37.0, -11.0  # camera centre (world); the mount is 1.5 m behind the bumper
    a = w._density(tiny, (cx + 1.5, cy, 0.0))
    b = w._density(tiny, (cx - 1.5, cy, math.pi))
    c = w._density(tiny, (cx + 1.5 + 10.0, cy, 0.0))
    assert np.allclose(a, b, atol=1e-4) and not np.allclose(a, c, atol=1e-3)


# ---------------------------------------------------------------------- night
def test_night_is_darker_but_brighter_in_the_headlight_cone(cam, scene) -> None:
    rgb, depth = scene
    night = Weather(WeatherSpec(kind="night", street_lights=False), cam, seed=3, far=FAR)
    out = night.apply(rgb, depth, 0, EGO)
    assert luma(out).mean() < 0.35 * luma(rgb).mean()
    lit = luma(out)
    inside = ground_pixels(cam, np.linspace(8, 16, 5), np.linspace(-1.0, 1.0, 5))
    outside = ground_pixels(cam, np.linspace(12, 16, 3), np.linspace(-10.0, -9.0, 3))
    far = ground_pixels(cam, np.linspace(120, 150, 4), np.linspace(-1.0, 1.0, 3))
    assert lit[inside].mean() > 3.0 * lit[outside].mean()
    assert lit[inside].mean() > 3.0 * lit[far].mean()
    # the lit road near ahead is about as bright as by day; the unlit road is far darker
    assert lit[inside].mean() > 0.4 * luma(rgb)[inside].mean()
    assert lit[outside].mean() < 0.3 * luma(rgb)[outside].mean()
    off = Weather(WeatherSpec(kind="night", headlights="off", street_lights=False), cam, 3, far=FAR)
    assert luma(off.apply(rgb, depth, 0, EGO))[inside].mean() < 0.3 * lit[inside].mean()


def test_street_lamps_light_the_ground_under_them(cam, scene) -> None:
    rgb, depth = scene
    kw = dict(kind="night", headlights="off", sensor_noise=0)
    lamps = lamp_heads(ROAD)
    lit = Weather(WeatherSpec(**kw), cam, 3, far=FAR, lights=lamps).apply(rgb, depth, 0, EGO)
    dark = Weather(WeatherSpec(**kw, street_lights=False), cam, 3, far=FAR).apply(rgb, depth, 0, EGO)
    # under the lamp 30 m ahead on the right (world x = 160, y = -11.65)
    under = ground_pixels(cam, np.linspace(40.0, 44.0, 3), np.linspace(-11.5, -10.5, 3))
    assert luma(lit)[under].mean() > 4.0 * luma(dark)[under].mean()


def test_lamp_heads_are_where_the_renderer_draws_them(cam, scene) -> None:
    _, depth = scene
    heads = lamp_heads(ROAD)
    assert len(heads) == 2 * 67 and np.allclose(heads[:, 2], 6.85)
    ex = EGO[0]
    near = heads[(heads[:, 0] > ex + 5) & (heads[:, 0] < ex + 25)]  # farther ones are < 1 px
    assert len(near) == 2  # x = 130 on both sides
    ego_pts = near - np.array([ex, 0.0, 0.0])
    uv = cam.project(ego_pts)
    zc = cam.ego_to_camera(ego_pts)[:, 2]
    for (u, v), z in zip(uv, zc, strict=True):
        win = depth[int(v) - 1 : int(v) + 2, int(u) - 1 : int(u) + 2]
        assert np.abs(win - z).min() < 0.4, (u, v, z, win)


# ---------------------------------------------------------------------- rain
def test_rain_changes_the_image_and_lowers_contrast(cam, scene) -> None:
    rgb, depth = scene
    w = Weather(WeatherSpec(kind="rain", intensity=0.7), cam, seed=3, far=FAR)
    out = w.apply(rgb, depth, 0, EGO)
    assert out.shape == rgb.shape and out.dtype == np.uint8
    diff = np.abs(out.astype(int) - rgb.astype(int)).sum(axis=2)
    assert (diff > 10).mean() > 0.3
    def rms_contrast(img: np.ndarray) -> float:
        y = luma(img)
        return float(y.std() / y.mean())

    assert rms_contrast(out) < 0.9 * rms_contrast(rgb)
    ground = depth < FAR * 0.999
    assert luma(out)[ground].std() < 0.9 * luma(rgb)[ground].std()
    # streaks: a frame with no haze or blur still differs along thin bright lines
    streaky = luma(out) - luma(w.apply(rgb, depth, 1, EGO))
    assert (np.abs(streaky) > 0.02).mean() > 0.01


# ---------------------------------------------------------------------- determinism, clear
@pytest.mark.parametrize(
    "kw", [dict(kind="night"), dict(kind="rain"), dict(kind="fog", visibility=90), dict(kind="night", visibility=150)]
)
def test_same_seed_and_frame_give_identical_bytes(cam, scene, kw) -> None:
    rgb, depth = scene
    lamps = lamp_heads(ROAD)
    a = Weather(WeatherSpec(**kw), cam, seed=11, far=FAR, lights=lamps)
    b = Weather(WeatherSpec(**kw), cam, seed=11, far=FAR, lights=lamps)
    before = rgb.copy()
    out = a.apply(rgb, depth, 5, EGO)
    assert out.tobytes() == b.apply(rgb, depth, 5, EGO).tobytes()
    assert np.array_equal(rgb, before)  # the input is not modified
    other = a.apply(rgb, depth, 6, EGO)
    if kw["kind"] == "fog":
        assert other.tobytes() == out.tobytes()  # fog is static in the world
    else:
        assert other.tobytes() != out.tobytes()  # fresh rain streaks / sensor noise
        c = Weather(WeatherSpec(**kw), cam, seed=12, far=FAR, lights=lamps)
        assert c.apply(rgb, depth, 5, EGO).tobytes() != out.tobytes()


def test_clear_is_a_no_op(cam, scene) -> None:
    rgb, depth = scene
    w = Weather(WeatherSpec(), cam, seed=0)
    assert not w.active
    assert w.apply(rgb, depth, 0, EGO) is rgb


def test_decode_encode_round_trip() -> None:
    x = np.arange(256, dtype=np.uint8).reshape(16, 16, 1).repeat(3, axis=2)
    assert np.array_equal(encode(decode(x)), x)


# ---------------------------------------------------------------------- the spec
@pytest.mark.parametrize(
    "weather, field",
    [
        ("{kind: fog, visibility: -5}", "weather.visibility"),
        ("{kind: fog, visibility: foggy}", "weather.visibility"),
        ("{kind: rain, intensity: 1.5}", "weather.intensity"),
        ("{kind: snow}", "weather.kind"),
        ("{kind: fog, visiblity: 100}", "weather.visiblity"),
        ("{kind: night, sensor_noise: -1}", "weather.sensor_noise"),
        ("{kind: fog, variation_scale: 1}", "weather.variation_scale"),
        ("{kind: night, headlights: full}", "weather.headlights"),
        ("{kind: rain, wind: 90}", "weather.wind"),
    ],
)
def test_weather_spec_rejects_bad_values(weather: str, field: str) -> None:
    with pytest.raises(ScenarioError) as e:
        parse_scenario(f"name: w\nweather: {weather}\n", "w.yaml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("w.yaml:2: ") and field in msg, msg


def test_weather_spec_accepts_presets_and_combinations() -> None:
    sc = parse_scenario("name: w\nweather: {kind: night, visibility: moderate, intensity: 0.9, headlights: high}\n")
    w = sc.weather
    assert (w.kind, w.visibility_m, w.night_darkness, w.headlights) == ("night", 500.0, 0.9, "high")
    assert parse_scenario("name: w\n").weather.kind == "clear"
    # a full dump validates again for every kind (fields of other kinds are ignored)
    for kind in ("clear", "night", "fog", "rain"):
        spec = WeatherSpec(kind=kind, visibility="dense", intensity=0.2)
        assert WeatherSpec.model_validate(spec.model_dump(mode="json")) == spec


# ---------------------------------------------------------------------- the runner
def test_runner_weathers_the_image_only() -> None:
    from lookahead.sim.runner import Runner

    text = """
name: fog_hook
seed: 3
duration: 1.0
road: {kind: straight, lanes: 2, sidewalks: true}
ego: {lane: 1, speed: 10.0}
camera: {width: 160, height: 90, fov_h: 90, rate: 10, renderer: tiny}
weather: {kind: fog, visibility: 60}
perception: {detector: {kind: gt}}
actors:
  - {id: lead, type: car, start: {lane: 1, s: 25}, speed: 8.0}
"""
    frames = {}
    for kind in ("fog", "clear"):  # the render worker weathers the image of a fog scenario only
        sc = parse_scenario(text if kind == "fog" else text.replace("{kind: fog, visibility: 60}", "{kind: clear}"))
        runner = Runner(sc, render=True, renderer_backend="tiny")
        try:
            frames[kind] = runner.frame()
            pose = runner.world.ego_pose()
        finally:
            runner.close()
    (fog, gt_fog, _), (clear, gt_clear, _) = frames["fog"], frames["clear"]
    assert not np.array_equal(fog.image, clear.image)
    assert np.array_equal(fog.depth, clear.depth) and np.array_equal(fog.segmentation, clear.segmentation)
    np.testing.assert_array_equal(gt_fog.visible, gt_clear.visible)
    np.testing.assert_array_equal(gt_fog.visible_fraction, gt_clear.visible_fraction)
    assert len(gt_fog) >= 1
    w = Weather.from_scenario(parse_scenario(text), runner.camera, runner.world.layout)
    assert w.visibility == 60.0
    redo = w.apply(clear.image, clear.depth, clear.index, pose)
    assert np.array_equal(redo, fog.image)
