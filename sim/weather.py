"""Weather and light for the simulated camera: fog / haze, night and rain on the rendered RGB.

Only the image changes: depth, segmentation and therefore ground truth stay exact, and
the detector and every sink see the weathered image. ``Weather`` is built once per run
from the scenario's ``WeatherSpec``, the ``CameraModel`` and the scenario seed (per-camera
constants such as the pixel rays are precomputed); ``Weather.apply`` runs per frame.

Inputs of ``apply`` (frames and units as in docs/architecture.md):

* ``rgb``: (H, W, 3) uint8 sRGB, as rendered (daylight).
* ``depth``: (H, W) float32 metric depth **z along the optical axis** (m), ``far`` for
  the sky (``sim.renderer.RenderResult``). The optics need the distance along the
  pixel's ray, ``d = z * |q|``, ``q`` being the pixel's camera-frame ray scaled to z = 1
  (from ``CameraModel.pixel_rays``).
* ``ego_pose``: world (x, y, heading) of the ego-frame origin (m, rad); it anchors the
  fog density field and the street lamps in the world.
* ``frame_index``: with the seed, keys every per-frame random draw
  (``numpy.random.default_rng([seed, salt, frame_index])``): the same scenario, seed and
  frame give byte-identical images.

Light is handled in linear RGB: the image is decoded with the exact sRGB transfer
function (a 256-entry table), the effects act on linear radiance, and the result is
encoded back (a 65536-entry table).

**Fog and haze** (Koschmieder's atmospheric scattering model)::

    I = J * t + A * (1 - t),   t = exp(-integral of beta(x) ds along the ray, s = 0 .. d)
    beta0 = -ln(0.05) / MOR  (~ 3.0 / MOR, MOR = meteorological optical range in m)
    beta(x) = beta0 * exp(sigma * n(x) - sigma^2 / 2)

``n`` is a unit-variance smooth Gaussian random field on the world ground plane (spectral
synthesis on a periodic grid: correlation length ``variation_scale``, period 32 of them),
so fog banks stay where they are while the camera drives through them; the mean of beta
along each ray is the midpoint rule over 3 samples (bilinear look-ups, at quarter
resolution: the field is smooth). ``sigma = variation``; with 0, ``t = exp(-beta0 * d)``
exactly. The airlight ``A`` is the horizon colour of the renderer's sky, so distant road
fades into the sky (the sky itself, at ``far``, is almost pure airlight in fog). At night
``A`` is the ambient level times that colour plus the veil the fog scatters back from the
ego's own beams, ``beta * I0 * p_back * B(ray) / s0`` (``p_back`` = 0.03 / sr, ``s0`` = 3 m,
``B`` below; precomputed per pixel); in rain ``A`` is an overcast grey and the sky is cloud
(``t = 0``).

**Night**: the day render is read as surface reflectance under unit illumination, ``J``,
and re-lit: ``L = J * (a * c_amb + E_head * c_head + E_lamp * c_lamp) + glow``:

* ``a`` = ambient (sky glow) level, ``0.12 * (1 - darkness)^2 + 0.006``;
* headlamps, two at ego-frame ``(-0.3, +-0.72, 0.65)`` m: ``E = I0 * B * cos(i) / r^2``,
  ``B = exp(-tan(h)^2 / (2 tan(s_h)^2) - tan(v)^2 / (2 tan(s_v)^2))`` over the horizontal
  and vertical angles ``h, v`` from the beam axis. Low beam: axis 1.2 deg down and 1 deg
  right, ``s_h`` 18 deg, ``s_v`` 5 deg below the axis and a sharp 0.8 deg cut-off above;
  high beam: level, 11 / 4 deg, 3x brighter. ``r`` = lamp distance, ``i`` = incidence
  angle on the surface normal estimated from the depth map (cross product of the
  back-projected points' image gradients; across depth edges, a face toward the camera);
* street lamps (the scene's lamp posts, ``sim.roadside.lamp_heads``; within 90 m ahead):
  ``E = Is * cos^2(theta) * cos(i) / r^2``, ``theta`` off straight down, plus a Gaussian
  glow sprite on each unoccluded lamp head;
* illumination is computed at half resolution (it is smooth) and resized;
* sensor: shot + read noise in linear units, ``L + k * sqrt(0.004 * L + 0.002^2) * N(0, 1)``
  (``k = sensor_noise``, ``N`` cropped per frame at a random offset from a seeded bank),
  then the tone curve ``1 - exp(-L)`` and the sRGB encoding (one table).

**Rain**: overcast dimming and desaturation, haze at the rain's visibility (``WeatherSpec.
visibility_m``), seeded motion-blurred streaks (a bank of 8 periodic layers drawn once;
each frame takes one at a random torus shift, so the streaks change every frame as real
drops cross the view within one exposure), then a slight lens blur.

Cost: a few ms per 640x360 frame (numbers in docs/architecture.md, "Weather").
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import cv2
import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.sim.layout import RoadLayout
from lookahead.sim.roadside import lamp_heads  # also importable from here, as before
from lookahead.sim.scenario import Scenario, WeatherSpec

log = logging.getLogger(__name__)

BETA_PER_INVERSE_MOR = -math.log(0.05)  # beta = this / MOR (Koschmieder, 5 % contrast)
SKY_HORIZON_RGB = (190, 210, 228)  # sim.renderer's sky colour at the horizon (sRGB)
OVERCAST_RGB = (172, 176, 182)  # rain airlight (sRGB)
_SALT = 0x57EA  # mixes "weather" into the generators' keys
_SKY_EPS = 1e-3  # depth >= far * (1 - eps) is sky
_F32 = np.float32

_HEADLAMPS = ((-0.3, 0.72, 0.65), (-0.3, -0.72, 0.65))  # ego frame (m)
# beam: axis pitch (deg), axis yaw (deg), sigma_h, sigma_v below, sigma_v above (deg), I0
_BEAMS = {"low": (-1.2, -1.0, 18.0, 5.0, 0.8, 1500.0), "high": (0.0, 0.0, 11.0, 4.0, 4.0, 4500.0)}
_C_AMB = (0.75, 0.85, 1.1)  # moonlight / sky-glow tint
_C_HEAD = (1.0, 0.97, 0.9)
_C_LAMP = (1.0, 0.78, 0.5)  # sodium-ish street light
_LAMP_POWER = 60.0  # Is: E = 1.3 on the ground straight under a lamp
_LAMP_REACH = 90.0  # m ahead of the ego; lamps further away light too little to matter
_NIGHT_TOP = 4.0  # linear sensor signal at the top of the night tone table
_NOISE_PAD = 32  # the sensor-noise bank is this much larger than the image


def beta_from_visibility(mor: float) -> float:
    """Extinction coefficient beta (1/m) for a meteorological optical range ``mor`` (m)."""
    return BETA_PER_INVERSE_MOR / float(mor)


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """sRGB in [0, 1] -> linear (the exact IEC 61966-2-1 transfer function)."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """Linear in [0, 1] -> sRGB in [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


_DECODE = srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)
_ENCODE = np.round(255.0 * linear_to_srgb(np.arange(65536) / 65535.0)).astype(np.uint8)
_ALPHA = (np.arange(256) / 255.0).astype(np.float32)  # uint8 alpha -> [0, 1]
_ENCODE_NIGHT = np.round(
    255.0 * linear_to_srgb(-np.expm1(-np.arange(65536) * (_NIGHT_TOP / 65535.0)))
).astype(np.uint8)


