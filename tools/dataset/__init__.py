"""Detector datasets from simulated runs: COCO / YOLO export and the scene generators."""
