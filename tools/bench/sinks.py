"""``lookahead bench sinks``: what writing every output costs, rendering on.

The same scenario runs alternately bare (no sink) and with every sink (run
directory, SQLite store, annotated video, rerun recording), in one process;
per-frame tick times (ms, the runner's own ``tick`` stage, which includes the
sinks) are pooled per configuration. Ratio ``sinks_over_bare_tick`` =
median(tick with sinks) / median(bare tick).

``bench_sinks_memory``: a long rendered run (default 2000 frames) with every sink, RSS
sampled from frame 200 to the end (``rss_growth_mb_200_to_end``): every sink's memory
must stay flat in run length.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.tools.bench.common import case, machine
from lookahead.tools.sinks.rundir import RunDirWriter
from lookahead.tools.sinks.store import SqliteStore
from lookahead.tools.sinks.video import VideoSink


def _all_sinks(scenario, out: Path, rerun_footer: bool = False) -> list:
    # lazy: rerun-sdk loads when the benchmark runs, not when bench.all imports this module
    from lookahead.tools.sinks.rerun import RerunSink

    return [
        RunDirWriter(out, scenario),
        SqliteStore(out / "run.sqlite", scenario, run_dir=out),
        VideoSink(out / "annotated.mp4", fps=scenario.camera.rate),
        RerunSink(out / "run.rrd", footer=rerun_footer),
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


def _rss_mb() -> float:
    """This process's resident set (MB): /proc/self/statm on Linux, else the peak from getrusage."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        import resource

        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak / 2**20 if sys.platform == "darwin" else peak / 2**10


class _RssProbe:
    """A sink (put it last) sampling RSS (MB) at the start, after frame ``start`` and every later
    frame (the last sample is the run's end, before any sink closes), and after the others closed."""

    def __init__(self, start: int) -> None:
        self.start = start
        self.frames = 0
        self.first = self.closed = float("nan")
        self.samples: list[float] = []  # from frame ``start`` on
        self.ticks: list[float] = []  # ms; a frame's timings are complete once the next one arrives
        self._last: dict | None = None

    def on_start(self, info: dict) -> None:
        self.first = _rss_mb()

    def on_tick(self, record) -> None:
        self.frames += 1
        if self._last is not None:
            self.ticks.append(self._last["tick"])
        self._last = record.timings
        if self.frames >= self.start:
            self.samples.append(_rss_mb())

    def on_end(self, summary: dict) -> None:
        self.closed = _rss_mb()


def long_scenario(scenario_path: Path, frames: int):
    """The scenario lengthened to ``frames`` camera frames (road long enough for the ego), gt
    detector (the sinks are under test), a collision does not end it."""
    sc = with_detector(load_scenario(scenario_path), "gt")
    duration = frames / sc.camera.rate
    road = sc.road.model_copy(update={"length": min(max(sc.road.length, sc.ego.s + 60.0 * duration + 500.0),
                                                    20000.0)})
    return sc.model_copy(update={"duration": duration, "road": road, "end_on_collision": False})


def bench_sinks_memory(scenario_path: Path, frames: int = 2000, start: int = 200, bare: bool = False,
                       rerun_footer: bool = False) -> dict:
    """RSS growth of a long rendered run with every sink (run dir, SQLite, video, rerun), from
    frame ``start`` to the last frame, before the sinks close (``rss_growth_mb_200_to_end`` for
    the default ``start``; the issue's bar: < 20 MB over 2000 frames). ``cases`` has the run's
    tick times; ``memory`` the RSS samples (MB) per configuration. ``bare`` also measures the run
    without sinks (what the loop itself grows), first, in the same process. ``rerun_footer`` has
    the rerun sink write its footer (what it cost before: a manifest entry kept per chunk)."""
    if frames <= start:
        raise ValueError(f"frames ({frames}) must exceed start ({start})")
    scenario = long_scenario(scenario_path, frames)
    key = f"rss_growth_mb_{start}_to_end"
    out: dict = {"machine": machine(), "scenario": str(scenario_path), "frames_asked": frames, "start_frame": start,
                 "sinks": ["run_dir", "sqlite", "video", "rerun"], "rerun_footer": rerun_footer,
                 "cases": {}, "ratios": {}, "memory": {}}
    with tempfile.TemporaryDirectory(prefix="lookahead-bench-sinks-mem-") as tmp:
        for mode in ("bare", "sinks") if bare else ("sinks",):
            probe = _RssProbe(start)
            sinks = _all_sinks(scenario, Path(tmp) / mode, rerun_footer) if mode == "sinks" else []
            t0 = time.perf_counter()
            summary = Runner(scenario, sinks=[*sinks, probe], render=True).run()
            wall = time.perf_counter() - t0
            if not probe.samples:
                raise RuntimeError(f"the run ended after {summary.frames} frames, before frame {start}")
            first, last = probe.samples[0], probe.samples[-1]
            out["cases"][f"tick_{'with_sinks' if mode == 'sinks' else 'bare'}"] = case(probe.ticks)
            out["memory"][mode] = {
                "frames": summary.frames, "wall_s": round(wall, 1), "rss_mb_start": round(probe.first, 1),
                f"rss_mb_frame_{start}": round(first, 1), "rss_mb_end": round(last, 1),
                "rss_mb_peak": round(max(probe.samples), 1), "rss_mb_after_close": round(probe.closed, 1),
                key: round(last - first, 2),
                "rss_growth_kb_per_frame": round((last - first) * 1024 / max(summary.frames - start, 1), 2),
            }
            if mode == "sinks":
                out["video_mb"] = round((Path(tmp) / mode / "annotated.mp4").stat().st_size / 2**20, 1)
                out["rrd_mb"] = round((Path(tmp) / mode / "run.rrd").stat().st_size / 2**20, 1)
    out["frames"] = out["memory"]["sinks"]["frames"]
    out[key] = out["memory"]["sinks"][key]
    return out
