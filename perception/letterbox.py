"""YOLO-style letterbox: resize keeping aspect ratio, pad with grey 114, and its inverse for boxes."""

from __future__ import annotations

import cv2
import numpy as np

PAD_VALUE = 114


def _hw(size: int | tuple[int, int]) -> tuple[int, int]:
    if isinstance(size, int | np.integer):
        return int(size), int(size)
    h, w = size
    return int(h), int(w)


def letterbox(
    image: np.ndarray, size: int | tuple[int, int], scale: float | None = None
) -> tuple[np.ndarray, float, tuple[float, float]]:
    """Fit ``image`` into ``size`` without distortion, centred on grey padding.

    Args:
        image: (H, W) or (H, W, C) uint8 image.
        size: target side (px) or (height, width).
        scale: resize factor (target px per source px); default, and at most, the largest
            that fits.

    Returns:
        ``(padded, scale, (pad_x, pad_y))``: the target-size image, the resize
        factor (target px per source px) and the left/top padding (px, whole
        numbers). A source point p maps to ``p * scale + pad``. The resized
        content is ``round(W * scale)`` x ``round(H * scale)`` px, so pixel
        content matches the point mapping to within half a target pixel.
    """
    th, tw = _hw(size)
    h, w = image.shape[:2]
    if h <= 0 or w <= 0:
        raise ValueError(f"letterbox: empty image of shape {image.shape}")
    fit = min(th / h, tw / w)
    scale = fit if scale is None else min(float(scale), fit)
    nw, nh = min(tw, round(w * scale)), min(th, round(h * scale))
    if (nw, nh) != (w, h):
        image = cv2.resize(image, (nw, nh), interpolation=cv2.INTER_LINEAR)
    dw, dh = (tw - nw) / 2.0, (th - nh) / 2.0
    left, top = round(dw - 0.1), round(dh - 0.1)
    right, bottom = tw - nw - left, th - nh - top
    if left or right or top or bottom:
        channels = 1 if image.ndim == 2 else image.shape[2]
        image = cv2.copyMakeBorder(
            image, top, bottom, left, right, cv2.BORDER_CONSTANT, value=(PAD_VALUE,) * channels
        )
    return image, float(scale), (float(left), float(top))


def padded_size(height: int, width: int, scale: float, multiple: int = 32) -> tuple[int, int]:
    """(height, width) of an image resized by ``scale`` and padded up to a ``multiple`` (px):
    the input of a model whose input size is dynamic ("rectangular" letterbox)."""
    def up(n: int) -> int:
        return max(multiple, -(-round(n * scale) // multiple) * multiple)

    return up(height), up(width)


def letterbox_boxes(xyxy: np.ndarray, scale: float, pad: tuple[float, float]) -> np.ndarray:
    """Map xyxy boxes (N, 4) from source pixels into letterboxed pixels."""
    b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    offset = np.array([pad[0], pad[1], pad[0], pad[1]])
    return b * scale + offset


def unletterbox_boxes(xyxy: np.ndarray, scale: float, pad: tuple[float, float]) -> np.ndarray:
    """Map xyxy boxes (N, 4) from letterboxed pixels back to source pixels (inverse of ``letterbox_boxes``)."""
    b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    offset = np.array([pad[0], pad[1], pad[0], pad[1]])
    return (b - offset) / scale
