"""Training data for ``CenterDet``: COCO splits written by ``lookahead export-dataset``.

Training crops are cut from images letterboxed exactly as
``perception.detectors.onnx_detector`` does at run time (``perception.letterbox``), so
training sees the grey bands inference sees. A frame larger than the model input (a
1280 x 720 camera's) is letterboxed at its own resolution instead and its scale range
shrunk by the same factor (``native_letterbox``): the crops have the geometry of the
run-time letterbox, and a magnified one keeps the detail the camera resolved, as a zoom
window on such a frame does.
Boxes are visible boxes, xyxy px. An object is *trained* when its visible box is at
least ``MIN_TRAIN_H`` px tall and ``MIN_TRAIN_W`` wide with visible fraction >=
``MIN_TRAIN_VISIBLE``; other labelled objects are *ignored*: the heat-map loss is
masked over their boxes (the network is neither taught nor punished there).

Targets (CenterNet, stride ``STRIDE``): a Gaussian per trained object on its class's
heat map, peak 1 at the cell holding the box centre (sigma from the box size, as
CenterNet's ``gaussian_radius`` with min overlap 0.7). Box regression is taught at that
cell and at its nearer neighbour along x and along y (2 x 2 cells, as YOLOv5 assigns
neighbour cells), so a peak one cell off still carries a trained box: the centre's
offset from the cell (cells, in [-0.5, 1.5), ``model.cell_offset``) and log(w / STRIDE),
log(h / STRIDE).
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from lookahead.perception.detections import CLASSES
from lookahead.perception.letterbox import letterbox, letterbox_boxes

log = logging.getLogger(__name__)

STRIDE = 4
INPUT_HW = (384, 640)
MIN_TRAIN_H, MIN_TRAIN_W, MIN_TRAIN_VISIBLE = 4.0, 2.0, 0.25
MAX_OBJECTS = 96
REG_CELLS = 4  # regression cells per object (2 x 2)
SCALE_RANGE = (0.8, 1.25)  # default rescaling of training frames (log-uniform factor)


class ImageFiles(Sequence):
    """A split's camera images, read from disk when indexed: RGB uint8, all one size (``hw``).

    Nothing is held decoded (19 200 frames of 640 x 360 are 13 GB), so the training set can
    grow past RAM; the OS page cache keeps the PNG files (~170 kB each) once read. Missing
    files are reported when the split is opened; an unreadable or odd-sized one when read.
    """

    def __init__(self, paths: list[Path], hw: tuple[int, int]) -> None:
        missing = [p for p in paths if not p.is_file()]
        if missing:
            raise FileNotFoundError(f"{missing[0]}: no such image ({len(missing)} of {len(paths)} missing)")
        self.paths, self.hw = paths, hw

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i: int) -> np.ndarray:  # type: ignore[override]
        path = self.paths[i]
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise FileNotFoundError(f"{path}: unreadable image")
        if bgr.shape[:2] != self.hw:
            raise ValueError(f"{path}: {bgr.shape[1]}x{bgr.shape[0]} px, the split's first image is "
                             f"{self.hw[1]}x{self.hw[0]}")
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


@dataclass
class Split:
    """One COCO split: camera images (decoded when indexed) and per-image labels."""

    images: Sequence[np.ndarray]  # N images (H, W, 3) uint8 RGB: ``ImageFiles``, or an array
    boxes: list[np.ndarray]  # per image (K, 4) xyxy px
    classes: list[np.ndarray]  # per image (K,) int class id
    visible: list[np.ndarray]  # per image (K,) visible fraction
    ranges: list[np.ndarray]  # per image (K,) range (m)
    names: list[str]  # image file names


class DatasetError(ValueError):
    """A COCO annotations file that is not what ``export-dataset --format coco`` writes (one line
    naming the file and the field)."""


def _is_number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


# what load_split reads of a COCO file: (key, check, expected), per image and per annotation
_IMAGE_FIELDS = (("id", _is_int, "an integer"), ("file_name", lambda v: isinstance(v, str) and v != "", "a file name"),
                 ("width", lambda v: _is_int(v) and 0 < v <= 1 << 15, "an integer 1..32768"),
                 ("height", lambda v: _is_int(v) and 0 < v <= 1 << 15, "an integer 1..32768"))
_ANNOTATION_FIELDS = (
    ("image_id", _is_int, "an integer"),
    ("category_id", lambda v: _is_int(v) and 1 <= v <= len(CLASSES), f"a class id 1..{len(CLASSES)}"),
    ("bbox", lambda v: isinstance(v, list) and len(v) == 4 and all(map(_is_number, v)), "[x, y, w, h] numbers"),
    ("occlusion", lambda v: _is_number(v) and 0 <= v <= 1, "a number 0..1"),
    ("attributes", lambda v: isinstance(v, dict) and _is_number(v.get("range_m")), "a mapping with range_m, a number"),
)


def _read_coco(ann_file: Path) -> dict:
    """``ann_file`` parsed and checked for what ``load_split`` reads; ``DatasetError`` names the file and
    the first bad field (``images[3].width``)."""
    try:
        doc = json.loads(ann_file.read_bytes())
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DatasetError(f"{ann_file}: not a COCO annotations file (not JSON: {str(e).splitlines()[0]})") from None
    except RecursionError:
        raise DatasetError(f"{ann_file}: not a COCO annotations file (nested too deeply)") from None
    if not isinstance(doc, dict):
        raise DatasetError(f"{ann_file}: not a COCO annotations file (a JSON object expected, got {type(doc).__name__})")
    for key, fields in (("images", _IMAGE_FIELDS), ("annotations", _ANNOTATION_FIELDS)):
        if key not in doc:
            raise DatasetError(f"{ann_file}: no {key!r} key (a COCO annotations file has images and annotations)")
        if not isinstance(doc[key], list):
            raise DatasetError(f"{ann_file}: {key}: a list expected, got {type(doc[key]).__name__}")
        for i, item in enumerate(doc[key]):
            if not isinstance(item, dict):
                raise DatasetError(f"{ann_file}: {key}[{i}]: a JSON object expected, got {type(item).__name__}")
            for name, ok, expected in fields:
                if name not in item:
                    raise DatasetError(f"{ann_file}: {key}[{i}]: no {name!r} key")
                if not ok(item[name]):
                    raise DatasetError(f"{ann_file}: {key}[{i}].{name}: {expected} expected, got {item[name]!r:.40}")
    return doc


def load_split(path: str | Path, limit: int | None = None) -> Split:
    """Read ``path/annotations.json``; its images are read when used (``ImageFiles``). A file that is
    not JSON or lacks what is read is a ``DatasetError`` naming it and the field."""
    root = Path(path)
    ann_file = root / "annotations.json"
    if not ann_file.is_file():
        raise FileNotFoundError(f"{ann_file}: no COCO annotations (export with --format coco)")
    doc = _read_coco(ann_file)
    images = doc["images"][:limit] if limit else doc["images"]
    by_image: dict[int, list[dict]] = {}
    for a in doc["annotations"]:
        by_image.setdefault(a["image_id"], []).append(a)
    hw = (images[0]["height"], images[0]["width"]) if images else INPUT_HW
    boxes, classes, visible, ranges, names = [], [], [], [], []
    for im in images:
        anns = by_image.get(im["id"], [])
        xywh = np.array([a["bbox"] for a in anns], dtype=np.float64).reshape(-1, 4)
        xyxy = np.concatenate([xywh[:, :2], xywh[:, :2] + xywh[:, 2:]], axis=1)
        boxes.append(xyxy.astype(np.float32))
        classes.append(np.array([a["category_id"] - 1 for a in anns], dtype=np.int64))
        visible.append(np.array([1.0 - a["occlusion"] for a in anns], dtype=np.float32))
        ranges.append(np.array([a["attributes"]["range_m"] for a in anns], dtype=np.float32))
        names.append(im["file_name"])
    files = ImageFiles([root / n for n in names], hw)
    log.info("%s: %d images, %d objects", root, len(images), sum(len(b) for b in boxes))
    return Split(files, boxes, classes, visible, ranges, names)


def load_splits(paths: Sequence[str | Path], limit: int | None = None) -> Split:
    """Several splits read as one, in order (``load_split`` each); ``limit`` counts across them.

    Their images must all be one size (one line naming the first split that differs)."""
    parts: list[Split] = []
    for path in paths:
        left = None if limit is None else limit - sum(len(p.names) for p in parts)
        if left is not None and left <= 0:
            break
        parts.append(load_split(path, left))
    if len(parts) == 1:
        return parts[0]
    for path, part in zip(paths[1:], parts[1:], strict=False):  # a limit may leave later paths unread
        if len(part.names) and part.images.hw != parts[0].images.hw:
            h, w = part.images.hw
            raise ValueError(f"{path}: {w}x{h} px images, {paths[0]}'s are "
                             f"{parts[0].images.hw[1]}x{parts[0].images.hw[0]}")
    files = ImageFiles([f for p in parts for f in p.images.paths], parts[0].images.hw)
    return Split(files, *([x for p in parts for x in getattr(p, f)]
                          for f in ("boxes", "classes", "visible", "ranges", "names")))


def trained_mask(boxes: np.ndarray, visible: np.ndarray) -> np.ndarray:
    w, h = boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]
    return (h >= MIN_TRAIN_H) & (w >= MIN_TRAIN_W) & (visible >= MIN_TRAIN_VISIBLE)


# ------------------------------------------------------------------ augmentation
def _photometric(img: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Saturation / contrast / brightness / white-balance / gamma jitter (one per-channel LUT),
    sometimes blur or sensor noise (uint8 in/out)."""
    sat = rng.uniform(0.6, 1.4)
    grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    img = cv2.addWeighted(img, sat, cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB), 1.0 - sat, 0.0)
    mean = float(grey.mean())
    v = np.arange(256, dtype=np.float32)[:, None]
    v = mean + (v - mean) * rng.uniform(0.7, 1.3) + rng.uniform(-25.0, 25.0)
    v = np.clip(v * rng.uniform(0.9, 1.1, size=(1, 3)), 0.0, 255.0)
    lut = np.clip(255.0 * (v / 255.0) ** rng.uniform(0.7, 1.4), 0, 255).astype(np.uint8)
    img = cv2.LUT(img, np.ascontiguousarray(lut[None]))  # (1, 256, 3): one table per channel
    if rng.random() < 0.2:
        k = int(rng.choice([3, 5]))
        img = cv2.GaussianBlur(img, (k, k), 0)
    if rng.random() < 0.3:
        noise = rng.standard_normal(img.shape, dtype=np.float32) * rng.uniform(2.0, 10.0)
        img = np.clip(img + noise, 0, 255).astype(np.uint8)
    return img


