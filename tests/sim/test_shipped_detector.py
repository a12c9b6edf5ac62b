"""The shipped ONNX detector finds the actors in rendered frames (and only them)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from perception.detectors.onnx_detector import OnnxDetector
from sim.runner import DEFAULT_MODEL, Runner
from sim.scenario import DetectorSpec, load_scenario
from tools.scoring.matching import class_iou, hungarian_match

ROOT = Path(__file__).resolve().parents[2]


def frames_of(name: str, seconds: tuple[float, ...]):
    sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    sc = sc.model_copy(update={"perception": sc.perception.model_copy(update={"detector": DetectorSpec(kind="gt")})})
    runner = Runner(sc, render=True)
    out = []
    try:
        for t in seconds:
            while runner.world.t < t - 1e-9:
                runner.world.step()
            frame, gt, _ = runner.frame()
            out.append((frame.image, gt))
    finally:
        runner.close()
    return out


@pytest.fixture(scope="module")
def detector() -> OnnxDetector:
    assert DEFAULT_MODEL.is_file(), f"{DEFAULT_MODEL} is missing (see models/MODEL_CARD.md)"
    return OnnxDetector(DEFAULT_MODEL)


@pytest.mark.parametrize("name", ["ped_crossing_nearside", "cyclist_crossing", "dog_entering", "urban_mix"])
def test_shipped_model_finds_the_actors(detector, name):
    found = total = false_pos = 0
    for image, gt in frames_of(name, (1.0, 3.0)):
        dets = detector.detect(image)
        vis = gt.visible
        ok = (gt.class_id >= 0) & np.all(np.isfinite(vis), axis=1)
        care = ok & (gt.visible_fraction >= 0.5) & (gt.range >= 5.0) & (gt.range <= 40.0) & (gt.truncation < 0.3)
        rows, cols = hungarian_match(class_iou(dets.xyxy, dets.class_id, vis[care], gt.class_id[care]))
        found += len(cols)
        total += int(care.sum())
        # a detection that overlaps no labelled object at all is a false positive
        any_iou = class_iou(dets.xyxy, None, vis[ok], None)
        false_pos += int(np.sum(any_iou.max(axis=1, initial=0.0) < 0.3))
    assert total > 0
    assert found == total, f"{name}: found {found} of {total} actors"
    assert false_pos <= 1, f"{name}: {false_pos} detections on nothing"
