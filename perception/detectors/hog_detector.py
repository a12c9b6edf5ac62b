"""``HogDetector``: the Dalal-Triggs HOG + linear-SVM pedestrian detector (OpenCV's default people detector).

A classic, model-free baseline: it needs only the image (no ground truth, no ONNX model) and finds
upright pedestrians of at least ~100 px height (the 64 x 128 detection window at scale 1; see
``upscale`` for smaller ones). Class: ``pedestrian``.

Implementation. OpenCV 4 ships the detector as ``cv2.HOGDescriptor`` with the SVM weights of
``cv2.HOGDescriptor_getDefaultPeopleDetector()``; OpenCV 5 moved HOG out of its main modules
(into opencv_contrib), and this project installs OpenCV 5. So the descriptor is computed here, in
vectorised numpy, exactly as OpenCV computes it (``HOGDescriptor()`` defaults), and scored with
OpenCV's default people-detector weights (3780 + 1 float32, the same numbers, embedded below):

- sqrt gamma, centred [-1, 0, 1] gradients per colour channel, the channel of largest magnitude;
- 9 unsigned orientation bins over 0-180 deg, each vote split linearly between the two nearest bins;
- 8 x 8 px cells, 16 x 16 px blocks with an 8 px stride, votes spread bilinearly over the block's
  four cells and weighted by a Gaussian of sigma 4 px about the block centre;
- L2-Hys block normalisation (clip at 0.2); a 64 x 128 window = 7 x 15 blocks = 3780 values;
- margin = w . descriptor + b (the SVM's signed distance; OpenCV's ``hitThreshold`` compares it).

Window scores for every position of a pyramid level come from one matrix product of the level's
block descriptors with the weights, so one level costs a few numpy calls. Levels: the image scaled
by ``upscale`` (after frames wider than ``max_width`` are brought down to it), then smaller by
``scale_step`` per level until the window no longer fits. ``stride`` 8 px is one block step; 4 px
also scores the grids shifted by half a cell (4x the work).

Score: the SVM margin m mapped to [0, 1] by a logistic, ``score = 1 / (1 + exp(-m / temperature))``
(Platt scaling with fixed, uncalibrated parameters; ``temperature`` 0.5 by default): the SVM's
decision boundary m = 0 is score 0.5, m = 1 is 0.88, m = -0.5 is 0.27. The mapping is monotonic, so
``min_score`` is a margin threshold in disguise (m = temperature * logit(min_score)). Windows at or
above ``min_score`` are shrunk to the person inside them (by ``shrink``: 15 % of the width on each
side and 5 % of the height, as OpenCV's peopledetect sample draws them), mapped back to the image
and reduced with NMS (``perception.nms``: IoU > ``iou`` or more than ``ioa`` of a box inside a
better one, the same person's hits at other scales).

Checked against OpenCV 4.14's ``HOGDescriptor``: descriptors agree to 3e-7, window margins to 1e-6.
Speed on OpenCV's sample clip vtest.avi (768 x 576, full resolution, defaults: scale step 1.2,
stride 8) on a busy 2-core machine: 95-140 ms a frame (7-10 fps; OpenCV 4's own C++ HOG takes
30-50 ms at these settings), 3.5 detections a frame; scale step 1.05 (OpenCV's default) ~3.5x that.
The small matrix products go through ``cv2.gemm`` rather than numpy's BLAS, whose threads cost
more than they gain here on a loaded machine. Larger video: ``max_width``
(800 px) scales it down first, so HD frames cost about as much as vtest's.

The embedded weights are OpenCV's (``modules/objdetect/src/hog.cpp``, Apache-2.0 / BSD, Navneet
Dalal and Bill Triggs' INRIA person detector), stored as zlib-compressed little-endian float32.
"""

from __future__ import annotations

import base64
import math
import zlib
from functools import lru_cache
from typing import Literal

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.nms import nms

#: The detection window (px): 64 wide, 128 high, as the default people detector was trained.
WINDOW = (64, 128)
CELL = 8  # px; a block is 2 x 2 cells, stepped one cell
NBINS = 9
BLOCKS = (WINDOW[0] // CELL - 1, WINDOW[1] // CELL - 1)  # 7 x 15 blocks per window
PEDESTRIAN = CLASS_ID["pedestrian"]


class HogConfig(BaseModel):
    """Settings of ``HogDetector`` (defaults tuned for speed on 640-800 px wide video); a scenario's
    ``perception.detector.options`` with ``kind: hog``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    min_score: float = Field(0.5, gt=0.0, lt=1.0, description="keep windows scoring at least this (the logistic "
                             "of the SVM margin; 0.5 = margin 0, OpenCV's default hitThreshold)")
    temperature: float = Field(0.5, gt=0.0, description="the margin's scale in the logistic score")
    scale_step: float = Field(1.2, gt=1.0, le=2.0, description="factor between pyramid levels (OpenCV's default "
                              "1.05 costs ~4x as much and finds little more after NMS)")
    stride: Literal[4, 8] = Field(8, description="window stride (px); 4 scores four grids, 4x the work")
    upscale: float = Field(1.0, ge=0.25, le=4.0, description="the first level's magnification: 2 finds "
                           "pedestrians down to ~50 px high at ~4x the cost")
    max_width: int = Field(800, ge=0, description="frames wider than this (px) are scaled down to it first; 0 = never")
    min_height: float = Field(0.0, ge=0.0, description="skip levels whose window is shorter than this in the image (px)")
    max_height: float = Field(0.0, ge=0.0, description="skip levels whose window is taller than this (px); 0 = no limit")
    pad: int = Field(8, ge=0, le=64, description="px of reflected border around each level (people cut by the edge)")
    iou: float = Field(0.4, gt=0.0, le=1.0, description="NMS IoU threshold")
    ioa: float | None = Field(0.7, gt=0.0, le=1.0, description="NMS: drop a box more than this fraction inside a "
                              "better one (the same person at another scale); null = IoU only")
    shrink: tuple[float, float] = Field((0.15, 0.05), description="x, y fraction of the window cut from each side "
                                        "to box the person (OpenCV's peopledetect sample)")
    max_det: int = Field(100, ge=1, description="at most this many detections per frame")

    @field_validator("shrink")
    @classmethod
    def _shrink(cls, v: tuple[float, float]) -> tuple[float, float]:
        if not all(0.0 <= s < 0.5 for s in v):
            raise ValueError(f"expected two fractions in [0, 0.5), got {list(v)}")
        return v


@lru_cache(maxsize=1)
def people_svm() -> tuple[np.ndarray, float]:
    """OpenCV's default people detector: weights (7, 15, 36) in OpenCV's block order (x-major
    blocks, x-major cells within a block, 9 bins per cell) and the bias."""
    w = np.frombuffer(zlib.decompress(base64.b64decode("".join(_PEOPLE_SVM))), dtype="<f4")
    assert w.size == BLOCKS[0] * BLOCKS[1] * 4 * NBINS + 1
    return w[:-1].astype(np.float64).reshape(BLOCKS[0], BLOCKS[1], 4 * NBINS), float(w[-1])


@lru_cache(maxsize=1)
def _block_kernels() -> np.ndarray:
    """(4 tiles, 64 px, 4 cells): the weight of each pixel of each 8 x 8 tile of a 16 x 16 block
    in each of the block's cells (bilinear spatial interpolation x Gaussian, as OpenCV's HOGCache).
    Tiles and cells are indexed x-major (index = x * 2 + y), OpenCV's order."""
    j = np.arange(2 * CELL, dtype=np.float64)
    gauss_1d = j - CELL  # OpenCV: offsets from blockSize / 2, integer pixels
    sigma = (2 * CELL + 2 * CELL) / 8.0  # winSigma = -1 -> (block w + h) / 8
    centres = np.array([CELL / 2, CELL * 1.5])
    interp = np.clip(1.0 - np.abs(j[:, None] + 0.5 - centres[None, :]) / CELL, 0.0, None)  # (16, 2)
    g = np.exp(-(gauss_1d[:, None] ** 2 + gauss_1d[None, :] ** 2) / (2 * sigma**2))  # (y, x)
    k = np.zeros((4, CELL * CELL, 4))
    for tx in range(2):
        for ty in range(2):
            ys = slice(ty * CELL, (ty + 1) * CELL)
            xs = slice(tx * CELL, (tx + 1) * CELL)
            for cx in range(2):
                for cy in range(2):
                    w = g[ys, xs] * interp[ys, cy][:, None] * interp[xs, cx][None, :]
                    k[tx * 2 + ty, :, cx * 2 + cy] = w.reshape(-1)
    return k.astype(np.float32)


