"""``HogDetector`` (``--detector hog``): OpenCV's HOG people detector, computed in numpy, on OpenCV's
sample clip vtest.avi (pedestrians walking in a square, 768 x 576) and on a blank image."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from system_deps import vtest_avi

from lookahead.intent.stack import build_detector
from lookahead.perception.config import DetectorSpec, PerceptionSpec, SettingsError
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.detectors.base import Detector
from lookahead.perception.detectors.hog_detector import (
    HogConfig,
    HogDetector,
    block_descriptors,
    people_svm,
    window_margins,
)


def _frames(n: int = 5, every: int = 40) -> list[np.ndarray]:
    """``n`` RGB frames of vtest.avi, ``every`` frames apart."""
    cap = cv2.VideoCapture(str(vtest_avi()))
    frames = []
    try:
        i = 0
        while len(frames) < n:
            ok, bgr = cap.read()
            if not ok:
                break
            if i % every == 0:
                frames.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            i += 1
    finally:
        cap.release()
    assert len(frames) == n, "vtest.avi is shorter than expected"
    return frames


@pytest.fixture(scope="module")
def frames() -> list[np.ndarray]:
    return _frames()


def test_detects_several_plausible_pedestrians_on_most_vtest_frames(frames):
    det = HogDetector()
    assert isinstance(det, Detector)
    good = 0
    for img in frames:
        d = det.detect(img)
        assert np.all(d.class_id == CLASS_ID["pedestrian"])
        assert np.all((d.score >= 0.5) & (d.score <= 1.0))
        assert np.all(np.isfinite(d.xyxy))
        w = d.xyxy[:, 2] - d.xyxy[:, 0]
        h = d.xyxy[:, 3] - d.xyxy[:, 1]
        # upright people: taller than wide, and between ~a fifth and ~all of the frame's height
        plausible = (h / w > 1.5) & (h / w < 4.0) & (h > 60) & (h < img.shape[0])
        assert np.all(d.xyxy[:, [0, 2]] >= 0) and np.all(d.xyxy[:, [0, 2]] <= img.shape[1])
        good += int(plausible.sum() >= 3)
    assert good >= len(frames) - 1, f"only {good} of {len(frames)} frames with >= 3 plausible pedestrians"


def test_blank_and_flat_images_give_nothing():
    det = HogDetector()
    for img in (np.zeros((576, 768, 3), np.uint8), np.full((360, 640, 3), 128, np.uint8)):
        assert len(det.detect(img)) == 0
    tiny = np.zeros((40, 30, 3), np.uint8)  # smaller than the 64 x 128 window: no level at all
    assert len(det.detect(tiny)) == 0


def test_grey_and_rgb_agree_on_grey_content(frames):
    grey = cv2.cvtColor(frames[0], cv2.COLOR_RGB2GRAY)
    a = HogDetector().detect(grey)
    b = HogDetector().detect(np.repeat(grey[:, :, None], 3, axis=2))
    np.testing.assert_allclose(a.xyxy, b.xyxy)
    np.testing.assert_allclose(a.score, b.score)


def test_margins_and_the_score_mapping(frames):
    """A person's window scores a positive margin (score > 0.5), the flat sky of a blank image the
    bias alone; the score is the logistic of margin / temperature."""
    weights, bias = people_svm()
    assert weights.shape == (7, 15, 36) and bias < 0
    flat = window_margins(block_descriptors(np.zeros((128, 64, 3), np.uint8)))
    assert flat.shape == (1, 1) and flat[0, 0] == pytest.approx(bias)
    det = HogDetector(min_score=0.3, temperature=1.0)
    d = det.detect(frames[0])
    assert len(d) and d.score.min() >= 0.3
    strict = HogDetector(min_score=0.9).detect(frames[0])
    assert len(strict) < len(d)


def test_options_are_checked_and_change_the_work(frames):
    with pytest.raises(ValueError, match="stride"):
        HogConfig(stride=5)
    with pytest.raises(ValueError, match="scale_step"):
        HogConfig(scale_step=1.0)
    with pytest.raises(ValueError, match="shrink"):
        HogConfig(shrink=(0.6, 0.1))
    coarse = HogDetector(scale_step=1.5)
    coarse.detect(frames[0])
    fine = HogDetector()
    fine.detect(frames[0])
    assert len(coarse.last_levels) < len(fine.last_levels)
    assert fine.last_levels[0] == pytest.approx(1.0)  # 768 px <= max_width: full resolution
    small = HogDetector(max_width=384)
    small.detect(frames[0])
    assert small.last_levels[0] == pytest.approx(2.0)  # frames wider than max_width are scaled down
    with pytest.raises(ValueError, match="needs camera images"):
        fine.detect(None)


def test_detector_spec_kind_hog(frames):
    det = build_detector(DetectorSpec(kind="hog", options={"min_score": 0.6}), seed=0, render=True)
    assert isinstance(det, HogDetector) and det.config.min_score == 0.6
    with pytest.raises(SettingsError, match="hog needs rendered frames"):
        build_detector(DetectorSpec(kind="hog"), seed=0, render=False)
    with pytest.raises(ValueError, match=r"detector\.options\.strid"):
        PerceptionSpec.model_validate({"detector": {"kind": "hog", "options": {"strid": 4}}})


@pytest.mark.skipif(not hasattr(cv2, "HOGDescriptor"), reason="OpenCV 5 has no HOGDescriptor (moved to contrib)")
def test_matches_opencv_where_it_has_hog(frames):  # pragma: no cover - OpenCV 4 only
    hog = cv2.HOGDescriptor()
    crop = np.ascontiguousarray(frames[0][100:228, 200:264])
    ours = block_descriptors(crop).transpose(1, 0, 2).reshape(-1)
    np.testing.assert_allclose(ours, hog.compute(crop).ravel(), atol=1e-4)
    # the raw hits of the whole pyramid (no grouping) are OpenCV's, window for window
    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    img = frames[0]
    rects, weights = hog.detectMultiScale(img, hitThreshold=0, winStride=(8, 8), padding=(8, 8), scale=1.2,
                                          groupThreshold=0)
    det, boxes, margins, level = HogDetector(shrink=(0.0, 0.0)), [], [], 1.0
    while img.shape[0] * level >= 128:
        b, m = det._level(img, level)
        boxes.append(b)
        margins.append(m)
        level /= 1.2
    ours_b, ours_m = np.concatenate(boxes), np.concatenate(margins)
    assert len(ours_b) == len(rects)
    for (x, y, w, h), wt in zip(rects, weights.ravel(), strict=True):
        near = np.abs(ours_b - [x, y, x + w, y + h]).max(axis=1) <= 3
        assert np.any(near & (np.abs(ours_m - wt) < 1e-3)), (x, y, w, h, wt)
