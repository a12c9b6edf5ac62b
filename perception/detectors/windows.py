"""Zoom windows: a detector also run on magnified regions of the frame (SAHI-style slicing).

A window is a region of the image given as fractions of its width and height,
``(x0, y0, x1, y1)`` in [0, 1], optionally followed by a ``zoom``: model-input pixels per
image pixel. The detector sees it cropped and resized like a whole frame. Without a
zoom it is letterboxed into the model's input, so it is magnified by input size / window
size: the default window, the middle half of a 640 x 360 frame around the horizon
(160..480 x 80..272 px), reaches a 640 x 384 input at 2x. With a zoom, a model whose
input size is dynamic sees the window at exactly that magnification (padded to a
multiple of 32 px), so a flat band costs its own area, not a whole input; a model with
a fixed input caps the zoom at what fits. Distant objects -- a pedestrian at 40 m is
3 px wide -- are what a detector at 640 x 360 misses most, and magnified 2x they cover
four times the pixels.

Merging (``merge_windows``): each object is left to the view that sees it at a good
scale (as SNIP trains and tests each scale of an image pyramid on the objects of its
valid range). A window *keeps* its boxes that are interior to it -- each side at least
``EDGE_PX`` inside the window's edge, or that edge is the image's own -- and shorter than
``KEEP_HEIGHT_FRACTION`` of its height: small, whole, magnified; it drops the rest (cut by
it, or big enough for the whole frame). The whole frame *gives way* -- drops its box --
only where the window surely keeps it: at least ``GIVE_WAY_EDGE_PX`` inside and shorter
than ``MAX_HEIGHT_FRACTION``. The two tests overlap on purpose (hysteresis): the two
views box one object a few pixels apart, and with a single line between them a car the
whole frame boxed 47 px tall and the window 49 px, or 4 px inside the window and on its
edge, was dropped by both. In the overlap both boxes stay and per-class NMS keeps one,
as it resolves overlapping windows.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lookahead.perception.detections import Detections
from lookahead.perception.nms import nms

#: The middle half of the frame's width, 53 % of its height, just below the middle (the
#: horizon of a camera pitched 2 deg down): 160..480 x 80..272 px of a 640 x 360 frame.
DEFAULT_WINDOWS: tuple[tuple[float, float, float, float], ...] = ((0.25, 2 / 9, 0.75, 34 / 45),)

#: A box this close (px) to a window edge inside the image counts as cut by the window.
EDGE_PX = 1.0

#: A less magnified view gives a box up to a window only at least this far (px) inside its edge.
GIVE_WAY_EDGE_PX = 7.0

#: A less magnified view gives way to a window only for boxes shorter than this fraction of
#: the window's height (48 px of the default window's 192 at 640 x 360; 96 px of the model's
#: input once magnified).
MAX_HEIGHT_FRACTION = 0.25

#: A window keeps its boxes shorter than this fraction of its height (60 px of 192).
KEEP_HEIGHT_FRACTION = 0.3125

#: Smallest window side (px); a smaller region holds nothing worth a detector run.
MIN_WINDOW_PX = 8

#: Largest zoom (input px per image px) a window may ask for.
MAX_ZOOM = 8.0

#: A window: x0, y0, x1, y1 as fractions of the image, optionally a zoom (input px per image px).
Window = tuple[float, ...]


def check_windows(windows: Sequence[Sequence[float]]) -> tuple[Window, ...]:
    """``windows`` as a tuple of 4- or 5-tuples of floats, or ``ValueError`` naming the first bad one."""
    out = []
    for i, w in enumerate(windows):
        try:
            vals = tuple(float(v) for v in w)
        except (TypeError, ValueError):
            vals = ()
        if len(vals) not in (4, 5) or not all(np.isfinite(vals)):
            raise ValueError(f"window {i}: four numbers x0 y0 x1 y1 and an optional zoom expected, got {w!r}")
        x0, y0, x1, y1 = vals[:4]
        if not (0.0 <= x0 < x1 <= 1.0 and 0.0 <= y0 < y1 <= 1.0):
            raise ValueError(
                f"window {i}: fractions of the image with 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1 "
                f"expected, got {list(w)}"
            )
        if len(vals) == 5 and not 0.0 < vals[4] <= MAX_ZOOM:
            raise ValueError(f"window {i}: zoom (input px per image px) in (0, {MAX_ZOOM:g}] expected, got {vals[4]:g}")
        out.append(vals)
    return tuple(out)


def window_zoom(window: Sequence[float]) -> float | None:
    """The zoom a window asks for (input px per image px), None: fit into the model's input."""
    return float(window[4]) if len(window) > 4 else None


