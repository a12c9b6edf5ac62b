"""PyBullet camera renderer: RGB, metric depth and actor segmentation for one ``CameraModel``.

DIRECT mode, no physics: every body has mass 0 and is posed each frame. Frames:

* world: x along the road, y left, z up (m); ``RoadLayout`` lives here.
* ego pose ``(x, y, heading)``: world position of the ego-frame origin (front bumper
  centre on the ground) and its heading (rad, CCW from world +x).
* actor pose ``(x, y, heading, gait_phase)``: world position of the actor-local origin
  (ground, footprint centre), heading (rad) and gait phase (rad, see ``sim.shapes``).
  Actors standing on a sidewalk are lifted to its top (``RoadLayout.surface_height``), so ground
  truth must add the same height to their boxes.

The OpenGL projection is built from K, so a point ``CameraModel.project`` maps to
pixel (u, v) is drawn in pixel (floor(u), floor(v)) by both backends (TinyRenderer
samples pixel corners; its principal point is shifted half a pixel to match). Depth is
metric z along the optical axis (m). Segmentation holds actor ids, -1 for the static
scene and the sky. Beyond the modelled road an endless flat ground and a sky are
composited from the camera model (exact depth, no geometry), ``far`` for the sky.

Backends: "egl" (PyBullet's EGL plugin; with Mesa llvmpipe its depth buffer is 16-bit,
hence the default ``near`` of 1 m, and only one instance may live per process) and
"tiny" (TinyRenderer, CPU, float depth). Large triangles make llvmpipe rasterise depth
wrongly, so every surface is tiled into pieces of at most 25 m.

Repeated scenery (lane dashes, road patches, buildings, trees, lamp posts) is drawn by
fixed pools of bodies re-posed every frame to cover the camera's view; item k of a row
always uses pool slot k % N and a pose drawn from (seed, row, k), so a place always
looks the same and a 10 km road costs no more bodies than a 300 m one.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import logging
import os
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from lookahead.perception.camera import CameraModel
from lookahead.sim.layout import Rect, RoadLayout
from lookahead.sim.shapes import ActorShape, Part

log = logging.getLogger(__name__)

Pose = tuple[list[float], list[float]]  # position xyz, quaternion xyzw
_QUAT_ID = (0.0, 0.0, 0.0, 1.0)
_MARGIN = 30.0  # m of scenery kept around the camera's view sector
_DASH_REACH = 150.0  # m; dashes further away are below a pixel wide
_TILE = 25.0  # m; largest surface tile (llvmpipe mis-rasterises depth of larger triangles)
_BASE_Z = -0.1  # m; bottom of road and pavement slabs
# PyBullet clients holding the EGL plugin. The plugin keeps process-global GL state: a
# second live instance leaves the first rendering empty frames, so only one may exist.
_EGL_CLIENTS: set[int] = set()


@dataclass
class RenderResult:
    """One camera frame.

    rgb: (H, W, 3) uint8 RGB.
    depth: (H, W) float32 metric depth along the optical axis (m), capped at ``far``;
        ``far`` for the sky.
    seg: (H, W) int32 actor id, -1 for the static scene and the sky.
    """

    rgb: np.ndarray
    depth: np.ndarray
    seg: np.ndarray


# ---------------------------------------------------------------------- matrices
def gl_projection(
    camera: CameraModel, near: float, far: float, offset: tuple[float, float] = (0.0, 0.0)
) -> np.ndarray:
    """4x4 OpenGL projection (GL camera: x right, y up, z back) equal to the pinhole K.

    ``offset`` (du, dv) pixels is added to the principal point (rasteriser sampling fixes).
    """
    return _gl_projection(camera.K, camera.width, camera.height, near, far, offset)


def _gl_projection(
    K: np.ndarray, W: int, H: int, near: float, far: float, offset: tuple[float, float]
) -> np.ndarray:
    fx, fy, s = K[0, 0], K[1, 1], K[0, 1]
    cx, cy = K[0, 2] + offset[0], K[1, 2] + offset[1]
    return np.array(
        [
            [2 * fx / W, -2 * s / W, 1 - 2 * cx / W, 0.0],
            [0.0, 2 * fy / H, 2 * cy / H - 1, 0.0],
            [0.0, 0.0, -(far + near) / (far - near), -2 * far * near / (far - near)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )


def camera_world_pose(
    camera: CameraModel, ego_pose: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """Camera centre (3,) in the world and R_cam_from_world (3, 3) (OpenCV camera axes)."""
    ex, ey, eh = (float(v) for v in ego_pose[:3])
    c, s = np.cos(eh), np.sin(eh)
    r_world_from_ego = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    centre = np.array([ex, ey, 0.0]) + r_world_from_ego @ camera.mount
    return centre, camera.R_cam_from_ego @ r_world_from_ego.T


def gl_view(camera: CameraModel, ego_pose: Sequence[float]) -> np.ndarray:
    """4x4 OpenGL view matrix (world -> GL camera) for the camera on an ego at ``ego_pose``."""
    centre, r_cw = camera_world_pose(camera, ego_pose)
    r_gl = np.diag([1.0, -1.0, -1.0]) @ r_cw
    v = np.eye(4)
    v[:3, :3] = r_gl
    v[:3, 3] = -r_gl @ centre
    return v


def _quat_z(a: float) -> list[float]:
    return [0.0, 0.0, float(np.sin(a / 2)), float(np.cos(a / 2))]


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
    "z": _QUAT_ID,
    "y": (-np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)),
    "x": (0.0, np.sin(np.pi / 4), 0.0, np.cos(np.pi / 4)),
}


@contextlib.contextmanager
def _quiet_c_output() -> Iterator[None]:
    """Silence C-level stdout/stderr (the EGL plugin prints its GL banner there)."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved: list[tuple[int, int]] = []
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in (1, 2):
            with contextlib.suppress(OSError):
                saved.append((fd, os.dup(fd)))
                os.dup2(devnull, fd)
        yield
    finally:
        with contextlib.suppress(Exception):
            ctypes.CDLL(None).fflush(None)
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