_SQRT = np.sqrt(np.arange(256, dtype=np.float32))  # gamma correction, as a lookup table
_DERIV = np.array([[-1.0, 0.0, 1.0]], dtype=np.float32)


@lru_cache(maxsize=1)
def _tile_kernel() -> np.ndarray:
    """``_block_kernels`` as one (64 px, 4 tiles x 4 cells) matrix."""
    return np.ascontiguousarray(_block_kernels().transpose(1, 0, 2).reshape(CELL * CELL, 16))


@lru_cache(maxsize=1)
def _window_weights() -> np.ndarray:
    """The SVM weights as a (105 blocks, 36) float32 matrix, x-major blocks."""
    weights, _ = people_svm()
    return np.ascontiguousarray(weights.reshape(BLOCKS[0] * BLOCKS[1], -1), dtype=np.float32)


def _matmul(a: np.ndarray, b: np.ndarray, trans_b: bool = False) -> np.ndarray:
    """``a @ b`` (or ``a @ b.T``) in float32 with OpenCV's gemm: single-threaded, so it does not
    spin up (and, on a busy machine, wait for) BLAS threads for these small products."""
    flags = cv2.GEMM_2_T if trans_b else 0
    return cv2.gemm(np.ascontiguousarray(a, dtype=np.float32), np.ascontiguousarray(b, dtype=np.float32),
                    1.0, None, 0.0, flags=flags)


