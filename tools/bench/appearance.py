"""``lookahead bench appearance``: what appearance re-identification costs the tracker per tick.

A synthetic 640 x 360 scene (a seeded noise image, so every crop differs) with ``objects``
pedestrian-sized boxes moving across it for ``frames`` frames at 10 fps; each object is hidden
(no detection) for 1 s once, at a seeded time, so lost tracks wait to be re-found. Three passes
over the same detections, interleaved over ``repeats`` rounds:

* ``track``: the tracker alone (``Tracker.update(dets)``), appearance off;
* ``track_appearance``: the stack's way (``PerceptionStack._features``): ``features_needed``,
  the ONNX embedder on the detections it marks only, then ``update(dets, features)``;
* ``track_embed_all``: every detection embedded every frame (DeepSORT's way), for scale.

Per-tick ms (median, p95) of each; ``embedded_frames`` is the share of frames the embedder ran
on in ``track_appearance``; ratio ``appearance_over_track`` = median tick with appearance / without.
"""

from __future__ import annotations

import time

import numpy as np

from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.embedder import AppearanceEmbedder
from lookahead.perception.tracker import Tracker
from lookahead.tools.bench.common import case, machine

WIDTH, HEIGHT, FPS = 640, 360, 10.0
BOX_W, BOX_H = 24.0, 56.0  # px: a pedestrian ~25 m away
HIDDEN_FRAMES = 10  # 1 s at 10 fps


def scene(objects: int, frames: int, seed: int = 0) -> tuple[np.ndarray, list[Detections]]:
    """(RGB image, per-frame detections) of ``objects`` boxes moving linearly, each hidden once."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 256, (HEIGHT, WIDTH, 3), dtype=np.uint8)
    start = np.column_stack([rng.uniform(0, WIDTH - BOX_W, objects), rng.uniform(0, HEIGHT - BOX_H, objects)])
    velocity = rng.uniform(-3.0, 3.0, (objects, 2))  # px per frame
    hidden_at = rng.integers(5, max(6, frames - HIDDEN_FRAMES), objects)
    dets = []
    for f in range(frames):
        xy = np.clip(start + velocity * f, 0, [WIDTH - BOX_W, HEIGHT - BOX_H])
        seen = ~((f >= hidden_at) & (f < hidden_at + HIDDEN_FRAMES))
        xyxy = np.column_stack([xy, xy + [BOX_W, BOX_H]])[seen]
        dets.append(Detections(xyxy=xyxy, score=np.full(len(xyxy), 0.9),
                               class_id=np.full(len(xyxy), CLASS_ID["pedestrian"])))
    return image, dets


def _pass(image: np.ndarray, dets: list[Detections], embedder: AppearanceEmbedder | None,
          embed_all: bool = False) -> tuple[list[float], int]:
    """Per-tick ms of one tracker over ``dets``, and the frames the embedder ran on."""
    tracker = Tracker(frame_rate=FPS)
    ticks, embedded = [], 0
    for d in dets:
        t0 = time.perf_counter()
        features = None
        if embedder is not None:
            need = np.ones(len(d), dtype=bool) if embed_all else tracker.features_needed(d)
            if need.any():
                features = np.full((len(d), embedder.dim), np.nan, dtype=np.float32)
                features[need] = embedder.embed(image, d.xyxy[need])
                embedded += 1
        tracker.update(d, features)
        ticks.append((time.perf_counter() - t0) * 1e3)
    return ticks, embedded


def bench_appearance(objects: int = 30, frames: int = 60, repeats: int = 2) -> dict:
    image, dets = scene(objects, frames)
    embedder = AppearanceEmbedder()
    embedder.embed(image, dets[0].xyxy[:2])  # warm-up
    ms: dict[str, list[float]] = {"track": [], "track_appearance": [], "track_embed_all": []}
    embedded = 0
    for rep in range(repeats):
        order = list(ms) if rep % 2 == 0 else list(reversed(ms))
        for name in order:
            ticks, n = _pass(image, dets, None if name == "track" else embedder, embed_all=name == "track_embed_all")
            ms[name] += ticks
            if name == "track_appearance" and rep == 0:
                embedded = n
    cases = {k: case(v) for k, v in ms.items()}
    return {
        "machine": machine(),
        "objects": objects,
        "frames": frames,
        "embedder": str(embedder.model_path.name),
        "embedded_frames": round(embedded / frames, 3),
        "cases": cases,
        "ratios": {"appearance_over_track": round(cases["track_appearance"]["ms_median"]
                                                  / cases["track"]["ms_median"], 3)},
    }