# ---------------------------------------------------------------------- rect helpers
def _subtract(r: Rect, s: Rect) -> list[Rect]:
    """``r`` minus ``s`` as up to four disjoint rectangles."""
    if s.x1 <= r.x0 or s.x0 >= r.x1 or s.y1 <= r.y0 or s.y0 >= r.y1:
        return [r]
    out = []
    if s.x0 > r.x0:
        out.append(Rect(r.x0, r.y0, s.x0, r.y1))
    if s.x1 < r.x1:
        out.append(Rect(s.x1, r.y0, r.x1, r.y1))
    x0, x1 = max(r.x0, s.x0), min(r.x1, s.x1)
    if s.y0 > r.y0:
        out.append(Rect(x0, r.y0, x1, s.y0))
    if s.y1 < r.y1:
        out.append(Rect(x0, s.y1, x1, r.y1))
    return out


def _disjoint(rects: Sequence[Rect], minus: Sequence[Rect] = ()) -> list[Rect]:
    """Pieces covering the union of ``rects`` without overlaps, minus ``minus``."""
    done: list[Rect] = []
    for r in rects:
        pieces = [r]
        for s in [*done, *minus]:
            pieces = [q for piece in pieces for q in _subtract(piece, s)]
        done.extend(q for q in pieces if q.x1 - q.x0 > 1e-6 and q.y1 - q.y0 > 1e-6)
    return done


def _kerb_strips(sidewalks: Sequence[Rect], asphalt: Sequence[Rect], width: float) -> list[Rect]:
    """Strips ``width`` m wide along every sidewalk edge that touches the asphalt."""
    tol, out = 0.05, []
    for r in sidewalks:
        for a in asphalt:
            x0, x1 = max(r.x0, a.x0), min(r.x1, a.x1)
            y0, y1 = max(r.y0, a.y0), min(r.y1, a.y1)
            w = min(width, r.y1 - r.y0, r.x1 - r.x0)
            if x1 - x0 > 0.5 and abs(a.y1 - r.y0) < tol:
                out.append(Rect(x0, r.y0, x1, r.y0 + w))
            elif x1 - x0 > 0.5 and abs(a.y0 - r.y1) < tol:
                out.append(Rect(x0, r.y1 - w, x1, r.y1))
            elif y1 - y0 > 0.5 and abs(a.x1 - r.x0) < tol:
                out.append(Rect(r.x0, y0, r.x0 + w, y1))
            elif y1 - y0 > 0.5 and abs(a.x0 - r.x1) < tol:
                out.append(Rect(r.x1 - w, y0, r.x1, y1))
    return out


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
        client: _Client,
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


