"""``lookahead watch``: the simulator's perception stack on real video (issue 32).

A source (``perception.sources.open_source``: video file, image folder, camera index, URL) is
read in its own thread (``CaptureThread``); each frame is undistorted when the calibration has
distortion (``perception.calibration.Undistorter``), becomes a ``Frame`` (``tick`` = frame
index, ``t`` = the source's time) and goes through the same ``PerceptionStack`` the simulator
runs (``intent.stack.build_stack``, the shipped ONNX detector or ``model``). Every frame is
handed, as a ``TickRecord`` shaped as the runner's with empty ground truth, to the same sinks
(run directory, SQLite store, annotated video).

* **Camera.** ``calibration`` (a calibration file); without one, a pinhole camera of ``fov``
  degrees (default 90) at the source's image size on the simulator's default mount
  (``sim.scenario.MountSpec``: x -1.5 m, y 0, height 1.4 m, pitch -2 deg). A frame whose size
  is not the calibration's is one ``SourceError`` line.
* **Ego speed.** ``perception.ego_speed.open_ego_speed(ego_speed)``. A frame without it
  (``--ego-speed`` not given, or a log that does not cover the frame) gets
  ``EgoOdometry(speed_known=False)``: the stack then works on relative motion only -- range,
  lateral position, closing speed and TTC stay; the ground-speed estimates (``ground_vx``,
  ``accel``, ``yaw_rate``: ``Estimator.NEEDS_EGO_SPEED``) are NaN, behaviours ``unknown``, the
  ego's corridor straight ahead, and risk and alerts come from the relative TTC and range alone
  (``intent.labels``). Each record's ``ego.speed_known`` says which, and the run's config
  (``ego_speed_available``) and summary (``frames_without_ego_speed``) say so for the run.
  Ego acceleration and yaw rate are always 0 (no source for them yet).
* **Run record.** The sinks take a "scenario" (name, seed, ``model_dump``): a watch passes a
  ``WatchConfig`` (source, calibration used, detector, ego speed), recorded where a scenario
  run records its scenario (``run.json`` ``scenario``, the store's ``runs.scenario``). Such a
  run directory has no ground truth: ``lookahead score`` summarises what the stack produced
  (``tools.scoring.observed``), or, for a simulated run's raw video, scores it against that
  run's ground truth (``score --truth``, ``tools.scoring.truth``).
* **Live configuration.** ``config`` (``--config``) is a YAML file of the thresholds that are
  safe to change between frames (``intent.live_config``: detector score and NMS IoU thresholds,
  intent overrides -- risk zones, distance and TTC thresholds, behaviours -- and the alerts'
  debounce). Missing or invalid at start: ``LiveConfigError`` (one line). The configuration in
  force at start is recorded in ``WatchConfig`` (``config_file``, ``config``; the defaults
  without a file). Before each frame ``ConfigWatcher.poll`` stats the file (its ``config``
  timing, ms); an edit is applied to the stack (``PerceptionStack.reconfigure``) from that frame
  on -- an edit made while frame k is processed applies to frame k+1 -- with one INFO line on
  the logger ``lookahead.tools.runs.watch.config`` and an entry in the summary's
  ``config_reloads`` (``{frame, t, changed: {setting: {from, to}}}``, ``frame`` the first frame
  it applied to). An invalid edit (YAML or schema error, a half-written or vanished file) is one
  warning line ``file:line: problem`` and the configuration in force stays (``config_rejected``
  counts them); the run goes on.
* **Latency and timing.** Each record's ``timings`` (ms) holds the stack's stages
  (``preprocess``, ``detect``, ``track``, ``estimate``, ``intent``), ``undistort``, ``config``
  (with a live configuration), ``sinks``, ``tick`` (the whole frame) and ``latency``: from the
  moment the capture thread read the frame (``CapturedFrame.captured_at``, ``time.monotonic``) to
  the moment the stack's alerts for it were ready -- so it includes the wait in the capture
  queue (a file source reads up to ``QUEUE_FRAMES`` ahead; a live source drops the oldest frame
  instead). The summary has ``latency_ms`` (``p50``, ``p95``, ``max``) and ``stage_ms`` (each
  timing's mean but ``latency``); the latencies are kept for the percentiles (8 bytes a frame).
* **Progress.** ``progress`` gets a ``WatchStatus`` after every frame (frames, rate, dropped
  frames, alerts, gaps and reconnects, the last latency, reloads), and once more when the
  source has ended by itself (not after ``max_frames`` or a signal), with its final gaps.
* **Durability.** Every frame is written to ``ticks.jsonl`` (flushed) and then committed to the
  store (``SqliteStore.flush`` at the end of each frame, not at the next one: a live source may
  pause for long), so after a SIGKILL the store holds exactly the frames of ``ticks.jsonl``, or
  all but its last line when the kill fell between the two writes; the video holds all but the
  encoder's queue.
* **Ending.** The source's end, ``max_frames``, SIGINT or SIGTERM (the handler only calls
  ``CaptureThread.stop``; the frame in hand is finished) end the run normally: every sink
  gets ``on_end`` and the run is complete (``interrupted`` and ``interrupted_by``, the signal's
  name, in the summary). An exception ends it incomplete (its ``error`` in the summary) and is
  re-raised.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from array import array
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import BaseModel, ConfigDict

from lookahead.intent.live_config import ConfigWatcher, LiveConfig
from lookahead.intent.stack import build_detector, build_stack
from lookahead.perception.calibration import CameraCalibration, Undistorter, load_calibration
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import DetectorSpec, PerceptionSpec, SettingsError, StackSpec
from lookahead.perception.ego_speed import NoSpeed, open_ego_speed
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.plugins import override_detector
from lookahead.perception.sources import (
    CaptureThread,
    ReconnectPolicy,
    SourceError,
    SourceGap,
    open_source,
)
from lookahead.perception.tracker import TrackState
from lookahead.sim.groundtruth import GroundTruth
from lookahead.sim.records import Sink, TickRecord
from lookahead.sim.scenario import MountSpec, mounted_camera

if TYPE_CHECKING:
    from lookahead.tools.sinks.narration import NarrationConfig

log = logging.getLogger(__name__)
config_log = log.getChild("config")  # one INFO line per applied reload (the CLI shows them)

DEFAULT_FOV = 90.0  # deg: the default camera's horizontal field of view (the simulator's default)
LIVE_FPS = 30.0  # frames/s: the tracker's time base for a live source that gives no frame rate
QUEUE_FRAMES = 2  # CaptureThread queue: a file is read this far ahead; a live source drops its oldest frame beyond it (latency <= 2 frames of waiting)
NO_SPEED_NOTE = (
    "no ego speed: ground speeds and behaviours are unavailable; range, closing speed, TTC, and risk "
    "and alerts from them, are relative to the ego"
)


class WatchConfig(BaseModel):
    """What a watch ran with; recorded where a scenario run records its scenario."""

    model_config = ConfigDict(extra="forbid")
    kind: str = "watch"
    name: str
    seed: int = 0
    source: str
    live: bool
    fps: float  # the stack's frame rate (frames/s): the source's, else LIVE_FPS
    fps_from_source: bool
    calibration_file: str | None
    camera_from: str  # how the camera was made (calibration file, or the default camera)
    calibration: dict  # the calibration used (the file's, or the default camera's)
    undistort: bool
    ego_speed: str | None
    ego_speed_available: bool
    ego_speed_note: str | None
    detector: dict
    stack: dict | None = None  # a stack plug-in in place of detector, tracker and estimator
    max_frames: int | None
    config_file: str | None = None  # the live configuration file (--config), re-read while running
    config: dict = {}  # the live configuration in force at start (intent.live_config.LiveConfig)


@dataclass(frozen=True)
class WatchStatus:
    """What ``watch``'s ``progress`` gets after every frame (and once when the source ends)."""

    frames: int  # frames done
    total: int | None  # frames the run will have at most (source_frames), None: unknown (live)
    t: float  # the last frame's source time (s)
    fps: float | None  # frames done per second of wall time so far
    dropped: int  # frames a live source dropped because the stack fell behind
    alerts: int  # alert events so far
    gaps: int  # live-source outages so far
    reconnects: int  # outages that ended in a reconnect
    latency_ms: float  # the last frame's capture-to-alert latency
    config_reloads: int  # live configuration edits applied
    config_rejected: int  # live configuration edits refused