def random_crop(
    img: np.ndarray, boxes: np.ndarray, crop_hw: tuple[int, int], rng: np.random.Generator,
    scale_range: tuple[float, float] = SCALE_RANGE, weights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rescale by a random factor, crop ``crop_hw`` (biased toward objects), flip half the time.

    Most crops are centred near an object drawn with probability ``weights`` (per box;
    uniform when None), the rest placed uniformly. Returns the crop, its boxes
    (clipped) and a mask of boxes that keep >= 60 % of their area (the others
    become ignore regions).
    """
    s = float(np.exp(rng.uniform(np.log(scale_range[0]), np.log(scale_range[1]))))
    h, w = img.shape[:2]
    nh, nw = max(crop_hw[0], round(h * s)), max(crop_hw[1], round(w * s))
    sx, sy = nw / w, nh / h
    img = cv2.resize(img, (nw, nh), interpolation=cv2.INTER_LINEAR)
    b = boxes * np.array([sx, sy, sx, sy], dtype=np.float32)
    ch, cw = crop_hw
    if len(b) and rng.random() < 0.7:  # centre the crop near an object
        k = int(rng.integers(len(b))) if weights is None else int(rng.choice(len(b), p=weights / weights.sum()))
        cx, cy = (b[k, 0] + b[k, 2]) / 2 + rng.uniform(-cw / 3, cw / 3), (b[k, 1] + b[k, 3]) / 2
        x0 = int(np.clip(cx - cw / 2, 0, nw - cw))
        y0 = int(np.clip(cy - ch / 2 + rng.uniform(-ch / 4, ch / 4), 0, nh - ch))
    else:
        x0, y0 = int(rng.integers(0, nw - cw + 1)), int(rng.integers(0, nh - ch + 1))
    crop = img[y0:y0 + ch, x0:x0 + cw]
    area = np.maximum(b[:, 2] - b[:, 0], 0) * np.maximum(b[:, 3] - b[:, 1], 0)
    b = b - np.array([x0, y0, x0, y0], dtype=np.float32)
    c = np.clip(b, 0, [cw, ch, cw, ch]).astype(np.float32)
    carea = np.maximum(c[:, 2] - c[:, 0], 0) * np.maximum(c[:, 3] - c[:, 1], 0)
    whole = carea >= 0.6 * np.maximum(area, 1e-6)
    if rng.random() < 0.5:
        crop = crop[:, ::-1]
        c = np.stack([cw - c[:, 2], c[:, 1], cw - c[:, 0], c[:, 3]], axis=1)
    return np.ascontiguousarray(crop), c, whole & (carea > 0)


# ------------------------------------------------------------------ targets
def gaussian_radius(h: float, w: float, min_overlap: float = 0.7) -> float:
    """CenterNet's radius (cells) within which a corner shift keeps IoU >= ``min_overlap``."""
    a1, b1 = 1.0, h + w
    c1 = w * h * (1 - min_overlap) / (1 + min_overlap)
    r1 = (b1 + math.sqrt(b1 * b1 - 4 * a1 * c1)) / 2
    a2, b2 = 4.0, 2 * (h + w)
    c2 = (1 - min_overlap) * w * h
    r2 = (b2 + math.sqrt(b2 * b2 - 4 * a2 * c2)) / 2
    a3, b3 = 4 * min_overlap, -2 * min_overlap * (h + w)
    c3 = (min_overlap - 1) * w * h
    r3 = (b3 + math.sqrt(b3 * b3 - 4 * a3 * c3)) / 2
    return min(r1, r2, r3)


@dataclass
class Targets:
    heat: np.ndarray  # (C, h, w) float32 in [0, 1]
    mask: np.ndarray  # (h, w) float32: 0 inside ignored boxes
    index: np.ndarray  # (K,) int64 flat index of each regression cell (REG_CELLS per object)
    reg: np.ndarray  # (K, 4) float32 centre offset x, y from the cell (cells), log w, log h (cells)
    valid: np.ndarray  # (K,) float32 1 for real entries


def encode(boxes: np.ndarray, classes: np.ndarray, train: np.ndarray, hw: tuple[int, int],
           num_classes: int) -> Targets:
    """CenterNet targets for an image of ``hw`` px (module docstring)."""
    gh, gw = hw[0] // STRIDE, hw[1] // STRIDE
    heat = np.zeros((num_classes, gh, gw), dtype=np.float32)
    mask = np.ones((gh, gw), dtype=np.float32)
    k_max = MAX_OBJECTS * REG_CELLS
    index = np.zeros(k_max, dtype=np.int64)
    reg = np.zeros((k_max, 4), dtype=np.float32)
    valid = np.zeros(k_max, dtype=np.float32)
    ys, xs = np.arange(gh, dtype=np.float32)[:, None], np.arange(gw, dtype=np.float32)[None, :]
    k = 0
    for box, cls, t in zip(boxes, classes, train, strict=True):
        x0, y0, x1, y1 = (float(v) / STRIDE for v in box)
        if not t:
            mask[max(0, int(y0)):int(math.ceil(y1)) + 1, max(0, int(x0)):int(math.ceil(x1)) + 1] = 0.0
            continue
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        ix, iy = min(int(cx), gw - 1), min(int(cy), gh - 1)
        r = max(0.0, gaussian_radius(y1 - y0, x1 - x0))
        sigma = (2 * r + 1) / 6
        g = np.exp(-((xs - ix) ** 2 + (ys - iy) ** 2) / (2 * sigma * sigma))
        np.maximum(heat[cls], g, out=heat[cls])
        heat[cls, iy, ix] = 1.0
        nx = ix + (1 if cx - ix >= 0.5 else -1)  # the nearer neighbour along each axis
        ny = iy + (1 if cy - iy >= 0.5 else -1)
        lw, lh = math.log(max(x1 - x0, 1e-2)), math.log(max(y1 - y0, 1e-2))
        for jx, jy in ((ix, iy), (nx, iy), (ix, ny), (nx, ny)):
            if k < k_max and 0 <= jx < gw and 0 <= jy < gh:
                index[k] = jy * gw + jx
                reg[k] = (cx - jx, cy - jy, lw, lh)
                valid[k] = 1.0
                k += 1
    mask = np.maximum(mask, heat.max(axis=0) >= 1.0)  # a trained centre is never masked
    return Targets(heat, mask, index, reg, valid)


def native_letterbox(img: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``img`` letterboxed to the aspect of ``INPUT_HW`` at its own resolution when it is larger
    than the input, else to ``INPUT_HW``: the padded image, its boxes (px) and the factor from
    it to ``INPUT_HW`` (1 for a frame no larger than the input; 0.5 for 1280 x 720)."""
    h, w = img.shape[:2]
    fit = min(INPUT_HW[0] / h, INPUT_HW[1] / w)
    to_input = min(1.0, fit)
    hw = (round(INPUT_HW[0] / to_input), round(INPUT_HW[1] / to_input))
    padded, scale, pad = letterbox(img, hw)
    return padded, letterbox_boxes(boxes, scale, pad).astype(np.float32), to_input


class TrainSampler:
    """Random training samples (crop, targets) from a ``Split``; every draw from ``rng``."""

    def __init__(self, split: Split, crop_hw: tuple[int, int], num_classes: int, seed: int,
                 balance: float = 0.5, scale_range: tuple[float, float] = SCALE_RANGE) -> None:
        """``balance``: crops centre on an object of class c with weight freq(c) ** -balance
        (0: every object alike; 1: every class alike), so rare, small classes get seen.
        ``scale_range``: frames are rescaled by a factor drawn log-uniformly from it."""
        self.split, self.crop_hw, self.num_classes = split, crop_hw, num_classes
        self.scale_range = scale_range
        self.rng = np.random.default_rng(seed)
        counts = np.bincount(np.concatenate(split.classes) if split.classes else np.zeros(0, np.int64),
                             minlength=num_classes).astype(np.float64)
        self.class_weight = np.where(counts > 0, np.maximum(counts, 1.0) ** -balance, 0.0)

    def sample(self, i: int) -> tuple[np.ndarray, Targets]:
        s = self.split
        train = trained_mask(s.boxes[i], s.visible[i])
        padded, boxes, to_input = native_letterbox(s.images[i], s.boxes[i])
        w = self.class_weight[s.classes[i]] * (0.1 + 0.9 * train)  # ignored objects seldom centre a crop
        lo, hi = self.scale_range
        crop, boxes, whole = random_crop(padded, boxes, self.crop_hw, self.rng, (lo * to_input, hi * to_input), w)
        crop = _photometric(crop, self.rng)
        w, h = boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]
        keep = (w > 0) & (h > 0)
        ok = train & whole & (h >= MIN_TRAIN_H) & (w >= MIN_TRAIN_W)
        tgt = encode(boxes[keep], s.classes[i][keep], ok[keep], self.crop_hw, self.num_classes)
        return crop, tgt

    def batch(self, idx: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        samples = [self.sample(int(i)) for i in idx]
        x = np.stack([c for c, _ in samples]).transpose(0, 3, 1, 2)
        t = {f: np.stack([getattr(tg, f) for _, tg in samples]) for f in ("heat", "mask", "index", "reg", "valid")}
        return x, t
