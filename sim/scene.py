"""The scene the camera sees, built in PyBullet: road, markings, roadside scenery, actors.

A ``Scene`` creates every body of a ``RoadLayout`` in a ``BulletClient`` (asphalt and
pavement slabs, kerbs, lane markings, surface patches, buildings, trees, lamp posts)
and one compound body per actor, and poses them for a camera view; ``sim.renderer``
captures frames of it. Where things stand is ``sim.roadside``'s (pure geometry);
what they look like (shapes, colours, seeded variation) is decided here.

Frames (m, rad):

* world: x along the road, y left, z up; ``RoadLayout`` lives here.
* ego pose ``(x, y, heading)``: world position of the ego-frame origin (front bumper
  centre on the ground) and its heading (rad, CCW from world +x).
* actor pose ``(x, y, heading, gait_phase)``: world position of the actor-local origin
  (ground, footprint centre), heading (rad) and gait phase (rad, see ``sim.shapes``).
  Actors standing on a sidewalk are lifted to its top (``RoadLayout.surface_height``), so ground
  truth must add the same height to their boxes.

Large triangles make llvmpipe rasterise depth wrongly, so every surface is tiled into
pieces of at most 25 m. Repeated scenery (lane dashes, road patches, buildings, trees,
lamp posts) is drawn by fixed pools of bodies re-posed every frame to cover the camera's
view; item k of a row always uses pool slot k % N and a pose drawn from (seed, row, k),
so a place always looks the same and a 10 km road costs no more bodies than a 300 m one.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from lookahead.perception.camera import CameraModel
from lookahead.sim.bullet import QUAT_ID, BulletClient, Link, Pose, quat_z
from lookahead.sim.layout import Rect, RoadLayout
from lookahead.sim.roadside import (
    LAMP_ARM,
    POST_FIRST,
    POST_HEIGHT,
    POST_SPACING,
    disjoint,
    kerb_strips,
    lamp_posts,
    zone_side,
)
from lookahead.sim.shapes import ActorShape, Part, pose_parts

log = logging.getLogger(__name__)

_MARGIN = 30.0  # m of scenery kept around the camera's view sector
_DASH_REACH = 150.0  # m; dashes further away are below a pixel wide
_TILE = 25.0  # m; largest surface tile (llvmpipe mis-rasterises depth of larger triangles)
_BASE_Z = -0.1  # m; bottom of road and pavement slabs


def camera_world_pose(
    camera: CameraModel, ego_pose: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """Camera centre (3,) in the world and R_cam_from_world (3, 3) (OpenCV camera axes)."""
    ex, ey, eh = (float(v) for v in ego_pose[:3])
    c, s = np.cos(eh), np.sin(eh)
    r_world_from_ego = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    centre = np.array([ex, ey, 0.0]) + r_world_from_ego @ camera.mount
    return centre, camera.R_cam_from_ego @ r_world_from_ego.T


def _quat_mul(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


# Rotations taking a z-axis cylinder to the named axis.
_AXIS_QUAT = {
    "z": QUAT_ID,
    "y": (-np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)),
    "x": (0.0, np.sin(np.pi / 4), 0.0, np.cos(np.pi / 4)),
}


# ---------------------------------------------------------------------- pooled rows
@dataclass(frozen=True)
class _Row:
    """Items k = 0..n-1 at ``origin + direction * (offset + k * spacing)`` (world xy).

    ``reach``: |along| and ``half_width``: lateral extent of an item (m), for windowing.
    """

    origin: np.ndarray
    direction: np.ndarray
    length: float
    spacing: float
    offset: float
    n: int
    reach: float
    half_width: float

    def index_range(self, window: np.ndarray) -> tuple[int, int]:
        """Inclusive item range [k0, k1] overlapping the xy ``window`` [x0, y0, x1, y1]."""
        lo, hi = 0.0, self.length
        pad = self.half_width
        for ax in (0, 1):
            o, d = self.origin[ax], self.direction[ax]
            a, b = window[ax] - pad, window[ax + 2] + pad
            if abs(d) < 1e-12:
                if o < a or o > b:
                    return 0, -1
                continue
            t0, t1 = sorted(((a - o) / d, (b - o) / d))
            lo, hi = max(lo, t0), min(hi, t1)
        if lo > hi:
            return 0, -1
        k0 = int(np.ceil((lo - self.offset - self.reach) / self.spacing))
        k1 = int(np.floor((hi - self.offset + self.reach) / self.spacing))
        return max(k0, 0), min(k1, self.n - 1)

    def point(self, k: int, along: float = 0.0, across: float = 0.0) -> np.ndarray:
        s = self.offset + k * self.spacing + along
        d = self.direction
        return self.origin + d * s + np.array([-d[1], d[0]]) * across

    @property
    def yaw(self) -> float:
        return float(np.arctan2(self.direction[1], self.direction[0]))


class _Pool:
    """A row's items drawn by ``n_slots`` reusable slots: item k uses slot k % n_slots.

    ``bodies[j]``: the body ids of slot j. ``place(k, j)`` returns one pose (or None =
    hidden) per body of slot j for item k. ``view_reach``: how far (m) the row is drawn.
    """

    def __init__(
        self,
        client: BulletClient,
        row: _Row,
        n_slots: int,
        make_slot: Callable[[int], list[int]],
        place: Callable[[int, int], list[Pose | None]],
        view_reach: float,
    ) -> None:
        self.client, self.row, self.place, self.view_reach = client, row, place, view_reach
        self.n_slots = max(1, min(n_slots, row.n))
        self.bodies = [make_slot(j) for j in range(self.n_slots)]  # created hidden
        self.current: list[int | None] = [None] * self.n_slots

    def update(self, window: np.ndarray) -> None:
        k0, k1 = self.row.index_range(window)
        if k1 - k0 + 1 > self.n_slots:
            log.debug("pool of %d slots short for %d items", self.n_slots, k1 - k0 + 1)
            k1 = k0 + self.n_slots - 1
        want: list[int | None] = [None] * self.n_slots
        for k in range(k0, k1 + 1):
            want[k % self.n_slots] = k
        for j, k in enumerate(want):
            if self.current[j] == k:
                continue
            poses = [None] * len(self.bodies[j]) if k is None else self.place(k, j)
            for b, pose in zip(self.bodies[j], poses, strict=True):
                self.client.pose(b, pose)
            self.current[j] = k

    def hide(self) -> None:
        for j in range(self.n_slots):
            if self.current[j] is not None:
                for b in self.bodies[j]:
                    self.client.hide(b)
                self.current[j] = None

def _shape_links(shape: ActorShape) -> list[Link]:
    """Links of an actor's multibody: one per part, revolute about y at the pivot if it swings."""
    links = []
    for part in shape.parts:
        links.append(_part_link(part, shape.stride > 0 and part.swing != 0.0))
    return links