def default_camera(width: int, height: int, fov: float = DEFAULT_FOV) -> CameraModel:
    """A pinhole camera of ``fov`` deg at ``width`` x ``height`` px on the simulator's default mount."""
    return mounted_camera(width, height, fov, MountSpec())


class _Interrupt:
    """SIGINT and SIGTERM -> ``capture.stop()`` while installed (main thread only); restores the
    old handlers. ``by`` is the first signal's name."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self, capture: CaptureThread) -> None:
        self.capture = capture
        self.fired = False
        self.by: str | None = None
        self._old: dict[int, Any] = {}

    def _handle(self, signum: int, frame: object) -> None:
        if not self.fired:
            self.by = signal.Signals(signum).name
        self.fired = True
        self.capture.stop()

    def __enter__(self) -> _Interrupt:
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()


def source_frames(src: Any, max_frames: int | None) -> int | None:
    """Frames the run will have at most: a file's or folder's frame count, capped by ``max_frames``
    (a live source: ``max_frames``); None when unknown."""
    n = None if src.live else getattr(src, "frame_count", None)
    if n is None and not src.live and hasattr(src, "paths"):
        n = len(src.paths)
    if n is None:
        return max_frames
    return n if max_frames is None else min(n, max_frames)


def gap_record(gap: SourceGap, opened_at: float) -> dict[str, Any]:
    """A live-source outage as the summary records it: ``after_index`` (the last frame before it),
    ``t_lost`` / ``t_resumed`` (s, on the frames' clock: since the source opened; None if it never
    resumed), ``duration_s``, and the raw ``lost_at`` / ``resumed_at`` (``time.monotonic``)."""
    def r(x: float | None) -> float | None:
        return None if x is None else round(x, 3)

    return {"after_index": gap.after_index, "t_lost": r(gap.lost_at - opened_at),
            "t_resumed": r(None if gap.resumed_at is None else gap.resumed_at - opened_at),
            "duration_s": r(gap.duration), "lost_at": r(gap.lost_at), "resumed_at": r(gap.resumed_at)}


def latency_summary(latency: array) -> dict[str, float | None]:
    """``{p50, p95, max}`` of capture-to-alert latencies (ms), None without frames."""
    if not len(latency):
        return {"p50": None, "p95": None, "max": None}
    a = np.frombuffer(latency, dtype=np.float64)
    p50, p95 = np.percentile(a, [50, 95])
    return {"p50": round(float(p50), 3), "p95": round(float(p95), 3), "max": round(float(a.max()), 3)}


def watch(
    source: str | int | Path,
    out: Path,
    calibration: Path | None = None,
    ego_speed: str | float | None = None,
    model: Path | None = None,
    video: Path | None = None,
    db: Path | None = None,
    max_frames: int | None = None,
    progress: Callable[[WatchStatus], None] | None = None,
    fov: float = DEFAULT_FOV,
    config: Path | None = None,
    reconnect: ReconnectPolicy | None = None,
    rerun_file: Path | None = None,
    rerun_live: bool = False,
    detector: str | None = None,
    stack: str | None = None,
    narration: NarrationConfig | None = None,
) -> dict:
    """Run the perception stack on ``source`` into the run directory ``out`` (and ``db`` /
    ``video``); returns the summary (module docstring). ``progress`` gets a ``WatchStatus``
    after every frame; ``config`` is the live configuration file (re-read while running);
    ``reconnect`` the backoff of a live source that drops (default ``ReconnectPolicy()``);
    ``rerun_file`` / ``rerun_live``: a rerun recording, to a file and/or a spawned viewer.
    ``detector``: gt is refused; onnx (default, ``model`` or the shipped one), hog, or a detector
    plug-in (``perception.plugins.override_detector``); ``stack``: a stack plug-in in place of
    detector, tracker and estimator (``intent.plugins.load_stack``, built at the first frame).

    Everything that can be checked before the first frame is (source, live configuration,
    calibration, ego speed, detector model, video path); the sinks are built on the first frame
    (the default camera needs its size), before anything is written.

    Raises:
        SourceError, LiveConfigError, CalibrationError, EgoSpeedError, ModelError, OutputError,
        StoreError: one line.
    """
    from lookahead.tools.sinks.rundir import RunDirWriter

    if max_frames is not None and max_frames < 1:
        raise ValueError(f"max_frames: expected >= 1, got {max_frames}")
    src = open_source(source, reconnect=reconnect)
    name = src.name
    try:
        watcher = ConfigWatcher(config) if config is not None else None
        live = watcher.config if watcher is not None else LiveConfig()
        cal = load_calibration(calibration) if calibration is not None else None
        speed = open_ego_speed(ego_speed)
        spec = watch_spec(live, detector, model, stack)
        frame_detector = None if stack is not None else build_detector(spec.detector, seed=0, render=True)
        if video is not None:
            from lookahead.tools.sinks.video import check_video_path

            check_video_path(video)
    except BaseException:
        src.close()
        raise
    capture = CaptureThread(src, maxsize=QUEUE_FRAMES)
    sinks: list[Sink] = []
    started: list[Sink] = []
    summary: dict[str, Any] = {"source": name, "frames": 0, "error": None}
    frames_no_speed = n_alerts = 0
    total = source_frames(src, max_frames)
    reloads: list[dict] = []
    latency = array("d")  # ms, per frame
    stage_sum: dict[str, float] = {}
    store = None
    confirmed: set[int] = set()
    t_first: float | None = None
    wall0 = time.perf_counter()
    with _Interrupt(capture) as interrupt:
        try:
            frames = iter(capture)
            first = next(frames, None)
            if first is None:
                raise SourceError(f"{name}: {'interrupted before the first frame' if interrupt.fired else 'no frames'}")
            h, w = first.image.shape[:2]
            if cal is not None:
                cam = cal.to_camera()
                how = f"calibration file {calibration}"
                if (cam.width, cam.height) != (w, h):
                    raise SourceError(f"{name}: frames are {w}x{h} px, the calibration {calibration} is "
                                      f"{cam.width}x{cam.height}")
            else:
                cam = default_camera(w, h, fov)
                m = MountSpec()
                how = (f"default: {fov:g} deg horizontal FOV at {w}x{h} px, the simulator's default mount "
                       f"(x {m.x} m, y {m.y} m, height {m.z} m, pitch {m.pitch} deg)")
            undistort = Undistorter(cam)
            camera = undistort.camera
            fps = src.fps or LIVE_FPS
            pipeline = build_stack(spec, camera, fps, intent=live.intent_config(), alerts=live.alerts,
                                   detector=frame_detector, render=True)
            if watcher is not None:
                watcher.apply = lambda new: pipeline.reconfigure(**new.stack_settings())
            no_speed = isinstance(speed, NoSpeed)
            run_config = WatchConfig(
                name=f"watch {name}", source=name, live=src.live, fps=fps, fps_from_source=src.fps is not None,
                calibration_file=None if calibration is None else str(calibration), camera_from=how,
                calibration=CameraCalibration.from_camera(cam).model_dump(mode="json", exclude_none=True),
                undistort=not undistort.identity, ego_speed=None if ego_speed is None else str(ego_speed),
                ego_speed_available=not no_speed, ego_speed_note=NO_SPEED_NOTE if no_speed else None,
                detector=spec.detector.model_dump(mode="json", exclude={"noise"}) | {"model": detector_model(spec)},
                stack=None if spec.stack is None else spec.stack.model_dump(mode="json"),
                max_frames=max_frames, config_file=None if config is None else str(config),
                config=live.model_dump(mode="json"),
            )
            sinks.append(RunDirWriter(out, run_config, source=name))  # type: ignore[arg-type]
            if db is not None:
                from lookahead.tools.sinks.store import SqliteStore

                store = SqliteStore(db, run_config, run_dir=out, source=name)  # type: ignore[arg-type]
                sinks.append(store)
            if video is not None:
                from lookahead.tools.sinks.video import VideoSink

                sinks.append(VideoSink(video, fps=fps))
            if rerun_file is not None or rerun_live:
                from lookahead.tools.sinks.rerun import RerunSink

                sinks.append(RerunSink(rerun_file, spawn=rerun_live))
            if narration is not None:
                from lookahead.tools.sinks.narration import NARRATION_FILE, NarrationSink

                sinks.append(NarrationSink(out / NARRATION_FILE, narration))
            info = {"scenario": run_config.name, "seed": 0, "ticks": None, "renderer": None, "camera": camera}
            for s in sinks:
                s.on_start(info)
                started.append(s)
            wall0 = time.perf_counter()

            def status() -> WatchStatus:
                n, elapsed = summary["frames"], time.perf_counter() - wall0
                return WatchStatus(
                    frames=n, total=total, t=summary["t_end"], fps=n / elapsed if elapsed > 0 else None,
                    dropped=capture.dropped, alerts=n_alerts, gaps=len(src.gaps),
                    reconnects=sum(g.resumed_at is not None for g in src.gaps), latency_ms=latency[-1],
                    config_reloads=len(reloads), config_rejected=0 if watcher is None else watcher.rejected,
                )

            captured = first
            while captured is not None:
                i = summary["frames"]
                t_start = time.perf_counter()
                timings: dict[str, float] = {}
                ch, cw = captured.image.shape[:2]
                if (cw, ch) != (camera.width, camera.height):
                    raise SourceError(f"{name}: frame {captured.index} is {cw}x{ch} px, the camera is "
                                      f"{camera.width}x{camera.height}")
                image = undistort(captured.image)
                timings["undistort"] = (time.perf_counter() - t_start) * 1e3
                if watcher is not None:
                    t0 = time.perf_counter()
                    changed = watcher.poll()
                    timings["config"] = (time.perf_counter() - t0) * 1e3
                    if changed:
                        reloads.append({"frame": i, "t": round(captured.t, 4), "changed": changed})
                        config_log.info("%s: reloaded from frame %d (t %.3f s): %s", config, i, captured.t,
                                        ", ".join(f"{k} {v['from']} -> {v['to']}" for k, v in changed.items()))
                v = speed.at(captured.t)
                if v is None:
                    frames_no_speed += 1
                odo = EgoOdometry(speed=0.0 if v is None else float(v), speed_known=v is not None)
                frame = Frame(tick=i, t=captured.t, camera=camera, odometry=odo, image=image, index=i)
                dets, tracks, est, assessment, alerts = pipeline.process(frame, None, timings)
                timings["latency"] = (time.monotonic() - captured.captured_at) * 1e3  # the alerts are ready
                latency.append(timings["latency"])
                confirmed.update(tracks.track_id[tracks.state == TrackState.CONFIRMED].tolist())
                n_alerts += len(alerts)
                ego = {**odo.to_dict(), "speed_known": odo.speed_known, "brake": None}
                record = TickRecord(
                    tick=i, frame_index=i, t=captured.t, ego=ego, frame=frame, ground_truth=GroundTruth.empty(),
                    detections=dets, tracks=tracks, estimates=est, assessments=assessment, alerts=alerts,
                    timings=timings,
                )
                t0 = time.perf_counter()
                for s in sinks:
                    s.on_tick(record)
                timings["sinks"] = (time.perf_counter() - t0) * 1e3
                timings["tick"] = (time.perf_counter() - t_start) * 1e3
                if store is not None:  # this frame committed now, not when the next one comes
                    store.flush()
                for k, ms in timings.items():
                    stage_sum[k] = stage_sum.get(k, 0.0) + ms
                if t_first is None:
                    t_first = captured.t
                summary["frames"] = i + 1
                summary["t_end"] = captured.t
                if progress is not None:
                    progress(status())
                if max_frames is not None and i + 1 >= max_frames:
                    capture.stop()
                    break
                captured = next(frames, None)
            if progress is not None and captured is None and not interrupt.fired:
                progress(status())  # the source ended: its last gap (a live source that gave up) is known now
        except BaseException as e:  # told to the sinks (an incomplete run), then re-raised
            summary["error"] = f"{type(e).__name__}: {e}".rstrip(": ")
            raise
        finally:
            capture.close()
            wall = time.perf_counter() - wall0
            n = summary["frames"]
            summary.update(
                fps=round(n / wall, 3) if n and wall > 0 else None,
                source_fps=src.fps,
                dropped=capture.dropped,
                gaps=[gap_record(g, getattr(src, "opened_at", 0.0)) for g in src.gaps],
                alerts=n_alerts,
                confirmed_tracks=len(confirmed),
                frames_without_ego_speed=frames_no_speed,
                interrupted=interrupt.fired,
                interrupted_by=interrupt.by,
                wall_s=round(wall, 3),
                latency_ms=latency_summary(latency),
                stage_ms={k: round(v / n, 3) for k, v in stage_sum.items() if k != "latency"} if n else {},
                config_reloads=reloads,
                config_rejected=0 if watcher is None else watcher.rejected,
            )
            for s in started:
                s.on_end(summary)
    log.info("watch %s: %d frames at %.1f fps", name, summary["frames"], summary["fps"] or 0.0)
    return summary


def watch_spec(live: LiveConfig, detector: str | None, model: Path | None, stack: str | None) -> PerceptionSpec:
    """The stack's settings: the live configuration's thresholds on the shipped ONNX detector, or
    ``model``, or ``detector`` (hog, a plug-in); ``stack`` a stack plug-in. ``SettingsError`` (one
    line) for the ground-truth detector (real video has no truth) or an unknown plug-in."""
    if detector is not None and detector.strip() == "gt":
        raise SettingsError("--detector gt: real video has no ground truth to detect from; use onnx, hog or a plug-in")
    base = DetectorSpec(kind="onnx", conf=live.detector.conf, iou=live.detector.iou)
    return PerceptionSpec(detector=override_detector(base, detector, model),
                          stack=None if stack is None else StackSpec(plugin=stack))


def detector_model(spec: PerceptionSpec) -> str:
    """What detects: the ONNX model file, ``hog``, the detector plug-in, or the stack plug-in."""
    from lookahead.intent.stack import resolve_detector

    if spec.stack is not None:
        return f"stack {spec.stack.plugin}"
    d = resolve_detector(spec.detector, render=True)
    return str(d.model) if d.kind == "onnx" else (d.plugin or d.kind)
