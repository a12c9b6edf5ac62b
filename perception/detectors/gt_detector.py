"""``GtNoiseDetector``: ground-truth boxes through a seeded, vectorised noise model.

Per frame, for the N ground-truth objects (all draws made for every object, in a
fixed order, so the same seed and truth sequence give identical output):

1. never detected: non-finite boxes, ``visible_fraction < min_visible``, box
   height < ``min_height_px``;
2. missed with probability ``miss_rate + miss_per_m * max(0, range - miss_range_m)
   + miss_occlusion * (1 - visible_fraction) + miss_truncation * truncation``, clipped to [0, 1];
3. each edge jittered by a Gaussian of ``box_sigma`` times the box width (x edges)
   or height (y edges), then clipped to the image;
4. class swapped with probability ``class_confusion`` to a similar class (``CONFUSABLE``);
5. scored ``score_hard + (score_easy - score_hard) * ease + N(0, score_sigma)`` with
   ``ease = sqrt(visible_fraction) * (1 - exp(-height / score_size_px))``;
6. Poisson(``fp_rate``) false positives: plausible boxes in the lower 2/3 of the
   image, scores uniform in [``fp_score_min``, ``fp_score_max``], ``source_id`` -1;
7. emitted ``latency_frames`` frames late through a FIFO (empty until it fills).
"""

from __future__ import annotations

from collections import deque

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from lookahead.perception.detections import CLASS_ID, CLASSES, Detections
from lookahead.perception.detectors.base import DetectorTruth

#: Classes a detector plausibly confuses each class with (picked uniformly; none: never swapped).
CONFUSABLE: dict[str, tuple[str, ...]] = {
    "pedestrian": ("cyclist",),
    "cyclist": ("pedestrian", "motorcyclist"),
    "motorcyclist": ("cyclist",),
    "tricycle": ("cyclist", "motorcyclist"),
    "car": ("truck",),
    "truck": ("car", "bus"),
    "bus": ("truck",),
    "animal": ("pedestrian",),
    "obstacle": (),  # a cone is not mistaken for a road user (it may still be missed)
}

#: Typical width / height of each class's 2D box, for false positives.
_ASPECT = {
    "pedestrian": 0.4,
    "cyclist": 0.6,
    "motorcyclist": 0.6,
    "tricycle": 0.9,
    "car": 1.4,
    "truck": 1.1,
    "bus": 1.2,
    "animal": 1.3,
    "obstacle": 1.5,
}


def _confusion_table() -> tuple[np.ndarray, np.ndarray]:
    width = max(len(v) for v in CONFUSABLE.values())
    table = np.zeros((len(CLASSES), width), dtype=np.int64)
    count = np.zeros(len(CLASSES), dtype=np.int64)
    for name, others in CONFUSABLE.items():
        i = CLASS_ID[name]
        table[i, : len(others)] = [CLASS_ID[o] for o in others]
        count[i] = len(others)
    return table, count


#: Per class id: the ids it may be mistaken for (``CONFUSABLE``, padded with 0) and how many there are.
CONFUSION_TABLE, CONFUSION_COUNT = _confusion_table()
_ASPECTS = np.array([_ASPECT[c] for c in CLASSES])


