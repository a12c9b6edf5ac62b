"""PyBullet camera renderer: RGB, metric depth and actor segmentation for one ``CameraModel``.

The ``Renderer`` captures frames of a ``sim.scene.Scene`` (the road, scenery and actor
bodies it builds and poses in the same PyBullet client): the view and projection
matrices from the camera model, ``getCameraImage``, depth linearisation, the
segmentation decoded to actor ids, the composited ground and sky, and actor
silhouettes. DIRECT mode, no physics. Frames as in ``sim.scene``: world x along the
road, y left, z up (m); ego pose ``(x, y, heading)`` (m, rad); actor pose
``(x, y, heading, gait_phase)``.

The OpenGL projection is built from K, so a point ``CameraModel.project`` maps to
pixel (u, v) is drawn in pixel (floor(u), floor(v)) by both backends (TinyRenderer
samples pixel corners; its principal point is shifted half a pixel to match). Depth is
metric z along the optical axis (m). Segmentation holds actor ids, -1 for the static
scene and the sky. Beyond the modelled road an endless flat ground and a sky are
composited from the camera model (exact depth, no geometry), ``far`` for the sky.

Backends: "egl" (PyBullet's EGL plugin; with Mesa llvmpipe its depth buffer is 16-bit,
hence the default ``near`` of 1 m, and only one instance may live per process) and
"tiny" (TinyRenderer, CPU, float depth).
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from lookahead.perception.camera import CameraModel
from lookahead.sim.bullet import BulletClient, quiet_c_output
from lookahead.sim.gl_camera import TINY_OFFSET, gl_projection, gl_projection_window, gl_view
from lookahead.sim.layout import RoadLayout
from lookahead.sim.scene import Scene, camera_world_pose, ground_colour
from lookahead.sim.shapes import ActorShape
from lookahead.sim.silhouettes import Silhouettes

__all__ = ["RenderResult", "Renderer", "camera_world_pose", "gl_projection", "gl_view"]

log = logging.getLogger(__name__)

# PyBullet clients holding the EGL plugin. The plugin keeps process-global GL state: a
# second live instance leaves the first rendering empty frames, so only one may exist.
_EGL_CLIENTS: set[int] = set()
_EGL_LOADED = False  # the EGL plugin was loaded in this process (its GL threads may live on)


def egl_in_use() -> bool:
    """Whether an EGL renderer is open in this process (then no other may be)."""
    return bool(_EGL_CLIENTS)


def egl_loaded() -> bool:
    """Whether the EGL plugin was ever loaded in this process: a fork of it may then hang in
    GL (``sim.render_process`` starts its worker another way)."""
    return _EGL_LOADED


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
        self._client = BulletClient(hidden_z=-4.0 * self.far)
        self.backend = self._resolve_backend(backend)
        self._renderer_flag = (
            p.ER_BULLET_HARDWARE_OPENGL if self.backend == "egl" else p.ER_TINY_RENDERER
        )
        log.info("PyBullet renderer backend: %s (%dx%d)", self.backend, camera.width, camera.height)
        # TinyRenderer samples pixel corners rather than centres: shift by half a pixel.
        self._offset = TINY_OFFSET if self.backend == "tiny" else (0.0, 0.0)
        self._proj = tuple(gl_projection(camera, self.near, self.far, self._offset).T.ravel().tolist())
        self._warm = False
        self._bg_rgb, self._bg_depth = self._background()
        self.scene = Scene(self._client, camera, layout, self.seed, self.far, self.backend)
        self._silhouettes = Silhouettes(camera, layout, self.seed, self.near, self.far)

    # ------------------------------------------------------------------ backend
    def _resolve_backend(self, backend: str) -> str:
        if backend == "tiny":
            return "tiny"
        try:
            self._load_egl()
            return "egl"
        except Exception as exc:  # noqa: BLE001 - any EGL failure means fall back
            if backend == "egl":
                self._close_client()
                raise RuntimeError(f"EGL rendering unavailable: {exc}") from exc
            log.info("EGL renderer unavailable (%s); using TinyRenderer", exc)
            self._close_client()
            self._client = BulletClient(hidden_z=self._client.hidden_z)
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
        with quiet_c_output():
            plugin = p.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=cid)
            if plugin < 0:
                raise RuntimeError("loading _eglRendererPlugin failed")
            self._client.plugin = plugin
            _EGL_CLIENTS.add(self._client.cid)
            global _EGL_LOADED
            _EGL_LOADED = True
            eye = np.eye(4).ravel().tolist()
            proj = gl_projection(self.camera, self.near, self.far).T.ravel().tolist()
            out = p.getCameraImage(
                32, 24, eye, proj, renderer=p.ER_BULLET_HARDWARE_OPENGL, physicsClientId=cid
            )
        if np.asarray(out[2]).size != 32 * 24 * 4:
            raise RuntimeError("EGL test frame has the wrong size")

    # ------------------------------------------------------------------ composited background
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
        z = cam.ground_depth()
        hit = np.isfinite(z)
        elev = np.arcsin(np.clip(rays[..., 2], -1.0, 1.0))[..., None]
        top, horizon = np.array([70, 120, 190.0]), np.array([190, 210, 228.0])
        sky = horizon + (top - horizon) * np.sqrt(np.clip(elev / 0.6, 0.0, 1.0))
        base = ground_colour(self.seed) * 200.0
        dist = np.where(hit, z, np.inf)[..., None]
        haze = 1.0 - np.exp(-dist / 400.0)
        grass = base + (horizon * 0.9 - base) * haze
        rgb = np.where(hit[..., None], grass, sky)
        depth = np.where(hit, np.minimum(z, self.far), self.far)
        return np.clip(rgb, 0, 255).astype(np.uint8), depth.astype(np.float32)

    # ------------------------------------------------------------------ actors
    def add_actor(self, actor_id: int, shape: ActorShape) -> None:
        """Create the body of actor ``actor_id`` (hidden until rendered with a pose)."""
        self.scene.add_actor(actor_id, shape)
        self._silhouettes.add_actor(actor_id, shape)

    def remove_actor(self, actor_id: int) -> None:
        """Delete actor ``actor_id``'s body; unknown ids are ignored."""
        self.scene.remove_actor(actor_id)
        self._silhouettes.remove_actor(actor_id)

    def ground_z(self, xy: np.ndarray) -> np.ndarray:
        """Surface height (m) under world points ``xy`` (N, 2) where actors are drawn."""
        return self.layout.surface_height(xy)

    # ------------------------------------------------------------------ frame
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
            with quiet_c_output():
                return self._capture(ego_pose, window)
        width, height, proj = self.camera.width, self.camera.height, self._proj
        if window is not None:
            width, height, proj = gl_projection_window(self.camera, window, self.near, self.far, self._offset)
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
        self.scene.place_actors(actors)
        self.scene.show_scenery(ego_pose, structures=True)
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
        return RenderResult(rgb=rgb, depth=depth, seg=self.scene.actor_ids(raw))

    def silhouettes(
        self, ego_pose: Sequence[float], actors: Mapping[int, Sequence[float]], ids: Sequence[int],
        window: tuple[int, int, int, int] | None = None,
    ) -> np.ndarray:
        """(H, W) int32 segmentation of a frame with ONLY actors ``ids`` (no other actors and no
        static scene): their unoccluded silhouettes, -1 elsewhere; ``window`` (u0, v0, u1, v1)
        px renders only that part (the same pixels there). Drawn by ``sim.silhouettes``
        (TinyRenderer, each actor alone in a client of its own), whatever the backend."""
        return self._silhouettes(ego_pose, actors, ids, window)

    def close(self) -> None:
        """Disconnect the PyBullet clients (idempotent)."""
        self._close_client()

    def _close_client(self) -> None:
        """Give back the EGL slot (if this client held it), unload the plugin, disconnect."""
        _EGL_CLIENTS.discard(self._client.cid)
        self._client.close()
        silhouettes = getattr(self, "_silhouettes", None)  # absent while __init__ falls back
        if silhouettes is not None:
            silhouettes.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        with contextlib.suppress(Exception):
            self.close()
