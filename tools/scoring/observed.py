"""What a run without ground truth (``lookahead watch`` on real video) can be summarised by.

Nothing is scored without truth; ``observed_section`` counts what the stack produced, the
``observed`` section of such a run's ``metrics.json``: frames, detections per class, tracks
(distinct confirmed ids, and how many frames each lasted), alerts per level, and the frames
without ego speed (where ego-motion-dependent estimates are unavailable).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from lookahead.perception.detections import CLASSES
from lookahead.tools.sinks.rundir import RunDir

#: ``run.json`` ``scenario.kind`` of a run without ground truth (``tools.runs.watch.WatchConfig``).
NO_TRUTH_KINDS = ("watch",)


def has_ground_truth(rd: RunDir) -> bool:
    """Whether the run's records carry ground truth (a simulated run, or a watch joined with one)."""
    scenario = rd.run.get("scenario") if rd.has("run.json") else None
    return not (isinstance(scenario, dict) and scenario.get("kind") in NO_TRUTH_KINDS)


def _class_name(i: int) -> str:
    return CLASSES[i] if 0 <= i < len(CLASSES) else str(i)


def observed_section(rd: RunDir) -> dict:
    """Counts of what the stack produced over the run's records (no truth needed)."""
    dets: Counter[str] = Counter()
    alerts: Counter[str] = Counter()
    track_frames: Counter[int] = Counter()
    no_speed = 0
    records = rd.ticks
    for rec in records:
        d = rec.get("detections") or {}
        dets.update(_class_name(int(c)) for c in d.get("class_id") or [])
        tr = rec.get("tracks") or {}
        for tid, state in zip(tr.get("track_id") or [], tr.get("state") or [], strict=False):
            if state in ("confirmed", 1):
                track_frames[int(tid)] += 1
        alerts.update(str(a.get("level_name", a.get("level"))) for a in rec.get("alerts") or [])
        if (rec.get("ego") or {}).get("speed_known") is False:
            no_speed += 1
    lengths = np.asarray(list(track_frames.values()), dtype=np.float64)
    return {
        "frames": len(records),
        "detections": int(sum(dets.values())),
        "detections_per_frame": round(sum(dets.values()) / len(records), 3) if records else None,
        "detections_per_class": dict(sorted(dets.items())),
        "confirmed_tracks": len(track_frames),
        "track_frames_median": float(np.median(lengths)) if len(lengths) else None,
        "alerts": int(sum(alerts.values())),
        "alerts_per_level": dict(sorted(alerts.items())),
        "frames_without_ego_speed": no_speed,
    }
