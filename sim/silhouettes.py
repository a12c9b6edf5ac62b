"""Actors' unoccluded silhouettes: each actor alone, drawn by TinyRenderer in a client of its own.

Ground truth's visible fraction needs the pixels an actor would cover if nothing hid it
(``sim.groundtruth.with_visibility``). ``Silhouettes`` keeps one DIRECT PyBullet client per
actor holding only that actor's body (built on first use), because TinyRenderer transforms
every body of a client on every frame, hidden or not: alone, a small window costs ~0.1 ms,
where a client with a dozen actors costs ~1 ms and a pass in the full scene with EGL ~35 ms.
TinyRenderer's pixels agree with EGL's (the same pixel-centre convention: its principal
point shifted half a pixel; on ``urban_mix`` the median silhouette differs by 0 pixels, the
95th percentile by 1), so silhouettes need no EGL and can be drawn in any process.
Frames and poses as in ``sim.scene``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pybullet as p

from lookahead.perception.camera import CameraModel
from lookahead.sim.bullet import BulletClient
from lookahead.sim.gl_camera import TINY_OFFSET, gl_projection_window, gl_view
from lookahead.sim.layout import RoadLayout
from lookahead.sim.scene import Scene
from lookahead.sim.shapes import ActorShape


class Silhouettes:
    """Renders actors alone (see the module docstring).

    Args:
        camera: the frame's camera; layout: gives the surface height actors stand on;
        seed: the scene's seed; near, far: clip planes (m), as the renderer's.
    """

    def __init__(self, camera: CameraModel, layout: RoadLayout, seed: int, near: float = 1.0,
                 far: float = 250.0) -> None:
        self.camera, self.layout, self.seed = camera, layout, int(seed)
        self.near, self.far = float(near), float(far)
        self._shapes: dict[int, ActorShape] = {}
        self._scenes: dict[int, Scene] = {}  # actor id -> its body alone, built on first use

    def add_actor(self, actor_id: int, shape: ActorShape) -> None:
        self._shapes[actor_id] = shape

    def remove_actor(self, actor_id: int) -> None:
        self._shapes.pop(actor_id, None)
        scene = self._scenes.pop(actor_id, None)
        if scene is not None:
            scene.client.close()

    def _scene(self, actor_id: int) -> Scene:
        scene = self._scenes.get(actor_id)
        if scene is None:
            client = BulletClient(hidden_z=-4.0 * self.far)
            scene = Scene(client, self.camera, self.layout, self.seed, self.far, "tiny", static=False)
            scene.add_actor(actor_id, self._shapes[actor_id])
            self._scenes[actor_id] = scene
        return scene

    def __call__(
        self, ego_pose: Sequence[float], actors: Mapping[int, Sequence[float]], ids: Sequence[int],
        window: tuple[int, int, int, int] | None = None,
    ) -> np.ndarray:
        """(H, W) int32 segmentation of a frame with ONLY actors ``ids`` (no other actors and no
        static scene), the nearest where they overlap, -1 elsewhere. ``window`` (u0, v0, u1, v1)
        px renders only that part of the frame (the rest is -1): the same pixels there as a
        whole frame's (the pinhole with its principal point moved), and much cheaper.

        Args:
            ego_pose: world (x, y, heading) of the ego (m, rad); actors: id -> world
                (x, y, heading, gait phase) of every actor named in ``ids``.
        """
        W, H = self.camera.width, self.camera.height
        u0, v0, u1, v1 = (0, 0, W, H) if window is None else (int(v) for v in window)
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, W), min(v1, H)
        seg = np.full((H, W), -1, dtype=np.int32)
        if u1 - u0 < 1 or v1 - v0 < 1:
            return seg
        width, height, proj = gl_projection_window(self.camera, (u0, v0, u1, v1), self.near, self.far, TINY_OFFSET)
        view = tuple(gl_view(self.camera, ego_pose).T.ravel().tolist())
        crop, nearest = seg[v0:v1, u0:u1], np.full((height, width), np.inf, dtype=np.float32)
        for actor_id in ids:
            scene = self._scene(actor_id)
            scene.place_actors({actor_id: actors[actor_id]})
            out = p.getCameraImage(width, height, view, proj, shadow=0, renderer=p.ER_TINY_RENDERER,
                                   physicsClientId=scene.client.cid)
            here = scene.actor_ids(np.asarray(out[4], dtype=np.int32).reshape(height, width))
            depth = np.asarray(out[3], dtype=np.float32).reshape(height, width)
            front = (here >= 0) & (depth < nearest)
            crop[front], nearest[front] = here[front], depth[front]
        return seg

    def close(self) -> None:
        """Disconnect every actor's client (idempotent)."""
        for scene in self._scenes.values():
            scene.client.close()
        self._scenes = {}
