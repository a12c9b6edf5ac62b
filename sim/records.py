"""``TickRecord``: everything one camera frame of the loop produced, as sinks receive it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from lookahead.intent.labels import NEVER
from lookahead.perception.detections import Detections
from lookahead.perception.frame import Frame
from lookahead.sim.collision import Collision
from lookahead.sim.groundtruth import GroundTruth


def jsonable(obj: Any) -> Any:
    """Plain JSON types, deterministic: NaN -> None, +-inf -> +-``NEVER``, numpy -> python."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        f = float(obj)
        if math.isnan(f):
            return None
        if math.isinf(f):
            return NEVER if f > 0 else -NEVER
        return f
    return obj


@dataclass
class TickRecord:
    """One perception frame of the closed loop (emitted at the camera rate).

    ``to_dict`` excludes the image and the timings so that the same scenario
    and seed give byte-identical ``ticks.jsonl``; timings go to ``timings.jsonl``.
    """

    tick: int
    frame_index: int
    t: float
    ego: dict
    frame: Frame
    ground_truth: GroundTruth
    detections: Detections
    tracks: Any = None
    estimates: Any = None
    assessments: Any = None
    alerts: list = field(default_factory=list)
    collisions: list[Collision] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    cooperative: dict | None = None  # other cameras' objects and their fusion (``sim.cooperation``); None: none
    sender_frames: dict[str, Frame] = field(default_factory=dict)  # other cameras' frames by sender (images if rendered)
    cipv: dict | None = None  # the primary target: ``{track_id, range, truth_actor, truth_range}`` (``sim.runner``)

    def to_dict(self) -> dict:
        d = {
            "tick": self.tick,
            "frame": self.frame_index,
            "t": round(self.t, 4),
            "ego": {k: round(v, 4) if isinstance(v, float) else v for k, v in self.ego.items()},
            "ground_truth": self.ground_truth.to_dict(),
            "detections": self.detections.to_dict(),
            "tracks": None if self.tracks is None else {
                **self.tracks.to_dict(), **(self.estimates.to_dict() if self.estimates is not None else {})
            },
            "assessments": self.assessments.to_dict() if hasattr(self.assessments, "to_dict") else None,
            "alerts": [a.to_dict() if hasattr(a, "to_dict") else a for a in self.alerts],
            "collisions": [c.to_dict() for c in self.collisions],
        }
        if self.cipv is not None:  # the closed loop's records (``sim.runner.cipv_record``); real video has none
            d["cipv"] = self.cipv
        if self.cooperative is not None:  # only with other cameras: other runs record exactly as before
            d["cooperative"] = self.cooperative
        return jsonable(d)


class Sink(Protocol):
    """An observer the runner calls; ``sim`` never imports concrete sinks (they live in ``tools``)."""

    def on_start(self, info: dict) -> None: ...

    def on_tick(self, record: TickRecord) -> None: ...

    def on_end(self, summary: dict) -> None: ...


class RecordCollector:
    """A sink that keeps every ``TickRecord`` in memory (tests, notebooks, benchmarks)."""

    def __init__(self) -> None:
        self.records: list[TickRecord] = []
        self.info: dict = {}
        self.summary: dict = {}

    def on_start(self, info: dict) -> None:
        self.info = info

    def on_tick(self, record: TickRecord) -> None:
        self.records.append(record)

    def on_end(self, summary: dict) -> None:
        self.summary = summary
