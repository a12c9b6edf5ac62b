"""``lookahead bench watch``: the ``lookahead watch`` pipeline against its stages alone.

A scenario is rendered once to a raw camera video with its calibration (``lookahead run
--raw-video``). Then, in one process, interleaved over ``repeats`` rounds:

* **capture** alone: the file decoded (``perception.sources.open_source``), frames/s;
* **stack** alone: the shipped ONNX detector, tracker, estimator, intent and alerts on the frames
  already decoded (``intent.stack.build_stack`` with the run's camera), frames/s;
* **sinks** alone: the records the stack produced written to a run directory, a SQLite store
  (committed every frame, as watch does) and an annotated video, frames/s;
* **watch**: the whole pipeline (``tools.runs.watch.watch``: capture thread, stack, the same
  sinks) on the file, frames/s.

Each rate is frames over the wall time after the first ``WARMUP`` frames. Ratio
``watch_over_slowest_stage`` = watch's rate / the slowest stage's rate (the same round's, median
over rounds): the pipeline adds nothing beyond its slowest stage when it is near 1 (target
>= 0.9; watch runs capture in its own thread, but stack and sinks in turn on one). The
capture-to-alert latency (``latency_ms``: p50, p95 of watch's per-frame latency, from the capture
thread reading the frame to its alerts) is reported; on a file source it includes the frames the
capture thread reads ahead (``QUEUE_FRAMES``).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from lookahead.intent.stack import PerceptionStack, build_detector, build_stack
from lookahead.perception.calibration import load_calibration
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import DetectorSpec, PerceptionSpec
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.sources import CapturedFrame, open_source
from lookahead.sim.groundtruth import GroundTruth
from lookahead.sim.records import TickRecord
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import Scenario, load_scenario, with_detector
from lookahead.tools.bench.common import case, machine
from lookahead.tools.runs.watch import watch
from lookahead.tools.sinks.rundir import CALIBRATION_FILE, RunDir, RunDirWriter
from lookahead.tools.sinks.store import SqliteStore
from lookahead.tools.sinks.video import VideoSink

WARMUP = 3  # frames left out of every rate (model and cache warm-up)
TARGET = 0.9  # watch_over_slowest_stage at least this


def render_clip(scenario_path: Path, out: Path) -> tuple[Path, Path]:
    """(raw video, calibration file) of ``scenario_path`` rendered into ``out``."""
    scenario = with_detector(load_scenario(scenario_path), "gt", None)
    video = out / "camera.mp4"
    runner = Runner(scenario, render=True)
    runner.sinks = [RunDirWriter(out, scenario), VideoSink(video, fps=scenario.camera.rate, raw=True)]
    runner.run()
    return video, out / CALIBRATION_FILE


def rate(stamps: list[float]) -> float:
    """Frames/s from the completion time of each frame (s), after ``WARMUP`` frames."""
    s = stamps[WARMUP:] if len(stamps) > WARMUP + 1 else stamps
    return (len(s) - 1) / (s[-1] - s[0]) if len(s) > 1 and s[-1] > s[0] else float("nan")


def _timed(items: Iterable, work: Callable[[Any], None]) -> list[float]:
    """Completion time (s) of ``work`` on each item, in turn."""
    stamps = []
    for item in items:
        work(item)
        stamps.append(time.perf_counter())
    return stamps


def time_capture(video: Path) -> tuple[list[CapturedFrame], list[float]]:
    """The frames of ``video`` decoded, and when each was (s)."""
    frames: list[CapturedFrame] = []
    with open_source(video) as src:
        stamps = _timed(src.frames(), frames.append)
    return frames, stamps


def time_stack(frames: list[CapturedFrame], stack: PerceptionStack, camera: CameraModel) -> tuple[list[TickRecord], list[float]]:
    """The stack's records of ``frames`` (shaped as watch's), and when each was done (s)."""
    records: list[TickRecord] = []

    def process(f: CapturedFrame) -> None:
        frame = Frame(tick=f.index, t=f.t, camera=camera, odometry=EgoOdometry(), image=f.image, index=f.index)
        timings: dict[str, float] = {}
        dets, tracks, est, a, alerts = stack.process(frame, None, timings)
        records.append(TickRecord(
            tick=f.index, frame_index=f.index, t=f.t, ego={**frame.odometry.to_dict(), "brake": None}, frame=frame,
            ground_truth=GroundTruth.empty(), detections=dets, tracks=tracks, estimates=est, assessments=a,
            alerts=alerts, timings=timings))

    return records, _timed(frames, process)


def time_sinks(records: list[TickRecord], scenario: Scenario, out: Path, camera: CameraModel) -> list[float]:
    """When each record was written (s) to watch's sinks: run directory, store (committed every
    frame), annotated video."""
    store = SqliteStore(out / "run.sqlite", scenario, run_dir=out)
    sinks = [RunDirWriter(out, scenario), store, VideoSink(out / "annotated.mp4", fps=scenario.camera.rate)]
    for s in sinks:
        s.on_start({"scenario": scenario.name, "seed": scenario.seed, "camera": camera})

    def write(record: TickRecord) -> None:
        for s in sinks:
            s.on_tick(record)
        store.flush()

    stamps = _timed(records, write)
    for s in sinks:
        s.on_end({"error": None})
    return stamps


def time_watch(video: Path, calibration: Path, out: Path) -> tuple[list[float], list[float]]:
    """When each frame of ``watch`` on ``video`` was done (s), and its capture-to-alert latency (ms)."""
    stamps: list[float] = []
    summary = watch(video, out, calibration=calibration, video=out / "annotated.mp4", db=out / "run.sqlite",
                    progress=lambda status: stamps.append(time.perf_counter()))
    latency = [float(t["latency"]) for t in RunDir(out).timings if "latency" in t]
    return stamps[: summary["frames"]], latency  # (a last call tells the source's end)


def _ms(t0: float, stamps: list[float]) -> list[float]:
    return list(np.diff([t0, *stamps]) * 1e3)[WARMUP:]


def bench_watch(scenario_path: Path, repeats: int = 3) -> dict:
    scenario = load_scenario(scenario_path)
    rates: dict[str, list[float]] = {"capture": [], "stack": [], "sinks": [], "watch": []}
    ms: dict[str, list[float]] = {k: [] for k in rates}
    latency: list[float] = []
    with tempfile.TemporaryDirectory(prefix="lookahead-bench-watch-") as tmp:
        root = Path(tmp)
        video, calibration = render_clip(scenario_path, root / "clip")
        camera = load_calibration(calibration).to_camera()
        spec = PerceptionSpec(detector=DetectorSpec(kind="onnx"))
        detector = build_detector(spec.detector, seed=0, render=True)
        for rep in range(repeats):
            t0 = time.perf_counter()
            frames, stamps = time_capture(video)
            rates["capture"].append(rate(stamps))
            ms["capture"] += _ms(t0, stamps)
            t0 = time.perf_counter()
            stack = build_stack(spec, camera, scenario.camera.rate, detector=detector, render=True)
            records, stamps = time_stack(frames, stack, camera)
            rates["stack"].append(rate(stamps))
            ms["stack"] += _ms(t0, stamps)
            t0 = time.perf_counter()
            stamps = time_sinks(records, scenario, root / f"sinks{rep}", camera)
            rates["sinks"].append(rate(stamps))
            ms["sinks"] += _ms(t0, stamps)
            stamps, lat = time_watch(video, calibration, root / f"watch{rep}")
            rates["watch"].append(rate(stamps))
            ms["watch"] += _ms(stamps[0], stamps[1:])
            latency += lat[WARMUP:]
    per_round = [w / min(c, s, k) for w, c, s, k in
                 zip(rates["watch"], rates["capture"], rates["stack"], rates["sinks"], strict=True)]
    slowest = min(("capture", "stack", "sinks"), key=lambda k: float(np.median(rates[k])))
    lat = np.asarray(latency)
    return {
        "machine": machine(),
        "scenario": str(scenario_path),
        "frames": len(frames),
        "fps": {k: round(float(np.median(v)), 3) for k, v in rates.items()},
        "slowest_stage": slowest,
        "latency_ms": {"p50": round(float(np.percentile(lat, 50)), 2), "p95": round(float(np.percentile(lat, 95)), 2)},
        "cases": {k: case(v) for k, v in ms.items()},
        "ratios": {"watch_over_slowest_stage": round(float(np.median(per_round)), 4)},
        "target": {"watch_over_slowest_stage": TARGET},
    }
