"""Thresholds a running stack takes from a YAML file, re-read when the file changes (``watch --config``).

The file holds the settings of ``PerceptionStack`` that are safe to change between two frames --
they are read afresh every frame and no state was built from them:

- ``detector``: ``conf`` (minimum detection score) and ``iou`` (NMS IoU threshold) of the ONNX
  detector (``perception.config.DetectorSpec``'s defaults);
- ``intent``: overrides of ``intent.config.IntentConfig``, nested like it and given in part, as
  a scenario's ``intent``: the risk zones (``ego_half_width``, ``corridor_margin``, ``horizon``),
  the per-class distance and TTC thresholds (``risk.<group>.high_ttc`` ...), behaviours, ...;
- ``alerts``: ``intent.alerts.AlertConfig`` (debounce and hysteresis, in frames).

Not live, a restart is needed: the detector's model and zoom windows, preprocessing, the tracker
and estimator (their state -- gates, filters -- is tuned to their settings), the camera and the
ego speed. The file is the whole live configuration: a field left out is its default (not the
value before the edit). Example::

    detector: {conf: 0.3}
    intent:
      corridor_margin: 0.7
      risk:
        pedestrian: {high_ttc: 3.5, critical_ttc: 1.8}
    alerts: {on_frames_high: 3}

``ConfigWatcher.poll()`` (once a frame) costs one ``stat``: the file is re-read only when its
modification time (ns), size or inode changed, or, as git does for "racy" entries, while its
modification time is within ``RACY_S`` of now (an edit within the file system's timestamp
granularity keeps both); it is re-parsed only when its text changed. A valid new configuration
is handed to ``apply``; an invalid one (YAML error, schema error, a half-written or vanished
file, or one ``apply`` refuses) is one ``logging.warning`` line ``file:line: problem`` -- once
per edit, not once per frame -- and the configuration in force stays.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

from lookahead.intent.alerts import AlertConfig
from lookahead.intent.config import IntentConfig
from lookahead.perception.config import DetectorSpec, Overrides, SettingsError
from lookahead.perception.safe_yaml import YamlError, read_yaml_text
from lookahead.perception.yaml_model import parse_yaml_model

log = logging.getLogger(__name__)

#: While a file's modification time is this close to now (s), it is re-read on every poll (see module doc).
RACY_S = 2.0
#: Most bytes a live configuration file may have (a full one is about 3 kB).
MAX_BYTES = 256 * 1024


class LiveConfigError(SettingsError):
    """A live configuration file that cannot be used; ``str()`` is one line ``file[:line]: problem``."""


def _check_intent(v: dict) -> dict:
    IntentConfig().with_overrides(v)  # its ValidationError, located under ``intent``
    return v


IntentOverrides = Annotated[dict[str, Any], Overrides(_check_intent, IntentConfig, partial=True)]
_DETECTOR = DetectorSpec.model_fields


class LiveDetector(BaseModel):
    """The detector's thresholds (ONNX detector)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    conf: float = Field(_DETECTOR["conf"].default, gt=0.0, lt=1.0, description="minimum detection score")
    iou: float = Field(_DETECTOR["iou"].default, gt=0.0, le=1.0, description="per-class NMS IoU threshold")


