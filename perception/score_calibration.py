"""Score calibration: a detector's scores mapped onto the scale the tracker's thresholds are set for.

The tracker's score thresholds (``TrackerConfig.high_score`` 0.45, ``low_score`` 0.1,
``new_track_score`` 0.45) and the detector's own ``conf`` were tuned on the shipped detector
and the simulated one, whose true positives score alike: the 90th percentile of their
true-positive scores on the smoke suite is 0.931 (shipped ONNX detector, rendered) and 0.929
(``gt`` noise model). Another detector -- a user's YOLO whose scores rarely pass 0.6 --
would find most of its true detections below ``high_score``, and the tracker would drop them
(measured: the noise model with its scores scaled to top out at 0.6 takes the smoke suite's
MOTA from 0.93 to 0.53).

A ``ScoreCalibration`` is measured once per detector by ``lookahead calibrate-scores`` (its
true positives' 90th-percentile score, ``measured``, on simulated frames where the truth is
known) and stored beside the model (``<model>.scores.json``). The detector then maps every
score ``s`` through the piecewise-linear, strictly increasing function that takes
``measured`` to ``SCORE_REFERENCE`` (0 to 0 and 1 to 1): the order of the scores, so the
detector's AP, is unchanged, and the same defaults work for it.

Why per detector and not per run: a percentile measured on the run itself cannot tell a
low-scoring detector from a hard scene (small, far, occluded objects) -- adapting the
thresholds to each run's percentile took the shipped detector's smoke MOTA from 0.92 to 0.82,
as every hard scene lowered them and let false positives in.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

#: The 90th-percentile true-positive score the default thresholds are set for (see the module docstring).
SCORE_REFERENCE = 0.93
#: The percentile of true-positive scores that ``measured`` is.
CALIBRATION_PERCENTILE = 90.0
#: The calibration file of a model: its path plus this suffix.
SIDECAR_SUFFIX = ".scores.json"


class ScoreCalibrationError(ValueError):
    """A calibration file that cannot be read or is not a score calibration (message names it)."""


class ScoreCalibration(BaseModel):
    """A detector's measured score scale and the map onto ``reference``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    measured: float = Field(
        gt=0, lt=1, description="the detector's true positives' CALIBRATION_PERCENTILE-th score on the calibration frames"
    )
    reference: float = Field(SCORE_REFERENCE, gt=0, lt=1, description="what ``measured`` maps to")
    percentile: float = Field(CALIBRATION_PERCENTILE, gt=0, lt=100, description="which percentile ``measured`` is")
    true_positives: int = Field(0, ge=0, description="true-positive detections it was measured on")
    frames: int = Field(0, ge=0, description="frames it was measured on")
    source: str = Field("", description="what it was measured on (suite, detector)")
    model_sha256: str = Field("", description="sha256 of the model file measured (empty: unknown)")

    def apply(self, scores: np.ndarray) -> np.ndarray:
        """Calibrated scores: ``measured`` -> ``reference``, linear on [0, measured] and [measured, 1];
        order kept, [0, 1] onto [0, 1] (scores outside are clipped first)."""
        s = np.clip(np.asarray(scores, dtype=np.float64), 0.0, 1.0)
        m, r = self.measured, self.reference
        return np.where(s <= m, s * (r / m), r + (s - m) * ((1.0 - r) / (1.0 - m)))

    def invert(self, calibrated: float | np.ndarray) -> np.ndarray:
        """The raw scores ``apply`` maps to ``calibrated`` (its inverse on [0, 1])."""
        c = np.clip(np.asarray(calibrated, dtype=np.float64), 0.0, 1.0)
        m, r = self.measured, self.reference
        return np.where(c <= r, c * (m / r), m + (c - r) * ((1.0 - m) / (1.0 - r)))

    def write(self, path: str | Path) -> None:
        """Write as JSON (the ``<model>.scores.json`` format)."""
        Path(path).write_text(json.dumps(self.model_dump(), indent=2) + "\n", encoding="utf-8")


def sidecar_path(model: str | Path) -> Path:
    """Where the calibration of ``model`` is kept: ``<model>.scores.json`` beside it."""
    return Path(str(model) + SIDECAR_SUFFIX)


def read_calibration(path: str | Path) -> ScoreCalibration:
    """A calibration file; ``ScoreCalibrationError`` (one line naming the file) when it is unreadable or wrong."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return ScoreCalibration.model_validate(data)
    except OSError as exc:
        raise ScoreCalibrationError(f"{path}: cannot read the score calibration ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ScoreCalibrationError(f"{path}: not a score calibration (not JSON: {str(exc).splitlines()[0]})") from None
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err["loc"]) or "the file"
        raise ScoreCalibrationError(f"{path}: not a score calibration ({where}: {err['msg']})") from None


def calibration_for(model: str | Path, calibration: str | None = None) -> ScoreCalibration | None:
    """The calibration a model is run with: ``calibration`` "none" -> None; a path -> that file;
    None -> the model's ``<model>.scores.json`` when it exists, else None (uncalibrated)."""
    if calibration is not None:
        return None if calibration.strip().lower() == "none" else read_calibration(calibration)
    side = sidecar_path(model)
    return read_calibration(side) if side.is_file() else None


def measure(tp_scores: np.ndarray, percentile: float = CALIBRATION_PERCENTILE) -> float:
    """The ``percentile``-th of true-positive scores (linear interpolation); ``ValueError`` without any."""
    s = np.asarray(tp_scores, dtype=np.float64)
    s = s[np.isfinite(s)]
    if not len(s):
        raise ValueError("no true-positive detection to calibrate on")
    return float(np.percentile(s, percentile))