class GtNoiseConfig(BaseModel):
    """Noise model of ``GtNoiseDetector``; defaults give a good but imperfect detector."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    miss_rate: float = Field(
        0.05, ge=0, le=1, description="Base miss probability of an easy object."
    )
    miss_range_m: float = Field(50.0, ge=0, description="Range (m) beyond which misses grow.")
    miss_per_m: float = Field(
        0.005, ge=0, description="Extra miss probability per m beyond miss_range_m."
    )
    miss_occlusion: float = Field(
        0.5, ge=0, description="Extra miss probability times (1 - visible_fraction)."
    )
    miss_truncation: float = Field(
        0.2, ge=0, description="Extra miss probability times truncation."
    )
    box_sigma: float = Field(
        0.05, ge=0, description="Edge jitter std as a fraction of box width/height."
    )
    fp_rate: float = Field(0.1, ge=0, description="Mean false positives per frame (Poisson).")
    fp_score_min: float = Field(0.25, ge=0, le=1, description="Lowest false-positive score.")
    fp_score_max: float = Field(0.55, ge=0, le=1, description="Highest false-positive score.")
    class_confusion: float = Field(
        0.01, ge=0, le=1, description="Probability of a similar-class label."
    )
    latency_frames: int = Field(0, ge=0, description="Frames by which detections are emitted late.")
    min_visible: float = Field(
        0.1, ge=0, le=1, description="Less visible objects are never detected."
    )
    min_height_px: float = Field(4.0, ge=0, description="Shorter boxes (px) are never detected.")
    score_easy: float = Field(
        0.95, ge=0, le=1, description="Mean score of a large, fully visible object."
    )
    score_hard: float = Field(
        0.35, ge=0, le=1, description="Mean score as size or visibility go to 0."
    )
    score_size_px: float = Field(
        24.0, gt=0, description="Box height scale (px) of the size term of the score."
    )
    score_sigma: float = Field(0.05, ge=0, description="Score noise std.")

    @classmethod
    def perfect(cls) -> GtNoiseConfig:
        """No noise at all: every finite truth box is returned exactly, in order."""
        return cls(
            miss_rate=0.0,
            miss_per_m=0.0,
            miss_occlusion=0.0,
            miss_truncation=0.0,
            box_sigma=0.0,
            fp_rate=0.0,
            class_confusion=0.0,
            latency_frames=0,
            min_visible=0.0,
            min_height_px=0.0,
            score_sigma=0.0,
        )


class GtNoiseDetector:
    """Simulated detector: ``detect(image_or_None, truth)`` -> noisy ``Detections``.

    Deterministic: a ``numpy.random.Generator`` seeded with ``seed`` drives all noise.
    """

    name = "gt_noise"

    def __init__(self, config: GtNoiseConfig | None = None, seed: int = 0) -> None:
        self.config = config if config is not None else GtNoiseConfig()
        self.seed = int(seed)
        self.reset()

    def reset(self) -> None:
        """Restart the random stream from the seed and empty the latency FIFO."""
        self.rng = np.random.default_rng(self.seed)
        self._fifo: deque[Detections] = deque()

    def detect(self, image: np.ndarray | None, truth: DetectorTruth | None = None) -> Detections:
        """Noisy detections of ``truth`` (``image`` is ignored), ``latency_frames`` late."""
        if truth is None:
            raise ValueError("GtNoiseDetector.detect needs the frame's DetectorTruth")
        self._fifo.append(self._observe(truth))
        if len(self._fifo) > self.config.latency_frames:
            return self._fifo.popleft()
        return Detections.empty()

    def _observe(self, truth: DetectorTruth) -> Detections:
        """This frame's noisy detections (no latency)."""
        cfg, rng = self.config, self.rng
        n = len(truth)
        # Fixed draw order and sizes: identical streams for identical truth.
        u_miss = rng.random(n)
        jitter = rng.standard_normal((n, 4))
        u_conf = rng.random(n)
        u_pick = rng.random(n)
        z_score = rng.standard_normal(n)

        b = truth.xyxy
        w, h = b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]
        vis = np.clip(truth.visible_fraction, 0.0, 1.0)
        with np.errstate(invalid="ignore"):
            ok = np.all(np.isfinite(b), axis=1) & (w > 0) & (h > 0)
            ok &= (vis >= cfg.min_visible) & (h >= cfg.min_height_px)
        p_miss = (
            cfg.miss_rate
            + cfg.miss_per_m * np.clip(truth.range_m - cfg.miss_range_m, 0.0, None)
            + cfg.miss_occlusion * (1.0 - vis)
            + cfg.miss_truncation * np.clip(truth.truncation, 0.0, 1.0)
        )
        ok &= u_miss >= np.clip(np.nan_to_num(p_miss, nan=1.0), 0.0, 1.0)

        b, w, h, vis = b[ok], w[ok], h[ok], vis[ok]
        if cfg.box_sigma > 0:
            scale = np.stack([w, h, w, h], axis=1) * cfg.box_sigma
            b = b + jitter[ok] * scale
            b = np.concatenate(
                [np.minimum(b[:, :2], b[:, 2:]), np.maximum(b[:, :2], b[:, 2:])], axis=1
            )
            b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, truth.width)
            b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, truth.height)

        cls = truth.class_id[ok].copy()
        valid = (cls >= 0) & (cls < len(CLASSES))
        swap = valid & (u_conf[ok] < cfg.class_confusion)
        swap[swap] = CONFUSION_COUNT[cls[swap]] > 0
        if np.any(swap):
            c = cls[swap]
            pick = np.minimum(
                (u_pick[ok][swap] * CONFUSION_COUNT[c]).astype(np.int64), CONFUSION_COUNT[c] - 1
            )
            cls[swap] = CONFUSION_TABLE[c, pick]

        ease = np.sqrt(vis) * (1.0 - np.exp(-h / cfg.score_size_px))
        score = cfg.score_hard + (cfg.score_easy - cfg.score_hard) * ease
        score = np.clip(score + cfg.score_sigma * z_score[ok], 0.01, 0.99)

        fp = self._false_positives(truth.width, truth.height)
        return Detections(
            xyxy=np.concatenate([b, fp.xyxy]),
            score=np.concatenate([score, fp.score]),
            class_id=np.concatenate([cls, fp.class_id]),
            source_id=np.concatenate([truth.source_id[ok], fp.source_id]),
        )

    def _false_positives(self, width: int, height: int) -> Detections:
        """Poisson(fp_rate) plausible boxes in the lower 2/3 of a ``width`` x ``height`` image."""
        cfg, rng = self.config, self.rng
        k = int(rng.poisson(cfg.fp_rate))
        if k == 0:
            return Detections.empty()
        cls = rng.integers(0, len(CLASSES), k)
        h_lo = max(cfg.min_height_px, 8.0)
        h_hi = max(h_lo, height / 4.0)
        h = np.exp(rng.uniform(np.log(h_lo), np.log(h_hi), k))
        w = np.minimum(h * _ASPECTS[cls] * rng.uniform(0.8, 1.25, k), width)
        top = height / 3.0
        y1 = rng.uniform(np.minimum(top + h, height), height)
        cx = rng.uniform(w / 2.0, width - w / 2.0)
        xyxy = np.stack([cx - w / 2.0, np.maximum(y1 - h, top), cx + w / 2.0, y1], axis=1)
        score = rng.uniform(cfg.fp_score_min, max(cfg.fp_score_min, cfg.fp_score_max), k)
        return Detections(xyxy=xyxy, score=score, class_id=cls, source_id=np.full(k, -1))
