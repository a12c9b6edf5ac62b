"""A top-down picture of tracked objects in the ego frame, for envs and tools without a camera.

Ego frame (architecture page): x forward, y left, metres. The picture is RGB uint8, the ego's
front bumper at the bottom centre, forward up and left to the left, ``M_PER_PX`` metres per
pixel: grey range lines every 10 m, the ego's corridor (``corridor_half_width`` each side of
its centre line) as two lines, and each object with a finite range as a box
``2 * half_width`` wide and ``length_m`` long (tracks carry no length: the env passes the
estimator's class prior) from its nearest point, filled in its risk's colour.
"""

from __future__ import annotations

import cv2
import numpy as np

from lookahead.intent.labels import risk_colour

M_PER_PX = 0.25
SIZE_PX = (360, 160)  # (height, width): 90 m ahead, 20 m to each side
MIN_HALF_WIDTH_M = 0.25
BACKGROUND, GRID, CORRIDOR, EGO = (30, 30, 30), (70, 70, 70), (110, 110, 160), (220, 220, 220)


def to_pixel(x: np.ndarray, y: np.ndarray, size: tuple[int, int] = SIZE_PX) -> tuple[np.ndarray, np.ndarray]:
    """Ego-frame x forward, y left (m) -> picture column, row (px, float)."""
    h, w = size
    return w / 2 - np.asarray(y, float) / M_PER_PX, h - np.asarray(x, float) / M_PER_PX


def birdseye(
    range_m: np.ndarray, lateral_m: np.ndarray, half_width_m: np.ndarray, length_m: np.ndarray,
    risk: np.ndarray, corridor_half_width: float, size: tuple[int, int] = SIZE_PX,
) -> np.ndarray:
    """(H, W, 3) uint8 RGB top-down picture of objects (module docstring); (N,) arrays, NaN
    ranges or laterals skipped, NaN half widths drawn at ``MIN_HALF_WIDTH_M``."""
    h, w = size
    img = np.empty((h, w, 3), np.uint8)
    img[:] = BACKGROUND
    for x in np.arange(10.0, h * M_PER_PX, 10.0):
        _, row = to_pixel(x, 0.0, size)
        cv2.line(img, (0, int(round(row))), (w - 1, int(round(row))), GRID, 1)
    for side in (-1.0, 1.0):
        col, _ = to_pixel(0.0, side * corridor_half_width, size)
        cv2.line(img, (int(round(col)), 0), (int(round(col)), h - 1), CORRIDOR, 1)
    ego_col, _ = to_pixel(0.0, 0.0, size)
    cv2.rectangle(img, (int(round(ego_col - 0.9 / M_PER_PX)), h - 3), (int(round(ego_col + 0.9 / M_PER_PX)), h - 1),
                  EGO, -1)
    rng, lat = np.asarray(range_m, float), np.asarray(lateral_m, float)
    half = np.nan_to_num(np.asarray(half_width_m, float), nan=MIN_HALF_WIDTH_M)
    half = np.maximum(half, MIN_HALF_WIDTH_M)
    for i in np.flatnonzero(np.isfinite(rng) & np.isfinite(lat)):
        c0, r_near = to_pixel(rng[i], lat[i] + half[i], size)
        c1, r_far = to_pixel(rng[i] + length_m[i], lat[i] - half[i], size)
        colour = risk_colour(int(risk[i]))
        cv2.rectangle(img, (int(round(c0)), int(round(r_far))), (int(round(c1)), int(round(r_near))), colour, -1)
    return img