def _part_link(part: Part, swings: bool) -> Link:
    pos = np.asarray(part.position, dtype=np.float64)
    origin = np.asarray(part.pivot, dtype=np.float64) if swings else pos
    tilt = (0.0, float(np.sin(part.tilt / 2)), 0.0, float(np.cos(part.tilt / 2)))
    h = part.half_extents
    if part.kind == "box":
        shape, dims, orn = p.GEOM_BOX, (h[0], h[1], h[2]), tilt
    elif part.kind == "cylinder":
        shape, dims, orn = (
            p.GEOM_CYLINDER,
            (h[0], 2.0 * h[2]),
            _quat_mul(tilt, _AXIS_QUAT[part.axis]),
        )
    else:
        shape, dims, orn = p.GEOM_SPHERE, (h[0],), QUAT_ID
    return Link(
        shape,
        tuple(float(d) for d in dims),
        part.rgba,
        tuple(float(v) for v in origin),  # type: ignore[arg-type]
        tuple(float(v) for v in pos - origin),  # type: ignore[arg-type]
        tuple(float(v) for v in orn),  # type: ignore[arg-type]
        swings,
    )


@dataclass
class _ActorBody:
    body: int
    shape: ActorShape
    joints: list[int]  # joint indices of swinging parts
    parts: np.ndarray  # part index of each joint
    visible: bool = False