def window_pixels(windows: Sequence[Sequence[float]], width: int, height: int) -> np.ndarray:
    """(K, 4) int windows x0, y0, x1, y1 in pixels of a ``width`` x ``height`` image (rounded,
    at least ``MIN_WINDOW_PX`` a side; windows too small for that are left out; a zoom is ignored)."""
    if not len(windows):
        return np.zeros((0, 4), dtype=np.int64)
    frac = np.array([w[:4] for w in windows], dtype=np.float64)
    px = np.rint(frac * [width, height, width, height]).astype(np.int64)
    keep = (px[:, 2] - px[:, 0] >= MIN_WINDOW_PX) & (px[:, 3] - px[:, 1] >= MIN_WINDOW_PX)
    return px[keep]


def interior(xyxy: np.ndarray, window: np.ndarray, width: int, height: int, edge_px: float = EDGE_PX) -> np.ndarray:
    """(N,) mask of boxes (image px) each side at least ``edge_px`` inside ``window`` (px),
    or on an edge that is the image's own (module docstring)."""
    x0, y0, x1, y1 = (float(v) for v in window)
    lo_x = -np.inf if x0 <= 0 else x0 + edge_px
    lo_y = -np.inf if y0 <= 0 else y0 + edge_px
    hi_x = np.inf if x1 >= width else x1 - edge_px
    hi_y = np.inf if y1 >= height else y1 - edge_px
    b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    return (b[:, 0] >= lo_x) & (b[:, 1] >= lo_y) & (b[:, 2] <= hi_x) & (b[:, 3] <= hi_y)


def _within(xyxy: np.ndarray, window: np.ndarray, width: int, height: int, edge_px: float,
            height_fraction: float) -> np.ndarray:
    b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    small = b[:, 3] - b[:, 1] < height_fraction * float(window[3] - window[1])
    return small & interior(b, window, width, height, edge_px)


def window_keeps(xyxy: np.ndarray, window: np.ndarray, width: int, height: int) -> np.ndarray:
    """(N,) mask of a window's own boxes (image px) it keeps: interior to it and shorter
    than ``KEEP_HEIGHT_FRACTION`` of its height (module docstring)."""
    return _within(xyxy, window, width, height, EDGE_PX, KEEP_HEIGHT_FRACTION)


def gives_way(xyxy: np.ndarray, window: np.ndarray, width: int, height: int) -> np.ndarray:
    """(N,) mask of a less magnified view's boxes (image px) that it leaves to ``window``:
    ``GIVE_WAY_EDGE_PX`` inside it and shorter than ``MAX_HEIGHT_FRACTION`` of its height
    (module docstring)."""
    return _within(xyxy, window, width, height, GIVE_WAY_EDGE_PX, MAX_HEIGHT_FRACTION)


def merge_windows(
    frame: Detections, views: Sequence[Detections], windows_px: np.ndarray, width: int, height: int,
    iou_threshold: float, max_det: int, magnification: Sequence[float] | None = None,
    ioa_threshold: float | None = None,
) -> Detections:
    """Whole-frame detections and one ``Detections`` per window (all in image px) -> one set
    (module docstring), highest score first.

    ``magnification`` (K,): how much each window's view magnifies the image (its letterbox
    scale); a box a window takes is dropped from every less magnified view, so nested windows
    hand each object to the most magnified view that holds it whole. Default: all windows
    magnify alike and only the whole frame gives way to them. ``ioa_threshold``: as ``nms``'s."""
    mag = np.ones(len(views)) if magnification is None else np.asarray(magnification, dtype=np.float64)
    given = [gives_way(frame.xyxy, win, width, height) for win in windows_px]
    keep_frame = ~np.any(given, axis=0) if len(views) else np.ones(len(frame), dtype=bool)
    parts = [frame[keep_frame]]
    for k, (dets, win) in enumerate(zip(views, windows_px, strict=True)):
        keep = window_keeps(dets.xyxy, win, width, height)
        for j in np.flatnonzero(mag > mag[k]):
            keep &= ~gives_way(dets.xyxy, windows_px[j], width, height)
        parts.append(dets[keep])
    xyxy = np.concatenate([p.xyxy for p in parts])
    score = np.concatenate([p.score for p in parts])
    cls = np.concatenate([p.class_id for p in parts])
    idx = nms(xyxy, score, cls, iou_threshold, max_det, ioa_threshold)
    return Detections(xyxy=xyxy[idx], score=score[idx], class_id=cls[idx])
