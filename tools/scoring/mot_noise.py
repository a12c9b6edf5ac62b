"""Detections of another kind for MOTChallenge sequences: the ground truth through the
simulated detector's noise model (``GtNoiseDetector``).

A tracker's settings are only shown to generalise on detections they were not chosen
on. MOT15's public detections (ACF) are one detector; ``noisy_detections`` makes
others from the same sequences' ground truth -- misses, box jitter, Poisson false
positives, scores in [0, 1] that fall with size and occlusion -- at the levels of
``MOT_NOISE_LEVELS``, deterministic for a seed. Every row is a pedestrian (MOT is
single-class); MOT16+ ground truth gives each box its visibility, MOT15's none (1).
"""

from __future__ import annotations

import numpy as np

from lookahead.perception.detections import CLASS_ID
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.detectors.gt_detector import GtNoiseConfig, GtNoiseDetector
from lookahead.perception.geometry import clip_boxes
from lookahead.perception.mot import MotRecords, from_detections, iter_frames
from lookahead.tools.scoring.mot_eval import MOT_PEDESTRIAN, is_mot16_gt

#: Named noise levels: ``low`` is the simulated detector's default (5 % misses, 5 % box
#: jitter, 0.1 false positives per frame); ``high`` a poor detector (20 % misses, 10 %
#: jitter, one false positive per frame, noisier scores).
MOT_NOISE_LEVELS: dict[str, GtNoiseConfig] = {
    "low": GtNoiseConfig(class_confusion=0.0),
    "high": GtNoiseConfig(miss_rate=0.2, box_sigma=0.1, fp_rate=1.0, score_sigma=0.1, class_confusion=0.0),
}


def _truth(rows: MotRecords, width: int, height: int, mot16: bool) -> DetectorTruth:
    """One frame's ground truth clipped to the image, with its truncation and visibility."""
    b = rows.xyxy
    clipped = clip_boxes(b, width, height)
    area = np.maximum((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]), 1e-9)
    inside = (clipped[:, 2] - clipped[:, 0]) * (clipped[:, 3] - clipped[:, 1])
    return DetectorTruth(
        width=width, height=height, xyxy=clipped,
        class_id=np.full(len(rows), CLASS_ID["pedestrian"]),
        source_id=rows.track_id.astype(np.int64),
        visible_fraction=np.clip(rows.extra[:, 1], 0.0, 1.0) if mot16 else None,
        truncation=np.clip(1.0 - inside / area, 0.0, 1.0),
    )


def noisy_detections(
    gt: MotRecords, width: int, height: int, num_frames: int,
    config: GtNoiseConfig | str = "low", seed: int = 0,
) -> MotRecords:
    """MOT det rows (id -1, scores in [0, 1]) for frames 1..``num_frames`` of a sequence whose
    ground truth is ``gt`` and whose images are ``width`` x ``height`` px.

    Only ground-truth rows that count (``conf`` > 0; for MOT16+ pedestrians) are seen.
    ``config`` is a ``GtNoiseConfig`` or a ``MOT_NOISE_LEVELS`` name.
    """
    if isinstance(config, str):
        if config not in MOT_NOISE_LEVELS:
            raise ValueError(f"unknown noise level {config!r}: choose one of {', '.join(MOT_NOISE_LEVELS)}")
        config = MOT_NOISE_LEVELS[config]
    mot16 = is_mot16_gt(gt)
    keep = gt.conf > 0
    if mot16:
        keep &= gt.extra[:, 0] == MOT_PEDESTRIAN
    detector = GtNoiseDetector(config, seed=seed)
    out = []
    for f, rows in iter_frames(gt[keep], num_frames):
        out.append(from_detections(f, detector.detect(None, _truth(rows, width, height, mot16))))
    return MotRecords.concat(out)
