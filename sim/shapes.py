"""Recognisable compound actor shapes: boxes, cylinders and spheres in an actor-local frame.

Actor-local frame: x forward (the actor's heading), y left, z up, metres; origin on
the ground at the centre of the rest footprint. A part may swing about the local y
axis through its ``pivot`` (legs, arms): its angle is

    swing * sin(gait_phase + phase)   (rad, right-handed about +y: +z tips toward +x)

where ``gait_phase`` (rad) advances by 2 pi per ``stride`` metres travelled
(``ActorShape.gait_phase_at``). ``local_box`` is the exact, tight axis-aligned box of
all parts at a phase; ground truth projects it, the renderer draws the same parts.

Gestures. A pose (``Pose``) is the gait phase alone, or ``(gait_phase, arm, body)``: ``arm``
(rad) pitches the parts with a ``gesture`` weight (a pedestrian's right arm) further about
their pivot (``-2.6`` raises an arm overhead: a wave), and ``body`` (rad) pitches the whole
actor about the local y axis through its origin on the ground (``+pi / 2``: lying forward
along +x, fallen). Every geometry function takes either form.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

SUBTYPES: dict[str, tuple[str, ...]] = {
    "pedestrian": ("adult", "child"),
    "cyclist": ("bicycle",),
    "motorcyclist": ("e-bike", "motorcycle"),
    "tricycle": ("tricycle",),
    "car": ("sedan", "suv", "hatchback"),
    "truck": ("truck",),
    "bus": ("bus",),
    "animal": ("dog", "deer", "cow"),
    "obstacle": ("barrier", "cone", "box", "debris", "bicycle"),
}

Vec3 = tuple[float, float, float]
Rgba = tuple[float, float, float, float]
Pose = float | tuple[float, float, float]  # gait phase, or (gait phase, arm, body) (rad; module docstring)


def pose_parts(pose: Pose) -> tuple[float, float, float]:
    """(gait phase, arm, body) of ``pose`` (rad); a bare gait phase has no gesture."""
    if np.ndim(pose) == 0:
        return float(pose), 0.0, 0.0  # type: ignore[arg-type]
    g, a, b = (float(v) for v in pose)  # type: ignore[union-attr]
    return g, a, b
_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


@dataclass(frozen=True)
class Part:
    """One rigid primitive of an actor.

    Attributes:
        kind: "box", "cylinder" or "sphere".
        half_extents: box (hx, hy, hz); cylinder (radius, radius, half_length);
            sphere (r, r, r). Metres, in the part's own axes.
        position: part centre in the actor-local frame at rest (m).
        rgba: colour, components in [0, 1].
        axis: cylinder axis in the part's own frame ("y" for wheels).
        swing: swing amplitude (rad) about the local y axis through ``pivot``.
        pivot: swing pivot in the actor-local frame (m).
        phase: swing phase offset (rad).
        tilt: static rotation (rad) about the part's own centre and the local y
            axis, applied at rest (+ tips the part's +z toward +x). Extension: lets
            frames, riders' limbs and animals' necks lean.
        gesture: weight of a pose's ``arm`` angle in this part's swing (1: the arm that waves).
    """

    kind: Literal["box", "cylinder", "sphere"]
    half_extents: Vec3
    position: Vec3
    rgba: Rgba
    axis: Literal["x", "y", "z"] = "z"
    swing: float = 0.0
    pivot: Vec3 = (0.0, 0.0, 0.0)
    phase: float = 0.0
    tilt: float = 0.0
    gesture: float = 0.0


_UNIT_CORNERS = np.array(
    [[sx, sy, sz] for sz in (-1.0, 1.0) for sy in (-1.0, 1.0) for sx in (-1.0, 1.0)]
)


_ANG = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
_RIM = np.stack([np.cos(_ANG), np.sin(_ANG), np.ones(16)], axis=1)
_GOLD = np.pi * (3.0 - np.sqrt(5.0))
_SZ = 1.0 - (np.arange(32) + 0.5) / 16.0
_SPHERE = np.stack(
    [np.sqrt(1 - _SZ**2) * np.cos(_GOLD * np.arange(32)), np.sqrt(1 - _SZ**2) * np.sin(_GOLD * np.arange(32)), _SZ],
    axis=1,
)


@dataclass(frozen=True)
class ActorShape:
    """A class/subtype's compound shape and its gait.

    ``stride``: metres travelled per gait cycle (0 = no gait animation).
    """

    cls: str
    subtype: str
    parts: tuple[Part, ...]
    stride: float
    # Vectorised part tables, derived from ``parts``.
    _pos: np.ndarray = field(init=False, repr=False, compare=False)
    _pivot: np.ndarray = field(init=False, repr=False, compare=False)
    _swing: np.ndarray = field(init=False, repr=False, compare=False)
    _phase: np.ndarray = field(init=False, repr=False, compare=False)
    _tilt: np.ndarray = field(init=False, repr=False, compare=False)
    _gesture: np.ndarray = field(init=False, repr=False, compare=False)
    _half: np.ndarray = field(init=False, repr=False, compare=False)
    _axis: np.ndarray = field(init=False, repr=False, compare=False)
    _kind: np.ndarray = field(init=False, repr=False, compare=False)
    _rest: tuple[np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)
    _animated: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.parts:
            raise ValueError("an ActorShape needs at least one part")
        ps = self.parts
        put = object.__setattr__
        put(self, "_pos", np.array([p.position for p in ps], dtype=np.float64))
        put(self, "_pivot", np.array([p.pivot for p in ps], dtype=np.float64))
        put(self, "_swing", np.array([p.swing for p in ps], dtype=np.float64))
        put(self, "_phase", np.array([p.phase for p in ps], dtype=np.float64))
        put(self, "_tilt", np.array([p.tilt for p in ps], dtype=np.float64))
        put(self, "_gesture", np.array([p.gesture for p in ps], dtype=np.float64))
        put(self, "_half", np.array([p.half_extents for p in ps], dtype=np.float64))
        put(self, "_axis", np.array([_AXES[p.axis] for p in ps], dtype=np.float64))
        put(self, "_kind", np.array([{"box": 0, "cylinder": 1, "sphere": 2}[p.kind] for p in ps]))
        put(self, "_animated", bool(self.stride > 0 and np.any(self._swing != 0.0)))
        put(self, "_rest", self._box(self._centres(np.zeros(len(ps))), self._tilt))

    # ------------------------------------------------------------------ poses
    def swing_angles(self, pose: Pose) -> np.ndarray:
        """Swing angle (P,) of each part (rad) in ``pose``: the gait's (0 when not animated)
        plus the pose's ``arm`` times the part's ``gesture`` weight."""
        g, arm, _ = pose_parts(pose)
        th = self._swing * np.sin(g + self._phase) if self._animated else np.zeros(len(self.parts))
        return th + arm * self._gesture if arm else th

    def _articulated(self, pose: Pose) -> tuple[np.ndarray, np.ndarray]:
        """Part centres (P, 3) and pitches (P,) in ``pose``: swung parts, then the whole body
        pitched by the pose's ``body`` about the origin."""
        th = self.swing_angles(pose)
        centres, pitch = self._centres(th), th + self._tilt
        body = pose_parts(pose)[2]
        if body:
            c, s = np.cos(body), np.sin(body)
            x, z = centres[:, 0].copy(), centres[:, 2].copy()
            centres[:, 0], centres[:, 2] = c * x + s * z, -s * x + c * z
            pitch = pitch + body
        return centres, pitch

    def part_poses(self, pose: Pose) -> tuple[np.ndarray, np.ndarray]:
        """Part centres (P, 3) and pitch angles about local y (P,) in ``pose``.

        Local frame; the pitch includes the static ``tilt``.
        """
        return self._articulated(pose)

    def _centres(self, th: np.ndarray) -> np.ndarray:
        c, s = np.cos(th), np.sin(th)
        d = self._pos - self._pivot
        out = self._pivot.copy()
        out[:, 0] += c * d[:, 0] + s * d[:, 2]
        out[:, 1] += d[:, 1]
        out[:, 2] += -s * d[:, 0] + c * d[:, 2]
        return out

    def _box(self, centres: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tight box (center, size) of all parts at ``centres`` (P, 3) pitched by ``a`` (P,)."""
        c, s = np.abs(np.cos(a)), np.abs(np.sin(a))
        h = self._half
        # Box: rotated about y; extents sum |R_ij| h_j.
        ext_box = np.stack([c * h[:, 0] + s * h[:, 2], h[:, 1], s * h[:, 0] + c * h[:, 2]], axis=1)
        # Cylinder: axis u rotated about y; extent_i = hl |u_i| + r sqrt(1 - u_i^2).
        ax = self._axis
        ca, sa = np.cos(a), np.sin(a)
        u = np.stack(
            [ca * ax[:, 0] + sa * ax[:, 2], ax[:, 1], -sa * ax[:, 0] + ca * ax[:, 2]], axis=1
        )
        u = np.abs(u)
        ext_cyl = h[:, 2:3] * u + h[:, 0:1] * np.sqrt(np.clip(1.0 - u * u, 0.0, None))
        ext = np.where((self._kind == 0)[:, None], ext_box, ext_cyl)
        ext = np.where((self._kind == 2)[:, None], h[:, 0:1], ext)
        lo = (centres - ext).min(axis=0)
        hi = (centres + ext).max(axis=0)
        return (lo + hi) / 2.0, hi - lo

    def part_corners(self, pose: Pose = 0.0) -> np.ndarray:
        """Corners (P, 8, 3) of each part's own bounding box in ``pose``, local frame.

        Boxes are exact; a cylinder's box has its half-length along the axis and
        its radius across; a sphere's is a cube. The union of their projections
        bounds the rendered silhouette (exactly for box parts).
        """
        centres, pitch = self._articulated(pose)
        h = self._half
        cyl = self._axis * h[:, 2:3] + (1.0 - self._axis) * h[:, 0:1]
        half = np.where((self._kind == 1)[:, None], cyl, h)
        half = np.where((self._kind == 2)[:, None], h[:, 0:1], half)
        local = _UNIT_CORNERS[None] * half[:, None, :]  # (P, 8, 3)
        c, s = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
        x = c * local[..., 0] + s * local[..., 2]
        z = -s * local[..., 0] + c * local[..., 2]
        return np.stack([x, local[..., 1], z], axis=-1) + centres[:, None, :]

    def part_points(self, pose: Pose = 0.0) -> np.ndarray:
        """Surface points (P, 32, 3) of each part in ``pose``, local frame.

        Boxes: their 8 corners (repeated); cylinders: two rims of 16 points;
        spheres: 32 points spread over the surface. Their projections bound the
        rendered silhouette much more tightly than the parts' bounding boxes.
        """
        centres, pitch = self._articulated(pose)
        h = self._half
        # Cylinder rims in a frame whose z is the cylinder axis, then mapped onto the part's axis.
        rim = np.concatenate([_RIM, _RIM * [1.0, 1.0, -1.0]])  # (32, 3), unit radius / half-length
        cyl = rim[None] * np.stack([h[:, 0], h[:, 0], h[:, 2]], axis=1)[:, None, :]
        ax = self._axis
        cyl = np.where(ax[:, None, 0:1] > 0.5, cyl[..., [2, 0, 1]], cyl)  # axis x
        cyl = np.where(ax[:, None, 1:2] > 0.5, cyl[..., [1, 2, 0]], cyl)  # axis y
        box = np.tile(_UNIT_CORNERS, (4, 1))[None] * h[:, None, :]
        sph = _SPHERE[None] * h[:, 0:1, None]
        kind = self._kind[:, None, None]
        local = np.where(kind == 0, box, np.where(kind == 1, cyl, sph))
        c, s = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
        x = c * local[..., 0] + s * local[..., 2]
        z = -s * local[..., 0] + c * local[..., 2]
        return np.stack([x, local[..., 1], z], axis=-1) + centres[:, None, :]

    def local_box(self, pose: Pose = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Tight axis-aligned box of all parts in ``pose``, local frame.

        Returns center (3,) and size (3,) = (length x, width y, height z), metres.
        """
        _, arm, body = pose_parts(pose)
        if not self._animated and not (arm and self._gesture.any()) and not body:
            return self._rest[0].copy(), self._rest[1].copy()
        return self._box(*self._articulated(pose))

    @property
    def footprint(self) -> tuple[float, float]:
        """(length, width) of the rest box (m), for collisions."""
        return float(self._rest[1][0]), float(self._rest[1][1])

    @property
    def height(self) -> float:
        """Rest height (m)."""
        return float(self._rest[1][2])

    def gait_phase_at(self, distance: float) -> float:
        """Gait phase (rad, wrapped to [0, 2 pi)) after travelling ``distance`` m from phase 0."""
        if self.stride <= 0:
            return 0.0
        return float((2.0 * np.pi * distance / self.stride) % (2.0 * np.pi))


# ---------------------------------------------------------------------- builders
class _Builder:
    """Accumulates parts; ``shape`` re-centres them on the rest footprint."""

    def __init__(self) -> None:
        self.parts: list[Part] = []

    def box(self, c: Vec3, h: Vec3, rgba: Rgba, tilt: float = 0.0, **kw) -> None:
        self.parts.append(Part("box", _f3(h), _f3(c), rgba, tilt=tilt, **kw))

    def cyl(self, c: Vec3, r: float, hl: float, rgba: Rgba, axis: str = "z", **kw) -> None:
        self.parts.append(Part("cylinder", (r, r, hl), _f3(c), rgba, axis=axis, **kw))  # type: ignore[arg-type]

    def sph(self, c: Vec3, r: float, rgba: Rgba) -> None:
        self.parts.append(Part("sphere", (r, r, r), _f3(c), rgba))

    def wheel(
        self, x: float, y: float, r: float, half_w: float, rgba: Rgba = (0.06, 0.06, 0.07, 1)
    ) -> None:
        self.cyl((x, y, r), r, half_w, rgba, axis="y")

    def limb(
        self,
        top: tuple[float, float],
        bottom: tuple[float, float],
        y: float,
        r: float,
        rgba: Rgba,
        swing: float = 0.0,
        phase: float = 0.0,
        pivot: tuple[float, float] | None = None,
        square: bool = False,
        gesture: float = 0.0,
    ) -> None:
        """A cylinder (or square rod) from ``top`` to ``bottom`` (x, z) at lateral ``y``.

        Swings about ``pivot`` (x, z), by default ``top``; ``gesture``: its weight of a pose's arm angle.
        """
        (x0, z0), (x1, z1) = top, bottom
        ux, uz = x0 - x1, z0 - z1
        hl = 0.5 * float(np.hypot(ux, uz))
        tilt = float(np.arctan2(ux, uz))
        pv = top if pivot is None else pivot
        c = ((x0 + x1) / 2, y, (z0 + z1) / 2)
        kw = {"swing": swing, "phase": phase, "pivot": (pv[0], y, pv[1]), "tilt": tilt, "gesture": gesture}
        if square:
            self.parts.append(Part("box", (r, r, hl), _f3(c), rgba, **kw))
        else:
            self.parts.append(Part("cylinder", (r, r, hl), _f3(c), rgba, **kw))

    def shape(self, cls: str, subtype: str, stride: float) -> ActorShape:
        raw = ActorShape(cls, subtype, tuple(self.parts), stride)
        c, s = raw._rest
        off = np.array([-c[0], -c[1], -(c[2] - s[2] / 2.0)])
        moved = tuple(
            Part(
                p.kind,
                p.half_extents,
                _f3(np.asarray(p.position) + off),
                tuple(float(v) for v in p.rgba),  # type: ignore[arg-type]
                p.axis,
                p.swing,
                _f3(np.asarray(p.pivot) + off),
                p.phase,
                p.tilt,
                p.gesture,
            )
            for p in self.parts
        )
        return ActorShape(cls, subtype, moved, float(stride))


def _f3(v) -> Vec3:
    a = np.asarray(v, dtype=np.float64).reshape(3)
    return (float(a[0]), float(a[1]), float(a[2]))


def _rgba(rgb, a: float = 1.0) -> Rgba:
    r, g, b = (float(np.clip(v, 0.0, 1.0)) for v in rgb)
    return (r, g, b, a)


def _pick(rng: np.random.Generator, palette: list, jitter: float = 0.04) -> Rgba:
    base = np.asarray(palette[int(rng.integers(len(palette)))], dtype=np.float64)
    return _rgba(base + rng.uniform(-jitter, jitter, 3))


_CAR_PAINT = [
    (0.92, 0.92, 0.92), (0.08, 0.08, 0.09), (0.62, 0.63, 0.66), (0.38, 0.39, 0.42),
    (0.10, 0.16, 0.38), (0.62, 0.08, 0.08), (0.15, 0.35, 0.65), (0.12, 0.28, 0.18),
    (0.78, 0.72, 0.58), (0.90, 0.72, 0.10), (0.85, 0.40, 0.10),
]  # fmt: skip
_GLASS = (0.10, 0.13, 0.17, 1.0)
_TYRE = (0.06, 0.06, 0.07, 1.0)
_SKIN = [
    (0.95, 0.80, 0.68),
    (0.87, 0.68, 0.53),
    (0.72, 0.53, 0.38),
    (0.55, 0.38, 0.26),
    (0.36, 0.24, 0.16),
]
_SHIRT = [
    (0.80, 0.10, 0.10), (0.10, 0.30, 0.75), (0.95, 0.95, 0.95), (0.15, 0.15, 0.15),
    (0.20, 0.55, 0.25), (0.95, 0.75, 0.10), (0.55, 0.25, 0.60), (0.95, 0.50, 0.15),
    (0.45, 0.65, 0.85), (0.85, 0.45, 0.60),
]  # fmt: skip
_TROUSERS = [
    (0.12, 0.14, 0.25),
    (0.10, 0.10, 0.10),
    (0.35, 0.30, 0.25),
    (0.30, 0.35, 0.45),
    (0.55, 0.50, 0.40),
]
_HAIR = [(0.08, 0.06, 0.05), (0.30, 0.20, 0.12), (0.60, 0.45, 0.25), (0.45, 0.45, 0.45)]


# ---------------------------------------------------------------------- people
def _person_standing(b: _Builder, rng: np.random.Generator, height: float, child: bool) -> float:
    """Walking person centred at x = 0; returns the stride (m)."""
    H = height
    s = H / 1.75
    skin, shirt = _pick(rng, _SKIN), _pick(rng, _SHIRT)
    legs, hair = _pick(rng, _TROUSERS), _pick(rng, _HAIR)
    leg_len = (0.45 if child else 0.47) * H
    head_r = (0.08 if child else 0.064) * H
    shoulder = H - 2 * head_r - 0.05 * H
    hy = (0.17 if child else 0.19) * s * rng.uniform(0.92, 1.1)
    hx = 0.11 * s * rng.uniform(0.9, 1.15)
    leg_r, arm_r = 0.06 * s, 0.042 * s
    swing_leg, swing_arm = 0.42, 0.32
    for side, ph in ((1.0, 0.0), (-1.0, np.pi)):
        y = side * 0.09 * s
        b.limb((0.0, leg_len), (0.0, 0.0), y, leg_r, legs, swing=swing_leg, phase=ph)
        ya = side * (hy + arm_r + 0.005)
        b.limb((0.0, shoulder - arm_r), (0.0, shoulder - arm_r - 0.38 * H), ya, arm_r, shirt,
               swing=swing_arm, phase=ph + np.pi, gesture=1.0 if side < 0 else 0.0)  # the right arm waves
    b.box((0.0, 0.0, (leg_len + shoulder) / 2), (hx, hy, (shoulder - leg_len) / 2 + 0.02), shirt)
    b.cyl((0.0, 0.0, shoulder + 0.03 * H), 0.045 * s, 0.035 * H, skin)
    b.sph((0.0, 0.0, H - head_r), head_r, skin)
    b.sph((-0.15 * head_r, 0.0, H - head_r * 0.92), head_r * 0.92, hair)
    return 0.8 * H


def _rider(
    b: _Builder,
    rng: np.random.Generator,
    hip: tuple[float, float],
    hands: tuple[float, float],
    feet: tuple[float, float],
    lean: float,
    pedal: bool,
    helmet: Rgba | None = None,
) -> None:
    """A seated rider: hip (x, z), hands (x, z) on the bars, feet (x, z); lean (rad) forward."""
    skin, shirt, legs = _pick(rng, _SKIN), _pick(rng, _SHIRT), _pick(rng, _TROUSERS)
    s = rng.uniform(0.94, 1.06)
    torso = 0.56 * s
    hx, hz = hip
    sx, sz = hx + torso * np.sin(lean), hz + torso * np.cos(lean)
    b.box(
        ((hx + sx) / 2, 0.0, (hz + sz) / 2),
        (0.11 * s, 0.19 * s, torso / 2 + 0.03),
        shirt,
        tilt=lean,
    )
    head_r = 0.11 * s
    hc = (sx + 0.06, sz + 0.07 + head_r)
    b.sph((hc[0], 0.0, hc[1]), head_r, skin if helmet is None else helmet)
    for side, ph in ((1.0, 0.0), (-1.0, np.pi)):
        b.limb((sx, sz - 0.03), hands, side * 0.2 * s, 0.042, shirt)
        if pedal:  # one straight leg per side, hip to pedal, pedalling with the gait
            b.limb(hip, feet, side * 0.11, 0.062, legs, swing=0.28, phase=ph)
        else:  # motor riders: thigh forward, shin down to the footrest
            knee = (hx + 0.45 * s, hz + 0.05)
            b.limb(hip, knee, side * 0.13, 0.065, legs)
            b.limb(knee, feet, side * 0.15, 0.055, legs)


def _pedestrian(rng: np.random.Generator, subtype: str) -> ActorShape:
    b = _Builder()
    child = subtype == "child"
    H = rng.uniform(1.05, 1.32) if child else rng.uniform(1.58, 1.92)
    stride = _person_standing(b, rng, H, child)
    return b.shape("pedestrian", subtype, stride)


def _bicycle_frame(b: _Builder, rng: np.random.Generator) -> tuple[float, tuple, tuple, tuple]:
    """A bicycle's wheels and frame; (wheel radius, seat, head, bottom bracket) in (x, z) m."""
    frame = _pick(
        rng, [(0.8, 0.1, 0.1), (0.1, 0.3, 0.8), (0.1, 0.1, 0.1), (0.9, 0.9, 0.9), (0.2, 0.6, 0.3)]
    )
    r = rng.uniform(0.31, 0.35)
    wb = rng.uniform(1.0, 1.1)
    xr, xf = -wb / 2, wb / 2
    for x in (xr, xf):
        b.wheel(x, 0.0, r, 0.025)
    bb = (0.0, r - 0.03)
    seat = (xr + 0.3, r + 0.62)
    head = (xf - 0.1, r + 0.58)
    t = 0.022
    b.limb(seat, bb, 0.0, t, frame, square=True)  # seat tube
    b.limb(head, bb, 0.0, t, frame, square=True)  # down tube
    b.limb(head, (seat[0], seat[1] - 0.06), 0.0, t, frame, square=True)  # top tube
    b.limb((head[0], head[1] + 0.1), (xf, r), 0.0, t, frame, square=True)  # fork
    b.limb((xr, r), bb, 0.0, t, frame, square=True)  # chain stay
    b.box((head[0], 0.0, head[1] + 0.12), (0.03, 0.28, 0.02), _TYRE)  # handlebar
    b.box((seat[0], 0.0, seat[1] + 0.03), (0.12, 0.07, 0.03), _TYRE)  # saddle
    return r, seat, head, bb


def _bicycle(rng: np.random.Generator) -> ActorShape:
    b = _Builder()
    r, seat, head, bb = _bicycle_frame(b, rng)
    _rider(b, rng, (seat[0], seat[1] + 0.08), (head[0] - 0.02, head[1] + 0.12), (bb[0], bb[1] + 0.02),
           lean=rng.uniform(0.25, 0.45), pedal=True)  # fmt: skip
    return b.shape("cyclist", "bicycle", 2.0 * np.pi * r * 2.2)


def _motor(rng: np.random.Generator, subtype: str) -> ActorShape:
    b = _Builder()
    body = _pick(rng, _CAR_PAINT)
    helmet = _pick(
        rng, [(0.9, 0.9, 0.9), (0.1, 0.1, 0.1), (0.8, 0.1, 0.1), (0.9, 0.8, 0.1), (0.1, 0.3, 0.8)]
    )
    if subtype == "e-bike":  # scooter-style electric two-wheeler
        r, hw, wb = rng.uniform(0.22, 0.26), 0.045, rng.uniform(1.15, 1.3)
        xr, xf = -wb / 2, wb / 2
        for x in (xr, xf):
            b.wheel(x, 0.0, r, hw)
        b.box((xr + 0.2, 0.0, r + 0.22), (0.32, 0.17, 0.2), body)  # rear body
        b.box((0.0, 0.0, 0.26), (0.3, 0.16, 0.05), _TYRE)  # footboard
        b.box((xf - 0.2, 0.0, r + 0.38), (0.06, 0.2, 0.38), body, tilt=-0.25)  # leg shield
        b.box((xr + 0.2, 0.0, r + 0.46), (0.26, 0.15, 0.04), _TYRE)  # seat
        b.box((xf - 0.12, 0.0, r + 0.85), (0.04, 0.3, 0.025), _TYRE)  # handlebar
        _rider(b, rng, (xr + 0.22, r + 0.58), (xf - 0.14, r + 0.85), (0.05, 0.32), lean=0.08,
               pedal=False, helmet=helmet)  # fmt: skip
    else:  # motorcycle
        r, hw, wb = rng.uniform(0.3, 0.34), 0.07, rng.uniform(1.35, 1.5)
        xr, xf = -wb / 2, wb / 2
        for x in (xr, xf):
            b.wheel(x, 0.0, r, hw)
        b.box((0.0, 0.0, r + 0.05), (0.32, 0.16, 0.2), (0.25, 0.25, 0.27, 1.0))  # engine
        b.box((0.12, 0.0, r + 0.38), (0.26, 0.2, 0.13), body)  # tank
        b.box((-0.32, 0.0, r + 0.38), (0.32, 0.16, 0.06), _TYRE)  # seat
        b.box((-0.55, 0.0, r + 0.3), (0.22, 0.12, 0.07), body)  # tail
        b.limb(
            (xf - 0.14, r + 0.72), (xf, r), 0.0, 0.035, (0.6, 0.6, 0.62, 1.0), square=True
        )  # fork
        b.box((xf - 0.12, 0.0, r + 0.74), (0.04, 0.36, 0.025), _TYRE)  # handlebar
        b.box((xf - 0.06, 0.0, r + 0.6), (0.06, 0.1, 0.08), (0.95, 0.95, 0.85, 1.0))  # headlight
        _rider(b, rng, (-0.3, r + 0.5), (xf - 0.16, r + 0.74), (0.0, r + 0.05), lean=0.35,
               pedal=False, helmet=helmet)  # fmt: skip
    return b.shape("motorcyclist", subtype, 0.0)


def _tricycle(rng: np.random.Generator) -> ActorShape:
    b = _Builder()
    frame = _pick(rng, [(0.15, 0.35, 0.7), (0.7, 0.15, 0.15), (0.2, 0.5, 0.25), (0.3, 0.3, 0.3)])
    cargo = _pick(rng, [(0.2, 0.4, 0.75), (0.55, 0.55, 0.55), (0.7, 0.55, 0.3), (0.85, 0.85, 0.85)])
    r = rng.uniform(0.28, 0.33)
    track = rng.uniform(0.95, 1.15)
    xf, xr = 0.9, -0.55
    b.wheel(xf, 0.0, r, 0.025)
    for y in (track / 2 - 0.04, -track / 2 + 0.04):
        b.wheel(xr, y, r, 0.035)
    L = rng.uniform(0.9, 1.2)
    b.box((xr - 0.05, 0.0, r + 0.32), (L / 2, track / 2 + 0.03, 0.28), cargo)  # cargo box
    b.box((xr - 0.05, 0.0, r + 0.02), (L / 2 - 0.05, track / 2 - 0.05, 0.03), frame)  # bed
    seat = (0.28, r + 0.55)
    bb = (0.55, r - 0.02)
    head = (xf - 0.1, r + 0.55)
    b.limb(seat, bb, 0.0, 0.025, frame, square=True)
    b.limb(head, bb, 0.0, 0.025, frame, square=True)
    b.limb((head[0], head[1] + 0.1), (xf, r), 0.0, 0.025, frame, square=True)
    b.limb((xr + L / 2 - 0.05, r + 0.05), bb, 0.0, 0.025, frame, square=True)
    b.box((head[0], 0.0, head[1] + 0.12), (0.03, 0.28, 0.02), _TYRE)
    b.box((seat[0], 0.0, seat[1] + 0.03), (0.12, 0.08, 0.03), _TYRE)
    _rider(b, rng, (seat[0], seat[1] + 0.08), (head[0] - 0.02, head[1] + 0.12), (bb[0], bb[1] + 0.02),
           lean=0.2, pedal=True)  # fmt: skip
    return b.shape("tricycle", "tricycle", 2.0 * np.pi * r * 1.6)


# ---------------------------------------------------------------------- vehicles
def _car(rng: np.random.Generator, subtype: str) -> ActorShape:
    b = _Builder()
    paint = _pick(rng, _CAR_PAINT, 0.03)
    if subtype == "suv":
        L, W, H = rng.uniform(4.5, 4.95), rng.uniform(1.85, 1.95), rng.uniform(1.65, 1.8)
        r, clr, belt, cab_l, cab_x = rng.uniform(0.36, 0.39), 0.26, 0.58, 0.66, -0.06
    elif subtype == "hatchback":
        L, W, H = rng.uniform(3.8, 4.2), rng.uniform(1.68, 1.78), rng.uniform(1.45, 1.55)
        r, clr, belt, cab_l, cab_x = rng.uniform(0.29, 0.31), 0.18, 0.55, 0.62, -0.09
    else:
        L, W, H = rng.uniform(4.4, 4.9), rng.uniform(1.75, 1.86), rng.uniform(1.4, 1.5)
        r, clr, belt, cab_l, cab_x = rng.uniform(0.31, 0.33), 0.17, 0.6, 0.48, -0.04
    z_belt = belt * H
    ov_f, ov_r = 0.19 * L, 0.21 * L
    hw = 0.11
    for x in (L / 2 - ov_f, -L / 2 + ov_r):
        for y in (W / 2 - hw - 0.03, -W / 2 + hw + 0.03):
            b.wheel(x, y, r, hw)
    z_low = r + 0.1  # body sill above the wheel centres; bumpers go lower
    b.box((0.0, 0.0, (z_low + z_belt) / 2), (L / 2 - 0.02, W / 2, (z_belt - z_low) / 2), paint)
    bl = 0.45
    for x in (L / 2 - bl / 2, -L / 2 + bl / 2):  # bumpers
        b.box((x, 0.0, (clr + z_low) / 2), (bl / 2, W / 2 - 0.02, (z_low - clr) / 2), paint)
    x0, x1 = -L / 2 + ov_r + r + 0.03, L / 2 - ov_f - r - 0.03  # sill between the wheels
    b.box(
        ((x0 + x1) / 2, 0.0, (clr + z_low) / 2),
        ((x1 - x0) / 2, W / 2 - 0.05, (z_low - clr) / 2),
        paint,
    )
    cl = cab_l * L
    cx = cab_x * L
    if subtype == "hatchback":
        cx = -L / 2 + cl / 2 + 0.12
    roof_t = 0.07
    b.box(
        (cx, 0.0, (z_belt + H - roof_t) / 2),
        (cl / 2, W / 2 - 0.1, (H - roof_t - z_belt) / 2),
        _GLASS,
    )
    b.box((cx, 0.0, H - roof_t / 2), (cl / 2 - 0.12, W / 2 - 0.13, roof_t / 2), paint)
    lamp_z = z_belt - 0.1
    for y in (W / 2 - 0.22, -W / 2 + 0.22):
        b.box((L / 2 - 0.01, y, lamp_z), (0.012, 0.16, 0.05), (0.95, 0.95, 0.88, 1.0))
        b.box((-L / 2 + 0.01, y, lamp_z), (0.012, 0.15, 0.05), (0.75, 0.04, 0.04, 1.0))
    b.box(
        (-L / 2 - 0.01, 0.0, (clr + z_low) / 2 + 0.02), (0.012, 0.26, 0.06), (0.9, 0.9, 0.9, 1.0)
    )  # plate
    return b.shape("car", subtype, 0.0)


def _truck(rng: np.random.Generator) -> ActorShape:
    b = _Builder()
    cab = _pick(
        rng,
        [(0.85, 0.85, 0.85), (0.1, 0.25, 0.6), (0.7, 0.1, 0.1), (0.2, 0.45, 0.2), (0.95, 0.6, 0.1)],
    )
    cargo = _pick(rng, [(0.9, 0.9, 0.88), (0.6, 0.62, 0.65), (0.2, 0.3, 0.5), (0.75, 0.65, 0.35)])
    L, W, H = rng.uniform(6.5, 9.5), rng.uniform(2.3, 2.5), rng.uniform(3.0, 3.7)
    r, hw = 0.5, 0.15
    cab_l, cab_h = 1.9, min(H - 0.2, rng.uniform(2.7, 3.0))
    xf = L / 2 - 1.25
    axles = [xf, -L / 2 + 1.6] + ([-L / 2 + 2.65] if L > 8.0 else [])
    for x in axles:
        for y in (W / 2 - hw - 0.02, -W / 2 + hw + 0.02):
            b.wheel(x, y, r, hw)
    x_cab = L / 2 - cab_l / 2
    z0 = 0.55
    b.box((x_cab, 0.0, (z0 + 1.5) / 2), (cab_l / 2, W / 2, (1.5 - z0) / 2), cab)
    b.box(
        (x_cab - 0.02, 0.0, (1.5 + cab_h) / 2),
        (cab_l / 2 - 0.02, W / 2 - 0.02, (cab_h - 1.5) / 2),
        cab,
    )
    b.box(
        (L / 2 - 0.025, 0.0, (1.6 + cab_h - 0.2) / 2),
        (0.03, W / 2 - 0.15, (cab_h - 0.2 - 1.6) / 2),
        _GLASS,
    )
    for y in (W / 2 - 0.3, -W / 2 + 0.3):
        b.box((L / 2 + 0.01, y, 0.8), (0.012, 0.18, 0.07), (0.95, 0.95, 0.88, 1.0))
    cargo_l = L - cab_l - 0.15
    xc = -L / 2 + cargo_l / 2
    b.box((xc, 0.0, (1.1 + H) / 2), (cargo_l / 2, W / 2, (H - 1.1) / 2), cargo)
    b.box(
        (xc + 0.3, 0.0, 0.82), (cargo_l / 2 - 0.3, W / 2 - 0.35, 0.27), (0.12, 0.12, 0.13, 1.0)
    )  # chassis
    for y in (W / 2 - 0.25, -W / 2 + 0.25):
        b.box((-L / 2 + 0.01, y, 0.85), (0.012, 0.15, 0.06), (0.75, 0.04, 0.04, 1.0))
    b.box(
        (-L / 2 + 0.06, 0.0, 0.6), (0.06, W / 2 - 0.1, 0.05), (0.15, 0.15, 0.15, 1.0)
    )  # under-run bar
    return b.shape("truck", "truck", 0.0)


def _bus(rng: np.random.Generator) -> ActorShape:
    b = _Builder()
    paint = _pick(
        rng,
        [
            (0.9, 0.9, 0.9),
            (0.85, 0.15, 0.1),
            (0.1, 0.45, 0.25),
            (0.95, 0.7, 0.1),
            (0.15, 0.35, 0.7),
        ],
    )
    stripe = _pick(rng, _CAR_PAINT)
    L, W, H = rng.uniform(10.5, 12.5), 2.5, rng.uniform(3.0, 3.3)
    r, hw = 0.5, 0.15
    for x in (L / 2 - 2.4, -L / 2 + 3.0):
        for y in (W / 2 - hw - 0.05, -W / 2 + hw + 0.05):
            b.wheel(x, y, r, hw)
    z0, z_win, z_roof = 0.32, 1.25, H - 0.3
    b.box((0.0, 0.0, (z0 + z_win) / 2), (L / 2, W / 2, (z_win - z0) / 2), paint)
    b.box((0.0, 0.0, z_win + 0.06), (L / 2 - 0.01, W / 2 - 0.005, 0.06), stripe)
    e = 0.12  # end pillars
    z1 = z_win + 0.12
    b.box((0.0, 0.0, (z1 + z_roof) / 2), (L / 2 - e, W / 2 - 0.02, (z_roof - z1) / 2), _GLASS)
    for x in (L / 2 - e / 2, -L / 2 + e / 2):
        b.box((x, 0.0, (z1 + z_roof) / 2), (e / 2, W / 2, (z_roof - z1) / 2), paint)
    b.box((0.0, 0.0, (z_roof + H) / 2), (L / 2, W / 2, (H - z_roof) / 2), paint)
    b.box(
        (L / 2 + 0.005, 0.0, (0.95 + z_roof) / 2),
        (0.025, W / 2 - 0.14, (z_roof - 0.95) / 2),
        _GLASS,
    )
    b.box(
        (L / 2 + 0.005, 0.0, z_roof + 0.14), (0.025, W / 2 - 0.3, 0.1), (0.1, 0.1, 0.1, 1.0)
    )  # sign
    for y in (W / 2 - 0.3, -W / 2 + 0.3):
        b.box((L / 2 + 0.01, y, 0.6), (0.015, 0.18, 0.07), (0.95, 0.95, 0.88, 1.0))
        b.box((-L / 2 - 0.01, y, 0.7), (0.015, 0.12, 0.15), (0.75, 0.04, 0.04, 1.0))
    return b.shape("bus", "bus", 0.0)


# ---------------------------------------------------------------------- animals
# Per subtype: body length and back height ranges (m), body half height / half width,
# leg radius, neck length, head half sizes (x, y, z), tail length, stride (m per cycle).
_ANIMAL = {
    "dog": dict(L=(0.5, 0.7), back=(0.34, 0.42), bh=0.11, bw=0.1, leg_r=0.028, neck=0.16,
                head=(0.1, 0.075, 0.075), tail=0.25, stride=0.9),
    "deer": dict(L=(1.0, 1.2), back=(0.85, 0.95), bh=0.19, bw=0.15, leg_r=0.028, neck=0.36,
                 head=(0.13, 0.065, 0.08), tail=0.12, stride=1.6),
    "cow": dict(L=(1.5, 1.8), back=(1.3, 1.45), bh=0.36, bw=0.32, leg_r=0.07, neck=0.3,
                head=(0.22, 0.12, 0.15), tail=0.6, stride=1.5),
}  # fmt: skip
_FUR = {
    "dog": [
        (0.55, 0.38, 0.2),
        (0.12, 0.1, 0.08),
        (0.85, 0.75, 0.55),
        (0.95, 0.93, 0.9),
        (0.45, 0.42, 0.4),
    ],
    "deer": [(0.55, 0.38, 0.22), (0.48, 0.33, 0.2), (0.62, 0.45, 0.28)],
    "cow": [(0.1, 0.1, 0.1), (0.93, 0.92, 0.9), (0.45, 0.28, 0.15), (0.7, 0.55, 0.35)],
}


def _animal(rng: np.random.Generator, subtype: str) -> ActorShape:
    """Four-legged animal: body box, trotting legs, neck, head, tail (+ antlers/horns/ears)."""
    b = _Builder()
    p = _ANIMAL[subtype]
    fur = _pick(rng, _FUR[subtype], 0.05)
    s = rng.uniform(0.9, 1.1)
    L, back = rng.uniform(*p["L"]) * s, rng.uniform(*p["back"]) * s
    bh, bw, lr = p["bh"] * s, p["bw"] * s, p["leg_r"] * s
    body_z = back - bh
    b.box((0.0, 0.0, body_z), (L / 2, bw, bh), fur)
    if subtype == "cow":  # a contrasting flank patch, slightly proud of the body, and an udder
        patch = _pick(rng, [(0.95, 0.95, 0.93), (0.1, 0.1, 0.1)])
        b.box((-0.1 * L, 0.0, body_z + 0.1 * bh), (0.22 * L, bw + 0.025, 0.55 * bh), patch)
        b.box((0.05 * L, 0.0, body_z - bh - 0.05), (0.12, 0.1, 0.06), _rgba((0.9, 0.7, 0.7)))
    amp = 0.3 if subtype == "cow" else 0.45
    leg_top = body_z - 0.3 * bh
    for i, x in enumerate((L / 2 - 1.5 * lr - 0.02, -L / 2 + 1.5 * lr + 0.02)):
        for j, y in enumerate((bw - lr, lr - bw)):
            b.limb((x, leg_top), (x, 0.0), y, lr, fur, swing=amp, phase=np.pi * ((i + j) % 2))
    # Neck from the front of the body up and forward (a cow's reaches forward and down).
    neck = p["neck"] * s
    n0 = (L / 2 - 0.6 * bw, body_z + 0.3 * bh)
    if subtype == "cow":
        n1 = (L / 2 + 0.8 * neck, body_z + 0.2 * bh)
    else:
        n1 = (L / 2 + 0.45 * neck, body_z + bh + 0.75 * neck)
    b.limb(n1, n0, 0.0, 0.5 * bw, fur)
    hx, hy, hz = (v * s for v in p["head"])
    tilt = 0.7 if subtype == "cow" else 0.3  # snout forward and down
    b.box((n1[0] + 0.7 * hx, 0.0, n1[1] - 0.3 * hx), (hx, hy, hz), fur, tilt=tilt)
    if subtype == "deer" and rng.random() < 0.5:  # a buck's antlers
        for y in (0.05 * s, -0.05 * s):
            b.limb(
                (n1[0] - 0.05, n1[1] + 0.3 * s),
                (n1[0], n1[1] + 0.05),
                y,
                0.012,
                _rgba((0.4, 0.32, 0.22)),
            )
    elif subtype == "cow":  # horns
        b.box((n1[0] - 0.05, 0.0, n1[1] + 0.12), (0.025, 0.2 * s, 0.025), _rgba((0.9, 0.88, 0.8)))
    else:  # ears
        for y in (0.045 * s, -0.045 * s):
            b.box(
                (n1[0] - 0.02, y, n1[1] + 0.09 * s),
                (0.02, 0.02, 0.04 * s),
                _rgba((0.15, 0.1, 0.08)),
            )
    tail = p["tail"] * s
    t0 = (-L / 2 + 0.02, body_z + 0.6 * bh)
    tip = (
        (t0[0] - 0.3 * tail, t0[1] - 0.9 * tail)
        if subtype == "cow"
        else (t0[0] - 0.45 * tail, t0[1] + 0.8 * tail)
    )
    b.limb(t0, tip, 0.0, 0.022 * s, fur)
    return b.shape("animal", subtype, p["stride"] * s)


# ---------------------------------------------------------------------- obstacles
def _obstacle(rng: np.random.Generator, subtype: str) -> ActorShape:
    b = _Builder()
    if subtype == "cone":
        s = rng.uniform(0.85, 1.15)
        orange, white = _rgba((0.98, 0.42, 0.05)), (0.95, 0.95, 0.95, 1.0)
        b.box((0.0, 0.0, 0.02 * s), (0.2 * s, 0.2 * s, 0.02 * s), orange)
        n = 5
        for k in range(n):
            rr = (0.15 - 0.11 * k / n) * s
            hz = 0.06 * s
            col = white if k == 2 else orange
            b.cyl((0.0, 0.0, 0.04 * s + hz * (2 * k + 1)), rr, hz, col)
    elif subtype == "barrier":
        L = rng.uniform(1.5, 2.5)
        red, white = _rgba((0.85, 0.1, 0.08)), (0.95, 0.95, 0.95, 1.0)
        for x in (-L / 2 + 0.1, L / 2 - 0.1):
            b.box((x, 0.0, 0.45), (0.04, 0.04, 0.45), (0.3, 0.3, 0.3, 1.0))
            b.box((x, 0.0, 0.02), (0.1, 0.3, 0.02), (0.3, 0.3, 0.3, 1.0))
        n = 6
        for k in range(n):
            seg = L / n
            b.box(
                (-L / 2 + seg * (k + 0.5), 0.0, 0.75),
                (seg / 2, 0.03, 0.12),
                red if k % 2 == 0 else white,
            )
            b.box(
                (-L / 2 + seg * (k + 0.5), 0.0, 0.4),
                (seg / 2, 0.03, 0.08),
                white if k % 2 == 0 else red,
            )
    elif subtype == "debris":  # a lost tyre and broken pieces of load
        tr = rng.uniform(0.3, 0.4)
        b.cyl((rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.1), tr, 0.1, _TYRE)
        for _ in range(int(rng.integers(2, 5))):
            h = rng.uniform(0.08, 0.3, 3) * np.array([1.0, 1.0, 0.7])
            col = _pick(rng, [(0.45, 0.45, 0.45), (0.55, 0.4, 0.25), (0.25, 0.25, 0.28), (0.7, 0.7, 0.65)])
            b.box((rng.uniform(-0.8, 0.8), rng.uniform(-0.6, 0.6), h[2]), tuple(h), col,
                  tilt=rng.uniform(-0.3, 0.3))
    elif subtype == "bicycle":  # riderless, standing where it was left
        _bicycle_frame(b, rng)
    else:  # box
        sx, sy, sz = rng.uniform(0.3, 0.8, 3) * np.array([1.0, 1.0, 0.8])
        col = _pick(rng, [(0.6, 0.45, 0.28), (0.4, 0.4, 0.4), (0.2, 0.2, 0.25), (0.7, 0.6, 0.4)])
        b.box((0.0, 0.0, sz / 2), (sx / 2, sy / 2, sz / 2), col)
        b.box((0.0, 0.0, sz + 0.005), (sx / 2 - 0.02, 0.04, 0.005), _rgba((0.8, 0.7, 0.45)))  # tape
    return b.shape("obstacle", subtype, 0.0)


def make_shape(cls: str, subtype: str, rng: np.random.Generator) -> ActorShape:
    """The compound shape of a ``cls``/``subtype`` actor with sizes and colours from ``rng``.

    Deterministic: the same ``rng`` state gives the same shape. Raises ``ValueError``
    for an unknown class or subtype (see ``SUBTYPES``).
    """
    if cls not in SUBTYPES:
        raise ValueError(f"unknown actor class {cls!r}; expected one of {sorted(SUBTYPES)}")
    if subtype not in SUBTYPES[cls]:
        raise ValueError(
            f"unknown subtype {subtype!r} for class {cls!r}; expected one of {SUBTYPES[cls]}"
        )
    if cls == "pedestrian":
        return _pedestrian(rng, subtype)
    if cls == "cyclist":
        return _bicycle(rng)
    if cls == "motorcyclist":
        return _motor(rng, subtype)
    if cls == "tricycle":
        return _tricycle(rng)
    if cls == "car":
        return _car(rng, subtype)
    if cls == "truck":
        return _truck(rng)
    if cls == "bus":
        return _bus(rng)
    if cls == "animal":
        return _animal(rng, subtype)
    return _obstacle(rng, subtype)
