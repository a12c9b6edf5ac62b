"""Small vectorised geometry helpers: 3D box corners and 2D box algebra.

3D boxes are (center xyz, size lwh, yaw) in a right-handed z-up frame (m, rad);
``size`` = (length along heading, width, height). 2D boxes are float xyxy pixels.
"""

from __future__ import annotations

import numpy as np

# Unit corners: bottom face 0-3 counter-clockwise from rear-right, top face 4-7 above them.
_UNIT_CORNERS = np.array(
    [
        [-0.5, -0.5, -0.5],
        [0.5, -0.5, -0.5],
        [0.5, 0.5, -0.5],
        [-0.5, 0.5, -0.5],
        [-0.5, -0.5, 0.5],
        [0.5, -0.5, 0.5],
        [0.5, 0.5, 0.5],
        [-0.5, 0.5, 0.5],
    ]
)


def rotation_2d(angle: float) -> np.ndarray:
    """2x2 matrix rotating ground vectors by ``angle`` (rad, counter-clockwise)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def nearest_x_extent(rel_yaw: np.ndarray, length: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Half extent (m) along a frame's x axis of footprints ``length`` x ``width`` turned by
    ``rel_yaw`` (rad) in it: how far beyond its centre an object's nearest face lies."""
    return 0.5 * (np.abs(np.cos(rel_yaw)) * length + np.abs(np.sin(rel_yaw)) * width)


def box_corners(center: np.ndarray, size: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Corners (N, 8, 3) of boxes with centers (N, 3), sizes (N, 3) and yaws (N,)."""
    center = np.asarray(center, dtype=np.float64).reshape(-1, 3)
    size = np.asarray(size, dtype=np.float64).reshape(-1, 3)
    yaw = np.asarray(yaw, dtype=np.float64).reshape(-1)
    local = _UNIT_CORNERS[None] * size[:, None, :]  # (N, 8, 3)
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    x = c * local[..., 0] - s * local[..., 1]
    y = s * local[..., 0] + c * local[..., 1]
    return np.stack([x, y, local[..., 2]], axis=-1) + center[:, None, :]


def box_area(boxes: np.ndarray) -> np.ndarray:
    """Areas (N,) of xyxy boxes; 0 for degenerate boxes."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return np.clip(b[:, 2] - b[:, 0], 0, None) * np.clip(b[:, 3] - b[:, 1], 0, None)


def grow_boxes(boxes: np.ndarray, min_size: float, buffer: float = 0.0) -> np.ndarray:
    """xyxy boxes (N, 4) grown about their centres: each side pushed out by ``buffer``
    times the box's width / height, then to at least ``min_size`` px wide and high
    (with ``buffer`` 0, sides already that long are unchanged)."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    centre = (b[:, :2] + b[:, 2:]) / 2.0
    half = np.maximum((b[:, 2:] - b[:, :2]) * (1.0 + 2.0 * buffer), min_size) / 2.0
    return np.concatenate([centre - half, centre + half], axis=1)


def intersection_areas(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) intersection areas (px^2) of xyxy boxes ``a`` (N, 4) and ``b`` (M, 4)."""
    lt = np.maximum(a[:, None, :2], b[None, :, :2])
    rb = np.minimum(a[:, None, 2:], b[None, :, 2:])
    wh = np.clip(rb - lt, 0, None)
    return wh[..., 0] * wh[..., 1]


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise IoU (N, M) of xyxy boxes ``a`` (N, 4) and ``b`` (M, 4)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    inter = intersection_areas(a, b)
    union = box_area(a)[:, None] + box_area(b)[None, :] - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(union > 0, inter / union, 0.0)


def ioa_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise intersection over the area of ``a`` (N, M): the fraction of each box of ``a``
    (N, 4, xyxy) inside each box of ``b`` (M, 4); 0 for an empty box of ``a``."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    area = box_area(a)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(area > 0, intersection_areas(a, b) / area, 0.0)


def clip_boxes(boxes: np.ndarray, width: int, height: int) -> np.ndarray:
    """xyxy boxes clipped to the image [0, width] x [0, height]."""
    b = np.array(boxes, dtype=np.float64).reshape(-1, 4)
    b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, width)
    b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, height)
    return b


def mask_boxes(labels: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tight xyxy boxes and pixel counts of each id in an integer label image.

    Args:
        labels: (H, W) integer image of object ids (anything else = background).
        ids: (N,) ids to measure.

    Returns:
        boxes (N, 4) float xyxy (pixel (i, j) spans [i, i+1) x [j, j+1); NaN when
        the id has no pixel) and counts (N,) int.
    """
    ids = np.asarray(ids).reshape(-1)
    boxes = np.full((len(ids), 4), np.nan)
    counts = np.zeros(len(ids), dtype=np.int64)
    if len(ids) == 0:
        return boxes, counts
    lab = np.asarray(labels)
    present = np.isin(lab, ids)
    rows, cols = np.nonzero(present)
    if len(rows) == 0:
        return boxes, counts
    vals = lab[rows, cols]
    order = np.argsort(ids)
    sorted_ids = ids[order]
    idx = order[np.searchsorted(sorted_ids, vals)]
    counts[:] = np.bincount(idx, minlength=len(ids))
    has = counts > 0
    inf = np.iinfo(np.int64).max
    x0 = np.full(len(ids), inf)
    y0 = np.full(len(ids), inf)
    x1 = np.full(len(ids), -1)
    y1 = np.full(len(ids), -1)
    np.minimum.at(x0, idx, cols)
    np.minimum.at(y0, idx, rows)
    np.maximum.at(x1, idx, cols)
    np.maximum.at(y1, idx, rows)
    boxes[has] = np.stack([x0[has], y0[has], x1[has] + 1, y1[has] + 1], axis=1)
    return boxes, counts
