"""Letterbox geometry: padding, scale and the exact box round trip."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.letterbox import PAD_VALUE, letterbox, letterbox_boxes, unletterbox_boxes


def test_wide_image_into_square() -> None:
    img = np.random.default_rng(0).integers(0, 255, (360, 640, 3), dtype=np.uint8)
    out, scale, pad = letterbox(img, 640)
    assert out.shape == (640, 640, 3) and out.dtype == np.uint8
    assert scale == 1.0 and pad == (0.0, 140.0)
    assert np.all(out[:140] == PAD_VALUE) and np.all(out[500:] == PAD_VALUE)
    np.testing.assert_array_equal(out[140:500], img)


@pytest.mark.parametrize(
    ("hw", "size"),
    [
        ((360, 640), 416),
        ((640, 360), 320),
        ((100, 100), 640),
        ((375, 1242), (384, 640)),
        ((7, 5), 32),
    ],
)
def test_box_round_trip(hw: tuple[int, int], size: int | tuple[int, int]) -> None:
    rng = np.random.default_rng(1)
    img = np.zeros((*hw, 3), dtype=np.uint8)
    out, scale, pad = letterbox(img, size)
    th, tw = (size, size) if isinstance(size, int) else size
    assert out.shape[:2] == (th, tw)
    xy = rng.uniform(0, 1, (50, 2)) * [hw[1], hw[0]]
    boxes = np.concatenate([xy, xy + rng.uniform(1, 50, (50, 2))], axis=1)
    fwd = letterbox_boxes(boxes, scale, pad)
    assert np.all(fwd[:, [0, 2]] >= pad[0] - 1e-9) and np.all(fwd[:, [1, 3]] >= pad[1] - 1e-9)
    np.testing.assert_allclose(unletterbox_boxes(fwd, scale, pad), boxes, atol=1e-9)


def test_pixel_content_matches_mapping() -> None:
    img = np.zeros((360, 640, 3), dtype=np.uint8)
    img[100:200, 300:420] = 255
    out, scale, pad = letterbox(img, 416)
    ys, xs = np.nonzero(out[:, :, 0] > 127)
    found = np.array([[xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]], dtype=float)
    back = unletterbox_boxes(found, scale, pad)
    np.testing.assert_allclose(back, [[300, 100, 420, 200]], atol=1.0 / scale + 1e-9)
    assert np.all(out[: int(pad[1])] == PAD_VALUE)


def test_grayscale() -> None:
    out, scale, pad = letterbox(np.zeros((50, 100), dtype=np.uint8), 64)
    assert out.shape == (64, 64) and scale == 0.64 and pad == (0.0, 16.0)
