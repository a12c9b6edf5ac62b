"""Replay: re-run tracker -> estimator -> intent -> alerts on a recorded run directory.

A run directory's ``ticks.jsonl`` keeps, per camera frame, the detections the
tracker saw, the ego odometry, the time, and the ground truth; ``run.json``
keeps the scenario (camera, tracker / estimator / intent / alert settings).
``replay_run`` feeds those detections through a fresh stack (``intent.stack.build_stack``)
-- the very object the closed loop uses, with a detector that hands back the
recorded boxes -- and writes a new run directory: ``run.json`` (the source's,
plus a ``replay`` entry), ``ticks.jsonl`` (every line of the source with
``detections``, ``tracks``, ``assessments`` and ``alerts`` replaced, everything
else -- ground truth, ego, collisions -- copied) and ``timings.jsonl`` (the
replayed stages only). ``lookahead score`` scores it exactly as a recorded run;
``replay_run`` does so unless ``score=False``. A suite directory (with
``summary.json``) is replayed run by run into a suite directory with its own
``summary.json`` (totals recomputed as ``lookahead suite`` does).

Use: record an expensive (rendered) run once, then iterate on perception and
intent in seconds. With unchanged code, a replay reproduces the recorded
tracks, assessments and alerts: ids, states, labels, risks and alert events
exactly; floats to the recording's rounding -- ``ticks.jsonl`` keeps boxes to
0.01 px and odometry to 1e-4, so the replayed filters see inputs within half
that of the original ones (tested in ``tests/tools/test_replay.py``).

Limitations:
* Open loop. The ego motion, the world and the detections are the recording's.
  When the replayed stack's alerts would have changed what the AEB did (or a
  different ego motion would have changed what the camera saw), the replay is
  an approximation. ``run.json`` ``replay.aeb_divergent_frames`` counts frames
  where an AEB fed by the replayed alerts (same ``AebConfig``) would brake and
  the recorded ego did not, or the reverse; 0 when AEB is off (as in the smoke
  suite) or when nothing changed.
* Detector latency and noise are whatever the recording had; only the
  perturbation below is added. Detector timings are not replayed.

Perturbation (``Perturbation``, all off by default; seeded, per frame and
detection in file order): per-edge jitter (std ``jitter`` x box width / height),
extra bottom-edge noise (std ``bottom_sigma`` x box height: feet, wheels,
shadows), both optionally AR(1)-correlated over frames per source object
(``correlation`` = frame-to-frame coefficient; real detectors' errors persist),
a box scale bias (``scale_bias``: every box grown by that fraction about its
centre), misses (``miss_rate``, independent per detection) and class flips
(``class_flip``: to a plausible other class, ``gt_detector.CONFUSABLE``).
It stands in for a neural detector on pixels when checking that estimation and
intent degrade gracefully, not only under the ``gt`` detector's noise model.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from lookahead.intent.config import deep_merge
from lookahead.intent.stack import build_stack
from lookahead.perception.detections import CLASSES, Detections
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.detectors.gt_detector import CONFUSION_COUNT, CONFUSION_TABLE
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.ground_map import GroundMap
from lookahead.sim.aeb import Aeb
from lookahead.sim.layout import RoadLayout
from lookahead.sim.records import jsonable
from lookahead.sim.runner import camera_from_scenario
from lookahead.sim.scenario import Scenario, format_validation
from lookahead.sim.world import scenario_road
from lookahead.tools.runs.inputs import OVERRIDE_SECTIONS, ReplayError, read_overrides  # noqa: F401 (re-exported)
from lookahead.tools.scoring.intent import aeb_brake_of
from lookahead.tools.scoring.io import MAX_TICK, run_record, ticks_records
from lookahead.tools.scoring.run import score_run
from lookahead.tools.scoring.totals import RunFrames, suite_totals
from lookahead.tools.sinks.rundir import (
    METRICS_FILE,
    SUMMARY_FILE,
    TICKS_FILE,
    TIMINGS_FILE,
    OutputError,
    RunDir,
    as_rundir,
    prepare_dir,
    read_summary,
    tick_line,
    timings_line,
    write_run_json,
    write_summary,
)

log = logging.getLogger(__name__)

REPLAY_STAGES = ("preprocess", "detect", "track", "estimate", "intent", "tick")
class Perturbation(BaseModel):
    """Extra detector noise added to the recorded detections (fractions of box size, probabilities)."""

    model_config = ConfigDict(extra="forbid")
    jitter: float = Field(0.0, ge=0, description="per-edge std as a fraction of box width / height")
    bottom_sigma: float = Field(0.0, ge=0, description="extra bottom-edge std as a fraction of box height")
    correlation: float = Field(0.0, ge=0, lt=1, description="AR(1) frame-to-frame coefficient of the edge noise")
    scale_bias: float = Field(0.0, gt=-0.5, lt=0.5, description="every box grown by this fraction about its centre")
    miss_rate: float = Field(0.0, ge=0, le=1, description="probability of dropping a detection")
    class_flip: float = Field(0.0, ge=0, le=1, description="probability of a plausible other class")
    seed: int = Field(0, ge=0, description="random stream (with the run's seed)")

    @property
    def active(self) -> bool:
        return any(v for k, v in self.model_dump().items() if k != "seed")


class Perturber:
    """Applies a ``Perturbation`` frame by frame (state: the AR(1) noise per source object)."""

    def __init__(self, config: Perturbation, run_seed: int, width: int, height: int) -> None:
        self.config, self.width, self.height = config, width, height
        self.rng = np.random.default_rng([config.seed, run_seed, 0x5EA1])
        self._noise: dict[int, np.ndarray] = {}  # source id -> last (4,) unit noise
        self._table, self._count = CONFUSION_TABLE, CONFUSION_COUNT

    def __call__(self, dets: Detections) -> Detections:
        cfg, rng = self.config, self.rng
        n = len(dets)
        # fixed draw sizes per frame: the stream does not depend on the values
        u_miss, u_flip, u_pick = rng.random(n), rng.random(n), rng.random(n)
        white = rng.standard_normal((n, 5))
        if n == 0:
            return dets
        b = dets.xyxy.copy()
        w, h = b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]
        rho = cfg.correlation
        z = np.empty((n, 5))
        for i, sid in enumerate(dets.source_id.tolist()):
            prev = self._noise.get(sid) if sid >= 0 else None
            z[i] = white[i] if prev is None else rho * prev + np.sqrt(1.0 - rho * rho) * white[i]
            if sid >= 0:
                self._noise[sid] = z[i]
        b += z[:, :4] * np.stack([w, h, w, h], axis=1) * cfg.jitter
        b[:, 3] += z[:, 4] * h * cfg.bottom_sigma
        if cfg.scale_bias:
            g = 0.5 * cfg.scale_bias * np.stack([-w, -h, w, h], axis=1)
            b += g
        b = np.concatenate([np.minimum(b[:, :2], b[:, 2:]), np.maximum(b[:, :2], b[:, 2:])], axis=1)
        b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, self.width)
        b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, self.height)
        cls = dets.class_id.copy()
        ok = (cls >= 0) & (cls < len(CLASSES))
        flip = ok & (u_flip < cfg.class_flip)
        if np.any(flip):
            c = cls[flip]
            pick = np.minimum((u_pick[flip] * self._count[c]).astype(np.int64), self._count[c] - 1)
            cls[flip] = self._table[c, pick]
        keep = u_miss >= cfg.miss_rate
        out = Detections(xyxy=b, score=dets.score, class_id=cls, source_id=dets.source_id)
        return out[keep]


class RecordedDetector:
    """A ``Detector`` that returns the detections set for the current frame."""

    def __init__(self) -> None:
        self.next = Detections.empty()

    def detect(self, image: np.ndarray | None, truth: DetectorTruth | None = None) -> Detections:
        return self.next


def _detections(obj: dict | None) -> Detections:
    if not obj:
        return Detections.empty()
    n = len(obj.get("xyxy") or [])
    src = obj.get("source_id")
    return Detections(
        xyxy=np.array(obj["xyxy"], dtype=np.float64).reshape(n, 4),
        score=np.array(obj["score"], dtype=np.float64),
        class_id=np.array(obj["class_id"], dtype=np.int64),
        source_id=None if src is None else np.array(src, dtype=np.int64),
    )


def _odometry(ego: dict) -> EgoOdometry:
    def f(key: str) -> float:
        v = ego.get(key)
        return 0.0 if v is None else float(v)

    return EgoOdometry(speed=f("speed"), accel=f("accel"), yaw_rate=f("yaw_rate"))


def _ground(layout: RoadLayout, ego: dict) -> GroundMap | None:
    """The recorded ego pose's ground map, as the run's frames had it (None without a pose)."""
    pose = [ego.get(k) for k in ("x", "y", "yaw")]
    if not all(isinstance(v, int | float) and np.isfinite(v) for v in pose):
        return None
    return layout.ground_map(tuple(float(v) for v in pose))


def _finite(value: object, what: str) -> float:
    if not isinstance(value, int | float) or isinstance(value, bool) or not np.isfinite(value):
        raise ValueError(f"{what}: expected a finite number, got {value!r:.40}")
    return float(value)


def _recorded_frames(source: RunDir) -> list[tuple[dict, float, dict, Detections, int, int]]:
    """Every record of ``ticks.jsonl`` with what the replay reads of it parsed: (record, t, ego,
    detections, tick, frame index). All are read before anything is written; a binary file or a
    record of the wrong shape is a ``RunDirError`` / ``ReplayError`` naming ``file:line``."""
    frames = []
    for i, rec in enumerate(ticks_records(source)):  # binary: RunDirError naming file:line
        try:
            if "t" not in rec:
                raise ValueError("t: missing")
            t = _finite(rec["t"], "t")
            ego = rec.get("ego") or {}
            if not isinstance(ego, dict):
                raise ValueError(f"ego: expected an object, got {type(ego).__name__}")
            for key in ("speed", "accel", "yaw_rate"):
                if ego.get(key) is not None:
                    _finite(ego[key], f"ego.{key}")
            dets = rec.get("detections")
            if dets is not None and not isinstance(dets, dict):
                raise ValueError(f"detections: expected an object or null, got {type(dets).__name__}")
            try:
                parsed = _detections(dets)
            except KeyError as e:
                raise ValueError(f"detections.{e.args[0]}: missing") from None
            except (TypeError, ValueError, OverflowError) as e:
                raise ValueError(f"detections: {' '.join(str(e).split())}") from None
            tick, index = rec.get("tick", 0), rec.get("frame", i)
            if not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= MAX_TICK for v in (tick, index)):
                raise ValueError(f"tick / frame: expected integers 0..{MAX_TICK}, got {tick!r:.20} / {index!r:.20}")
        except (TypeError, ValueError, OverflowError) as e:
            raise ReplayError(f"{source.where(i)}: {' '.join(str(e).split())}") from None
        frames.append((rec, t, ego, parsed, tick, index))
    return frames


def load_scenario_of(run_dir: Path | RunDir) -> tuple[dict, Scenario]:
    """``run.json`` of a run directory and the scenario it was run with; ``ReplayError`` naming
    the file and field when it has none or a malformed one."""
    rd = as_rundir(run_dir)
    path = rd.file("run.json")
    run = run_record(rd)  # binary, not an object, wrong shapes: RunDirError naming the file
    if not isinstance(run.get("scenario"), dict):
        raise ReplayError(f"{path}: scenario: missing (a replay runs the recorded scenario again)")
    try:
        return run, Scenario.model_validate(run["scenario"])
    except ValidationError as e:
        raise ReplayError(format_validation(str(path), e, under=("scenario",))) from None


def replay_run(
    run_dir: Path,
    out_dir: Path,
    perturb: Perturbation | None = None,
    overrides: dict | None = None,
    score: bool = True,
    where: str = "replay overrides",
) -> dict:
    """Replay ``run_dir`` into ``out_dir``; returns the replay summary (and ``metrics`` when scored).

    ``overrides``: ``{"tracker": {...}, "estimator": {...}, "intent": {...},
    "alerts": {...}}`` merged over the scenario's settings (experiments; the
    replay's ``run.json`` carries the resulting scenario); ``where`` names them in errors
    (the config file).
    """
    source, out_dir = RunDir(run_dir), Path(out_dir)
    run_dir = source.path
    source.file(TICKS_FILE)  # one-line error for a missing directory or ticks file
    if out_dir.resolve() == run_dir.resolve():
        raise OutputError(f"{out_dir}: the replay must go to another directory than its source")
    records = _recorded_frames(source)  # parsed and checked once, before anything is written
    run, scenario = load_scenario_of(source)
    scenario = _with_overrides(scenario, overrides or {}, where)
    perturb = perturb or Perturbation()
    camera = camera_from_scenario(scenario)
    layout = scenario_road(scenario)[2]  # the recorded road's pavements, for the ranger as in the run
    detector = RecordedDetector()
    stack = build_stack(scenario.perception, camera, scenario.camera.rate, intent=scenario.intent,
                        alerts=scenario.alerts, detector=detector, render=False)
    aeb = Aeb(scenario.ego.aeb_config) if scenario.ego.aeb_config is not None else None
    sim_dt = 1.0 / scenario.rate
    perturber = Perturber(perturb, scenario.seed, camera.width, camera.height) if perturb.active else None

    prepare_dir(out_dir)
    divergent, first_divergence, frames = 0, None, 0
    t_start = time.perf_counter()
    with (out_dir / TICKS_FILE).open("w", encoding="utf-8") as fout, \
            (out_dir / TIMINGS_FILE).open("w", encoding="utf-8") as ftim:
        for rec, t, ego, dets, tick, index in records:  # each line copied with the outputs replaced
            if perturber is not None:
                dets = perturber(dets)
            detector.next = dets
            frame = Frame(tick=tick, t=t, camera=camera, odometry=_odometry(ego), index=index,
                          ground=_ground(layout, ego))
            timings: dict[str, float] = {}
            t0 = time.perf_counter()
            dets, tracks, est, assessment, alerts = stack.process(frame, None, timings)
            timings["tick"] = (time.perf_counter() - t0) * 1e3
            if aeb is not None:
                would_brake = aeb.command(t - sim_dt) is not None
                if would_brake != bool(aeb_brake_of(ego)):  # the recorded AEB's own brake
                    divergent += 1
                    first_divergence = t if first_divergence is None else first_divergence
                crit, nearest = stack.critical_in_path(tracks, est, assessment)
                aeb.decide(t, crit, nearest, frame.odometry.speed)
            line = {**rec, "detections": dets.to_dict(), "tracks": {**tracks.to_dict(), **est.to_dict()},
                    "assessments": assessment.to_dict(), "alerts": [a.to_dict() for a in alerts]}
            fout.write(tick_line(jsonable(line)))
            ftim.write(timings_line({k: timings[k] for k in REPLAY_STAGES if k in timings}))
            frames += 1
    replay = {
        "source": str(run_dir),
        "frames": frames,
        "perturbation": perturb.model_dump() if perturb.active else None,
        "overrides": overrides or None,
        "aeb": aeb is not None,
        "aeb_divergent_frames": divergent,
        "aeb_first_divergence_t": first_divergence,
        "elapsed_s": round(time.perf_counter() - t_start, 3),
    }
    if aeb is not None and divergent:
        log.warning("%s: AEB fed by the replayed alerts differs from the recorded ego on %d frame(s) from "
                    "t=%.2f s: the replay is open-loop there", run_dir, divergent, first_divergence)
    out_run = {**run, "scenario": scenario.model_dump(mode="json"), "replay": replay}
    write_run_json(out_dir, out_run)
    (out_dir / METRICS_FILE).unlink(missing_ok=True)
    result = {"name": scenario.name, "dir": str(out_dir), "summary": run.get("summary") or {}, "replay": replay}
    if score:
        replayed = RunDir(out_dir)  # one parse of the replay: scoring, then suite totals' frames
        result["metrics"] = score_run(replayed)
        result["frames"] = RunFrames.of(replayed)
    return result


def _with_overrides(scenario: Scenario, overrides: dict, where: str = "replay overrides") -> Scenario:
    """``scenario`` with ``overrides`` merged in; ``ReplayError`` naming ``where`` (the config file)
    and the field for an unknown section or field or a wrong value."""
    unknown = set(overrides) - set(OVERRIDE_SECTIONS)
    if unknown:
        raise ReplayError(f"{where}: unknown section(s) {', '.join(sorted(map(str, unknown)))}; "
                          f"expected {', '.join(OVERRIDE_SECTIONS)}")
    if not overrides:
        return scenario
    bad = next((k for k, v in overrides.items() if not isinstance(v, dict)), None)
    if bad is not None:
        raise ReplayError(f"{where}: {bad}: expected a mapping of settings, got {type(overrides[bad]).__name__}")
    data = scenario.model_dump(mode="json")
    for key in ("tracker", "estimator"):
        if key in overrides:
            data["perception"][key] = deep_merge(data["perception"].get(key) or {}, overrides[key])
    if "intent" in overrides:
        data["intent"] = deep_merge(data.get("intent") or {}, overrides["intent"])
    if "alerts" in overrides:
        data["alerts"] = deep_merge(data.get("alerts") or {}, overrides["alerts"])
    try:
        return Scenario.model_validate(data)
    except ValidationError as e:
        raise ReplayError(format_validation(where, e, drop=("perception",))) from None
    except (TypeError, ValueError) as e:  # a validator's own error
        raise ReplayError(f"{where}: {' '.join(str(e).split())}") from None


def is_suite_dir(path: Path) -> bool:
    return (Path(path) / SUMMARY_FILE).is_file() and not (Path(path) / TICKS_FILE).is_file()


def replay_suite(
    suite_dir: Path, out: Path, perturb: Perturbation | None = None, overrides: dict | None = None,
    progress=None, where: str = "replay overrides",
) -> dict:
    """Replay every run of a suite directory into ``out``; writes ``out/summary.json`` like
    ``lookahead suite`` (totals: ``tools.scoring.totals.suite_totals``)."""
    suite_dir, out = Path(suite_dir), Path(out)
    src = read_summary(suite_dir)
    runs = src.get("runs")
    if not isinstance(runs, dict) or not all(isinstance(r, dict) and isinstance(r.get("dir"), str)
                                             for r in runs.values()):
        raise ReplayError(f"{suite_dir / SUMMARY_FILE}: runs: expected a mapping of runs, each with its dir")
    prepare_dir(out)
    results = []
    for name, r in runs.items():
        res = replay_run(suite_dir / r["dir"], out / r["dir"], perturb, overrides, where=where)
        res["dir_name"] = r["dir"]
        results.append(res)
        if progress:
            progress(name)
    totals = suite_totals([r["frames"] for r in results], [r["metrics"] for r in results])
    summary = {
        "suite": src.get("suite"),
        "render": src.get("render"),
        "replay": {"source": str(suite_dir), "perturbation": (perturb or Perturbation()).model_dump()
                   if perturb is not None and perturb.active else None, "overrides": overrides or None},
        "runs": {r["name"]: {"dir": r["dir_name"], "summary": r["summary"], "metrics": r["metrics"],
                             "replay": r["replay"]} for r in results},
        "totals": totals,
    }
    write_summary(out, summary)
    return summary


def replay_command(
    source: Path, out: Path, perturb: Perturbation, config: Path | None = None, overrides: dict | None = None,
) -> dict:
    """CLI body: a run or a suite directory; ``config`` a YAML/JSON file of overrides (``overrides``:
    its content, already read by ``tools.runs.inputs.read_overrides``)."""
    if overrides is None and config is not None:
        overrides = read_overrides(config)
    where = str(config) if config is not None else "replay overrides"
    source = Path(source)
    if not source.exists():
        raise FileNotFoundError(f"{source}: no such run or suite directory")
    if is_suite_dir(source):
        return replay_suite(source, out, perturb, overrides, where=where)
    return replay_run(source, out, perturb, overrides, where=where)
