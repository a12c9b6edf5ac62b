"""``lookahead bench sinks``: what writing every output costs, rendering on.

The same scenario runs alternately bare (no sink) and with every sink (run
directory, SQLite store, annotated video, rerun recording), in one process;
per-frame tick times (ms, the runner's own ``tick`` stage, which includes the
sinks) are pooled per configuration. Ratio ``sinks_over_bare_tick`` =
median(tick with sinks) / median(bare tick).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario
from lookahead.tools.bench.common import case, machine
from lookahead.tools.sinks.rundir import RunDirWriter
from lookahead.tools.sinks.store import SqliteStore
from lookahead.tools.sinks.video import VideoSink


def _all_sinks(scenario, out: Path) -> list:
    # lazy: rerun-sdk loads when the benchmark runs, not when bench.all imports this module
    from lookahead.tools.sinks.rerun import RerunSink

    return [
        RunDirWriter(out, scenario),
        SqliteStore(out / "run.sqlite", scenario, run_dir=out),
        VideoSink(out / "annotated.mp4", fps=scenario.camera.rate),
        RerunSink(out / "run.rrd"),
    ]


def bench_sinks(scenario_path: Path, repeats: int = 3) -> dict:
    scenario = load_scenario(scenario_path)
    ticks: dict[str, list[float]] = {"bare": [], "sinks": []}
    sink_ms: list[float] = []
    backend = None
    with tempfile.TemporaryDirectory(prefix="lookahead-bench-sinks-") as tmp:
        for rep in range(repeats):
            for mode in ("bare", "sinks") if rep % 2 == 0 else ("sinks", "bare"):
                probe = RecordCollector()  # timings are complete once the run ends
                sinks = [probe] + (_all_sinks(scenario, Path(tmp) / f"{mode}{rep}") if mode == "sinks" else [])
                runner = Runner(scenario, sinks=sinks, render=True)
                backend = runner.renderer.backend
                runner.run()
                ticks[mode] += [r.timings["tick"] for r in probe.records]
                if mode == "sinks":
                    sink_ms += [r.timings["sinks"] for r in probe.records]
    cases = {"tick_bare": case(ticks["bare"]), "tick_with_sinks": case(ticks["sinks"]), "sinks": case(sink_ms)}
    ratio = cases["tick_with_sinks"]["ms_median"] / cases["tick_bare"]["ms_median"]
    return {
        "machine": machine(),
        "scenario": str(scenario_path),
        "renderer": backend,
        "sinks": ["run_dir", "sqlite", "video", "rerun"],
        "cases": cases,
        "ratios": {"sinks_over_bare_tick": round(ratio, 4)},
    }
