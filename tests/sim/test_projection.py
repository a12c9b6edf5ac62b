"""The camera model and the renderer agree: projected boxes match segmentation masks.

Runs the smoke suite once with rendering (the issue's acceptance check).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lookahead.perception.geometry import iou_matrix
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.tools.runs.inputs import load_suite

ROOT = Path(__file__).resolve().parents[2]
MIN_HEIGHT_PX = 10.0  # objects smaller than this are below what detectors are asked to find


class Collect:
    def __init__(self) -> None:
        self.rows: list[dict] = []

    def on_start(self, info: dict) -> None: ...

    def on_end(self, summary: dict) -> None: ...

    def on_tick(self, rec) -> None:
        gt = rec.ground_truth
        for i in range(len(gt)):
            self.rows.append({
                "name": gt.name[i], "frame": rec.frame_index, "class_id": gt.class_id[i],
                "visible_fraction": gt.visible_fraction[i], "truncation": gt.truncation[i],
                "amodal": gt.amodal[i], "visible": gt.visible[i], "lateral": gt.lateral[i],
            })


@pytest.fixture(scope="module")
def smoke_rows() -> list[dict]:
    _, paths = load_suite(ROOT / "scenarios" / "suites" / "smoke.yaml")
    rows: list[dict] = []
    for path in paths:
        sink = Collect()
        # the ground-truth detector: the projection is what is checked, not the ONNX model (which would
        # triple the time)
        Runner(with_detector(load_scenario(path), "gt", None), sinks=[sink], render=True).run()
        rows += sink.rows
    return rows


def snap(box: np.ndarray) -> np.ndarray:
    """The pixels a rasteriser covers: those whose centres lie inside the box."""
    return np.floor(np.asarray(box) + 0.5)


def unhidden(rows: list[dict]) -> list[dict]:
    """Actors the issue's projection check covers: visible fraction >= 0.9, no truncation."""
    return [r for r in rows if r["visible_fraction"] >= 0.9 and r["truncation"] == 0.0
            and np.all(np.isfinite(r["visible"]))]


def test_amodal_boxes_match_the_segmentation(smoke_rows):
    sel = [r for r in unhidden(smoke_rows) if r["visible"][3] - r["visible"][1] >= MIN_HEIGHT_PX]
    assert len(sel) > 100
    raw = np.array([iou_matrix(r["amodal"][None], r["visible"][None])[0, 0] for r in sel])
    snapped = np.array([iou_matrix(snap(r["amodal"])[None], r["visible"][None])[0, 0] for r in sel])
    assert np.median(raw) >= 0.95
    assert np.median(snapped) >= 0.95
    assert snapped.min() >= 0.85, sel[int(np.argmin(snapped))]


def test_projected_edges_are_off_by_pixel_quantisation_only(smoke_rows):
    """Scale-free and without the size floor: each edge of the amodal box lies within a pixel of
    the segmentation's, unbiased, scattered as pixel quantisation is (std 1/sqrt(12) = 0.29 px)."""
    sel = unhidden(smoke_rows)
    assert len(sel) > 200
    edge = np.array([r["visible"] for r in sel]) - np.array([r["amodal"] for r in sel])  # px, x0 y0 x1 y1
    assert np.all(np.abs(edge.mean(axis=0)) <= 0.15), edge.mean(axis=0)
    assert np.all(edge.std(axis=0) <= 0.4), edge.std(axis=0)
    worst = int(np.argmax(np.abs(edge).max(axis=1)))
    assert np.abs(edge).max() <= 1.5, sel[worst]


def test_left_is_left_in_the_rendered_image(smoke_rows):
    seen = [r for r in smoke_rows if np.all(np.isfinite(r["visible"])) and abs(r["lateral"]) > 2.0]
    assert any(r["lateral"] > 0 for r in seen) and any(r["lateral"] < 0 for r in seen)
    for r in seen:
        centre = (r["visible"][0] + r["visible"][2]) / 2
        assert (centre < 320) == (r["lateral"] > 0), r