# ---------------------------------------------------------------------- pybullet client
@dataclass(frozen=True)
class _Link:
    """One visual part of a compound body: shape, colour, link-frame origin (relative to
    the base), visual offset/orientation inside the link, and whether it swings about y."""

    shape: int
    dims: tuple[float, ...]  # box half extents / (radius, length) / (radius,)
    rgba: tuple[float, float, float, float]
    origin: tuple[float, float, float]
    vis_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    vis_orn: tuple[float, float, float, float] = _QUAT_ID
    revolute: bool = False


class _Client:
    """A DIRECT PyBullet client with helpers; every call names its physicsClientId."""

    def __init__(self, hidden_z: float) -> None:
        self.cid = p.connect(p.DIRECT)
        if self.cid < 0:
            raise RuntimeError("could not connect to a PyBullet DIRECT server")
        self.hidden_z = hidden_z
        self.plugin = -1

    def visual(self, link: _Link) -> int:
        kw: dict = {
            "rgbaColor": list(link.rgba),
            "specularColor": [0.05, 0.05, 0.05],
            "visualFramePosition": list(link.vis_pos),
            "visualFrameOrientation": list(link.vis_orn),
            "physicsClientId": self.cid,
        }
        if link.shape == p.GEOM_BOX:
            kw["halfExtents"] = list(link.dims)
        elif link.shape == p.GEOM_CYLINDER:
            kw["radius"], kw["length"] = link.dims
        else:
            kw["radius"] = link.dims[0]
        return p.createVisualShape(link.shape, **kw)

    def body(self, links: Sequence[_Link]) -> int:
        """A massless body; one link = a single-shape body, more = base + fixed/revolute links."""
        if len(links) == 1 and links[0].origin == (0.0, 0.0, 0.0) and not links[0].revolute:
            return p.createMultiBody(
                0.0, -1, self.visual(links[0]), [0, 0, self.hidden_z], physicsClientId=self.cid
            )
        n = len(links)
        return p.createMultiBody(
            0.0,
            -1,
            -1,
            [0, 0, self.hidden_z],
            linkMasses=[0.0] * n,
            linkCollisionShapeIndices=[-1] * n,
            linkVisualShapeIndices=[self.visual(lk) for lk in links],
            linkPositions=[list(lk.origin) for lk in links],
            linkOrientations=[list(_QUAT_ID)] * n,
            linkInertialFramePositions=[[0.0, 0.0, 0.0]] * n,
            linkInertialFrameOrientations=[list(_QUAT_ID)] * n,
            linkParentIndices=[0] * n,
            linkJointTypes=[p.JOINT_REVOLUTE if lk.revolute else p.JOINT_FIXED for lk in links],
            linkJointAxis=[[0.0, 1.0, 0.0]] * n,
            physicsClientId=self.cid,
        )

    def box(self, half: Sequence[float], rgba: Sequence[float]) -> int:
        return self.body(
            [_Link(p.GEOM_BOX, tuple(float(h) for h in half), tuple(rgba), (0.0, 0.0, 0.0))]
        )  # type: ignore[arg-type]

    def pose(self, body: int, pose: Pose | None) -> None:
        if pose is None:
            self.hide(body)
        else:
            p.resetBasePositionAndOrientation(body, pose[0], pose[1], physicsClientId=self.cid)

    def hide(self, body: int) -> None:
        p.resetBasePositionAndOrientation(
            body, [0.0, 0.0, self.hidden_z], _QUAT_ID, physicsClientId=self.cid
        )

    def close(self) -> None:
        if self.cid >= 0:
            _EGL_CLIENTS.discard(self.cid)
            with _quiet_c_output(), contextlib.suppress(Exception):
                if self.plugin >= 0:
                    p.unloadPlugin(self.plugin, physicsClientId=self.cid)
                p.disconnect(self.cid)
            self.cid = -1


