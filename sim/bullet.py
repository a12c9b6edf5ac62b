"""A DIRECT PyBullet client and the massless compound bodies the scene is made of.

Every call names its ``physicsClientId``, so several clients live side by side. Bodies
have mass 0 and no collision shapes: they are posed each frame, never simulated.
Positions in m (world frame, z up), quaternions xyzw (PyBullet's order).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

Pose = tuple[list[float], list[float]]  # position xyz, quaternion xyzw
QUAT_ID = (0.0, 0.0, 0.0, 1.0)


def quat_z(a: float) -> list[float]:
    """Quaternion (xyzw) of a rotation by ``a`` rad about z."""
    return [0.0, 0.0, float(np.sin(a / 2)), float(np.cos(a / 2))]


@contextlib.contextmanager
def quiet_c_output() -> Iterator[None]:
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

@dataclass(frozen=True)
class Link:
    """One visual part of a compound body: shape, colour, link-frame origin (relative to
    the base), visual offset/orientation inside the link, and whether it swings about y."""

    shape: int
    dims: tuple[float, ...]  # box half extents / (radius, length) / (radius,)
    rgba: tuple[float, float, float, float]
    origin: tuple[float, float, float]
    vis_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    vis_orn: tuple[float, float, float, float] = QUAT_ID
    revolute: bool = False


class BulletClient:
    """A DIRECT PyBullet client with helpers; every call names its physicsClientId.

    ``hidden_z``: height (m) where hidden bodies are parked, below every view.
    ``plugin``: id of a plugin loaded into the client (the renderer's EGL), -1 for none.
    """

    def __init__(self, hidden_z: float) -> None:
        self.cid = p.connect(p.DIRECT)
        if self.cid < 0:
            raise RuntimeError("could not connect to a PyBullet DIRECT server")
        self.hidden_z = hidden_z
        self.plugin = -1

    def visual(self, link: Link) -> int:
        """A visual shape for ``link`` (its id)."""
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

    def body(self, links: Sequence[Link]) -> int:
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
            linkOrientations=[list(QUAT_ID)] * n,
            linkInertialFramePositions=[[0.0, 0.0, 0.0]] * n,
            linkInertialFrameOrientations=[list(QUAT_ID)] * n,
            linkParentIndices=[0] * n,
            linkJointTypes=[p.JOINT_REVOLUTE if lk.revolute else p.JOINT_FIXED for lk in links],
            linkJointAxis=[[0.0, 1.0, 0.0]] * n,
            physicsClientId=self.cid,
        )

    def box(self, half: Sequence[float], rgba: Sequence[float]) -> int:
        """A single box body with half extents ``half`` (m), hidden."""
        return self.body(
            [Link(p.GEOM_BOX, tuple(float(h) for h in half), tuple(rgba), (0.0, 0.0, 0.0))]
        )  # type: ignore[arg-type]

    def pose(self, body: int, pose: Pose | None) -> None:
        """Place ``body`` at ``pose`` (world), or hide it when None."""
        if pose is None:
            self.hide(body)
        else:
            p.resetBasePositionAndOrientation(body, pose[0], pose[1], physicsClientId=self.cid)

    def hide(self, body: int) -> None:
        """Park ``body`` at ``hidden_z``, out of view."""
        p.resetBasePositionAndOrientation(
            body, [0.0, 0.0, self.hidden_z], QUAT_ID, physicsClientId=self.cid
        )

    def close(self) -> None:
        """Unload the plugin (if any) and disconnect, quietly (idempotent)."""
        if self.cid >= 0:
            with quiet_c_output(), contextlib.suppress(Exception):
                if self.plugin >= 0:
                    p.unloadPlugin(self.plugin, physicsClientId=self.cid)
                p.disconnect(self.cid)
            self.cid = -1
