"""``lookahead bench detect``: the ONNX detector end to end vs its bare ``session.run``.

Rendered frames of a scenario (its camera's 640 x 360, or another size asked for) go
through ``OnnxDetector.detect`` as the scenarios run it, with the default zoom windows or
those asked for (``perception.detectors.windows``: letterbox, inference, decode and
per-class NMS of the whole frame and of each window, then the merge) and, interleaved
frame by frame in the same process, through ``session.run`` alone on the same
already-letterboxed tensors (one per view). Ratio ``pipeline_over_session_run`` = median
pipeline ms / median summed ``session.run`` ms; ``fps`` = 1000 / median pipeline ms. The
cases ``preprocess`` and ``postprocess`` are the pipeline's own stage timings;
``whole_frame`` is the same detector without windows (``fps_whole_frame``, and
``windows_over_whole_frame``: what the windows cost).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lookahead.perception.config import DEFAULT_MODEL
from lookahead.perception.detectors.onnx_detector import OnnxDetector
from lookahead.perception.detectors.windows import DEFAULT_WINDOWS
from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import DetectorSpec, load_scenario
from lookahead.tools.bench.common import case, machine


def render_frames(scenario_path: Path, n: int, size: tuple[int, int] | None = None) -> list[np.ndarray]:
    """``n`` camera images of the scenario (one per camera frame, from the start); ``size``:
    (width, height) px of the camera instead of the scenario's."""
    sc = load_scenario(scenario_path)
    sc = sc.model_copy(update={"perception": sc.perception.model_copy(update={"detector": DetectorSpec(kind="gt")})})
    if size is not None:
        sc = sc.model_copy(update={"camera": sc.camera.model_copy(update={"width": size[0], "height": size[1]})})
    runner = Runner(sc, render=True)
    frames = []
    try:
        while len(frames) < n:
            for _ in range(runner.frame_every):
                runner.world.step()
            frames.append(runner.frame()[0].image)
    finally:
        runner.close()
    return frames


def bench_detect(model: Path = DEFAULT_MODEL, scenario_path: Path | None = None, frames: int = 30,
                 repeats: int = 3, windows: Sequence[Sequence[float]] = DEFAULT_WINDOWS,
                 size: tuple[int, int] | None = None) -> dict:
    """The benchmark record (module docstring); ``size``: camera (width, height) px, default the scenario's."""
    images = render_frames(scenario_path or SCENARIOS / "urban_mix.yaml", frames, size)
    det = OnnxDetector(model, windows=windows)
    det.warmup(3)
    samples: dict[str, list[float]] = {"pipeline": [], "session_run": [], "preprocess": [], "postprocess": [],
                                       "whole_frame": []}
    n_dets = []
    configured = det.windows
    for _ in range(repeats):
        for img in images:
            t0 = time.perf_counter()
            d = det.detect(img)
            samples["pipeline"].append((time.perf_counter() - t0) * 1e3)
            samples["preprocess"].append(det.last_timing_ms["preprocess"])
            samples["postprocess"].append(det.last_timing_ms["postprocess"])
            tensors = [det.preprocess(crop, zoom)[0] for crop, _, _, zoom in det.views(img)]
            t0 = time.perf_counter()
            for tensor in tensors:
                det.infer(tensor)
            samples["session_run"].append((time.perf_counter() - t0) * 1e3)
            det.windows = ()  # the same session: a second one's idle threads would steal the cores
            t0 = time.perf_counter()
            det.detect(img)
            samples["whole_frame"].append((time.perf_counter() - t0) * 1e3)
            det.windows = configured
            n_dets.append(len(d))
    cases = {k: case(v) for k, v in samples.items()}
    ms = {k: c["ms_median"] for k, c in cases.items()}
    return {
        "machine": machine(),
        "model": str(model),
        "image": [int(images[0].shape[1]), int(images[0].shape[0])],
        "windows": [list(w) for w in det.windows],
        "views": len(det.views(images[0])),
        "providers": det.session.get_providers(),
        "cases": cases,
        "ratios": {"pipeline_over_session_run": round(ms["pipeline"] / ms["session_run"], 4),
                   "windows_over_whole_frame": round(ms["pipeline"] / ms["whole_frame"], 4)},
        "fps": round(1000.0 / ms["pipeline"], 2),
        "fps_whole_frame": round(1000.0 / ms["whole_frame"], 2),
        "detections_per_frame": round(float(np.mean(n_dets)), 2),
    }
