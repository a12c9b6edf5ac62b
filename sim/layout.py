"""``RoadLayout``: what the renderer draws of the road, in the world frame.

World frame: right-handed, z up, x along the main road, y to the left (m).
Built by ``sim.road`` from the highway-env network; read by ``sim.renderer``. Also
``ego_frame``, the world -> ego frame transform (light: no simulator import).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from lookahead.perception.ground_map import GroundMap


@dataclass(frozen=True)
class Marking:
    """A painted line from ``start`` to ``end`` (world xy, m), ``width`` m wide.

    ``dashed``: 3 m dashes every 9 m (a 3 m paint / 6 m gap pattern) when True,
    continuous otherwise.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    width: float = 0.15
    dashed: bool = False


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in the world xy plane: x0 < x1, y0 < y1 (m)."""

    x0: float
    y0: float
    x1: float
    y1: float

    def long_axis(self) -> tuple[np.ndarray, np.ndarray, float, float]:
        """(start, unit direction, length, depth) of the centre line along the long side:
        ``start`` (world xy, m) is where that line enters the rectangle, ``depth`` is the
        short side (m)."""
        cx, cy = (self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2
        lx, ly = self.x1 - self.x0, self.y1 - self.y0
        if lx >= ly:
            return np.array([self.x0, cy]), np.array([1.0, 0.0]), lx, ly
        return np.array([cx, self.y0]), np.array([0.0, 1.0]), ly, lx


@dataclass(frozen=True)
class RoadLayout:
    """Everything static the camera sees.

    asphalt: driveable surface rectangles (z = 0).
    sidewalks: raised pavement rectangles (top at ``kerb_height``).
    markings: lane lines painted on the asphalt.
    structure_zones: rectangles beyond the pavements where roadside structures
        (buildings, poles, trees) may be placed, seeded by the scenario seed.
    """

    asphalt: tuple[Rect, ...]
    sidewalks: tuple[Rect, ...] = ()
    markings: tuple[Marking, ...] = ()
    structure_zones: tuple[Rect, ...] = ()
    kerb_height: float = 0.15
    extra: dict = field(default_factory=dict)

    def surface_height(self, xy: np.ndarray) -> np.ndarray:
        """Height (m) of the surface under world points ``xy`` (N, 2): ``kerb_height``
        on sidewalks, 0 elsewhere. Actors stand on it (renderer and ground truth alike)."""
        return self.ground_map((0.0, 0.0, 0.0)).height_at(np.asarray(xy, dtype=np.float64).reshape(-1, 2))

    def ground_map(self, pose: tuple[float, float, float]) -> GroundMap:
        """The raised ground (the sidewalks at ``kerb_height``) as perception's map, with the pose
        (world x, y, yaw) of the ego frame that looks at it (``perception.ground_map``)."""
        rects, heights = self._raised
        return GroundMap(rects, heights, tuple(float(v) for v in pose))

    @cached_property
    def _raised(self) -> tuple[np.ndarray, np.ndarray]:
        """The sidewalks (K, 4) [x0, y0, x1, y1] and their heights (K,), built once."""
        rects = np.array([[s.x0, s.y0, s.x1, s.y1] for s in self.sidewalks], dtype=np.float64).reshape(-1, 4)
        return rects, np.full(len(rects), self.kerb_height)

    def bounds(self) -> np.ndarray:
        """[x0, y0, x1, y1] of everything in the layout (m)."""
        rects = list(self.asphalt) + list(self.sidewalks) + list(self.structure_zones)
        a = np.array([[r.x0, r.y0, r.x1, r.y1] for r in rects])
        return np.array([a[:, 0].min(), a[:, 1].min(), a[:, 2].max(), a[:, 3].max()])


def ego_frame(
    origin: np.ndarray, yaw: float, xy: np.ndarray
) -> np.ndarray:
    """World xy (N, 2) -> ego-frame xy (N, 2) for an ego frame at ``origin`` with ``yaw``."""
    c, s = np.cos(yaw), np.sin(yaw)
    d = np.asarray(xy, dtype=np.float64).reshape(-1, 2) - origin
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)
