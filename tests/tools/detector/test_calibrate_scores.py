"""``lookahead calibrate-scores``: a real low-scoring ONNX detector (the shipped model with its class
scores times 0.6) measured on rendered frames, its calibration stored beside it and picked up."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from support.onnx_models import scaled_scores_model

from lookahead.intent.stack import build_detector
from lookahead.perception.config import DEFAULT_MODEL, DetectorSpec
from lookahead.perception.score_calibration import SCORE_REFERENCE, measure, sidecar_path
from lookahead.tools.detector.calibrate_scores import true_positive_scores

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


def _short_suite(tmp_path: Path) -> Path:
    """A suite of one busy scenario cut to 1.5 s (15 frames, about 75 true positives)."""
    data = yaml.safe_load((SCENARIOS / "urban_mix.yaml").read_text())
    data["duration"] = 1.5
    (tmp_path / "urban_mix_short.yaml").write_text(yaml.safe_dump(data))
    suite = tmp_path / "suite.yaml"
    suite.write_text("name: short\nscenarios:\n  - urban_mix_short.yaml\n")
    return suite


def test_a_low_scoring_detector_is_measured_and_its_calibration_used(tmp_path: Path, lookahead, capsys) -> None:
    weak = scaled_scores_model(DEFAULT_MODEL, tmp_path / "weak.onnx", 0.6)
    suite = _short_suite(tmp_path)
    assert lookahead("calibrate-scores", weak, "--suite", suite) == 0
    assert "wrote " + str(sidecar_path(weak)) in capsys.readouterr().out
    cal = json.loads(sidecar_path(weak).read_text())
    shipped, frames = true_positive_scores(DEFAULT_MODEL, [tmp_path / "urban_mix_short.yaml"])
    assert cal["frames"] == frames == 15 and cal["true_positives"] >= 50
    # the same boxes scored 0.6 times as high: measured 0.6 times the shipped model's (the shipped
    # model is the reference: its own measure is SCORE_REFERENCE to within the frames' spread)
    assert cal["measured"] == pytest.approx(0.6 * measure(shipped), rel=0.01)
    assert measure(shipped) == pytest.approx(SCORE_REFERENCE, abs=0.03)
    # a run with the model picks the file up; "none" runs it raw
    spec = DetectorSpec(kind="onnx", model=str(weak))
    assert build_detector(spec, seed=0).calibration.measured == cal["measured"]
    assert build_detector(spec.model_copy(update={"calibration": "none"}), seed=0).calibration is None


def test_refusals(tmp_path: Path, lookahead, capsys) -> None:
    assert lookahead("calibrate-scores", tmp_path / "missing.onnx") == 2
    assert "missing.onnx: model file not found" in capsys.readouterr().err
    (tmp_path / "m.onnx.scores.json").write_text("{")
    model = tmp_path / "m.onnx"
    model.write_bytes(DEFAULT_MODEL.read_bytes())
    spec = DetectorSpec(kind="onnx", model=str(model))
    with pytest.raises(ValueError, match=r"m\.onnx\.scores\.json: not a score calibration \(not JSON"):
        build_detector(spec, seed=0)