def decode(rgb: np.ndarray) -> np.ndarray:
    """uint8 sRGB (any shape) -> float32 linear in [0, 1]."""
    rgb = np.asarray(rgb, dtype=np.uint8)
    if rgb.ndim == 3 and rgb.shape[2] <= 4:
        return cv2.LUT(rgb, _DECODE)
    return _DECODE[rgb]


def encode(lin: np.ndarray, table: np.ndarray = _ENCODE, top: float = 1.0) -> np.ndarray:
    """float32 linear -> uint8 through ``table`` (65536 entries spanning [0, top])."""
    x = lin * _F32(65535.0 / top)
    x += _F32(0.5)
    np.clip(x, 0.0, 65535.0, out=x)
    return np.take(table, x.astype(np.uint16))


def smooth_field(rng: np.random.Generator, n: int, corr_cells: float) -> np.ndarray:
    """(n, n) float32 periodic Gaussian random field with zero mean and unit std whose
    correlation falls as exp(-r^2 / (2 corr^2)), ``corr`` = ``corr_cells`` grid cells."""
    k = np.fft.fftfreq(n)
    k2 = k[:, None] ** 2 + k[None, :] ** 2
    spec = np.fft.fft2(rng.standard_normal((n, n))) * np.exp(-((np.pi * corr_cells) ** 2) * k2)
    f = np.fft.ifft2(spec).real
    return ((f - f.mean()) / f.std()).astype(np.float32)


