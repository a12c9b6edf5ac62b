"""Rendered frames of a simulated run, the raw material of the tests that watch video."""

from __future__ import annotations

from lookahead.perception.camera import CameraModel
from lookahead.sim.catalogue import resolve_path
from lookahead.sim.records import RecordCollector, TickRecord
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector


def render_records(frames: int, scenario: str = "ped_crossing_nearside") -> tuple[list[TickRecord], CameraModel]:
    """The first ``frames`` camera frames of a packaged scenario, rendered (ground-truth
    detector: fast), as the runner's records, and the camera that took them."""
    runner = Runner(with_detector(load_scenario(resolve_path(scenario)), "gt", None), sinks=[col := RecordCollector()],
                    render=True)
    try:
        for _ in range(frames):
            runner.step()
    finally:
        runner.close()
    return col.records, runner.camera