def _gradients(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Magnitude and unsigned angle in bins ([0, 9)) per pixel: sqrt gamma, [-1, 0, 1] derivatives
    (reflected borders) per channel, the channel of largest magnitude, first on ties (OpenCV's
    computeGradient). OpenCV calls throughout: they are several times faster than numpy here."""
    channels = [image] if image.ndim == 2 else cv2.split(np.ascontiguousarray(image))
    bx = by = bm = None
    for ch in channels:  # per channel: uint8 split first, so every step below is one plane
        img = cv2.LUT(ch, _SQRT)
        dx = cv2.filter2D(img, cv2.CV_32F, _DERIV, borderType=cv2.BORDER_REFLECT_101)
        dy = cv2.filter2D(img, cv2.CV_32F, _DERIV.T, borderType=cv2.BORDER_REFLECT_101)
        if bm is None:
            bx, by = dx, dy
            if len(channels) > 1:
                bm = cv2.add(cv2.multiply(dx, dx), cv2.multiply(dy, dy))
            continue
        m = cv2.add(cv2.multiply(dx, dx), cv2.multiply(dy, dy))
        better = cv2.compare(m, bm, cv2.CMP_GT)
        cv2.copyTo(dx, better, bx)
        cv2.copyTo(dy, better, by)
        cv2.copyTo(m, better, bm)
    mag, angle = cv2.cartToPolar(bx, by)  # angle in [0, 2 pi)
    angle = cv2.multiply(angle, NBINS / np.pi)  # bins; unsigned: [0, 18) folds onto [0, 9)
    angle = cv2.subtract(angle, NBINS, mask=cv2.compare(angle, NBINS, cv2.CMP_GE), dst=angle)
    return mag, angle


def block_descriptors(image: np.ndarray) -> np.ndarray:
    """Normalised HOG block descriptors of ``image`` (H, W[, C], uint8), blocks at every 8 px:
    (H // 8 - 1, W // 8 - 1, 36), values in OpenCV's order (x-major cells, 9 bins each)."""
    h, w = image.shape[:2]
    hc, wc = h // CELL, w // CELL
    mag, angle = _gradients(image[: hc * CELL, : wc * CELL])
    a = angle.reshape(-1) - 0.5
    b0 = np.floor(a)
    frac = a - b0
    m = mag.reshape(-1)
    b0 = b0.astype(np.int64)
    b0[b0 < 0] += NBINS  # a in [-0.5, 8.5): bin -1 is bin 8
    b1 = b0 + 1
    b1[b1 == NBINS] = 0
    base = np.arange(0, m.size * NBINS, NBINS)
    votes = np.zeros(m.size * NBINS, dtype=np.float32)
    votes[base + b0] = m * (1.0 - frac)
    votes[base + b1] = m * frac  # b1 != b0: no vote is overwritten
    votes = votes.reshape(hc * CELL, wc * CELL, NBINS)
    # tiles (hc, wc, 64 px, 9) -> per tile and tile-position-in-block, the 4 cells' histograms
    tiles = votes.reshape(hc, CELL, wc, CELL, NBINS).transpose(0, 2, 4, 1, 3).reshape(hc * wc * NBINS, CELL * CELL)
    per = _matmul(tiles, _tile_kernel()).reshape(hc, wc, NBINS, 4, 4)  # 4 tile positions x 4 cells
    # per[y, x, bin, tile, cell]; block (by, bx) sums tile t = tx * 2 + ty from tile (by + ty, bx + tx)
    hist = (per[:-1, :-1, :, 0] + per[1:, :-1, :, 1] + per[:-1, 1:, :, 2] + per[1:, 1:, :, 3])
    blocks = hist.transpose(0, 1, 3, 2).reshape(hc - 1, wc - 1, 4 * NBINS)
    # L2-Hys (OpenCV normalizeBlockHistogram)
    blocks /= (np.sqrt((blocks**2).sum(axis=2, keepdims=True)) + 0.1 * blocks.shape[2])
    np.minimum(blocks, 0.2, out=blocks)
    blocks /= (np.sqrt((blocks**2).sum(axis=2, keepdims=True)) + 1e-3)
    return blocks


def window_margins(blocks: np.ndarray) -> np.ndarray:
    """SVM margin of the window at every block position (rows, cols: top-left block), i.e. one
    window per 8 px: (Hb - 14, Wb - 6); empty when the window does not fit."""
    _, bias = people_svm()
    hb, wb = blocks.shape[:2]
    nx, ny = BLOCKS
    oh, ow = hb - ny + 1, wb - nx + 1
    if oh <= 0 or ow <= 0:
        return np.zeros((max(oh, 0), max(ow, 0)))
    per = _matmul(_window_weights(), blocks.reshape(-1, blocks.shape[2]), trans_b=True).reshape(nx, ny, hb, wb)
    out = np.full((oh, ow), bias, dtype=np.float64)
    for ix in range(nx):
        col = per[ix, 0, :oh].astype(np.float64)  # the window's column ix of blocks, summed down
        for iy in range(1, ny):
            col += per[ix, iy, iy : iy + oh]
        out += col[:, ix : ix + ow]
    return out


class HogDetector:
    """Pedestrians in an RGB (or BGR, or grey) uint8 image by HOG + linear SVM; see the module doc.

    ``detect`` needs the image (``truth`` is ignored); ``last_levels`` holds the pyramid scales
    (image px per level px) of the last call.
    """

    name = "hog"

    def __init__(self, config: HogConfig | None = None, **options: object) -> None:
        self.config = config if config is not None else HogConfig.model_validate(options)
        self.last_levels: list[float] = []
        people_svm()  # decode the weights now, not on the first frame

    def detect(self, image: np.ndarray | None, truth: DetectorTruth | None = None) -> Detections:
        if image is None:
            raise ValueError("the hog detector needs camera images (rendering is off)")
        img = np.asarray(image)
        if img.dtype != np.uint8 or img.ndim not in (2, 3):
            raise ValueError(f"hog detector: expected a uint8 (H, W[, C]) image, got {img.dtype} {img.shape}")
        c = self.config
        h, w = img.shape[:2]
        base = 1.0
        if c.max_width and w > c.max_width:
            base = c.max_width / w  # level px per image px
        boxes, margins = [], []
        self.last_levels = []
        level = base * c.upscale
        win_w, win_h = WINDOW
        while h * level >= win_h and w * level >= win_w:
            size_in_image = win_h / level
            if c.max_height and size_in_image > c.max_height:
                level /= c.scale_step
                continue
            if size_in_image >= c.min_height:
                b, m = self._level(img, level)
                boxes.append(b)
                margins.append(m)
                self.last_levels.append(1.0 / level)
            level /= c.scale_step
        if not boxes:
            return Detections.empty()
        xyxy = np.concatenate(boxes)
        margin = np.concatenate(margins)
        score = 1.0 / (1.0 + np.exp(-margin / c.temperature))
        keep = nms(xyxy, score, None, iou_threshold=c.iou, max_det=c.max_det, ioa_threshold=c.ioa)
        xyxy = xyxy[keep]
        xyxy[:, [0, 2]] = np.clip(xyxy[:, [0, 2]], 0.0, w)
        xyxy[:, [1, 3]] = np.clip(xyxy[:, [1, 3]], 0.0, h)
        return Detections(xyxy=xyxy, score=score[keep], class_id=np.full(len(keep), PEDESTRIAN, dtype=np.int64))

    def _level(self, img: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
        """Boxes (image px, shrunk to the person) and margins of the windows of one level that pass."""
        c = self.config
        h, w = img.shape[:2]
        lw, lh = max(1, int(round(w * level))), max(1, int(round(h * level)))
        if (lw, lh) != (w, h):
            scaled = cv2.resize(img, (lw, lh), interpolation=cv2.INTER_LINEAR_EXACT)  # as detectMultiScale
        else:
            scaled = img
        if c.pad:
            scaled = cv2.copyMakeBorder(scaled, c.pad, c.pad, c.pad, c.pad, cv2.BORDER_REFLECT_101)
        sx, sy = w / lw, h / lh  # image px per level px
        min_margin = c.temperature * math.log(c.min_score / (1.0 - c.min_score))
        win_w, win_h = WINDOW
        dx, dy = win_w * c.shrink[0], win_h * c.shrink[1]
        out_b, out_m = [], []
        for oy in range(0, CELL, c.stride):
            for ox in range(0, CELL, c.stride):
                m = window_margins(block_descriptors(scaled[oy:, ox:]))
                rows, cols = np.nonzero(m >= min_margin)
                if not len(rows):
                    continue
                x0 = cols * CELL + ox - c.pad
                y0 = rows * CELL + oy - c.pad
                b = np.stack([x0 + dx, y0 + dy, x0 + win_w - dx, y0 + win_h - dy], axis=1).astype(np.float64)
                b[:, [0, 2]] *= sx
                b[:, [1, 3]] *= sy
                out_b.append(b)
                out_m.append(m[rows, cols])
        if not out_b:
            return np.zeros((0, 4)), np.zeros(0)
        return np.concatenate(out_b), np.concatenate(out_m)


#: OpenCV 4's ``HOGDescriptor_getDefaultPeopleDetector()``: 3780 weights + bias, float32 LE, zlib, base64.
_PEOPLE_SVM = (
    "eNoVWmc41t8bl529M5OGkUQi4zn3t9AghUoiUVRSqahUpLJn2ZuiEKWMRHjO/Y0iNBGiHUVDFP0qJf37vzwvznWdc5/P"
    "vK5DIlxh900FljfLE31+2MP348NQ3LcQmX4As19bsSujBOYEdUP0Dy4tOWdMUvo9CId5B/Yd9kTxUhmkLQnBL1cFGM2h"
    "IpDdsRGzbxtgo/1NWPf3DUgm5+Cavx4oOLgEZQ9+JZaZ5mCxaje3TyMfShzPgUz2ebg9cBK0XWpB2VsG2/tEwS3WG/Ij"
    "rdDpiBIYmkth7MF4mFGihu7eC8h703iilPwSDPSqQEPJmQPbXkG/zAU419cF591KifTBzzA8Kcgsd7z7b48rrJoXi/x3"
    "33GNR0s5mfH8sOqKF7n1+joJfvaIVFqbQ9WxFFi3mAesg4PRJucKYRcfhYaXFaBzMpWjXVZFREyRHJbZAXnlvXTcZAko"
    "HHpPTnTegO3sEqhpvwHi77Lg0yQlnYbdUOYTCuh3CFRM0jmLH2+EitpomFhYCngkBmQcI2HG1CzUlVag6ql+uLZukEyp"
    "28HSl7Fg7iICNo3q9V8lUmjs2Ul6e+dGOnxinN4ynUY8fKSwWWkut7LHCZyCvkJ9QiWNlHSBY3+j4HWGIyw4LURtAn6S"
    "fNsDELsnjFvRfZ+bPM8Xjv5soyaG28E3rATnaqVihiwDms5O9ILdA+rKN0UGlZeiqTTBwyVfifeSo1Dw5gYR1Yqjx73m"
    "k2pHM+I96QaaYWU0ln8Rbp+lgHsSTQl/ZDfdF1dDRdpqqZ6HGCZPm+KWN55A3nOCZML2Noz/NwOrFsajoq08c0B7Kx7Y"
    "W0K9d++FDf0DZGAsEROUHVEivRu9lQexb1E2hLVnY8d4FdYd+EYcop6S8/6exGxZCn1+iQfdX5dS4U+1oPHfangaKMbU"
    "S36And8+mdee4mDn+aT6/m+N+CzoM87vN4FzOsmER8mGI9z+HKSjtnBcJF7iYbtMVL31BPFzJr2/fy7TSi5yYVwf755o"
    "5H4IkSKq8Ydp+9+16NLHx+7x8DJ/EuVIpwXnoN/5p9TmlXH9TO1m0rg8ie4dUcO7jb7oES4A6s58jO2rYHieHsk9afwG"
    "ru3cTMZVSsmabfOgZf9G/DN8Dnglw2BL1l6c6H+Ao1VZcHx1OY2dm0K+nlXi+GxdgFfOp0NRngMIn/qPOrRVU/0D0+Hl"
    "HyMYTduBrU52qGZrjnwCnuTJwgry9WYV9VQVY7f3boVhbhiZecQF7p5ZBhKccvM1mjmwYVYzuC6TIbZfB2nQmZfw5ZUY"
    "HlqWhOXf/JFv0Ut6uXOIe185kk4XcCU8Zo+RmbAG0Qd78E39Kxpyaz5R77iMTX8VIN0wEGRrnYnPlzx8mqsMwQ9Fsaom"
    "ANdHLcCMgALMViuqbwuaoCvTV1ONVSFovXA56AQT/FxUDm8iH5L/Wr8RdeYxfEpPhE06ZtDtYIxPzgkyWxpLgV1fSW7M"
    "FOUumVJA7q9LVPi1KvY1B9Llm56TLaLjsC32KM7XfEut063QpXsVrJUOhdB5kmC615d4RmSbp21fDPOCBDiC82bj/Zv6"
    "dPxzJ0cn4D9SJCCG59LzqeDNVdTCMIH7vq/93zx7ySoaQe/0Peb4y5+jy1/kcjiWtuAjoArrH6TCuqd7QcRCCTvEo0jf"
    "CRF6q3oOBBQUo6leL5k5Mhcnn7ym402aGNgQY+6z2BKXvIvBilwJ8j23ii7wrjTfse8XXdw4TuckDdPJLStp050VuPxq"
    "HSbr3UfhfxzRb/eu934Uh9NeZ9LEdDl8w/WihTFZZI/4ZSphywXRNdK4SdwNQv/oQqXdRhKZJ4Kn3k3gtXdx4L9IERfm"
    "qJLfVUUcnoe7oEo0mGMnM0j8BDxRV0gRVVe/p58ljfGvjA6dZ5tNyvRF6d+hBhyfsKfCTWXUtLodvYvzkV5R52SYRnKL"
    "BFeQ9LnhOPN7Lx770EaFF1+n+zMyUMgkDURLvM1/H55DwqkI2XZPEd5PfqZabjKg+2MxHpD4jmmqvNA8YMQdKn8BhuEO"
    "8NbTmav7ah3u9S7iFPF4Y/GeJu7bB5txVNWaPkjaQPxPzCa1Yj+5Z0tPoKKOLNew8wKZ51lEPz2LxynDKJzUm45lgTUo"
    "qSiChyoz8Lt2LW22D8Jfgks4sfv2YOma5dj7KwvoDWPO1ogFAFN/SKyRM3T81oDZ67/TA01qONrwlqqc/kRj+wMJV6uK"
    "4LQCOt1mLsdaqRO1BJejfcQwHdkcxEkwX0K+PxMieadXYMFRU7yqoIir1RKwZsMbbN9nwPWdHDOvijyI6lKBGGd6FV0O"
    "meGfHbvN5Qt9UUHYgNviEkof3JIDAR4PaAxNg+8O1ZwkuTD45JZBPnRTblA4H0qsi+PsVF9K3F5jvW9+Ldn5cTpK8CeA"
    "9PZYrn6tNLUsu4DKvx2B2X8MHtrpwK42ag52TWi6czaOOuvBh50JROqxCcqO/+Q6NBaS4/uXQvDpWjDWOY+e95biTHkH"
    "pC9Duc6TmzGyfxFh98nicbckrDwmDXdTnpG8RRJgVZpM/JW3ASdPjUxY8iK/sS9EDLMkrC2C6Ep6YfzjDvQQuoxRG9Jg"
    "SeZ5WpHVQxWy7tHOOMCPyrfNfZ57ANfEge4szqNjUaHQ/XYNiCR+p3oJkiS64i79EeiBa1TfmgufFsaMpwHk+qsRyD16"
    "tX7Dpii0HPMGy0ajet71RrguthHEvy/A32mueKwliSzu6iBij/vRrEPyn+4Z0RPpXbiETJGM4CtUaCId5z9aDwure2Hi"
    "ZAW++TRM540Zkr/T5JkHvLLcU3b78c6WDJSI3A15AfzM42VrcGFMO5hOrIXv2jxM4RAXEhaEQUtGAMloaITSWYEgpyjD"
    "7m4cpZ9X9pMYm0oiaXW8XmydHg5L3UU+kUWA4b7wx3AlKuwNAR3DVtJDZfHkAyXScUMfWEdtmixeDFvMqsBZTojtqBIg"
    "YsP76Kz+r2RERQ54JaZzk8RqCco3w4VbDZCXOUrlJfLxY8B1qtzIz92/ZTG5a+9Dv0S/J70u4zC9fYRT3P8Y459mQ+j7"
    "Ymp3OolzuCeMHPexxr3uVfjx6G+uZ3A1HGgJAO1jkfBr4RdOdoM0RFbORJi8R0dLY1Er/h6EXV5I+TM8yZ1VaejW840z"
    "ENkHzzo+0bmWt4mWhiDaSZWToQVqINTWSnb91cczup9ppPFm8M/yJyE318DHE/zMIecGmGjXh+sZ09HFPw7tD5mSt+KL"
    "mN4IMfRVCcZbUak0ZP4XiJ4MRFJXiR1BYjjn3VJwnlcMdEwKnDjpROPVEAxnC8Ce8n9cik8g0TopdJtDDz6xdeaKB/ma"
    "Wd7eT15zy+gyTjcNb9Kg9yX0ga69QodvFGCRSQ/pm7xCjQrjMfz2dHZa9GlcVtrC3fSnBDiv1BmVJA0OJ0GabFaZjzs2"
    "lhAXfWfIHZ+kH9sHyWEqwSicyIV9/zTU4O93ei52HgaOutNfUqewyuE1fSssylzkU2UG3m5Bg/63uLKmggz2cMjLi5uw"
    "WjoKPZa8oZyPX2HUxJAJ3HocP7q8QcVDbjRMMIGevFyOOxVM0FLlH/+teqFdciOjNcTFYQFzc/9cGfh9OwXsp9WQqPo0"
    "MpIwjfqIHSZG5XLM86wwXDLxjXTOH653zt9Jw/rmY0HXQe7aBfX43+9b8FurGmw5fXSPxg+6/2MHWT8hDZ4eqhjZu4e4"
    "va0lddafiLb2XGJdHoJBVYvgws4EkLm5DLXepmFZ0BNyJmCKHNGOhpPBr6A0M4Km7R4hPfM/E4XLhWDJjYfrJnHg49vC"
    "mRYazWnsqIGLA3/pfMMXxDJoKeG9FEEfSWVwcoJESb+uNMrYy8COx6c5odvPU6N5UjSquQncpp0g4jdmoUhZGnxZfgz2"
    "yImYPW/hpZqnm4ifSQC+xtdUYNU2/GKigzcfSsN8219EH76RcV1FxpgmkvCVX0nDeWvgLNMmrOMgcbe/BD4dr0hO62qq"
    "0PcFIrgqYJMkhAX8VzgXEtto5/Hn5NdCN7gV/Qjl7oSC40gqXaJUR6a7yoDJ8/kkVX0+crLn4fLCSNIcdRla3301273X"
    "BXd2lmGcyOP6U8sqafaMZGo+YyZckCiDXY5naFRhBQzrvQGb/7jQLloG57Ny4WHKDphV/Jycpfeh4FYdOMZFw7d4X7g8"
    "t5a66OXBV/Up6Fo/jYms21JfM/MgMajlQnCCFffh/nBMj07ElkpXMz/JahLaV0Hf61Vg0AIu7S4P4zCoSgIGL9Gxp4Ci"
    "fT+54lc8qHODOWpOF2bnZlSiark8ei3lkOlXBKFpdDFmnj0O07cYMyUVXSDW5EJ26D8Eo6kpuOZmgikb6mDfLw78vfEW"
    "9r8qB+4qKxCe88y8wKGRVPOqopM4D3wzOktP7NuNUzcbaUhoBEa67ESnzUnIywjhVlsL1OR00opRZ2InivhM0BO/T7dA"
    "p+Mi6HM2Bqt+WpCfvDdxW1okKeCowMbWXm54aR588k6F/OZlYF/7kKpMi6NKy4rwoOBRUMt8AkXeURgwNE5ut/SQQ625"
    "ZE3JVSw7HoLx30XYeQm5yC1TJO/aitDzaTtqa2/Evqhd5FxDHr7el03b7mZhbMYjDDm1EWOL7+GXmeX1qe9CcKWWLo7t"
    "/oOtEu9psNoxvHF/P2yiOZC0ORwVAviIsc5nsE+cBFfZCyQgxJCbVnQAgo4uRecX68FDcgH3z9FBSMq7CzJerfD0CYNm"
    "eUbUyjsBF4v+IUd0O+kJ1bPIiDhwSnuf4600pMZqAzjwTotes/pLfrja4qbP9aTT7DoHsq/gPA8FtkHpHE47L8z6uJkh"
    "n+g9tJfrIkLKEnBv+lJo2ToKISnNYOb+EiZc91HOTAPYERqLXZfKzN0bZRhX9RxwqOPCBz9vCB8bgjobY1o8UkIKjD/h"
    "Nt8sTC38SOfwrKNLLOKx4c1D1Dqhje4HqilPnQN9aJiFEga92KmUi2MJ95FN+YiCK3+g9p0GvL4lGYdkNFH9RyBeebcA"
    "nh06Cx1DWmB6dRpTvUWB0X/izuy05GF6kDBbVZ7W7+pS4Zx77EPesZIgHNBH8i+cJhkzt8BD/a9k6sMQxG47REV4wulF"
    "4/H6V9/jKM9Fd0xY4IJSRzfBUKMMjt+qqrvles08q8oYNxjqYZeXIHBPbsNrfe1YkpaC8r+eof9gI20P7gReeSNuzyN+"
    "XKOJJMjhPQn7+hhosDWj+b0DPEsK4cIGT3CpEGLPeMuymmFrOXxUBLXTZMjlA26Q8/0CV+KxJX3gmGp296E6Fl20xpXr"
    "Kol1iiednp5BxeZkkePVrXSCyyUyL4phMlYIyqr6cOzSXSL8fjPc42mmUs/50fZrNfeQaCEuXT9IJk7qwdzVmSTorjVc"
    "KtxLn2kH0tf+xSRHay029OhBz0AO+DWvBuHsI1icFce9ESTIiNXtpTpH8ynvxXkocHQKkzebczadscO+h/W4/fwXTpZ1"
    "A5wv/QqTt7I5WmeTON+jCrCFXw5LxkxgvnAtTadLIfyyE7y9UUEC4gm2LV9OZRe+obcDRRmZgOtg1JaHyrvyOAK/Qunp"
    "Xi2S+0Icd96mNEvwGoqsiYa4SR+Y8p3GGgohmbkiHcZnZoPaqdXwNu0Gvb75Pnq7yjGHEyPR5U0+Sj4dIjO6Req9Vi1F"
    "X40xLHv4C7Wd1VgVzjgV8SuCo+4izOcLnyBBzxJOH/Qgw/QAen47Tnu/e+Je6fvk5oJP/zSrn6jIH2YO9uxgkmQfw7Oq"
    "Mygd8gjZLjtW+YgdGsjGMblbkXnTW8H4/ExljuzeBSf+aMPB2ixIs35NZQ1EaOJgOtgGRZGk5AY0kW9CvXg/smgqCf0b"
    "xPHv8o9w7rEYo3MnFJ1JCLqsFCQmQiNQEFHEcbyeg3GzYuDl9TAmX7EO5mekMBbtgsz9bBdcLVdO906J4R21YJyoV4df"
    "6wkTZxTB3DcRgRbvTHJzsxVz57sZY2PkwRlt/kmHztgwQ7OrGY+rp5jPf/mwzCmVkT7/nHmUdpaRs7tJBFbfxZjY19xO"
    "wxsg8/kiPr71llwUOMk8iFvE6FqcAm5xN5ZHzWeD5wmxQvVlqLVpBducK8K64HZm8EEro7MwmlG+Z0MLTmiSWN7pTPns"
    "7zB0ZyW2K1/AH4qJME/pJMf4WyC6Nyqxf7I/4EtSjspamXhPYB77yl6IWRQbxoDHblgYfRo4Cc1c94X/vDNjOYypxcDD"
    "3rP0mfFJGKPTmT2VoWgca8XNuiSB3tI/OH6J6nCz7SN0P4gmnPNCRC3oP27Cq1EcUX+KmmJd+Dd+DT6qsq7/c/0HSfxi"
    "iSoJ//JAxn5MrRVkPw32oUfGSvax5X3s17uAF3vGzLK26dX/2DSb2bSxHMZf56KsViH+CQzCYNNssmHT0vpfSqehzVcN"
    "Qs7aMyYpHkzyjivc2B/7yNfSELx5/SMJ3OkN4isn4JOuGtw5Lw2u857SwzGdGFUSgWcK+tFcvha3Dj/E8Xv8hBG7zcnw"
    "6yHTaBy9avAKjb8WYHXfIC5xO4GSvIHo0RVKws4fRHtuA7jJ7GEESgVgojoWXHfUYmKTJjnAnCN+1RXwefUeesT1NZxW"
    "nc/M8G2hqalCaBGth94FK0l3TBt3mk88SPP9IHrHkknbqwHysXU7Gj+RoU/O22LEoyxw259ExJb5wWX/ArT3lofHU4e5"
    "Bjo1eOtKGE6DIpwxWwb6JZPRKH6Y+3b4NjpomTCLrikytSmXyLrgteh7ag3a5AeT62/vophZOHhOqDJhdcuYWO9R2Ktg"
    "QcVtauge+Vx6b3MnnOOMcPX6R2BRxAxGWTcPhnOaSPg5Vzxy7jwVC/AgZtNj4UVBBDrG7QEV/mbafVqSvfD7En3pANgh"
    "ugxbBtPpRp1zoPsPW7JhgeSWig17LvoFBAaqQDGnEedEFODXNBFUGuuHH9Y3yGM5XiZygxtzRGWURD/N5LB7OtHi8Ur0"
    "/+bJfWhYCc4Ha8ll52ZYN6LPCAwibsQvZjEKX1BT6hd+MVJn5btS4OtfZ4x7rAxPfq0HVVYFS2Jnwr35qmyV8jU0yCmi"
    "MjXaoOmjwpZACHk21AGyd/7jvBU7Q2KfxSHZ3USL5kUh02eAdbpFuMjvKUctVhh4ViXB8eQS0L4RiWRRDG4TTsA26wgM"
    "6ZVin4s30csd4dBYI0XWHkE43pKNV5Pt8dLVVvSwjkHuqCR74xs/jJ7hYV7ZJxLNT/yMi6EWnno6jvvLZ7AD8aVY/XIC"
    "vR3WwGY9dwhSCeb2bBYAMQ4vW/MoE70u7MZI83ia71GIocnumNx3mqb4DRNzkyRiXsrF2cf3cJyOPMKjO/uocPRFlDyr"
    "hlH3VtXX9oZDeqANM+OEDeomJ2LSxEqsaZ1PNZIvo9hneQCfGegfaws+LSUwrsnDfmgNxNocJcSf3Zz3zztQ3auTLBBJ"
    "5XC+KWKxsxmtueqGP2bvNv9U9wc1ZhzGlRunsPjnceyoScNYvlYS/iQB7qRn46bjK+sTUupwi9ZF3Fh/Bg3dVYnXy1U0"
    "9ts585GL0rR0wWVUDTTHj+PPsEN5N57Kk2C9B2rB9rkyE6nAC1qDxozxzytmRwQ2wJqcNrwnfgsFYstxvYMms4RnJbMs"
    "SIwU8XyC2U2HKeMwHYbzb+BWhqUyi58Sm4Vb4f1LKcwsTUHcHYdz6v7Sh38O4u8JA9Ynbja7g88WLVzCiNDlP9ivJsFY"
    "dLsyTzeJMHu+OzGvdarB/WcRbG9WAj27CbDdMQBnf/bBzVsSzJydI9C9ZwaTk7mKhOoxpG+9NISrXIfW/liaHXMWDa6W"
    "4Ej8S86hHW2UbhZglq5/DeoDbfD4twXQdYY4c5sK67PJhJ0m2IOfvKazMb1R+OzZNJSQOo0uh95jh1ACuu2xYuYvN2Ja"
    "1p+DeKsHIB5Wz9x9msgcG5nGzFg6h7ksIMVM7H6HC0Ul2Wvq9dhyWIqNz1kHgekLuL0yL/DHzzvIE+CMvpbB5D9ZO3h6"
    "NwEWc8doz81EsubKv04Rw4drMvM5pgcdYfsVOwxWa8a/nx/S5cVnwHFgJZkM2Aze08VxePQBJj4JxutvKjmH4h9y8Vcd"
    "Mf+dSFVmCMKtgnPQUTDFcT5pB+Z8UURpIUvvuN/D9A//esL1i+RB4GVcalMGee8U0Xl3OFqsD8A8BTEm/+1HbMlUx3fW"
    "yVi+RZ9jLyePftVt2J38BhsUFjNfNxoxci1zWXn/VHT0CCZPZh1iYkqzoWJPMGJyGqZZhTIhCnoM17YYr3EO4vX/NDBj"
    "1yvOAI8XjiWmof3WCSwo+gNK8zyZerHtuD1TCFWb9kDOyVXM+rC50FMXjtV/JzGzaymzdmkz1ix5h7dFp+B04CymbeEK"
    "Zs/cV2DyUQTOHRRgdwZ6oV5vLU4/4css9IpnCrqjGZKdCmH5Ooyw5U7m3I5MOCyziZ3uWYTrPiuxM/sS4GHJSzAbNmP8"
    "F65llH6JMCeFv2Hx7wFMsbdgeTuOwYb69Yyf6RQY/54F6R5pTJd4BnMjL56xaEihwf7zGdZuBbPoeg5Z3HMEtFOVOdm2"
    "p0j9nRekRf0DtAz8gBjRWbBgDODvzVqoVPsGIYP7uIKvq0nTtcfwqWwRs0buN9Rtt2SWztNgnBYwRDgklqbonqzXxhRI"
    "W8eQktElzA8ayLT4mzOK5+yYUxcOg9MRGSr9EGl1lyxjHy3FuM7xBFX1UOjusWIfbGuHuux0ZsaeKCbE8yboh6oyv+pW"
    "M/5P38PoKl7WVsmVZcMK6c6gSGzXiabHLDUwodYKRkLWwmMnSreM2rGfJ0OxPVSMMXrmxYweVmQyPlTC+4pY5um7QmbI"
    "qRWSrwKr4W/A/iqcT9sWzQVpgQVgHVKEfp1KeI9nBZ54txHd17qz1gVRKLDqK5E8QPC7zSYcun4FJx0+EJMJCfhwS4i4"
    "OvZjR8Y71K4qoLYjrlhYWI0tIcvYF2XueG/lWnzyxw3f/TqO/Q0vsFPEEMpPzYV23QBC7Cfw1LtVuO6wEc3WEoAazSPY"
    "fGaSHuKnNGHfaUy9UYVfCw+x/O+4GN7nibZ/DPDLonFkPi/AY0XHMPi6FUmp7CZiPuq4LSeS5mp306MDG6l50iw4sTsC"
    "3S+YEsOKB9yIxy+pPf9bPLZQCHKON5Htylowe0sv1mw9DEaPrcgzc17UL4mlW0RP4MXn6eRuynXuteo43Iq82HbiNoLV"
    "T/I6zhoVm0boCQFhtu2zFUrotXCET+6jDW3CbM+uOxgeMkjvd6wkSxZFg5NIMQ1oEmZUjfzhvzh5KmW/jB3K/Q/TB0Jw"
    "50EbomybDAK7noHT9AEIjImEhQZj9OVdTXaZrSTL27SBSvCoQeifelix0QF/yHtBeI467roUjKzDJwyVkmHrk8zw8HAo"
    "udTIhVyfSuhVsgZRnb24dywblwTqs1ZpPTTr+13KF/aMBPOPwPHJKtg3MpNZPLQMPgebwnz9Drza9BtnHFqBxSXbMMBo"
    "G0QfToc/fjvg+ZwS/PxEHKDYiW34weKRa8c4F/TkwNRPl3l0OhE8/raDvm4cysVv4Mz8yMNydBezuywuk72pZzEndgLE"
    "rWrhyKblUKnxARXvFmJyaRgbfqoIzSRecfaJfaHavau4nw8PoFoW4E/9fPy1eZJz8lUHGhafM59zdT2zq4EfO1VFiP3h"
    "PHJ+5XIavUaeveStB+MVUdzBvNPYa9JCH8eIsOa8ReZBkx9QfJUB9vXE0oY1e8Bv2Vy2V2uAbFjiAWurlVhu9T6yL6aB"
    "rNE1QO/Hq1GZ487M9ZqGh7rz6d0qc2ZJhQDukABuhngoSb46Ve8ZlYdyh5eC5p/73JsPaiDp0mbmZ+JaMn1LAh4fO4hG"
    "btk0xtMAIe4rDO9Ug4XCs/DLUy/g421FuS1XqO6kBAkwek3lvNahhthCxm7OGCmJLSUGG64AzwVhbNOVw3dD+3BLVTXu"
    "6xklRwtimVk9xyBfKwsET6kyqjNmodRPB6ycUKHN0wWxe+gaLtmYC1ytFFSm4kwTTz54qPKzQu3bsHLxLoxsE8RNUu9Q"
    "6rISBL44jHzBXFxatwvWWy/Cu+UTdGHULjoR0o41jZ6Uo23HzHpwnHJP5KLEV79/2SMf+0oC6KriLIxqacTVVIl95jqX"
    "EbhVCzrRVyGtSgR2OXHxUDsXc8TKMKlsHVbmd2N+yXzSL/ub5trchC6pcHjwYyYqGK3B8ydmsLP+OuL6q+X04qs50LZt"
    "Cr6UZ1CpPG10bv6G7r2rUKngGmppXUVesV687TsIJSefQ1/+csZB5DgIC7ymfl+uo6DcQnbWJmksv1zO1ft6CYT/psDj"
    "h7qQbr4U1BdKEuFv8XA6chcc6vQF8eG7RLqzlVgUTkGB507YLXwGVnNmwuitTPANrCPh/P5k8nMIvCXx4LHwC7Hg+wJh"
    "fmZwW1QAtE8Kcz6eLCYfYz9Aqo0BpE+GwRx1W7i3qxhCAYEvyBrCEmqJ9LYoet8jByx3HIPctxJMsOYA+WaVBD+Vy+Cl"
    "exyROlIH82aWMvMC7Zjjs9tAtvcCBMheg/wCXrZrUpy9tzUKK3+/Rok4UYgaXEJ9NdLwabAIWxLFx8b53IDibi48qngI"
    "zkcPMErpFczVtruwXq6QzCychE13cqAqSZE1U5rFhvBGoItZIt3vKwqGlkLsr64fqOHEYd+n6rD7h66R4yff0JvJqeTj"
    "YAHJt3Ammf6FMP5zFbE8ZMU5oelEleMOg9vXzVgcKYLp9zXo1vLTuF56NujlTdHn7XsQvleSNZ7zoctkAcdNcwUIXrkJ"
    "dfKC9MvKM2RXRTu962+LHR23qfvfKEjWDsEf7ubk9ZcdwK0uQWW1NsLN/0UvbLuBqetOQ41FCoS+zEGt3zxkdgMP9Rc9"
    "Al7ZppRrxeHuP2WFc/dkk28lSsxVz2B88fUC/RhmTqZ2V4FT/0x4uncmnVIuRNY9DJbbbaWHFLm4uTWBTJQsgeyLzaD+"
    "aCNItUtyZeYkYuZUKE3QE2SuLLpPX+rq0Ns9n6nFaxPIfLEeakwzycW5o9Tk5yXYJUCQQzTYgBt1+Dx4nB78wc+0J+xg"
    "tPyOMd8Wy4NAnAceXabPQRE1jJcPhyBZNRB3VoWAxcHMtvnlDEpeZE7cXsZ8Vq/AeyZGbEGvKntc4B4u+PmBPljlgmdD"
    "4+o5gtHocjcLHzUeIA8uZWMFa4qjHiLUTC+JxFzQhJFOeyb9xyyG/bEbeAojGR9FBWZh2Ali+N0OO3/NRP20vbT4iw2u"
    "5v8C8U1HmOHwKOa77QVm2vBDWHt+MS37uZXWztNn+I+tZbK363OKJixpkjeH8aWNQIxC0S0tHJMaPUjBsQfo9eTf2jaA"
    "c3DxSTAcfwy/SQzzd5og8c9AGqqoRHg9KQS3KYAtK0kH+5sx8thLemmlCBMafwO07J9wp6nzYfVEEnPKsZD5lATMpjpp"
    "9sAzSbZCJgV78spRc0clGm8yZKexK8yf+O2E1WqizDc9W9R7eRbpxadwLNoINxam4GopBThkmsrMTe5k0g6eZjLWncG1"
    "71zZQ5HqbNRSa1b1pgr77e4gmrzJgAvHLJm4sBjmyec8wt7RJItGK0iQxQVu4idDVFrByzaWRWPrx0EcbzaCJ0E7ICdX"
    "HTLlZOBwqC++ssvAoh8m7EB4OT7fqcqmXTmCW1wTcNm6V1zJ98FQeVW3fuEnU5qexKUn81dCYI4OtAYfZJrG5JgM/gLy"
    "cN93iPh8ghPv38zdFHAQXZb/ph4n83DBuxcwtb+CvEjoJxk9syE8ZAJ3V1tjQ/I9DNUNxxuvxNiIfYq49dwQ0TI3xCCz"
    "XOJ9rhN9Vntj67bnGKnUjCuHbuOSjI003XWStMh5E8b/ADR+quQOdZ2E2TzCmKoYh3lL9qFiFh9jG6zELHghB2vEZRi/"
    "rYvAYbYdDJZ54eyUMOJetfgf7ncwY39nMZbLlmH0mu+ktH4eN3vRHvA1zkZT1w9U5sppfCCQyi33CYdx1UPIU7MMN7en"
    "4xyPleB4YDrrFNSKmkKdePS2JMTmWcL3BFVUDmqBewpWsG+7BswuvITiRbeBd7sdGFW4MALJzbD1Fj+sLN0AK/kAbLYs"
    "gtOvn9Jvi4NxbTKlsY+WMddDnoBsqQGs748mc49fwSqNg+DA7UW/NyvR+VQpGizLA9lwRWip/455bnmcrqNPUCojEmbq"
    "ZePMr/zoOPMufv47QmvWc9hpl2cwbTtmkLRthih4vY7Yao3jn/C5aPR0iNy+78VkZ6xnbgnqMh71tbBWaSMpedcC/QkK"
    "aHPmHL1n9K/n+hTBL1ErpujKEPxeqA0Sau9QrNgA/owCu0ZnCFtUr2PNsstkcb4qe/TeV1jXYEQ3xM1hf+ypICL2Trj8"
    "/Qtc5CfBpocdhHT7R5ieZsdkBdVD/cxsyjbdhhU5iqi1oxE1x1vQ6/4BqKq9BLlr+BltvgrIqJnDHQ1sIqoq9ZxvY8Eo"
    "Jy7Axo6qgaCfIzjxvIS6IyLYnzaNXaDthqo3MnFqygJ7ddrRNSILInddhL33c6GgdQ1+tuNj7WLPok/rEPI31ONe293/"
    "8NYDr79lQnp0BGky56P2DyJxed5cfPJoKbqszqX1nDf4WNcGtFS/EL8vupAc7IN8Enfw3lJZfOwiip/2JOP6nb24Qq0P"
    "Ap6FgGj7Mfp0321ug2kuRhju4p56/ow2kk5syn1GFey0mH0wReR0KRGTjiD9XS9wMhXpUcPlmBnjie82hKPv53/n0WXg"
    "W3AO3nxxAkcW1uHpbh86MN0AdxYN4kPFjxgoxAtLzytg8KMxumFbFNqrCrNPkhLxyOgVlHDopSGayVh7xxx4jA4Q1tiU"
    "aSs1BvlVf7Fo8ScaZ/Qcf0wTxXu2KnitoZ1sgnyyXnYF0/1bgjF/5oc+EploSbrxs9xd8w4mhRzzFGCCVpiDy7vdOCL7"
    "DBs0RNj1fhEYsyQM095EcHV+bqZRXw1hS9Yg/orZjdYh4Ui+XMaG0vl4xXMf1rwvwU6TvailfBWKzKbjpI4kI3pdiDl8"
    "IAcs9mbD9vGfoH/Yiimcqcww2S7MykBpJoV1JGxqJiQ4RsJy+zgy0mcKTIoeY6rdCa7dWkx9kAfM8RXHmPQKsIi6AKov"
    "Z8PwvYvkxNUQzqUOARDjV2V6Ux1JtOxFtDrrRUS9EzlWS1TYDys/YIpzForw8dA5zBs6GNaObc/EGKkDkky9pAizY+A0"
    "c9atnHnonwsHnqfCzL+rGV7OPGZpoC42v+dlhy624cMH0+D+zddQo6HMbjhbg1WLk1FAfT4Ojd7nrI+yJwm1T2DmGV6m"
    "Rk2FWRTuTzbOCwENxzVUubUKj88tx51PvmHL2FX0rPpMu/Wb6LuT09ls9348lSHLBpepsN51s0Fe+XZdl/QCLJEKBDOJ"
    "XMIHxjTFfYRbNyOAnglMNP9zYzXeUCnE+4e5HBOXK6CcGYFX5RSgceIp9VL7gZIFMzBe6Ah82RtBIvff5R5qKYaJga1c"
    "Hq1PxOb5PjDTsYVXOgB2zdboW9qLoevrSfaSH3AgRobTtLkNHnj+oPXT3mGhkS2ur7lPQuYrYnpZOP10ppco8P7iTps5"
    "TJ2vncKFfVdwVX8KCDWlgk7fKbLC9g9Z/SuO8EerYEWzA9dAJIIE3hiik8pDIOp5tV7hQB4e/OddEbNEAId/gl1ePcmX"
    "d8YonbO0mFeA+bnQHbbMukm2CM2DtId/oOboLXhqQuFj5AVwK5EkeVn6jFmgKOWXKUQlgzh0kLcGGbKEJB/NR8eg9PrJ"
    "ETGUkf9AHmafhRutibihmtCQQVGqaRJNV52Zj15GbjBl+pFcdR0lVz6vgcXXXnOd2AjKOuXBaMY8WLR2FfWJ8uE0Hw9B"
    "8aFb4Pacj8lrm0lbx7RJnrEjHJqtRF1rI+mM8ytRY3AR3tz0BOLuFcLodMCp7tl4YPshGq8qyPhWHaNXMiKxJnQuPo7O"
    "IBnPWshlkyLwm/fOfNw/Ea7mXYfrKRe523UiMXb1JWxxzkO12fvJhk1VmH5xMbnTKEHHJR+Bsf0dsnR7DPYFFpIc11uc"
    "9jluEO+RDd6viklwzQ0y03YuWL7F+pGNMdw+71AwcX9Ahg+0EOF/+X1etyBtTLClCeJ6sOt2Au0TPQzDe1Xh1Nc0uuKk"
    "ASrNNsZnNi20PKaOdEQJcGaqLyd7u4xhyGwC9JNkYelIFx14P43bcqGYSC7qpZsv/6o/s+AmfrCQxeVDGjTF4jRSjaXI"
    "fXsPz9kuwBW0mxwckSNJhsk4vPtFHacukfx+8IbIujiRwmma0Jl2m+Sf3QzCT++TBTm2uG7jXxxYbsS85f0NfX1Z6HZW"
    "gqhv3Y1OsXK4NF+SXt+xkhomNSLv7izoPllIAy8+o8/cw/FZ/jEq5fuFYzl+h1P3iMV7uzh4/L4Qs3VcjZlZHEU5agM0"
    "s8UJj4o00p7iBrpydge+7eBjd/6RY8SNeBj5OwkcI7F3pPHOBjAepGBj4QfCVbeIbsQATa26BY5tLNkrxtKAHj5csz6Q"
    "QoomHVZ9Rs33rodUiwukQSgSnosm0FM62uRt/ykiM+Jg7lGeAyOQS0YSJqkr448PViPMEpVnaLUOcXH8Q+b03sZkVgW/"
    "uDwi9csniaFPEs7dJwzr3A24sTgNyhz2QmCkAMRc+2We2scL1Zsy4JLUdXLGMReq+wXBya8e7SwsQOtHAIRtmkux7ybH"
    "0z+AvtrEkkNNvWDaFc+p1AuE29t8wcfsL3XkW0WEDpfDd7kQjm/CQ8oz8b1e5r+LJHzD3PotWdZgsFEflfeswKTZK1Dr"
    "9j7a+s0BvhbIUrF4YaSBs2CsXxfWPNQHRe1Bkkb/I9MXaMFDJXnSX3sHMKULNno3kKoP2dzZ67TJgGg3qHN+wLBEG6z9"
    "1U1jhORhdbgfBK1YBXddl4OCgDoqlYzRAgtrerdZE+LDzhIhHy7NcRSGSdtM8r2rFrK7VMB6x276WiyfBKU/IPZvRbB+"
    "ahfeD42kw/EH4KgIA089S0mQCT9j/N2WmR12DgS7P3PvDGlC+h5e+BNeY/5aag8d78gkW8rLYLJOhBGf/w7C782Bk2pN"
    "YBz7hO6+KI5GCZYoU3IMg/OzOcG84SBQ3UoTzm7D0lsMmrlepIHJEqh3tAG/SYXh264UariilrO/t4/rHfSvH85+y5nt"
    "mUkb3+th3PkDqJPryO2pPgsOMAQWZvfgl8s4LZPaCeYLV8CnkVZ8evEmnjYQRGA3wtHzOuDeHMy5zNrhrv1zmBtfCLir"
    "/KVLjzKYrCqAHtV3aHeGAcr5GcDY6QastrLE4Ji11HvuP2+v3copWOKFzRkj3G2V/qikLojT5TJwUHodJ37rOWw02Q9q"
    "++/Solo1iKsWZ9or1ZgDXWfIIYWDVORZFzQ7b4ClHnl0YrsYNrutQh59hC0Pn0FT+TG4z+dOxxUyyIt/9/4dqoLuyp5m"
    "QV3uOLsjm2ic8KGlBd3UpewLnXz9kgSqnUJRj3G6x0kMvc50optALP7WcEKTgukQ9nsQ+y7H47xaCXbFUnlSrBFu9vB4"
    "BNdIfRLinG+CQXwaKP7ig98rskHSSQV2LVqDS7tTiFv1c/JFTITZdJRAl6k2HLIrg9VGk5C/y5n45djBGoNq7jLdWrSy"
    "qqWyicU4FhkE/20XwEYNfXq8x5me0PwP38sDhqT8wOhTsZhVVYnXW8LwvFESOaMmAWN3XuGpd99Jb6kko7pgHjN3gSlz"
    "T3wIXl9+Ah07asBw+zlwnBkDTwLLieXLMJib0QoH1+2FVb5vycGyJ+T86QI4yInjKH0SIYHBz6ig9VVuhnYl/eSdhc2T"
    "JRgZUEKvaWhTXo+M+l+fFOqtrqSg4GgagoA1Hl7wCt1nZ+H6rGrUeE2xhr7C8txuZAYugH1DP+F3+gAH1y5j8IYQXMwt"
    "Jz3XDoDIbxGuj+RRbrDlAOn88ZceE/Mlkp7hREp8B3XdYYTPp9xx7lYFVr5ZiV1cbQoanZfMxVV2ks0PdsLsfavwVLEV"
    "6vYI0AftClx/Wy6N2PsfLC9ahhIR1/GMcw6K6r3AAU9+5Hc7SnZtX4n9EbNRe0cTBGa7kbF3++n3+QvIuvGfdNOtMHK7"
    "Kdl83fs11D6ZwxENXQSLYuXZH/55FEtZmnP9PI2puvDPe2vonWUxKO8lAYf+/3eB85KO74qmcc4hsEmiBOWMM6HUxQas"
    "RExwSv8wfZSQAatyR/DZlAN0oDnMX38QRSWroVYulDYEKLJ7P+dD5sgy0D+4BUO109GnSBZ7X6gztDQXbBUPY6n/AJ2x"
    "dgAufVeCF3OXoInUaug6tIWEsWegvCsdDkl4wvXoz2QXfwMM7HkC6eLGuG0wl7Ql7Obmu8sz90o6ITDXEI1seNld/XXw"
    "lzsAVYuO4vs5d2COxA24V50Ihcu6ycD5m5zNSQfx3Jw/8LN+LycwZDmn9OgM2OBeTJY1zIcwRW1yrcOd1s8Lo6W+j8nH"
    "Ryz5u8WKkx4aQRgSDVW9B+A7u5q0RThSbftEkhHhAHs0IsHLxhhrPdU5YrttOBYt0TBlbYBPnRYR9fPhWC74T2MfTUFZ"
    "dQnwimXCWIwmjPqcgdaa23BqLS/Dc6mMVriXwQkBXZQLfEpDjuWQFW+EoHpImThNraY9zXq4PMmbWiyRxiffWui9vkqY"
    "SlgArxvbSC2fMTXzKuRKm44TgbYuMj0qmMqOmEJdTzyYJ1XCeE8c6FV2QNI+N+hVjYRxXWX82bGVyLYlwsQ1VxiNWg7u"
    "N0dhbGgrGGlk0e6REBgJmiLnrl2Bdb0llC9MFRZ29HNXvOzgrHJ3oIanEk0N+M3BNDeHCpxfi6e6/yNniw3JCctUzq+u"
    "ThJ26TadFPuXb4/1mze+OozrX76ki89HQqI6ENbVnhyWzACv6wrU2toGv0iVkeNG4WCjthjWpQrhvkpZOKj/krtguxK5"
    "qZNAYhaH4a6oOGw4WQT1qQM0QeY1WfclFJ78e4f0KG9IHasAh+af3CNvC2mJoSVa3IyiM2UiaCnZDv2DityMEBNSEXsc"
    "Im8E47meayiELB55tBDvXqrhSPKtgHHbJKIqX8EJn5zB1P0OxpMHv9DWLR/h1GI7VFpbx3mvcpkUhnGwd8ICdZLHiGYu"
    "i5b/GaH5jjVo4KmB1r82kj63YDD5Twk8rK7C5AdxpltnFfDsD0HPi7twf1A2UUgVRD8lEWANE5G8M8WrM3aQr2eLoUw2"
    "FR2ibxPD79dI95FuordLhw67KBL5g785FTEqTOKpS6TWtwXrNWvwrHIeGkneJByaRD8dF0DpuGKsGb2K4rlcMt7xHpdn"
    "SOOD62ZYvvcjPTAUC7e3LiFFPG2kY8W/rpJSBAF3ZHH8hjF52rAcEsYksJYRBUK98ehjMQImp7l2TvxgKbiR5inMp+e9"
    "L2DhSWHi/6/Hpkk40YS52TSq2Qg0r+0BVkYZo9TyCL38xDxVVRU1L+rCwm1KbNcHU/yru5L4SVVx9b9EUn+RXxzTE1no"
    "7HwFvJY8gDQbGzpsGglG0eYQmnkebDQmyLLIBNKaRqF6bVPdkHgv9E4shSizHDLXqI8+OBDPnZl0jSN+2Ye8HvGFxZeF"
    "cU0KgfSSbryWc5ZY/UgnTZanaatCDZWBZVAtcxKvTNtNf3dfA8POs8hM9RGrOQZ41/EPdTkljbNDs+nOX7aYNm0WzGkm"
    "cGi3LZxQ14fbdoADLn20ZLcYmbZSDeY77QfF/2ZCTmNinZrQJCHtArhu7haMXLoGFgwqU3OUgXRPPa7y09P1xlfGSKPw"
    "ISp78xeZk9RKBhdlkJ3HBGFFsxRycxfRH64mNPnbWH1gv0p9ufMSnBFmxen3Dwa7NRU0IMKaG1Rlj43fA4mO3npyqmgD"
    "OExXISkWrtw4p4/A5Z+FtYv0uYf3/SaOnWb0+rmvJP3TJxI7rAZSzuL4m+GCw5UKWth9DCYfnMR3dnlkDt8zTqtjNDqW"
    "SpDheHHYsbeFrIsVYrfP0EWzuEv0xd+FZOfFI6TlWxYWbjvOXT8VjLuEh2mOliDb+i4Fnaaz3Dv+YlRqRBlaVvYTb7/V"
    "UHH6CxU60wQfvM6S/KEAuKi4HK8JedKo+DFu/qtqOsxsomvuTnGinvwG894vJGCJLHSG5mFIsRn1cO0w++QfgM97TOjX"
    "lCzuvg25cNckFtsFd2Fp2SaEC+ZUSDqC9mpZoKWsEe25p0u0bDZx+Cf3YU3lWWR9hHGfjy4oHpeAUo96cvAhJfFLn3LK"
    "819D9rpbXOe//zxOZwHefcjiobet3OLD7TS/ZysRPKVATq/IoJq2Xnhx1xw8+C0Pd4f3c0YFDsPh++q4oiWYDOdY0TlD"
    "b7ge3n/o7D06iELBNCKboEPtRyJBK1F8Fz/2cF3RrcGHevkmoG98Jd7WNcO90vogtP0v4fgWw99Zi4hJSShs/3QCZrV+"
    "JKJbGkkEjYHP0gKoekGJqtpcgpJfN2jE+DqwSMqk9pfPk+TtBdQ9/TleXM4La20dOVcCy+n2jQuxZJoVyO7Th2V9XnDa"
    "Mote+OoJGy0mKLt/PyFtUXhrywH00lNCM/8WzBjkwzeLvdAvtwv3xmfAl94YjskxAZA7JMapvrcOktocqNSW2+RqQwhI"
    "vz+PXtGlwNN8HvfbRqDulfv02NMIkLswG66HW4NW3lKaLzoHdW56w+T1gxA9bSnVibvwz/MX4LGEzcTJvQ7UOx+CYtts"
    "7PxvNam/kIXS9fJ418AA396iEC02bmaS+IHsji4nFgGCZnuGPhFLo3Kct3gl3s69CPlte3F58S6Svl0cFiZFYYvqL9p3"
    "7h9vSAZukzEn7fuc/80hD5WLrtDoWx544ed0lofzk9y8HAOCdSex5vJ+9FIMBtb0M8l1iKbbbeRwWDaczjt5s37dKUkm"
    "o0uGrtUQwNphN05+pB7H+ex0mJnRTIeX6uExv6cw36674X84CeCw"
)
