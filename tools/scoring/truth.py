"""Score a run without ground truth against the ground truth of the run it watched.

``lookahead watch`` on the raw camera video of a simulated run (``lookahead run --raw-video``)
writes a run directory without ground truth; its frame ``i`` is camera frame ``i`` of the
simulated run. ``TruthJoined`` reads the watch's run directory with each frame's
``ground_truth`` and ``collisions`` taken from the simulated run's record of the same camera
frame (``frame``), and the scenario (expectations, AEB) from its ``run.json``; everything the
stack produced (detections, tracks, estimates, assessments, alerts, ego) stays the watch's.
Every scorer reads it as it reads a simulated run (``score_run(..., truth=...)``).
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

from lookahead.tools.sinks.rundir import RunDir, RunDirError, as_rundir

#: What a joined record takes from the truth run's record of the same camera frame.
TRUTH_KEYS = ("ground_truth", "collisions")


class TruthJoined(RunDir):
    """The run directory ``path`` (no ground truth) read with the ground truth of ``truth``.

    Raises (when read): ``RunDirError`` naming the frame when a frame of ``path`` has no record
    in ``truth`` (not the run it watched).
    """

    def __init__(self, path: Path | str, truth: RunDir | Path | str) -> None:
        super().__init__(path)
        self.truth = as_rundir(truth)

    def __repr__(self) -> str:
        return f"TruthJoined({str(self.path)!r}, truth={str(self.truth.path)!r})"

    @cached_property
    def run(self) -> dict:
        """The watch's ``run.json`` with the truth run's scenario (expectations, AEB)."""
        own = RunDir.run.func(self)  # type: ignore[attr-defined]
        return {**own, "watched": own.get("scenario"), "scenario": self.truth.run.get("scenario")}

    @cached_property
    def _ticks(self) -> tuple[list[dict], list[int]]:
        records, lines = RunDir._ticks.func(self)  # type: ignore[attr-defined]
        by_frame = {rec.get("frame"): rec for rec in self.truth.ticks}
        joined = []
        for i, rec in enumerate(records):
            frame = rec.get("frame", i)
            truth = by_frame.get(frame)
            if truth is None:
                raise RunDirError(f"{self.path}: frame {frame}: no such camera frame in the truth run "
                                  f"{self.truth.path} ({len(by_frame)} frames); is it the run this video came from?")
            joined.append({**rec, **{k: truth.get(k) for k in TRUTH_KEYS}})
        return joined, lines
