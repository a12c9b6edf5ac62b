"""GtNoiseDetector: determinism, zero noise, miss statistics, latency, false positives."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from lookahead.perception.detections import CLASS_ID, CLASSES
from lookahead.perception.detectors import Detector, DetectorTruth, GtNoiseConfig, GtNoiseDetector
from lookahead.perception.detectors.gt_detector import CONFUSABLE

W, H = 640, 360


def make_truth(
    rng: np.random.Generator,
    n: int = 10,
    range_m: float | None = None,
    visible: float | None = None,
) -> DetectorTruth:
    xy = rng.uniform([0, H / 3], [W - 120, H - 90], (n, 2))
    wh = rng.uniform([20, 20], [120, 90], (n, 2))
    return DetectorTruth(
        width=W,
        height=H,
        xyxy=np.concatenate([xy, xy + wh], axis=1),
        class_id=rng.integers(0, len(CLASSES), n),
        source_id=np.arange(n) + 100,
        range_m=np.full(n, range_m) if range_m is not None else rng.uniform(5, 40, n),
        visible_fraction=np.full(n, visible) if visible is not None else np.ones(n),
        truncation=np.zeros(n),
    )


def only(**kwargs: float) -> GtNoiseConfig:
    """The zero-noise config with some fields set."""
    return GtNoiseConfig.perfect().model_copy(update=kwargs)


def test_defaults_and_validation() -> None:
    cfg = GtNoiseConfig()
    assert (cfg.miss_rate, cfg.box_sigma, cfg.fp_rate, cfg.class_confusion) == (
        0.05,
        0.05,
        0.1,
        0.01,
    )
    assert (cfg.latency_frames, cfg.min_visible, cfg.min_height_px) == (0, 0.1, 4.0)
    with pytest.raises(pydantic.ValidationError, match="miss_rate"):
        GtNoiseConfig(miss_rate=-0.1)
    with pytest.raises(pydantic.ValidationError, match="miss_rat"):
        GtNoiseConfig(miss_rat=0.1)
    assert isinstance(GtNoiseDetector(cfg, seed=0), Detector)


def test_deterministic_per_seed() -> None:
    truths = [make_truth(np.random.default_rng(i)) for i in range(30)]
    cfg = GtNoiseConfig(fp_rate=1.0, class_confusion=0.2, latency_frames=2)
    a, b, c = (GtNoiseDetector(cfg, seed=s) for s in (7, 7, 8))
    outs_a = [a.detect(None, t).to_dict() for t in truths]
    assert outs_a == [b.detect(None, t).to_dict() for t in truths]
    assert outs_a != [c.detect(None, t).to_dict() for t in truths]
    a.reset()
    assert outs_a == [a.detect(None, t).to_dict() for t in truths]


def test_zero_noise_returns_truth_exactly() -> None:
    det = GtNoiseDetector(GtNoiseConfig.perfect(), seed=3)
    for i in range(5):
        truth = make_truth(np.random.default_rng(i), visible=0.05 + 0.2 * i)
        dets = det.detect(None, truth)
        np.testing.assert_array_equal(dets.xyxy, truth.xyxy)
        np.testing.assert_array_equal(dets.class_id, truth.class_id)
        np.testing.assert_array_equal(dets.source_id, truth.source_id)
        assert np.all((dets.score > 0) & (dets.score < 1))


def test_never_detected_filters() -> None:
    truth = DetectorTruth(
        width=W,
        height=H,
        xyxy=[[10, 10, 50, 50], [10, 10, 50, 13], [100, 100, 140, 140], [np.nan] * 4],
        class_id=[0, 0, 4, 4],
        source_id=[1, 2, 3, 4],
        visible_fraction=[1.0, 1.0, 0.05, 1.0],
    )
    dets = GtNoiseDetector(only(min_visible=0.1, min_height_px=4.0), seed=0).detect(None, truth)
    assert dets.source_id.tolist() == [1]


def _recall(cfg: GtNoiseConfig, frames: int, **truth_kwargs: float) -> float:
    det, rng = GtNoiseDetector(cfg, seed=11), np.random.default_rng(5)
    found = total = 0
    for _ in range(frames):
        truth = make_truth(rng, **truth_kwargs)
        found += len(det.detect(None, truth))
        total += len(truth)
    return found / total


def test_miss_rate_statistics() -> None:
    # 20000 objects: std of the miss fraction ~0.003.
    assert 1 - _recall(only(miss_rate=0.2), 2000) == pytest.approx(0.2, abs=0.015)


def test_far_and_occluded_missed_more() -> None:
    cfg = GtNoiseConfig(fp_rate=0.0)  # defaults: 0.05 + 0.005/m beyond 50 m + 0.5 * occluded share
    near = _recall(cfg, 500, range_m=20.0, visible=1.0)
    far = _recall(cfg, 500, range_m=150.0, visible=1.0)
    occluded = _recall(cfg, 500, range_m=20.0, visible=0.3)
    assert 1 - near == pytest.approx(0.05, abs=0.02)
    assert 1 - far == pytest.approx(0.55, abs=0.03)
    assert 1 - occluded == pytest.approx(0.40, abs=0.03)
    assert near > occluded > far


def test_latency_delays_by_k_frames() -> None:
    k = 3
    det = GtNoiseDetector(only(latency_frames=k), seed=0)
    for t in range(10):
        truth = DetectorTruth(
            width=W, height=H, xyxy=[[10, 10, 50, 50]], class_id=[4], source_id=[t]
        )
        dets = det.detect(None, truth)
        assert dets.source_id.tolist() == ([] if t < k else [t - k])


def test_false_positive_rate_and_placement() -> None:
    det = GtNoiseDetector(only(fp_rate=2.0, fp_score_min=0.25, fp_score_max=0.55), seed=4)
    empty = DetectorTruth(width=W, height=H)
    outs = [det.detect(None, empty) for _ in range(3000)]
    counts = np.array([len(d) for d in outs])
    assert counts.mean() == pytest.approx(2.0, abs=0.1)
    assert counts.var() == pytest.approx(2.0, abs=0.25)  # Poisson
    b = np.concatenate([d.xyxy for d in outs])
    assert np.all(b[:, 1] >= H / 3 - 1e-9) and np.all(b[:, 3] <= H)
    assert np.all(b[:, 0] >= 0) and np.all(b[:, 2] <= W)
    assert np.all((b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1]))
    scores = np.concatenate([d.score for d in outs])
    assert scores.min() >= 0.25 and scores.max() <= 0.55
    assert np.all(np.concatenate([d.source_id for d in outs]) == -1)


def test_box_jitter_scales_with_box_size() -> None:
    sigma = 0.1
    det = GtNoiseDetector(only(box_sigma=sigma), seed=2)
    truth = DetectorTruth(
        width=W, height=H, xyxy=[[200, 100, 400, 200]], class_id=[4], source_id=[1]
    )  # w 200, h 100: edge std 20 px in x, 10 px in y
    err = np.concatenate([det.detect(None, truth).xyxy for _ in range(3000)]) - truth.xyxy
    np.testing.assert_allclose(err.std(axis=0), [20, 10, 20, 10], rtol=0.06)
    np.testing.assert_allclose(err.mean(axis=0), 0, atol=1.0)


def test_class_confusion_goes_to_similar_classes() -> None:
    det = GtNoiseDetector(only(class_confusion=1.0), seed=0)
    n = len(CLASSES) * 50
    truth = DetectorTruth(
        width=W,
        height=H,
        xyxy=np.tile([[10, 10, 60, 60]], (n, 1)),
        class_id=np.arange(n) % len(CLASSES),
    )
    dets = det.detect(None, truth)
    for src, dst in zip(truth.class_id, dets.class_id, strict=True):
        assert CLASSES[dst] in (CONFUSABLE[CLASSES[src]] or (CLASSES[src],))  # none listed: kept
    assert set(dets.class_id[truth.class_id == CLASS_ID["truck"]].tolist()) == {
        CLASS_ID["car"],
        CLASS_ID["bus"],
    }
    rate = _confusion_rate(0.1)
    assert rate == pytest.approx(0.1, abs=0.02)


def _confusion_rate(p: float) -> float:
    det, rng = GtNoiseDetector(only(class_confusion=p), seed=9), np.random.default_rng(0)
    changed = total = 0
    for _ in range(400):
        truth = make_truth(rng)
        dets = det.detect(None, truth)
        changed += int(np.count_nonzero(dets.class_id != truth.class_id))
        total += len(truth)
    return changed / total


def test_scores_favour_easy_objects() -> None:
    cfg = only(score_sigma=0.0)
    det = GtNoiseDetector(cfg, seed=0)
    truth = DetectorTruth(
        width=W,
        height=H,
        xyxy=[[0, 0, 100, 150], [0, 0, 10, 12], [0, 0, 100, 150]],
        class_id=[4, 4, 4],
        visible_fraction=[1.0, 1.0, 0.3],
    )
    s = det.detect(None, truth).score
    assert s[0] > 0.9 and s[0] > s[2] > s[1]


def test_truth_required() -> None:
    with pytest.raises(ValueError, match="DetectorTruth"):
        GtNoiseDetector(GtNoiseConfig(), seed=0).detect(np.zeros((H, W, 3), np.uint8))