class LiveConfig(BaseModel):
    """The live configuration file of ``lookahead watch --config`` (module docstring)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    detector: LiveDetector = Field(default_factory=LiveDetector)
    intent: IntentOverrides = Field(
        default_factory=dict, description="overrides of intent.config.IntentConfig (risk zones, distance and TTC "
        "thresholds, behaviours), nested like it, given in part")
    alerts: AlertConfig = Field(default_factory=AlertConfig, description="alert debounce and hysteresis (frames)")

    def intent_config(self) -> IntentConfig:
        """The intent thresholds: the defaults with ``intent`` applied."""
        return IntentConfig().with_overrides(self.intent)

    def stack_settings(self) -> dict[str, Any]:
        """Keyword arguments of ``PerceptionStack.reconfigure``."""
        return {"intent_config": self.intent_config(), "alert_config": self.alerts,
                "detector_conf": self.detector.conf, "detector_iou": self.detector.iou}

    def effective(self) -> dict[str, Any]:
        """Every setting in force (defaults included), JSON-ready."""
        return {"detector": self.detector.model_dump(), "intent": self.intent_config().model_dump(),
                "alerts": self.alerts.model_dump()}


def parse_live_config(text: str, source: str) -> LiveConfig:
    """``text`` (YAML) as a ``LiveConfig``; ``LiveConfigError`` (one line, ``source:line``) if it is not one.
    An empty file is all defaults."""
    if not text.strip():
        return LiveConfig()
    return parse_yaml_model(text, source, LiveConfig, "live configuration", LiveConfigError)


def load_live_config(path: str | os.PathLike[str]) -> LiveConfig:
    """The live configuration file ``path``; ``LiveConfigError`` (one line) if missing or invalid."""
    return parse_live_config(_read(Path(path)), str(path))


def _read(path: Path) -> str:
    try:
        return read_yaml_text(path, "live configuration", max_bytes=MAX_BYTES)
    except YamlError as e:
        raise LiveConfigError(str(e)) from None


def flatten(d: dict, prefix: str = "") -> dict[str, Any]:
    """Nested mappings as ``{"a.b.c": leaf}``."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def changes(old: LiveConfig, new: LiveConfig) -> dict[str, dict[str, Any]]:
    """The settings ``new`` changes: ``{"intent.risk.pedestrian.high_ttc": {"from": 3.0, "to": 3.5}}``."""
    a, b = flatten(old.effective()), flatten(new.effective())
    return {k: {"from": a.get(k), "to": b.get(k)} for k in sorted(a.keys() | b.keys()) if a.get(k) != b.get(k)}


class ConfigWatcher:
    """Polls a live configuration file and hands each valid change to ``apply`` (module docstring).

    ``config`` is the configuration in force. The file is read and validated at construction:
    ``LiveConfigError`` (one line) when it is missing or invalid -- at start that is the user's
    error, later edits are only warned about. ``apply(new)`` may refuse a configuration by raising
    ``SettingsError`` (its message is the warning); it is then not in force.
    """

    def __init__(self, path: str | os.PathLike[str], apply: Callable[[LiveConfig], None] | None = None) -> None:
        self.path = Path(path)
        self.apply = apply
        self._stamp = self._stat_stamp()
        if self._stamp is None:
            raise LiveConfigError(f"{self.path}: no such live configuration file")
        self._text = _read(self.path)
        self.config = parse_live_config(self._text, str(self.path))
        self.rejected = 0  # edits refused so far

    def _stat_stamp(self) -> tuple[int, int, int] | None:
        try:
            st = os.stat(self.path)
        except OSError:
            return None
        return st.st_mtime_ns, st.st_size, st.st_ino

    def _reject(self, problem: str) -> None:
        self.rejected += 1
        log.warning("%s; the configuration in force stays", problem)

    def poll(self) -> dict[str, dict[str, Any]] | None:
        """After an edit to a valid configuration that changes a setting (now in force: ``config``),
        what it changed (``changes``); else None."""
        stamp = self._stat_stamp()
        if stamp is None:
            if self._stamp is not None:
                self._stamp = None
                self._text = None
                self._reject(f"{self.path}: the live configuration file is gone")
            return None
        racy = time.time_ns() - stamp[0] < RACY_S * 1e9
        if stamp == self._stamp and not racy:
            return None
        self._stamp = stamp
        try:
            text = _read(self.path)
        except LiveConfigError as e:
            if self._text is not None:  # warned once until it is readable again
                self._text = None
                self._reject(str(e))
            return None
        if text == self._text:
            return None
        self._text = text
        try:
            new = parse_live_config(text, str(self.path))
            changed = changes(self.config, new)
            if changed and self.apply is not None:
                self.apply(new)
        except SettingsError as e:
            self._reject(str(e))
            return None
        self.config = new  # also when nothing in force changed (a default written out, a comment)
        return changed or None
