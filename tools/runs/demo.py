"""``make demo``: run the smoke suite with rendering and leave things to look at."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from lookahead.sim.catalogue import SCENARIOS
from lookahead.tools.reports.report import build_report
from lookahead.tools.runs.suite import load_suite, run_suite
from lookahead.tools.sinks.rundir import prepare_dir


@dataclass
class DemoResult:
    """What ``make demo`` left: the suite's summary and the files to open (paths)."""

    summary: dict
    report: Path
    video: Path
    rerun: Path
    database: Path


def run_demo(out: Path) -> DemoResult:
    """The smoke suite rendered on two workers: run directories with key frames, one
    SQLite store, an annotated video and a rerun recording of the first scenario,
    and the HTML report of the whole suite."""
    suite = SCENARIOS / "suites" / "smoke.yaml"
    _, paths = load_suite(suite)
    outputs = {p.stem: ("keyframes",) for p in paths}
    outputs[paths[0].stem] = ("keyframes", "video", "rerun")
    db = prepare_dir(out) / "smoke.sqlite"
    if db.exists():
        db.unlink()
    summary = run_suite(suite, out, workers=2, render=True, db=db, outputs=outputs)
    first = out / paths[0].stem
    return DemoResult(summary, build_report(out), first / "annotated.mp4", first / "run.rrd", db)
