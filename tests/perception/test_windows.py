"""Zoom windows: pixel windows, the interior rule and the merge of window detections."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.detections import Detections
from lookahead.perception.detectors.windows import (
    DEFAULT_WINDOWS,
    KEEP_HEIGHT_FRACTION,
    MAX_HEIGHT_FRACTION,
    check_windows,
    interior,
    merge_windows,
    window_pixels,
    window_zoom,
)

W, H = 640, 360
WIN = np.array([160, 80, 480, 272])  # the default window on a 640 x 360 frame


def dets(*rows: tuple[float, float, float, float, float, int]) -> Detections:
    a = np.array(rows, dtype=np.float64).reshape(-1, 6)
    return Detections(xyxy=a[:, :4], score=a[:, 4], class_id=a[:, 5].astype(np.int64))


def test_the_default_window_is_the_middle_half_around_the_horizon_at_2x():
    assert window_pixels(DEFAULT_WINDOWS, W, H).tolist() == [WIN.tolist()]
    x0, y0, x1, y1 = WIN
    assert (640 / (x1 - x0), 384 / (y1 - y0)) == (2.0, 2.0)  # the shipped model's input


def test_bad_windows_are_named_with_what_was_expected():
    with pytest.raises(ValueError, match=r"window 1: fractions of the image .* got \[0.5, 0.0, 0.2, 1.0\]"):
        check_windows([(0, 0, 1, 1), (0.5, 0.0, 0.2, 1.0)])
    with pytest.raises(ValueError, match="window 0: four numbers x0 y0 x1 y1"):
        check_windows([(0.1, 0.2, 0.3)])
    assert check_windows([]) == ()


def test_windows_too_small_to_hold_anything_are_left_out():
    assert window_pixels([(0.5, 0.5, 0.505, 0.6)], W, H).shape == (0, 4)


def test_a_box_is_interior_unless_it_comes_within_a_pixel_of_a_window_edge_inside_the_image():
    boxes = np.array([[200, 100, 220, 140], [160.5, 100, 180, 140], [470, 100, 479.5, 140]])
    assert interior(boxes, WIN, W, H).tolist() == [True, False, False]
    # an edge that is the image's own cuts nothing
    whole_width = np.array([0, 80, 640, 272])
    assert interior(np.array([[0, 100, 20, 140], [630, 100, 640, 140]]), whole_width, W, H).tolist() == [True, True]


def test_small_objects_inside_a_window_are_the_windows_the_rest_the_whole_frames():
    assert MAX_HEIGHT_FRACTION * (WIN[3] - WIN[1]) == 48  # px
    assert KEEP_HEIGHT_FRACTION * (WIN[3] - WIN[1]) == 60  # px
    frame = dets(
        (300, 150, 306, 170, 0.6, 0),  # small, inside the window: replaced
        (10, 200, 90, 260, 0.9, 4),  # outside: kept
        (440, 120, 560, 220, 0.8, 4),  # across the window's right edge: kept
        (200, 100, 260, 170, 0.85, 4),  # inside, but 70 px tall: kept
    )
    window = dets(
        (300.5, 151, 305.5, 169, 0.7, 0),  # the small one, better boxed
        (320, 140, 328, 160, 0.4, 1),  # one the whole frame missed
        (440, 120, 480, 220, 0.9, 4),  # the cut one, cut by the window's edge: dropped
        (201, 101, 259, 169, 0.95, 4),  # the 70 px one: the whole frame's, dropped
    )
    merged = merge_windows(frame, [window], WIN[None], W, H, 0.45, 300)
    assert merged.xyxy.tolist() == [
        [10, 200, 90, 260], [200, 100, 260, 170], [440, 120, 560, 220], [300.5, 151, 305.5, 169], [320, 140, 328, 160]
    ]
    assert merged.score.tolist() == [0.9, 0.85, 0.8, 0.7, 0.4]


@pytest.mark.parametrize(
    ("frame_box", "window_box"),
    [
        # the whole frame boxes the car 47 px tall (the window's to take), the window 49 px
        ((325, 146, 387, 193), (326, 145, 388, 194)),
        # the whole frame's box is 4 px inside the window, the window's on its edge
        ((164.3, 161.5, 254.3, 208.8), (160.0, 161.8, 256.8, 209.0)),
    ],
)
def test_an_object_the_two_views_box_either_side_of_the_hand_off_is_kept_once(frame_box, window_box):
    # One line between the views dropped both boxes of these cars (clear test split).
    frame = dets((*frame_box, 0.9, 4))
    window = dets((*window_box, 0.8, 4))
    merged = merge_windows(frame, [window], WIN[None], W, H, 0.45, 300)
    assert len(merged) == 1 and merged.xyxy[0].tolist() in (list(frame_box), list(window_box))


def test_overlapping_windows_do_not_double_an_object():
    wins = np.array([[100, 80, 400, 272], [240, 80, 540, 272]])
    a = dets((300, 150, 306, 170, 0.7, 0))
    b = dets((300.2, 150.5, 306, 170, 0.6, 0))
    merged = merge_windows(Detections.empty(), [a, b], wins, W, H, 0.45, 300)
    assert len(merged) == 1 and merged.score[0] == 0.7


def test_a_window_may_ask_for_a_zoom_and_a_bad_one_is_named():
    assert check_windows([(0.25, 0.35, 0.75, 0.62, 3)]) == ((0.25, 0.35, 0.75, 0.62, 3.0),)
    assert window_zoom((0.25, 0.35, 0.75, 0.62, 3)) == 3.0 and window_zoom(DEFAULT_WINDOWS[0]) is None
    assert window_pixels([(0.25, 0.35, 0.75, 0.62, 3)], W, H).tolist() == [[160, 126, 480, 223]]
    with pytest.raises(ValueError, match=r"window 0: zoom \(input px per image px\) in \(0, 8\] expected, got 0"):
        check_windows([(0.25, 0.35, 0.75, 0.62, 0)])
    with pytest.raises(ValueError, match="window 0: four numbers x0 y0 x1 y1 and an optional zoom"):
        check_windows([(0.25, 0.35, 0.75, 0.62, 3, 1)])


def test_nested_windows_hand_an_object_to_the_most_magnified_view_that_holds_it_whole():
    fine = np.array([160, 128, 480, 224])  # 3x: owns boxes under 24 px tall inside it
    frame = dets((300, 150, 303, 162, 0.5, 0))
    coarse = dets(
        (300.2, 150, 303, 162, 0.6, 0),  # the small one: the fine window's, dropped here
        (300.1, 150, 302.9, 161.5, 0.55, 1),  # the same, another class: dropped too, no duplicate
        (200, 140, 212, 170, 0.8, 0),  # 30 px tall: too big for the fine window, the coarse one's
    )
    finer = dets((300.4, 150.2, 303.1, 162.2, 0.7, 0), (200, 140, 212, 170, 0.9, 0))
    merged = merge_windows(frame, [coarse, finer], np.array([WIN, fine]), W, H, 0.45, 300, magnification=[2.0, 3.0])
    assert merged.xyxy.tolist() == [[200, 140, 212, 170], [300.4, 150.2, 303.1, 162.2]]
    assert merged.score.tolist() == [0.8, 0.7]
