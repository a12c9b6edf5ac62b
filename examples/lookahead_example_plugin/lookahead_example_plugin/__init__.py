"""Example lookahead detector plug-ins (entry-point group ``lookahead.detectors``)."""

from lookahead_example_plugin.detector import VruDetector, make_hog_detector, make_vru_detector

__all__ = ["VruDetector", "make_hog_detector", "make_vru_detector"]