# ---------------------------------------------------------------------- roadside structures
_WALLS = [
    (0.75, 0.7, 0.62),
    (0.62, 0.6, 0.58),
    (0.7, 0.5, 0.4),
    (0.85, 0.83, 0.78),
    (0.5, 0.52, 0.56),
]


def _building_links(g: np.random.Generator, max_depth: float) -> tuple[list[Link], float]:
    """A building (origin on the ground at its centre) and its depth (m).

    A glazed core with wall slabs between the storeys and corner piers standing 0.08 m
    proud: window bands on the long facades and no coplanar faces (EGL's depth is 16-bit).
    """
    bl, bd, bh = g.uniform(6.0, 11.0), min(g.uniform(6.0, 16.0), max_depth), g.uniform(4.0, 22.0)
    wall = _rgba(_WALLS[int(g.integers(len(_WALLS)))], g, 0.05)
    glass = _rgba((0.16, 0.2, 0.26), g, 0.03)
    links = [Link(p.GEOM_BOX, (bl / 2, bd / 2, bh / 2), glass, (0.0, 0.0, bh / 2))]
    slab = (bl / 2 + 0.08, bd / 2 + 0.08)
    floors = max(int(bh // 3.0), 1)
    storey = bh / floors
    for f in range(floors + 1):
        z0 = _BASE_Z if f == 0 else f * storey - (0.35 if f < floors else 0.5)
        z1 = 0.9 if f == 0 else min(f * storey + 0.45, bh + 0.3)
        links.append(Link(p.GEOM_BOX, (*slab, (z1 - z0) / 2), wall, (0.0, 0.0, (z0 + z1) / 2)))
    for x in (-bl / 2 + 0.3, bl / 2 - 0.3):
        links.append(Link(p.GEOM_BOX, (0.45, slab[1], bh / 2), wall, (x, 0.0, bh / 2)))
    return links, bd


def _tree_links(g: np.random.Generator) -> list[Link]:
    """A trunk and a round crown (origin at the trunk's foot)."""
    th, cr, tr = g.uniform(1.8, 3.2), g.uniform(1.2, 2.8), g.uniform(0.12, 0.22)
    leaf = _rgba((0.18, 0.38, 0.14), g, 0.06)
    return [
        Link(p.GEOM_CYLINDER, (tr, th), (0.35, 0.25, 0.16, 1.0), (0.0, 0.0, th / 2)),
        Link(p.GEOM_SPHERE, (cr,), leaf, (0.0, 0.0, th + 0.7 * cr)),
    ]


def _post_links(side: float, h: float = POST_HEIGHT) -> list[Link]:
    """A lamp post whose arm reaches toward local +y (side = +1) or -y (side = -1)."""
    grey = (0.45, 0.46, 0.48, 1.0)
    return [
        Link(p.GEOM_CYLINDER, (0.08, h), grey, (0.0, 0.0, h / 2)),
        Link(p.GEOM_BOX, (0.05, 0.7, 0.04), grey, (0.0, side * 0.65, h - 0.05)),
        Link(
            p.GEOM_BOX, (0.18, 0.12, 0.05), (0.92, 0.92, 0.85, 1.0), (0.0, side * LAMP_ARM, h - 0.12)
        ),
    ]


def _rgba(
    rgb: Sequence[float], rng: np.random.Generator | None = None, jitter: float = 0.0
) -> tuple:
    c = np.asarray(rgb, dtype=np.float64)
    if rng is not None and jitter > 0:
        c = c + rng.uniform(-jitter, jitter) + rng.uniform(-jitter / 3, jitter / 3, 3)
    r, g, b = (float(v) for v in np.clip(c, 0.0, 1.0))
    return (r, g, b, 1.0)


def ground_colour(seed: int) -> np.ndarray:
    """(3,) RGB in [0, 1] of the endless flat ground beyond the modelled road (seeded)."""
    g = np.random.default_rng([int(seed), 1])
    grounds = [(0.33, 0.42, 0.21), (0.38, 0.4, 0.23), (0.42, 0.38, 0.28)]
    return np.array(_rgba(grounds[int(g.integers(len(grounds)))], g, 0.03)[:3])


# ---------------------------------------------------------------------- scene
class Scene:
    """The bodies of a ``RoadLayout`` and of the actors in one PyBullet client.

    Args:
        client: the PyBullet client to build in (the renderer's).
        camera: the camera whose view the pooled scenery covers (intrinsics, mount, yaw).
        layout: static road layout (world frame).
        seed: seeds the roadside scenery and surface colours.
        far: how far (m) scenery is drawn (the renderer's far plane).
        backend: the renderer's backend, "egl" or "tiny" (TinyRenderer gets short
            surface tiles).
        static: build the road and the roadside scenery; False: actors only
            (``sim.silhouettes``).
    """

    def __init__(
        self, client: BulletClient, camera: CameraModel, layout: RoadLayout, seed: int, far: float, backend: str,
        static: bool = True,
    ) -> None:
        self._client, self.camera, self.layout = client, camera, layout
        self.seed, self.far, self.backend = int(seed), float(far), backend
        self._lut = np.full(64, -1, dtype=np.int32)  # body uid + 1 -> actor id
        self._actors: dict[int, _ActorBody] = {}
        half_fov = max(
            np.arctan2(camera.K[0, 2], camera.fx),
            np.arctan2(camera.width - camera.K[0, 2], camera.fx),
        )
        self._fan = np.linspace(-1.0, 1.0, 9) * min(half_fov + 0.05, np.pi)
        self._extents: dict[float, np.ndarray] = {}
        self._pools: list[_Pool] = []  # ground-level rows (always shown)
        self._structures: list[_Pool] = []  # roadside structures (hidden without structures)
        if static:
            self._build()
        self._grow_lut(p.getNumBodies(physicsClientId=self._client.cid) + 1)

    @property
    def client(self) -> BulletClient:
        """The PyBullet client the scene's bodies live in."""
        return self._client

    # ------------------------------------------------------------------ static scene
    def _rng(self, *key: int) -> np.random.Generator:
        return np.random.default_rng([self.seed, *key])

    def _add_surface(self, r: Rect, z0: float, z1: float, rgba: Sequence[float]) -> None:
        """A flat slab over rect ``r`` from z0 to z1, as pooled tiles at most ``_TILE`` m."""
        lx, ly = r.x1 - r.x0, r.y1 - r.y0
        along_x = lx >= ly
        length, depth = (lx, ly) if along_x else (ly, lx)
        n_across = int(np.ceil(depth / _TILE - 1e-9))
        w = depth / n_across
        for s in range(n_across):
            if along_x:
                origin, d = np.array([r.x0, r.y0 + w * (s + 0.5)]), np.array([1.0, 0.0])
            else:
                origin, d = np.array([r.x0 + w * (s + 0.5), r.y0]), np.array([0.0, 1.0])
            self._add_strip(origin, d, length, w, z0, z1, rgba)

    def _add_strip(
        self,
        origin: np.ndarray,
        d: np.ndarray,
        length: float,
        width: float,
        z0: float,
        z1: float,
        rgba: Sequence[float],
    ) -> None:
        """A straight strip from ``origin`` along unit ``d``, as pooled equal tiles."""
        # TinyRenderer scans each triangle's screen bounding box: long thin tiles seen
        # end-on cost far more than their area, so it gets short tiles (hidden ones are free).
        tile = _TILE if self.backend == "egl" else min(_TILE, max(4.0 * width, 2.0))
        n = max(int(np.ceil(length / tile - 1e-9)), 1)
        step = length / n
        row = _Row(origin, d, length, step, step / 2, n, step / 2, width / 2)
        pose_z, yaw = (z0 + z1) / 2, quat_z(row.yaw)
        # Tiles overlap by 1 cm so no crack shows between them.
        half = (step / 2 + 0.005, width / 2, (z1 - z0) / 2)

        def place(k: int, j: int) -> list[Pose | None]:
            c = row.point(k)
            return [([c[0], c[1], pose_z], yaw)]

        make = lambda j: [self._client.box(half, rgba)]  # noqa: E731
        self._pools.append(
            _Pool(self._client, row, self._slots(row, self.far), make, place, self.far)
        )

    def _build(self) -> None:
        """Every static body: asphalt, pavements, kerbs, markings, patches, roadside structures."""
        lay = self.layout
        asphalt = disjoint(lay.asphalt)
        for i, r in enumerate(asphalt):
            self._add_surface(r, _BASE_Z, 0.0, _rgba((0.24, 0.24, 0.25), self._rng(2, i), 0.015))
        sidewalks = disjoint(lay.sidewalks, minus=asphalt)
        kerbs = kerb_strips(sidewalks, asphalt, 0.2)
        pavement = _rgba((0.6, 0.59, 0.56), self._rng(3), 0.01)
        for r in disjoint(sidewalks, minus=kerbs):
            self._add_surface(r, _BASE_Z, lay.kerb_height, pavement)
        for r in kerbs:
            self._add_surface(r, _BASE_Z, lay.kerb_height, (0.78, 0.78, 0.75, 1.0))
        white = (0.9, 0.9, 0.88, 1.0)
        for m in lay.markings:
            a, b = np.asarray(m.start, dtype=np.float64), np.asarray(m.end, dtype=np.float64)
            length = float(np.linalg.norm(b - a))
            if length < 1e-6:
                continue
            d = (b - a) / length
            if not m.dashed:
                self._add_strip(a, d, length, m.width, -0.01, 0.01, white)
            elif length >= 3.0:
                row = _Row(a, d, length, 9.0, 1.5, int((length - 3.0) // 9.0) + 1, 1.5, m.width / 2)
                self._add_dashes(row, m.width, white)
        for i, r in enumerate(asphalt):
            self._add_patches(i, r)
        for i, z in enumerate(lay.structure_zones):
            self._add_structures(i, z, asphalt)

    def _long_row(
        self, r: Rect, spacing: float, offset: float, reach: float
    ) -> tuple[_Row, float, float]:
        """Row along the long axis of rect ``r`` through its centre line; returns it and
        the rect's (length, depth)."""
        origin, d, length, depth = r.long_axis()
        n = max(int((length - offset) // spacing) + 1, 0)
        return _Row(origin, d, length, spacing, offset, n, reach, depth / 2), length, depth

    def _slots(self, row: _Row, reach: float) -> int:
        """Slots a row needs to cover the largest view window along its direction."""
        extent = self._max_window_extent(reach)
        d = np.abs(row.direction)
        with np.errstate(divide="ignore"):
            chord = float(np.min(np.where(d > 1e-9, extent / np.maximum(d, 1e-12), np.inf)))
        return int(np.ceil((chord + 2 * row.reach) / row.spacing)) + 2

    def _max_window_extent(self, reach: float) -> np.ndarray:
        """Largest (dx, dy) of the view window over all headings (m), memoised per reach."""
        if reach not in self._extents:
            ext = np.zeros(2)
            for h in np.linspace(0.0, 2 * np.pi, 73):
                w = self._window((0.0, 0.0, h), reach)
                ext = np.maximum(ext, w[2:] - w[:2])
            self._extents[reach] = ext
        return self._extents[reach]

    def _add_dashes(self, row: _Row, width: float, rgba: Sequence[float]) -> None:
        yaw = quat_z(row.yaw)

        def place(k: int, j: int) -> list[Pose | None]:
            c = row.point(k)
            return [([c[0], c[1], 0.0], yaw)]

        reach = min(self.far, _DASH_REACH)
        make = lambda j: [self._client.box((1.5, width / 2, 0.01), rgba)]  # noqa: E731
        self._pools.append(_Pool(self._client, row, self._slots(row, reach), make, place, reach))

    def _add_patches(self, i: int, r: Rect) -> None:
        """Sparse repair patches and stains on the asphalt (surface variation, motion cues)."""
        row, _, depth = self._long_row(r, 13.0, 6.5, 6.0)
        if row.n == 0 or depth < 2.0:
            return

        def make(j: int) -> list[int]:
            g = self._rng(4, i, j)
            shade = 0.24 + g.choice([-1.0, 1.0]) * g.uniform(0.025, 0.05)
            half = (g.uniform(0.6, 2.5), min(g.uniform(0.4, 1.5), depth / 2 - 0.1), 0.006)
            return [self._client.box(half, _rgba((shade, shade, shade * 1.02), g, 0.005))]

        def place(k: int, j: int) -> list[Pose | None]:
            g = self._rng(5, i, k)
            if g.random() > 0.45:
                return [None]
            c = row.point(k, g.uniform(-3.0, 3.0), g.uniform(-0.4, 0.4) * (depth - 2.0))
            return [([c[0], c[1], 0.0], quat_z(row.yaw + g.normal(0.0, 0.05)))]

        reach = min(self.far, _DASH_REACH)
        self._pools.append(_Pool(self._client, row, self._slots(row, reach), make, place, reach))

    def _add_structures(self, i: int, zone: Rect, asphalt: Sequence[Rect]) -> None:
        """Buildings and trees along a structure zone, lamp posts along its road side."""
        row, _, depth = self._long_row(zone, 12.0, 6.0, 6.0)
        if row.n == 0:
            return
        side = zone_side(zone, asphalt)  # +1 if the road lies to the row's left
        cl = self._client

        buildings = depth >= 3.5  # room for a building 1.2 m back from the road side
        depths: dict[int, float] = {}  # building depth of each slot

        def make(j: int) -> list[int]:
            g = self._rng(6, i, j)
            bodies = []
            if buildings:
                links, depths[j] = _building_links(g, depth - 1.2)
                bodies.append(cl.body(links))
            return [*bodies, cl.body(_tree_links(g))]

        def place(k: int, j: int) -> list[Pose | None]:
            g = self._rng(7, i, k)
            u, along = g.random(), g.uniform(-1.0, 1.0)
            yaw = quat_z(row.yaw)
            if buildings and u < 0.5:  # between the far side and 1.2 m off the road side
                bd = depths[j]
                gap = g.uniform(0.0, max(depth - 1.2 - bd, 0.0))
                c = row.point(k, along, -side * (depth / 2 - gap - bd / 2))
                return [([c[0], c[1], 0.0], yaw), None]
            tree: Pose | None = None
            if u < 0.8:  # a tree 1.5 m inside the road side
                c = row.point(k, 3.0 * along, side * max(depth / 2 - 1.5, 0.0))
                tree = ([c[0], c[1], 0.0], yaw)
            return [None, tree] if buildings else [tree]

        self._structures.append(_Pool(cl, row, self._slots(row, self.far), make, place, self.far))
        posts = lamp_posts(zone, side)  # sim.roadside: where the lamps stand (weather lights them)
        if posts is None:
            return
        prow = _Row(
            posts.foot_origin, posts.direction, posts.length, POST_SPACING, POST_FIRST, posts.n, 1.5, 1.5
        )

        def place_post(k: int, j: int) -> list[Pose | None]:
            c = prow.point(k)
            return [([c[0], c[1], 0.0], quat_z(prow.yaw))]

        make_post = lambda j: [cl.body(_post_links(side))]  # noqa: E731
        self._structures.append(
            _Pool(cl, prow, self._slots(prow, self.far), make_post, place_post, self.far)
        )

    # ------------------------------------------------------------------ actors
    def add_actor(self, actor_id: int, shape: ActorShape) -> None:
        """Create the body of actor ``actor_id`` (hidden until rendered with a pose)."""
        if actor_id in self._actors:
            raise ValueError(f"actor {actor_id} already added")
        body = self._client.body(_shape_links(shape))
        swings = [i for i, part in enumerate(shape.parts) if shape.stride > 0 and part.swing != 0.0]
        self._actors[actor_id] = _ActorBody(body, shape, swings, np.array(swings, dtype=np.int64))
        self._grow_lut(body + 1)
        self._lut[body + 1] = actor_id

    def _grow_lut(self, index: int) -> None:
        """Make ``self._lut[index]`` valid (the LUT maps body uid + 1 -> actor id, -1 static)."""
        if index >= len(self._lut):
            grown = np.full(max(2 * len(self._lut), index + 1), -1, dtype=np.int32)
            grown[: len(self._lut)] = self._lut
            self._lut = grown

    def remove_actor(self, actor_id: int) -> None:
        """Delete actor ``actor_id``'s body; unknown ids are ignored."""
        a = self._actors.pop(actor_id, None)
        if a is not None:
            self._lut[a.body + 1] = -1
            p.removeBody(a.body, physicsClientId=self._client.cid)

    def place_actors(self, actors: Mapping[int, Sequence[float]]) -> None:
        """Pose the actors ``actors`` (id -> world (x, y, heading, pose): ``sim.shapes.Pose``, the
        gait phase or (gait phase, arm, body)) on the surface under them; added actors not in
        the mapping are hidden."""
        unknown = set(actors) - set(self._actors)
        if unknown:
            raise KeyError(f"actors {sorted(unknown)} were not added to the renderer")
        cid = self._client.cid
        for aid, a in self._actors.items():
            if aid not in actors and a.visible:
                self._client.hide(a.body)
                a.visible = False
        if not actors:
            return
        ids = list(actors)
        poses = np.array(
            [[float(v) for v in actors[i][:3]] for i in ids], dtype=np.float64
        ).reshape(-1, 3)
        z = self.layout.surface_height(poses[:, :2])
        for aid, (x, y, heading), zi in zip(ids, poses, z, strict=True):
            a = self._actors[aid]
            pose = actors[aid][3]  # gait phase, or (gait phase, arm, body): sim.shapes.Pose
            body = pose_parts(pose)[2]
            orientation = quat_z(heading) if not body else p.multiplyTransforms(
                [0, 0, 0], quat_z(heading), [0, 0, 0], p.getQuaternionFromEuler([0.0, body, 0.0]))[1]
            p.resetBasePositionAndOrientation(
                a.body, [x, y, float(zi)], orientation, physicsClientId=cid
            )
            if a.joints:
                th = a.shape.swing_angles(pose)[a.parts]
                p.resetJointStatesMultiDof(
                    a.body, a.joints, [[float(t)] for t in th], physicsClientId=cid
                )
            a.visible = True

    # ------------------------------------------------------------------ view
    def _window(self, ego_pose: Sequence[float], reach: float) -> np.ndarray:
        """World xy box [x0, y0, x1, y1] covering the camera's view sector out to ``reach`` m."""
        centre, _ = camera_world_pose(self.camera, ego_pose)
        t = float(ego_pose[2]) + self.camera.yaw + self._fan
        xs = np.concatenate([[centre[0]], centre[0] + reach * np.cos(t)])
        ys = np.concatenate([[centre[1]], centre[1] + reach * np.sin(t)])
        return np.array(
            [xs.min() - _MARGIN, ys.min() - _MARGIN, xs.max() + _MARGIN, ys.max() + _MARGIN]
        )

    def show_scenery(self, ego_pose: Sequence[float], structures: bool) -> None:
        """Pose the pooled scenery to cover the camera's view from ``ego_pose`` (world x, y,
        heading); without ``structures`` the roadside buildings, trees and posts are hidden."""
        windows: dict[float, np.ndarray] = {}
        for pool in self._pools + (self._structures if structures else []):
            if pool.view_reach not in windows:
                windows[pool.view_reach] = self._window(ego_pose, pool.view_reach)
            pool.update(windows[pool.view_reach])
        if not structures:
            for pool in self._structures:
                pool.hide()

    def actor_ids(self, uids: np.ndarray) -> np.ndarray:
        """int32 actor id of each body uid in ``uids`` (a PyBullet segmentation buffer), -1 for
        the static scene and for no body (uid -1)."""
        return self._lut[uids + 1]
