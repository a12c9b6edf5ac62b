"""``lookahead calibrate-scores``: measure an ONNX detector's score scale on simulated frames and
store the calibration beside the model (``perception.score_calibration``).

The suite's scenarios are rendered and run with the model, uncalibrated, exactly as ``run``
would run them; every detection is matched to the ground truth as the ``detection`` section
of ``metrics.json`` matches it (``tools.scoring.detection.match_frame``: same class, IoU >= 0.5,
visible objects at least 10 px tall), and the ``CALIBRATION_PERCENTILE``-th score of the true
positives is the model's ``measured`` score. Deterministic: the scenarios' seeds drive everything.
"""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from lookahead.perception.score_calibration import CALIBRATION_PERCENTILE, ScoreCalibration, measure
from lookahead.tools.detector.export_embedder import sha256

log = logging.getLogger(__name__)

#: Saturated scores: a detector whose true positives' percentile is this close to 1 is stored at it.
MAX_MEASURED = 0.999


def true_positive_scores(
    model: Path, scenarios: Sequence[Path], layout: str = "auto",
    progress: Callable[[str], None] | None = None,
) -> tuple[np.ndarray, int]:
    """Scores of the model's true positives over the rendered ``scenarios``, and the frame count."""
    from lookahead.sim.runner import Runner
    from lookahead.sim.scenario import load_scenario, with_detector
    from lookahead.tools.scoring.detection import TP, match_frame
    from lookahead.tools.scoring.io import load_run
    from lookahead.tools.sinks.rundir import RunDirWriter

    scores, frames = [], 0
    with tempfile.TemporaryDirectory(prefix="lookahead-calibrate-") as tmp:
        for i, path in enumerate(scenarios):
            sc = with_detector(load_scenario(path), "onnx", model)
            det = sc.perception.detector.model_copy(update={"calibration": "none", "layout": layout})
            sc = sc.model_copy(update={"perception": sc.perception.model_copy(update={"detector": det})})
            out = Path(tmp) / f"{i:03d}"
            runner = Runner(sc, render=True)
            runner.sinks = [RunDirWriter(out, sc)]
            runner.run()
            run = load_run(out)
            for dets, gt in zip(run.dets, run.gt, strict=True):
                if len(dets.score):
                    scores.append(dets.score[match_frame(dets, gt) == TP])
            frames += len(run.gt)
            if progress is not None:
                progress(f"{path.stem}: {len(run.gt)} frames")
    return (np.concatenate(scores) if scores else np.zeros(0)), frames


def calibrate_scores(
    model: str | Path, scenarios: Sequence[Path], source: str = "", layout: str = "auto",
    progress: Callable[[str], None] | None = None,
) -> ScoreCalibration:
    """The score calibration of ``model`` measured on ``scenarios`` (``ValueError``: no true positive)."""
    model = Path(model)
    tp, frames = true_positive_scores(model, scenarios, layout, progress)
    measured = min(measure(tp, CALIBRATION_PERCENTILE), MAX_MEASURED)
    if not measured > 0:
        raise ValueError(f"{model}: its true positives score 0 (percentile {CALIBRATION_PERCENTILE:g})")
    cal = ScoreCalibration(measured=round(measured, 6), true_positives=len(tp), frames=frames,
                           source=source, model_sha256=sha256(model))
    log.info("%s: measured %.4f on %d true positives over %d frames", model, measured, len(tp), frames)
    return cal
