"""2D object detectors: the ``Detector`` protocol, an ONNX YOLO runner, a noisy GT detector."""

from lookahead.perception.detectors.base import Detector, DetectorTruth
from lookahead.perception.detectors.gt_detector import GtNoiseConfig, GtNoiseDetector
from lookahead.perception.detectors.onnx_detector import ModelError, OnnxDetector

__all__ = [
    "Detector",
    "DetectorTruth",
    "GtNoiseConfig",
    "GtNoiseDetector",
    "ModelError",
    "OnnxDetector",
]
