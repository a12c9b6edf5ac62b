"""Key frames: the PNGs a person looks at first, chosen by one rule for the demo and the report."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from lookahead.tools.sinks.draw import save_rgb
from lookahead.tools.sinks.rundir import prepare_dir
from lookahead.tools.sinks.video import Overlay

KEY_FRAMES = (0.25, 0.5, 0.75)  # fractions of each run at which a PNG is kept
KEY_ALERTS = ("fcw", "critical")  # the first alert event of each of these kinds is a key frame too
KEY_FRAMES_INDEX = "key_frames.json"


def key_frame_reason(index: int, frames_total: int, alert_kinds: Iterable[str], collision: bool,
                     seen: set[str]) -> str | None:
    """Why camera frame ``index`` is a key frame, or None: the first ``fcw`` / ``critical``
    alert and the first collision of the run (``seen`` collects those already used; pass
    the same set for every frame, in order), and the frames at ``KEY_FRAMES`` of
    ``frames_total``. One rule for the demo's PNGs and the report's frames from a video."""
    why = []
    for kind in KEY_ALERTS:
        if kind in alert_kinds and kind not in seen:
            seen.add(kind)
            why.append(f"first {kind} alert")
    if collision and "collision" not in seen:
        seen.add("collision")
        why.append("collision")
    why += [f"{f:.0%} of the run" for f in KEY_FRAMES if index == int(f * frames_total)]
    return ", ".join(why) or None


class KeyFrameSink:
    """Saves PNGs of the key frames (``key_frame_reason``) with the annotated video's overlay
    (``tools.sinks.video.Overlay``: tracks coloured by risk, labels, range, TTC, trails, alert banner)."""

    def __init__(self, out: Path, frames_total: int, lang: str = "en") -> None:
        self.out, self.frames_total = prepare_dir(out), frames_total
        self.overlay = Overlay(lang)
        self.saved: list[Path] = []
        self.reasons: dict[int, str] = {}
        self._seen: set[str] = set()

    def on_start(self, info: dict) -> None:
        self.overlay.reset()
        self._seen = set()

    def on_tick(self, rec) -> None:
        if rec.frame.image is None:
            return
        kinds = {a["kind"] if isinstance(a, dict) else a.kind for a in rec.alerts}
        why = key_frame_reason(rec.frame_index, self.frames_total, kinds, bool(rec.collisions), self._seen)
        if why is None:
            self.overlay.observe(rec)
            return
        path = self.out / f"frame_{rec.frame_index:04d}.png"
        save_rgb(path, self.overlay.annotate(rec))
        self.saved.append(path)
        self.reasons[path.name] = why

    def on_end(self, summary: dict) -> None:
        """``key_frames.json`` beside the PNGs: file name -> why it was kept (the report's captions)."""
        if self.reasons:
            (self.out / KEY_FRAMES_INDEX).write_text(json.dumps(self.reasons, indent=1) + "\n")
