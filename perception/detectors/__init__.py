"""2D object detectors: the ``Detector`` protocol, an ONNX YOLO runner, a noisy GT detector."""

from perception.detectors.base import Detector, DetectorTruth
from perception.detectors.gt_detector import GtNoiseConfig, GtNoiseDetector
from perception.detectors.onnx_detector import ModelError, OnnxDetector

__all__ = [
    "Detector",
    "DetectorTruth",
    "GtNoiseConfig",
    "GtNoiseDetector",
    "ModelError",
    "OnnxDetector",
]