def _add_glow(lin: np.ndarray, u: float, v: float, size: float) -> None:
    """Add a lamp head's glow (a Gaussian sprite, peak 3, sigma ``size`` px, lamp colour)
    centred on pixel coordinates (u, v) to the linear image ``lin`` in place."""
    H, W = lin.shape[:2]
    r = int(3 * size) + 1
    x0, x1, y0, y1 = max(int(u) - r, 0), min(int(u) + r + 1, W), max(int(v) - r, 0), min(int(v) + r + 1, H)
    if x0 >= x1 or y0 >= y1:
        return
    yy, xx = np.mgrid[y0:y1, x0:x1].astype(np.float32) + _F32(0.5)
    g = _F32(3.0) * np.exp(-((xx - u) ** 2 + (yy - v) ** 2) / _F32(2.0 * size * size))
    lin[y0:y1, x0:x1] += g[..., None] * np.array(_C_LAMP, np.float32)


def _every(a: np.ndarray, step: int) -> np.ndarray:
    """Every ``step``-th pixel from the middle of each block, contiguous."""
    o = step // 2
    return np.ascontiguousarray(a[o::step, o::step])


def _gradients(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Central differences (half the step) of a 2D array along v (rows) and u (columns)."""
    gv, gu = np.empty_like(a), np.empty_like(a)
    gv[1:-1], gu[:, 1:-1] = a[2:] - a[:-2], a[:, 2:] - a[:, :-2]
    gv[0], gv[-1], gu[:, 0], gu[:, -1] = gv[1], gv[-2], gu[:, 1], gu[:, -2]
    return gv, gu


class Weather:
    """Applies one scenario's weather to its rendered frames.

    Args:
        spec: the scenario's ``weather``.
        camera: the camera the frames come from (its rays are precomputed).
        seed: the scenario seed; with the frame index it keys every random draw.
        far: the renderer's far plane (m); depth >= far is sky.
        lights: (N, 3) world positions (m) of street lamps for ``night``, e.g.
            ``lamp_heads(layout)``; ignored unless ``spec.street_lights``.
    """

    def __init__(
        self,
        spec: WeatherSpec,
        camera: CameraModel,
        seed: int,
        far: float = 250.0,
        lights: np.ndarray | None = None,
    ) -> None:
        self.spec, self.camera, self.seed, self.far = spec, camera, int(seed), float(far)
        self.kind = spec.kind
        self.visibility = spec.visibility_m  # m, None = clear air
        self.beta = 0.0 if self.visibility is None else beta_from_visibility(self.visibility)
        self.lights = np.zeros((0, 3))
        if self.kind == "clear":
            return
        H, W = camera.height, camera.width
        u, v = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
        r_ego = camera.pixel_rays(np.stack([u, v], axis=-1))  # unit rays, ego frame
        r_cam_z = r_ego @ camera.R_cam_from_ego[2]
        q = (r_ego / r_cam_z[..., None]).astype(np.float32)  # ego offset per metre of z
        self._q = [np.ascontiguousarray(q[..., i]) for i in range(3)]
        self._ray_len = (1.0 / r_cam_z).astype(np.float32)  # ray distance per metre of z
        self._mount = tuple(float(m) for m in camera.mount)
        init = np.random.default_rng([self.seed, _SALT])
        self._airlight = tuple(float(a) for a in decode(np.array(SKY_HORIZON_RGB, np.uint8)))
        self._field = None
        if self.beta > 0 and spec.variation > 0:
            self._cell = spec.variation_scale / 8.0  # m per grid cell (8 per correlation length)
            n = smooth_field(init, 256, 8.0)
            self._field = np.exp(spec.variation * n - spec.variation**2 / 2).astype(np.float32)
            self._q4 = [_every(a, 4) for a in self._q[:2]]
        if self.kind == "night":
            self._ambient = 0.12 * (1.0 - spec.night_darkness) ** 2 + 0.006
            self._airlight = tuple(a * self._ambient for a in self._airlight)
            self._q2 = [_every(a, 2) for a in self._q]
            self._ray2 = [_every(r_ego[..., i].astype(np.float32), 2) for i in range(3)]
            if lights is not None and spec.street_lights:
                self.lights = np.asarray(lights, dtype=np.float64).reshape(-1, 3)
            self._noise = init.standard_normal((H + _NOISE_PAD, W + _NOISE_PAD, 3), dtype=np.float32)
        if self.kind == "rain":
            i = spec.rain_intensity
            dim, s = 1.0 - 0.35 * i, 0.4 * i
            w = np.array([0.2126, 0.7152, 0.0722])
            self._rain_m = (dim * ((1 - s) * np.eye(3) + s * np.outer(np.ones(3), w))).astype(np.float32)
            over = decode(np.array(OVERCAST_RGB, np.uint8))
            self._airlight = tuple(float(a) * dim for a in over)
            streak = np.minimum(np.array(self._airlight, np.float32) * 1.3, 1.0)
            self._streak_img = np.empty((H, W, 3), np.float32)
            self._streak_img[...] = streak
            self._blur = 0.45 + 0.6 * i
            self._streaks = self._streak_bank(init, i, spec.wind)
        if self.beta > 0:
            self._airlight_img = np.empty((H, W, 3), np.float32)
            self._airlight_img[...] = self._airlight
            if self.kind == "night" and spec.headlights != "off":  # the beams' veil in the fog
                veil = self._beam_veil(r_ego)
                for i in range(3):
                    self._airlight_img[..., i] += veil * _F32(_C_HEAD[i])
        log.info(
            "weather %s: visibility %s (beta %.4f /m)%s", self.kind,
            "clear air" if self.visibility is None else f"{self.visibility:g} m", self.beta,
            f", {len(self.lights)} street lamps" if self.kind == "night" else "",
        )

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, camera: CameraModel, layout: RoadLayout | None = None,
        far: float = 250.0,
    ) -> Weather:
        """The scenario's weather; street lamps from ``layout`` (night with ``street_lights``)."""
        w = scenario.weather
        lit = layout is not None and w.kind == "night" and w.street_lights
        return cls(w, camera, scenario.seed, far=far, lights=lamp_heads(layout) if lit else None)

    @property
    def active(self) -> bool:
        """False for ``clear``: ``apply`` then returns its input itself."""
        return self.kind != "clear"

    # ------------------------------------------------------------------ per frame
    def apply(
        self,
        rgb: np.ndarray,
        depth: np.ndarray,
        frame_index: int,
        ego_pose: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> np.ndarray:
        """The weathered (H, W, 3) uint8 RGB image (``rgb`` itself, not a copy, when clear).

        Args:
            rgb: (H, W, 3) uint8 rendered image. Not modified.
            depth: (H, W) depth along the optical axis (m), ``far`` for the sky.
            frame_index: the camera frame's index (keys the per-frame noise and rain).
            ego_pose: world (x, y, heading) of the ego (m, rad).
        """
        if self.kind == "clear":
            return rgb
        H, W = self.camera.height, self.camera.width
        if rgb.shape != (H, W, 3) or depth.shape != (H, W):
            raise ValueError(
                f"expected rgb ({H}, {W}, 3) and depth ({H}, {W}), got {rgb.shape} and {depth.shape}"
            )
        depth = np.ascontiguousarray(depth, dtype=np.float32)
        rng = np.random.default_rng([self.seed, _SALT, int(frame_index)])
        lin = decode(rgb)
        if self.kind == "night":
            illum, glows = self._night_light(depth, ego_pose)
            lin = cv2.multiply(lin, illum)
            for u, v, size in glows:
                _add_glow(lin, u, v, size)
        elif self.kind == "rain":
            lin = cv2.transform(lin, self._rain_m)
        if self.beta > 0:
            t = self.transmission(depth, ego_pose)
            if self.kind == "rain":  # overcast: the sky is cloud, all airlight
                t[depth >= _F32(self.far * (1.0 - _SKY_EPS))] = 0.0
            lin = cv2.blendLinear(lin, self._airlight_img, t, _F32(1.0) - t)  # J t + A (1 - t)
        if self.kind == "night":
            return encode(self._sensor_noise(lin, rng), _ENCODE_NIGHT, _NIGHT_TOP)
        if self.kind == "fog":
            return encode(lin)
        k = int(rng.integers(len(self._streaks)))
        alpha = np.roll(self._streaks[k], (int(rng.integers(H)), int(rng.integers(W))), axis=(0, 1))
        alpha = cv2.LUT(alpha, _ALPHA)
        lin = cv2.blendLinear(lin, self._streak_img, _F32(1.0) - alpha, alpha)
        return cv2.GaussianBlur(encode(lin), (0, 0), self._blur)

    def transmission(
        self, depth: np.ndarray, ego_pose: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> np.ndarray:
        """(H, W) float32 t = exp(-integral of beta along each pixel's ray); 1 in clear air."""
        depth = np.ascontiguousarray(depth, dtype=np.float32)
        if self.beta <= 0:
            return np.ones_like(depth)
        od = cv2.multiply(depth, self._ray_len, scale=self.beta)  # optical depth, mean density
        if self._field is not None:
            od = cv2.multiply(od, self._density(depth, ego_pose))
        return cv2.exp(-od)

    def _density(self, depth: np.ndarray, ego_pose: Sequence[float]) -> np.ndarray:
        """(H, W) float32 mean of beta / beta0 along each pixel's ray (quarter resolution)."""
        ex, ey, eh = (float(x) for x in ego_pose[:3])
        c, s = math.cos(eh), math.sin(eh)
        mx, my = self._mount[0], self._mount[1]
        # camera centre in grid cells, wrapped (keeps remap's coordinates small)
        gx = ((ex + c * mx - s * my) / self._cell) % 256.0
        gy = ((ey + s * mx + c * my) / self._cell) % 256.0
        z = _every(depth, 4) * _F32(1.0 / self._cell)
        qx, qy = self._q4
        wx = z * (_F32(c) * qx - _F32(s) * qy)  # ray's world xy extent in cells
        wy = z * (_F32(s) * qx + _F32(c) * qy)
        acc = np.zeros_like(z)
        for f in (1 / 6, 3 / 6, 5 / 6):
            acc += cv2.remap(
                self._field, _F32(gx) + _F32(f) * wx, _F32(gy) + _F32(f) * wy,
                cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP,
            )
        acc *= _F32(1.0 / 3.0)
        return cv2.resize(acc, (depth.shape[1], depth.shape[0]), interpolation=cv2.INTER_LINEAR)

    # ------------------------------------------------------------------ night
    def _beam(self, vx: np.ndarray, vy: np.ndarray, vz: np.ndarray) -> np.ndarray:
        """Relative headlamp intensity B toward the directions (vx, vy, vz) (ego frame)."""
        pitch, yaw, sh, sv_lo, sv_hi, _ = _BEAMS[self.spec.headlights]
        fwd = np.maximum(vx, _F32(0.05))
        th = vy / fwd - _F32(math.tan(math.radians(yaw)))
        tv = vz / fwd - _F32(math.tan(math.radians(pitch)))
        kh = _F32(0.5 / math.tan(math.radians(sh)) ** 2)
        kv = np.where(
            tv > 0, _F32(0.5 / math.tan(math.radians(sv_hi)) ** 2),
            _F32(0.5 / math.tan(math.radians(sv_lo)) ** 2),
        )
        b = np.exp(-(kh * th * th + kv * tv * tv))
        b[vx <= 0.1] = 0.0
        return b

    def _beam_veil(self, r_ego: np.ndarray) -> np.ndarray:
        """(H, W) float32 light the fog scatters back from the ego's own beams, at full
        depth: beta * I0 * p_back * B(ray) / s0, backscatter phase p_back = 0.03 / sr, beam
        entry distance s0 = 3 m (the lamps sit near the camera; parallax is ignored)."""
        i0 = _BEAMS[self.spec.headlights][5]
        r = r_ego.astype(np.float32)
        return (self.beta * i0 * 0.03 / 3.0) * self._beam(r[..., 0], r[..., 1], r[..., 2])

    def _night_light(
        self, depth: np.ndarray, ego_pose: Sequence[float]
    ) -> tuple[np.ndarray, list[tuple[float, float, float]]]:
        """Illumination (H, W, 3), computed at half size, and the visible lamp heads' glow
        sprites (u, v, size in px, full size)."""
        H, W = depth.shape
        z = _every(depth, 2)
        sky = z >= _F32(self.far * (1.0 - _SKY_EPS))
        m = self._mount
        p = [_F32(m[i]) + z * self._q2[i] for i in range(3)]  # ego-frame points (m)
        n = self._normals(p, z)
        e_head = np.zeros_like(z)
        if self.spec.headlights != "off":
            for lamp in _HEADLAMPS:
                vx, vy, vz = (p[i] - _F32(lamp[i]) for i in range(3))
                r2 = vx * vx + vy * vy + vz * vz
                cos_r = np.maximum(-(n[0] * vx + n[1] * vy + n[2] * vz), 0.0)  # cos(i) * r
                e_head += self._beam(vx, vy, vz) * cos_r / (r2 * np.sqrt(r2))
            e_head *= _F32(_BEAMS[self.spec.headlights][5])
        e_lamp, glows = self._street(p, n, z, ego_pose)
        e_head[sky] = 0.0
        e_lamp[sky] = 0.0
        a = _F32(self._ambient)
        illum = cv2.merge([
            a * _F32(_C_AMB[i]) + e_head * _F32(_C_HEAD[i]) + e_lamp * _F32(_C_LAMP[i])
            for i in range(3)
        ])
        illum = cv2.resize(illum, (W, H), interpolation=cv2.INTER_LINEAR)
        return illum, glows

    def _normals(self, p: list[np.ndarray], z: np.ndarray) -> list[np.ndarray]:
        """Unit surface normals (ego frame) from back-projected points, facing the camera;
        across depth edges a face toward the camera."""
        (xv, xu), (yv, yu), (zv, zu) = (_gradients(a) for a in p)
        nx, ny, nz = yv * zu - zv * yu, zv * xu - xv * zu, xv * yu - yv * xu
        norm = np.sqrt(nx * nx + ny * ny + nz * nz) + _F32(1e-12)
        r = self._ray2  # unit rays from the camera
        facing = -(nx * r[0] + ny * r[1] + nz * r[2]) / norm
        sign = np.where(facing < 0, _F32(-1.0), _F32(1.0)) / norm
        n = [nx * sign, ny * sign, nz * sign]
        # a depth edge: the neighbours are much further apart than the pixel footprint
        step = np.maximum(np.abs(zv), np.abs(zu))
        edge = step > _F32(0.25) * z
        for i in range(3):
            n[i][edge] = -r[i][edge]
        return n

    def _street(
        self, p: list[np.ndarray], n: list[np.ndarray], z: np.ndarray, ego_pose: Sequence[float]
    ) -> tuple[np.ndarray, list[tuple[float, float, float]]]:
        """Street-lamp illuminance at the half-size points ``p`` (computed at quarter size)
        and the glow sprites of the unoccluded lamp heads in view."""
        e = np.zeros_like(z)
        if not len(self.lights):
            return e, []
        ex, ey, eh = (float(x) for x in ego_pose[:3])
        c, s = math.cos(eh), math.sin(eh)
        dx, dy = self.lights[:, 0] - ex, self.lights[:, 1] - ey
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        keep = (lx > -5.0) & (lx < _LAMP_REACH) & (np.abs(ly) < 40.0)
        lamps = np.column_stack([lx, ly, self.lights[:, 2]])[keep]
        if not len(lamps):
            return e, []
        p4, n4 = [a[1::2, 1::2] for a in p], [a[1::2, 1::2] for a in n]  # the pools are smooth
        e4 = np.zeros_like(p4[0])
        for lamp in lamps:
            vx, vy, vz = (p4[i] - _F32(lamp[i]) for i in range(3))
            r2 = vx * vx + vy * vy + vz * vz + _F32(0.25)
            down = np.maximum(-vz, 0.0)  # r * cos(theta from straight down)
            cos_r = np.maximum(-(n4[0] * vx + n4[1] * vy + n4[2] * vz), 0.0)
            e4 += down * down * cos_r / (r2 * r2 * np.sqrt(r2))
        e4 *= _F32(_LAMP_POWER)
        e = cv2.resize(e4, (z.shape[1], z.shape[0]), interpolation=cv2.INTER_LINEAR)
        cam = self.camera
        uv = cam.project(lamps)
        zc = cam.ego_to_camera(lamps)[:, 2]
        h, w = z.shape
        glows = []
        for (u, v), zl in zip(uv, zc, strict=True):
            if not (zl > 1.0 and 0 <= u < 2 * w and 0 <= v < 2 * h):
                continue
            if z[int(v / 2), int(u / 2)] < zl - 1.0:  # behind something nearer
                continue
            glows.append((float(u), float(v), max(1.5, 0.2 * cam.fx / zl)))
        return e, glows

    def _sensor_noise(self, lin: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Shot + read noise for this frame (linear signal)."""
        k = float(self.spec.sensor_noise)
        if k <= 0:
            return lin
        H, W = lin.shape[:2]
        oy, ox = (int(x) for x in rng.integers(0, _NOISE_PAD + 1, 2))
        k *= 1.0 if rng.random() < 0.5 else -1.0
        sigma = np.maximum(lin, 0.0)
        sigma *= _F32(0.004)
        sigma += _F32(0.002**2)
        np.sqrt(sigma, out=sigma)
        sigma *= self._noise[oy : oy + H, ox : ox + W]
        sigma *= _F32(k)
        sigma += lin
        return sigma

    # ------------------------------------------------------------------ rain
    def _streak_bank(self, rng: np.random.Generator, intensity: float, wind_deg: float) -> np.ndarray:
        """(8, H, W) uint8 alpha layers of motion-blurred rain streaks, periodic in both axes."""
        H, W = self.camera.height, self.camera.width
        scale = H / 360.0
        n = int((120 + 1300 * intensity) * H * W / (640 * 360))
        bank = np.zeros((8, H, W), np.uint8)
        for layer in bank:
            x, y, near = rng.uniform(0, W, n), rng.uniform(0, H, n), rng.random(n)
            length = (6.0 + 44.0 * near**2) * scale
            ang = np.radians(wind_deg + rng.normal(0.0, 4.0, n))
            x1, y1 = x + length * np.sin(ang), y + length * np.cos(ang)
            alpha = (25 + 75 * near**2).astype(int)  # near drops: long, thick, brighter
            thick = np.where(near > 0.9, 2, 1)
            for i in range(n):
                xs = [0.0] + ([W] if min(x[i], x1[i]) < 0 else []) + ([-W] if max(x[i], x1[i]) >= W else [])
                ys = [0.0] + ([-H] if y1[i] >= H else [])
                for sx in xs:
                    for sy in ys:
                        p0 = (round((x[i] + sx) * 16), round((y[i] + sy) * 16))
                        p1 = (round((x1[i] + sx) * 16), round((y1[i] + sy) * 16))
                        cv2.line(layer, p0, p1, int(alpha[i]), int(thick[i]), cv2.LINE_AA, 4)
            layer[:] = cv2.GaussianBlur(layer, (0, 0), 0.8, borderType=cv2.BORDER_WRAP)
        return bank

