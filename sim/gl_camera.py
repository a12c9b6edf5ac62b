"""OpenGL view and projection matrices of a ``CameraModel`` (PyBullet's renderers take them).

Frames as in ``sim.scene``: world x along the road, y left, z up (m); ego pose
``(x, y, heading)``; the GL camera looks down -z with x right and y up. The projection
is built from K, so a point ``CameraModel.project`` maps to pixel (u, v) is drawn in pixel
(floor(u), floor(v)) -- by TinyRenderer too once its principal point is shifted by
``TINY_OFFSET`` (it samples pixel corners rather than centres).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.sim.scene import camera_world_pose

TINY_OFFSET = (-0.5, 0.5)  # px added to TinyRenderer's principal point: it samples pixel corners


def gl_projection(
    camera: CameraModel, near: float, far: float, offset: tuple[float, float] = (0.0, 0.0)
) -> np.ndarray:
    """4x4 OpenGL projection (GL camera: x right, y up, z back) equal to the pinhole K.

    ``offset`` (du, dv) pixels is added to the principal point (rasteriser sampling fixes).
    """
    return _gl_projection(camera.K, camera.width, camera.height, near, far, offset)


def gl_projection_window(
    camera: CameraModel, window: tuple[int, int, int, int], near: float, far: float,
    offset: tuple[float, float] = (0.0, 0.0),
) -> tuple[int, int, tuple[float, ...]]:
    """Width, height and column-major GL projection of the pixel ``window`` (u0, v0, u1, v1):
    the camera's pinhole with the principal point moved, so its pixels are the frame's there."""
    u0, v0, u1, v1 = window
    K = camera.K.copy()
    K[0, 2] -= u0
    K[1, 2] -= v0
    proj = _gl_projection(K, u1 - u0, v1 - v0, near, far, offset)
    return u1 - u0, v1 - v0, tuple(proj.T.ravel().tolist())


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


def gl_view(camera: CameraModel, ego_pose: Sequence[float]) -> np.ndarray:
    """4x4 OpenGL view matrix (world -> GL camera) for the camera on an ego at ``ego_pose``."""
    centre, r_cw = camera_world_pose(camera, ego_pose)
    r_gl = np.diag([1.0, -1.0, -1.0]) @ r_cw
    v = np.eye(4)
    v[:3, :3] = r_gl
    v[:3, 3] = -r_gl @ centre
    return v
