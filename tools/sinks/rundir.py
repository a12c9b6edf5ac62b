"""The run directory: ``run.json``, ``ticks.jsonl``, ``timings.jsonl``.

``ticks.jsonl`` holds one TickRecord per line (images and timings excluded, so
it is byte-identical for the same scenario, seed and version);
``timings.jsonl`` holds the per-stage timings (ms) of each line.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
from importlib import metadata
from pathlib import Path

from lookahead.sim.records import NEVER as NEVER  # re-exported: the "never" sentinel of run files
from lookahead.sim.records import TickRecord, jsonable
from lookahead.sim.scenario import Scenario

RUN_FILE = "run.json"
TICKS_FILE = "ticks.jsonl"
TIMINGS_FILE = "timings.jsonl"
METRICS_FILE = "metrics.json"
SUMMARY_FILE = "summary.json"  # a suite's (or sweep's) directory


class OutputError(RuntimeError):
    """An output path that cannot be written; ``str()`` is one line."""


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for pkg in ("lookahead", "highway-env", "pybullet", "numpy", "onnxruntime"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out


def config_hash(scenario: Scenario) -> str:
    text = json.dumps(scenario.model_dump(mode="json"), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def prepare_dir(path: Path) -> Path:
    """Create ``path`` (and parents); one clear error if it cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".write-test-{os.getpid()}"  # per process: workers share dirs
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise OutputError(f"{path}: cannot write the output directory ({e.strerror or e})") from None
    return path


class RunDirWriter:
    """A sink that writes the run directory of one scenario run.

    ``__init__`` only checks (creates the directory, probes a write, refuses run files that
    are directories or read-only); nothing is written or truncated before ``on_start``.
    """

    FILES = ("run.json", "ticks.jsonl", "timings.jsonl")

    def __init__(self, out_dir: Path, scenario: Scenario, source: str | None = None) -> None:
        self.dir = prepare_dir(Path(out_dir))
        for name in self.FILES:
            f = self.dir / name
            if f.is_dir():
                raise OutputError(f"{f}: is a directory, cannot write the run file")
            if f.exists() and not os.access(f, os.W_OK):
                raise OutputError(f"{f}: the run file is not writable")
        self.scenario = scenario
        self.source = source
        self._ticks = None
        self._timings: list[dict] = []
        self.frames = 0

    def on_start(self, info: dict) -> None:
        run = {
            "scenario": self.scenario.model_dump(mode="json"),
            "scenario_file": self.source,
            "seed": self.scenario.seed,
            "versions": versions(),
            "config_hash": config_hash(self.scenario),
            "renderer": info.get("renderer"),
            "complete": False,
        }
        (self.dir / "run.json").write_text(json.dumps(jsonable(run), indent=2, sort_keys=True) + "\n")
        self._ticks = (self.dir / "ticks.jsonl").open("w", encoding="utf-8")

    def on_tick(self, record: TickRecord) -> None:
        self._ticks.write(json.dumps(record.to_dict(), separators=(",", ":")) + "\n")
        self._timings.append(record.timings)  # completed by the runner after the sinks return
        self.frames += 1

    def on_end(self, summary: dict) -> None:
        if self._ticks is not None:
            self._ticks.close()
        with (self.dir / "timings.jsonl").open("w", encoding="utf-8") as f:
            for t in self._timings:
                f.write(json.dumps({k: round(v, 3) for k, v in t.items()}) + "\n")
        run = json.loads((self.dir / "run.json").read_text())
        run["complete"] = summary.get("error") is None
        run["summary"] = jsonable(summary)
        (self.dir / "run.json").write_text(json.dumps(run, indent=2, sort_keys=True) + "\n")
