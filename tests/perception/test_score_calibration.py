"""``perception.score_calibration``: the map onto the reference scale, its file, and the ONNX
detector running calibrated (a real ONNX model)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support.onnx_models import constant_output_model

from lookahead.perception.detectors.onnx_detector import OnnxDetector
from lookahead.perception.score_calibration import (
    SCORE_REFERENCE,
    ScoreCalibration,
    ScoreCalibrationError,
    calibration_for,
    read_calibration,
    sidecar_path,
)


def test_the_map_takes_measured_to_the_reference_and_keeps_order() -> None:
    cal = ScoreCalibration(measured=0.6)
    s = np.linspace(0.0, 1.0, 1001)
    out = cal.apply(s)
    assert out[0] == 0.0 and out[-1] == pytest.approx(1.0)
    assert cal.apply(np.array([0.6]))[0] == pytest.approx(SCORE_REFERENCE)
    assert np.all(np.diff(out) > 0)  # strictly increasing: the detector's ranking (its AP) is unchanged
    assert np.allclose(cal.invert(out), s)
    assert cal.apply(np.array([-3.0, 7.0])).tolist() == pytest.approx([0.0, 1.0])  # clipped first
    # a detector measured at the reference is left as it is
    assert np.allclose(ScoreCalibration(measured=SCORE_REFERENCE).apply(s), s)


def test_calibration_files(tmp_path: Path) -> None:
    model = tmp_path / "m.onnx"
    model.write_bytes(b"")
    assert calibration_for(model) is None  # no file beside it: uncalibrated
    ScoreCalibration(measured=0.5, true_positives=10, frames=3, source="s").write(sidecar_path(model))
    assert sidecar_path(model).name == "m.onnx.scores.json"
    assert calibration_for(model).measured == 0.5
    assert calibration_for(model, "none") is None and calibration_for(model, "NONE") is None
    other = tmp_path / "other.json"
    ScoreCalibration(measured=0.7).write(other)
    assert calibration_for(model, str(other)).measured == 0.7
    for text, what in (("{", "not JSON"), ('{"measured": 1.5}', "measured: Input should be less than 1"),
                       ('{"measured": 0.5, "x": 1}', "x: Extra inputs are not permitted"), ("[]", "the file")):
        other.write_text(text)
        with pytest.raises(ScoreCalibrationError, match=f"^{other}: not a score calibration .*{what}"):
            read_calibration(other)
    with pytest.raises(ScoreCalibrationError, match=f"^{tmp_path / 'gone.json'}: cannot read"):
        read_calibration(tmp_path / "gone.json")


def test_onnx_detector_runs_calibrated(tmp_path: Path) -> None:
    """Scores come out calibrated, and ``conf_threshold`` is on the calibrated scale."""
    out = np.zeros((1, 4 + 8, 3), np.float32)  # yolov8 layout, 8 classes, 3 boxes far apart
    out[0, :4] = np.array([[40, 40, 20, 20], [140, 40, 20, 20], [240, 40, 20, 20]], np.float32).T
    out[0, 4, :] = [0.6, 0.3, 0.1]  # raw scores of class 0
    model = constant_output_model(tmp_path / "m.onnx", out, [1, 3, 320, 320])
    image = np.zeros((320, 320, 3), np.uint8)
    raw = OnnxDetector(model, conf_threshold=0.2, layout="yolov8", windows=[]).detect(image)
    assert sorted(raw.score.round(3).tolist()) == [0.3, 0.6]
    cal = ScoreCalibration(measured=0.6)
    got = OnnxDetector(model, conf_threshold=0.2, layout="yolov8", windows=[], calibration=cal).detect(image)
    # 0.1 -> 0.155 stays below 0.2; 0.3 -> 0.465, 0.6 -> 0.93
    assert sorted(got.score.round(3).tolist()) == pytest.approx([0.465, SCORE_REFERENCE], abs=1e-3)
