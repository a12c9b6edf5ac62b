"""The top-down picture: objects where the ego frame puts them, in their risk's colour."""

from __future__ import annotations

import numpy as np

from lookahead.intent.labels import risk_colour
from lookahead.sim.birdseye import BACKGROUND, SIZE_PX, birdseye, to_pixel


def test_left_is_left_far_is_up_and_each_object_wears_its_risk():
    img = birdseye(range_m=np.array([20.0, 40.0, np.nan]), lateral_m=np.array([3.0, -1.0, 0.0]),
                   half_width_m=np.array([0.9, np.nan, 0.9]), length_m=np.array([4.5, 0.3, 4.5]), risk=np.array([4, 2, 4]),
                   corridor_half_width=1.4)
    assert img.shape == (*SIZE_PX, 3) and img.dtype == np.uint8
    h, w = SIZE_PX
    col, row = to_pixel(21.0, 3.0)  # 1 m into the first object's box (a car, 4.5 m long)
    assert col < w / 2 and row == h - 21.0 / 0.25
    assert tuple(img[int(row), int(col)]) == risk_colour(4)
    col, row = to_pixel(40.15, -1.0)  # the second (a pedestrian, 0.3 m), right of centre and further up
    assert col > w / 2 and row < h - 80
    assert tuple(img[int(row), int(col)]) == risk_colour(2)
    # the object with no range is not drawn: only the first object is in the risk-4 colour
    red = np.all(img == risk_colour(4), axis=-1)
    rows, cols = np.nonzero(red)
    assert cols.max() < w / 2 and rows.min() >= int(h - 24.5 / 0.25) - 1 and rows.max() <= h - 20.0 / 0.25 + 1


def test_an_empty_scene_is_the_background_grid_corridor_and_ego():
    img = birdseye(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, int), corridor_half_width=1.4)
    assert tuple(img[5, 5]) == BACKGROUND
    assert not np.any(np.all(img == risk_colour(4), axis=-1))
    col, _ = to_pixel(0.0, 1.4)
    assert tuple(img[100, int(round(col))]) != BACKGROUND  # the corridor line