def _shape_links(shape: ActorShape) -> list[_Link]:
    """Links of an actor's multibody: one per part, revolute about y at the pivot if it swings."""
    links = []
    for part in shape.parts:
        links.append(_part_link(part, shape.stride > 0 and part.swing != 0.0))
    return links


def _part_link(part: Part, swings: bool) -> _Link:
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
        shape, dims, orn = p.GEOM_SPHERE, (h[0],), _QUAT_ID
    return _Link(
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


def _building_links(g: np.random.Generator, max_depth: float) -> tuple[list[_Link], float]:
    """A building (origin on the ground at its centre) and its depth (m).

    A glazed core with wall slabs between the storeys and corner piers standing 0.08 m
    proud: window bands on the long facades and no coplanar faces (EGL's depth is 16-bit).
    """
    bl, bd, bh = g.uniform(6.0, 11.0), min(g.uniform(6.0, 16.0), max_depth), g.uniform(4.0, 22.0)
    wall = _rgba(_WALLS[int(g.integers(len(_WALLS)))], g, 0.05)
    glass = _rgba((0.16, 0.2, 0.26), g, 0.03)
    links = [_Link(p.GEOM_BOX, (bl / 2, bd / 2, bh / 2), glass, (0.0, 0.0, bh / 2))]
    slab = (bl / 2 + 0.08, bd / 2 + 0.08)
    floors = max(int(bh // 3.0), 1)
    storey = bh / floors
    for f in range(floors + 1):
        z0 = _BASE_Z if f == 0 else f * storey - (0.35 if f < floors else 0.5)
        z1 = 0.9 if f == 0 else min(f * storey + 0.45, bh + 0.3)
        links.append(_Link(p.GEOM_BOX, (*slab, (z1 - z0) / 2), wall, (0.0, 0.0, (z0 + z1) / 2)))
    for x in (-bl / 2 + 0.3, bl / 2 - 0.3):
        links.append(_Link(p.GEOM_BOX, (0.45, slab[1], bh / 2), wall, (x, 0.0, bh / 2)))
    return links, bd


def _tree_links(g: np.random.Generator) -> list[_Link]:
    """A trunk and a round crown (origin at the trunk's foot)."""
    th, cr, tr = g.uniform(1.8, 3.2), g.uniform(1.2, 2.8), g.uniform(0.12, 0.22)
    leaf = _rgba((0.18, 0.38, 0.14), g, 0.06)
    return [
        _Link(p.GEOM_CYLINDER, (tr, th), (0.35, 0.25, 0.16, 1.0), (0.0, 0.0, th / 2)),
        _Link(p.GEOM_SPHERE, (cr,), leaf, (0.0, 0.0, th + 0.7 * cr)),
    ]


def _post_links(side: float, h: float = 7.0) -> list[_Link]:
    """A lamp post whose arm reaches toward local +y (side = +1) or -y (side = -1)."""
    grey = (0.45, 0.46, 0.48, 1.0)
    return [
        _Link(p.GEOM_CYLINDER, (0.08, h), grey, (0.0, 0.0, h / 2)),
        _Link(p.GEOM_BOX, (0.05, 0.7, 0.04), grey, (0.0, side * 0.65, h - 0.05)),
        _Link(
            p.GEOM_BOX, (0.18, 0.12, 0.05), (0.92, 0.92, 0.85, 1.0), (0.0, side * 1.25, h - 0.12)
        ),
    ]


# ---------------------------------------------------------------------- renderer
class Renderer:
    """Renders the road layout and posed actors from a ``CameraModel`` with PyBullet.

    Args:
        camera: intrinsics and mount (ego frame).
        layout: static road layout (world frame).
        seed: seeds the roadside scenery and surface colours.
        backend: "auto" (EGL if it loads, renders a test frame and no other EGL
            renderer is open in this process; else TinyRenderer), "egl" (RuntimeError
            when unavailable) or "tiny". The resolved one is ``self.backend``.
        near, far: clip planes (m) along the optical axis. ``near`` defaults to 1 m: the
            camera sits behind the windscreen, and EGL's 16-bit depth buffer resolves
            z^2 / (near * 65536) m (6 mm at 20 m with near = 1, 6 cm with 0.1).
    """

    def __init__(
        self,
        camera: CameraModel,
        layout: RoadLayout,
        seed: int,
        backend: str = "auto",
        near: float = 1.0,
        far: float = 250.0,
    ) -> None:
        if backend not in ("auto", "egl", "tiny"):
            raise ValueError(f"backend must be 'auto', 'egl' or 'tiny', not {backend!r}")
        if not 0.0 < near < far:
            raise ValueError(f"need 0 < near < far, got near={near}, far={far}")
        if camera.has_distortion:
            log.warning(
                "renderer draws an undistorted pinhole image; distortion coefficients ignored"
            )
        self.camera, self.layout, self.seed = camera, layout, int(seed)
        self.near, self.far = float(near), float(far)
        self._client = _Client(hidden_z=-4.0 * self.far)
        self.backend = self._resolve_backend(backend)
        self._renderer_flag = (
            p.ER_BULLET_HARDWARE_OPENGL if self.backend == "egl" else p.ER_TINY_RENDERER
        )
        log.info("PyBullet renderer backend: %s (%dx%d)", self.backend, camera.width, camera.height)
        # TinyRenderer samples pixel corners rather than centres: shift by half a pixel.
        self._offset = (-0.5, 0.5) if self.backend == "tiny" else (0.0, 0.0)
        self._proj = tuple(gl_projection(camera, self.near, self.far, self._offset).T.ravel().tolist())
        self._lut = np.full(64, -1, dtype=np.int32)  # body uid + 1 -> actor id
        self._actors: dict[int, _ActorBody] = {}
        self._warm = False
        half_fov = max(
            np.arctan2(camera.K[0, 2], camera.fx),
            np.arctan2(camera.width - camera.K[0, 2], camera.fx),
        )
        self._fan = np.linspace(-1.0, 1.0, 9) * min(half_fov + 0.05, np.pi)
        self._bg_rgb, self._bg_depth = self._background()
        self._extents: dict[float, np.ndarray] = {}
        self._pools: list[_Pool] = []  # ground-level rows (kept in silhouettes)
        self._structures: list[_Pool] = []  # roadside structures (hidden in silhouettes)
        self._build_scene()
        self._grow_lut(p.getNumBodies(physicsClientId=self._client.cid) + 1)

    # ------------------------------------------------------------------ backend
    def _resolve_backend(self, backend: str) -> str:
        if backend == "tiny":
            return "tiny"
        try:
            self._load_egl()
            return "egl"
        except Exception as exc:  # noqa: BLE001 - any EGL failure means fall back
            if backend == "egl":
                self._client.close()
                raise RuntimeError(f"EGL rendering unavailable: {exc}") from exc
            log.info("EGL renderer unavailable (%s); using TinyRenderer", exc)
            self._client.close()
            self._client = _Client(hidden_z=self._client.hidden_z)
            return "tiny"

    def _load_egl(self) -> None:
        if _EGL_CLIENTS:
            raise RuntimeError(
                "another EGL renderer is open in this process (PyBullet's EGL plugin supports"
                " one at a time); close it or use backend='tiny'"
            )
        spec = importlib.util.find_spec("eglRenderer")
        if spec is None or spec.origin is None:
            raise RuntimeError("pybullet's eglRenderer module not found")
        cid = self._client.cid
        with _quiet_c_output():
            plugin = p.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=cid)
            if plugin < 0:
                raise RuntimeError("loading _eglRendererPlugin failed")
            self._client.plugin = plugin
            _EGL_CLIENTS.add(self._client.cid)
            eye = np.eye(4).ravel().tolist()
            proj = gl_projection(self.camera, self.near, self.far).T.ravel().tolist()
            out = p.getCameraImage(
                32, 24, eye, proj, renderer=p.ER_BULLET_HARDWARE_OPENGL, physicsClientId=cid
            )
        if np.asarray(out[2]).size != 32 * 24 * 4:
            raise RuntimeError("EGL test frame has the wrong size")

    # ------------------------------------------------------------------ static scene
    def _rng(self, *key: int) -> np.random.Generator:
        return np.random.default_rng([self.seed, *key])

    def _background(self) -> tuple[np.ndarray, np.ndarray]:
        """What shows where no body is hit: (H, W, 3) uint8 colour and (H, W) float32 depth.

        Below the horizon an endless flat grass/dirt ground (z = 0), hazing toward the
        horizon, at its exact metric depth (capped at ``far``); above it a sky gradient at
        ``far``. Composited per frame, so the ground costs no geometry.
        """
        cam = self.camera
        H, W = cam.height, cam.width
        u, v = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
        uv = np.stack([u, v], axis=-1)
        rays = cam.pixel_rays(uv)
        ground = cam.ground_points(uv)
        z = cam.ego_to_camera(ground)[..., 2]
        hit = np.isfinite(z)
        elev = np.arcsin(np.clip(rays[..., 2], -1.0, 1.0))[..., None]
        top, horizon = np.array([70, 120, 190.0]), np.array([190, 210, 228.0])
        sky = horizon + (top - horizon) * np.sqrt(np.clip(elev / 0.6, 0.0, 1.0))
        g = self._rng(1)
        grounds = [(0.33, 0.42, 0.21), (0.38, 0.4, 0.23), (0.42, 0.38, 0.28)]
        base = np.array(_rgba(grounds[int(g.integers(len(grounds)))], g, 0.03)[:3]) * 200.0
        dist = np.where(hit, z, np.inf)[..., None]
        haze = 1.0 - np.exp(-dist / 400.0)
        grass = base + (horizon * 0.9 - base) * haze
        rgb = np.where(hit[..., None], grass, sky)
        depth = np.where(hit, np.minimum(z, self.far), self.far)
        return np.clip(rgb, 0, 255).astype(np.uint8), depth.astype(np.float32)

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
        pose_z, yaw = (z0 + z1) / 2, _quat_z(row.yaw)
        # Tiles overlap by 1 cm so no crack shows between them.
        half = (step / 2 + 0.005, width / 2, (z1 - z0) / 2)

        def place(k: int, j: int) -> list[Pose | None]:
            c = row.point(k)
            return [([c[0], c[1], pose_z], yaw)]

        make = lambda j: [self._client.box(half, rgba)]  # noqa: E731
        self._pools.append(
            _Pool(self._client, row, self._slots(row, self.far), make, place, self.far)
        )

    def _build_scene(self) -> None:
        lay = self.layout
        asphalt = _disjoint(lay.asphalt)
        for i, r in enumerate(asphalt):
            self._add_surface(r, _BASE_Z, 0.0, _rgba((0.24, 0.24, 0.25), self._rng(2, i), 0.015))
        sidewalks = _disjoint(lay.sidewalks, minus=asphalt)
        kerbs = _kerb_strips(sidewalks, asphalt, 0.2)
        pavement = _rgba((0.6, 0.59, 0.56), self._rng(3), 0.01)
        for r in _disjoint(sidewalks, minus=kerbs):
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
        yaw = _quat_z(row.yaw)

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
            return [([c[0], c[1], 0.0], _quat_z(row.yaw + g.normal(0.0, 0.05)))]

        reach = min(self.far, _DASH_REACH)
        self._pools.append(_Pool(self._client, row, self._slots(row, reach), make, place, reach))

    def _add_structures(self, i: int, zone: Rect, asphalt: Sequence[Rect]) -> None:
        """Buildings and trees along a structure zone, lamp posts along its road side."""
        row, _, depth = self._long_row(zone, 12.0, 6.0, 6.0)
        if row.n == 0:
            return
        # Which side of the row faces the road: +1 if the road lies to its left.
        road = (
            np.array([[(a.x0 + a.x1) / 2, (a.y0 + a.y1) / 2] for a in asphalt])
            if asphalt
            else np.zeros((1, 2))
        )
        normal = np.array([-row.direction[1], row.direction[0]])
        rel = road - row.origin
        nearest = rel[np.argmin(np.abs(rel @ normal))] if len(asphalt) else -normal
        side = 1.0 if float(nearest @ normal) > 0 else -1.0
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
            yaw = _quat_z(row.yaw)
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
        # lamp posts every 30 m, 0.4 m inside the road side of the zone
        n_posts = int((row.length - 10.0) // 30.0) + 1
        if n_posts <= 0:
            return
        origin = row.origin + normal * side * (depth / 2 - 0.4)
        prow = _Row(origin, row.direction, row.length, 30.0, 10.0, n_posts, 1.5, 1.5)

        def place_post(k: int, j: int) -> list[Pose | None]:
            c = prow.point(k)
            return [([c[0], c[1], 0.0], _quat_z(prow.yaw))]

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

    def ground_z(self, xy: np.ndarray) -> np.ndarray:
        """Surface height (m) under world points ``xy`` (N, 2) where actors are drawn."""
        return self.layout.surface_height(xy)

    def _place_actors(self, actors: Mapping[int, Sequence[float]]) -> None:
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
            [[float(v) for v in actors[i][:4]] for i in ids], dtype=np.float64
        ).reshape(-1, 4)
        z = self.layout.surface_height(poses[:, :2])
        for aid, (x, y, heading, phase), zi in zip(ids, poses, z, strict=True):
            a = self._actors[aid]
            p.resetBasePositionAndOrientation(
                a.body, [x, y, float(zi)], _quat_z(heading), physicsClientId=cid
            )
            if a.joints:
                th = a.shape.swing_angles(phase)[a.parts]
                p.resetJointStatesMultiDof(
                    a.body, a.joints, [[float(t)] for t in th], physicsClientId=cid
                )
            a.visible = True

    # ------------------------------------------------------------------ frame
    def _window(self, ego_pose: Sequence[float], reach: float) -> np.ndarray:
        """World xy box [x0, y0, x1, y1] covering the camera's view sector out to ``reach`` m."""
        centre, _ = camera_world_pose(self.camera, ego_pose)
        t = float(ego_pose[2]) + self.camera.yaw + self._fan
        xs = np.concatenate([[centre[0]], centre[0] + reach * np.cos(t)])
        ys = np.concatenate([[centre[1]], centre[1] + reach * np.sin(t)])
        return np.array(
            [xs.min() - _MARGIN, ys.min() - _MARGIN, xs.max() + _MARGIN, ys.max() + _MARGIN]
        )

    def _update_scenery(self, ego_pose: Sequence[float], structures: bool) -> None:
        windows: dict[float, np.ndarray] = {}
        for pool in self._pools + (self._structures if structures else []):
            if pool.view_reach not in windows:
                windows[pool.view_reach] = self._window(ego_pose, pool.view_reach)
            pool.update(windows[pool.view_reach])
        if not structures:
            for pool in self._structures:
                pool.hide()

    def _light(self, ego_pose: Sequence[float]) -> list[float]:
        """Sun direction (world, toward the light): high, behind-left of the camera.

        Fixed relative to the camera so the EGL shader's specular glint never lands on
        the road ahead. The EGL plugin reads the vector as a light *position* (world), so
        it is pushed 1000 km away to act as a sun; TinyRenderer reads a direction.
        """
        h = float(ego_pose[2]) + self.camera.yaw
        lx, ly = -0.5, 0.12
        d = np.array([lx * np.cos(h) - ly * np.sin(h), lx * np.sin(h) + ly * np.cos(h), 1.0])
        d /= np.linalg.norm(d)
        return (d * (1e6 if self.backend == "egl" else 1.0)).tolist()

    def _capture(self, ego_pose: Sequence[float], window: tuple[int, int, int, int] | None = None) -> tuple:
        """``getCameraImage`` of the whole frame, or of the pixel ``window`` (u0, v0, u1, v1)
        only: the same pinhole with the principal point moved, so its pixels are exactly
        the frame's pixels there."""
        view = tuple(gl_view(self.camera, ego_pose).T.ravel().tolist())
        if not self._warm:  # the EGL plugin prints a banner on its first frame
            self._warm = True
            with _quiet_c_output():
                return self._capture(ego_pose, window)
        width, height, proj = self.camera.width, self.camera.height, self._proj
        if window is not None:
            u0, v0, u1, v1 = window
            width, height = u1 - u0, v1 - v0
            K = self.camera.K.copy()
            K[0, 2] -= u0
            K[1, 2] -= v0
            proj = tuple(_gl_projection(K, width, height, self.near, self.far, self._offset).T.ravel().tolist())
        return p.getCameraImage(
            width,
            height,
            view,
            proj,
            lightDirection=self._light(ego_pose),
            lightColor=[1.0, 1.0, 0.97],
            lightAmbientCoeff=0.55,
            lightDiffuseCoeff=0.5,
            lightSpecularCoeff=0.02,
            shadow=0,
            renderer=self._renderer_flag,
            physicsClientId=self._client.cid,
        )

    def _shape(self, buf, dtype) -> np.ndarray:
        return np.asarray(buf, dtype=dtype).reshape(self.camera.height, self.camera.width, -1)

    def render(
        self, ego_pose: Sequence[float], actors: Mapping[int, Sequence[float]]
    ) -> RenderResult:
        """Render one frame.

        Args:
            ego_pose: world (x, y, heading) of the ego-frame origin (m, rad).
            actors: id -> world (x, y, heading, gait_phase) of the actor-local origin;
                added actors not in the mapping are hidden.
        """
        self._place_actors(actors)
        self._update_scenery(ego_pose, structures=True)
        out = self._capture(ego_pose)
        raw = self._shape(out[4], np.int32)[..., 0]
        bg = raw < 0
        rgb = np.ascontiguousarray(self._shape(out[2], np.uint8)[..., :3])
        rgb[bg] = self._bg_rgb[bg]
        # GL depth d in [0, 1] -> metric z; 1 - d is exact in float32 where it matters.
        d = self._shape(out[3], np.float32)[..., 0]
        n, f = np.float32(self.near), np.float32(self.far)
        depth = (f * n) / (n + (f - n) * (np.float32(1.0) - d))
        np.minimum(depth, f, out=depth)
        depth[bg] = self._bg_depth[bg]
        return RenderResult(rgb=rgb, depth=depth, seg=self._lut[raw + 1])

    def silhouettes(
        self, ego_pose: Sequence[float], actors: Mapping[int, Sequence[float]], ids: Sequence[int],
        window: tuple[int, int, int, int] | None = None,
    ) -> np.ndarray:
        """(H, W) int32 segmentation of a frame with ONLY actors ``ids`` (no other actors,
        no roadside structures; the ground stays): their unoccluded silhouettes.

        ``window`` (u0, v0, u1, v1) px renders only that part of the frame (the rest is
        background, -1): enough when it holds the actors' boxes, and much cheaper."""
        self._place_actors({i: actors[i] for i in ids})
        self._update_scenery(ego_pose, structures=False)
        W, H = self.camera.width, self.camera.height
        if window is not None:
            u0, v0, u1, v1 = (int(v) for v in window)
            u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, W), min(v1, H)
            if u1 - u0 < 1 or v1 - v0 < 1:
                return np.full((H, W), -1, dtype=np.int32)
            if (u0, v0, u1, v1) != (0, 0, W, H):
                out = self._capture(ego_pose, (u0, v0, u1, v1))
                crop = np.asarray(out[4], dtype=np.int32).reshape(v1 - v0, u1 - u0)
                seg = np.full((H, W), -1, dtype=np.int32)
                seg[v0:v1, u0:u1] = self._lut[crop + 1]
                return seg
        out = self._capture(ego_pose)
        return self._lut[self._shape(out[4], np.int32)[..., 0] + 1]

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        self._client.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        with contextlib.suppress(Exception):
            self.close()


def _rgba(
    rgb: Sequence[float], rng: np.random.Generator | None = None, jitter: float = 0.0
) -> tuple:
    c = np.asarray(rgb, dtype=np.float64)
    if rng is not None and jitter > 0:
        c = c + rng.uniform(-jitter, jitter) + rng.uniform(-jitter / 3, jitter / 3, 3)
    r, g, b = (float(v) for v in np.clip(c, 0.0, 1.0))
    return (r, g, b, 1.0)
