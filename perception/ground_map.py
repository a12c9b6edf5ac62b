"""``GroundMap``: where the ground is raised above the road (pavements), and where the ego is.

A map with localisation, as a lane-level map gives a production stack: rectangles of raised
ground (a pavement's top ``height`` m above the road) in a map frame, and the pose of the ego
frame in it at this frame. The ranger (``perception.ranging``) finds a box's ground contact on
the surface its bottom ray meets first, not on the road plane: a pedestrian on a 0.15 m
pavement seen from a camera 1.4 m up is otherwise ranged about 11 % too far, and the scale
error turns the ego's own speed into a ground velocity the walker does not have.

Measured (``all`` suite, gt detector, 23 runs; ``EstimatorConfig.ground_map`` on against off):
range error median 0.023 -> 0.019 and p90 1.74 -> 1.37 m; ``kerbside_pedestrians`` median
0.068 -> 0.019; behaviour macro-F1 0.760 -> 0.815, accuracy 0.868 -> 0.867, risk accuracy 0.920
-> 0.922; correct primary target 0.960 -> 0.952. It is off by default because the pavement's
bias had been hiding others: cars and SUVs parked with their centre on the pavement are then
ranged from a correct ground cue fused with the *car's* height and width priors (1.50 / 1.80 m),
which an SUV (1.72 / 1.90 m) exceeds -- about 4 % short from a true box at 12-35 m, 1-2.5 m
short at 15-20 m once the gt detector's box noise dips the track, where the pavement's +11 % had
kept it long. Its outer edge then moves in and ``child_behind_parked_car`` reads the parked SUV in
path: a false critical alert and AEB brake at 2.1 s (without the map, a false FCW only); the
``cooperative`` suite's behaviour accuracy falls 0.987 -> 0.957. Ranging vehicles with their
learned height as well (which learns the SUV at 1.66 m) still braked at 2.5 s.

Frames and units: map frame (x, y, m; yaw rad, counter-clockwise); the ego frame is ISO 8855
(origin at the front bumper centre on the road, x forward, y left). Built by the simulator
(``sim.runner``) from its road layout; real video has none (``Frame.ground`` None).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.perception.geometry import rotation_2d


@dataclass(frozen=True)
class GroundMap:
    """Raised areas (K, 4) ``rects`` [x0, y0, x1, y1] (map frame, m) with their top ``heights``
    (K,) m above the road, and ``pose`` (x, y, yaw) of the ego frame's origin in the map frame."""

    rects: np.ndarray
    heights: np.ndarray
    pose: tuple[float, float, float]

    def height_at(self, xy: np.ndarray) -> np.ndarray:
        """Ground height (m) under ego-frame points ``xy`` (..., 2): the highest raised area
        containing each, 0 (the road) elsewhere."""
        x0, y0, yaw = self.pose
        m = np.asarray(xy, dtype=np.float64) @ rotation_2d(yaw).T + (x0, y0)  # map frame
        mx, my, r = m[..., 0], m[..., 1], self.rects
        inside = ((mx[..., None] >= r[:, 0]) & (mx[..., None] < r[:, 2])
                  & (my[..., None] >= r[:, 1]) & (my[..., None] < r[:, 3]))
        return np.max(np.where(inside, self.heights, 0.0), axis=-1, initial=0.0)

    def contact_heights(self, camera: CameraModel, uv: np.ndarray) -> np.ndarray:
        """Height (m) of the surface each pixel's ray (..., 2) meets first: of the levels in the map
        (the road's 0 and each raised area's top), the highest whose plane the ray meets over ground
        of that height. 0 where no raised area is met (or the ray misses the ground)."""
        uv = np.asarray(uv, dtype=np.float64)
        out = np.zeros(uv.shape[:-1])
        for h in np.unique(self.heights)[::-1]:
            if h <= 0.0:
                continue
            p = camera.ground_points(uv, ground_z=float(h))
            on = np.isfinite(p[..., 0]) & np.isclose(self.height_at(p[..., :2]), h) & (out == 0.0)
            out = np.where(on, h, out)
        return out
