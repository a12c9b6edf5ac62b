"""``lookahead watch``: the simulator's perception stack on real video (first slice, issue 32).

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
* **Ego speed.** ``perception.ego_speed.open_ego_speed(ego_speed)``. The stack is handed the
  speed, or 0.0 when none is known (``--ego-speed`` not given, or a log that does not cover
  the frame): each record's ``ego.speed_known`` says which, and the run's config
  (``ego_speed_available``) and summary (``frames_without_ego_speed``) say so for the run.
  Without ego speed, everything that depends on it -- ground speed of tracks, behaviour,
  in-path prediction, TTC, risk and therefore alerts -- is computed as if the ego stood still
  and is **not meaningful**; marking those estimates unavailable in the stack is a later slice.
  Ego acceleration and yaw rate are always 0 (no source for them yet).
* **Run record.** The sinks take a "scenario" (name, seed, ``model_dump``): a watch passes a
  ``WatchConfig`` (source, calibration used, detector, ego speed), recorded where a scenario
  run records its scenario (``run.json`` ``scenario``, the store's ``runs.scenario``). Such a
  run directory has no ground truth, so it cannot be scored or replayed.
* **Ending.** The source's end, ``max_frames``, or SIGINT (the handler only calls
  ``CaptureThread.stop``; the frame in hand is finished) end the run normally: every sink
  gets ``on_end`` and the run is complete (``interrupted`` in the summary). An exception ends
  it incomplete (its ``error`` in the summary) and is re-raised.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict

from lookahead.intent.stack import build_detector, build_stack
from lookahead.perception.calibration import CameraCalibration, Undistorter, load_calibration
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import DetectorSpec, PerceptionSpec
from lookahead.perception.ego_speed import NoSpeed, open_ego_speed
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.sources import CaptureThread, SourceError, open_source
from lookahead.perception.tracker import TrackState
from lookahead.sim.groundtruth import GroundTruth
from lookahead.sim.records import Sink, TickRecord
from lookahead.sim.scenario import MountSpec, mounted_camera

log = logging.getLogger(__name__)

DEFAULT_FOV = 90.0  # deg: the default camera's horizontal field of view (the simulator's default)
LIVE_FPS = 30.0  # frames/s: the tracker's time base for a live source that gives no frame rate
QUEUE_FRAMES = 4  # CaptureThread queue (a live source drops its oldest frame beyond it)
NO_SPEED_NOTE = (
    "no ego speed: the stack ran with ego speed 0; ground speeds, behaviours, in-path, TTC, risk "
    "and alerts that depend on the ego's motion are not meaningful"
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
    camera: str  # how the camera was made
    calibration: dict  # the calibration used (the file's, or the default camera's)
    undistort: bool
    ego_speed: str | None
    ego_speed_available: bool
    ego_speed_note: str | None
    detector: dict
    max_frames: int | None


def empty_ground_truth() -> GroundTruth:
    """Ground truth of a frame without any (real video)."""
    f = np.zeros(0)
    i = np.zeros(0, dtype=np.int64)
    return GroundTruth(
        actor_id=i, name=[], cls=[], subtype=[], class_id=i, box3d=np.zeros((0, 7)), velocity=np.zeros((0, 2)),
        amodal=np.zeros((0, 4)), projected=np.zeros((0, 4)), visible=np.zeros((0, 4)), visible_fraction=f,
        pixels=i, truncation=f, range=f, lateral=f, range_rate=f, lateral_rate=f, accel=f, yaw_rate=f, ttc=f,
        in_path=np.zeros(0, dtype=bool), label=i, behaviour=i, risk=i,
    )


def default_camera(width: int, height: int, fov: float = DEFAULT_FOV) -> CameraModel:
    """A pinhole camera of ``fov`` deg at ``width`` x ``height`` px on the simulator's default mount."""
    return mounted_camera(width, height, fov, MountSpec())


class _Interrupt:
    """SIGINT -> ``capture.stop()`` while installed (main thread only); restores the old handler."""

    def __init__(self, capture: CaptureThread) -> None:
        self.capture = capture
        self.fired = False
        self._old: Any = None
        self._installed = False

    def _handle(self, signum: int, frame: object) -> None:
        self.fired = True
        self.capture.stop()

    def __enter__(self) -> _Interrupt:
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._handle)
            self._installed = True
        return self

    def __exit__(self, *exc: object) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._old)


def watch(
    source: str | int | Path,
    out: Path,
    calibration: Path | None = None,
    ego_speed: str | float | None = None,
    model: Path | None = None,
    video: Path | None = None,
    db: Path | None = None,
    max_frames: int | None = None,
    progress: Callable[[int], None] | None = None,
    fov: float = DEFAULT_FOV,
) -> dict:
    """Run the perception stack on ``source`` into the run directory ``out`` (and ``db`` /
    ``video``); returns the summary (module docstring). ``progress`` gets the frame count after
    every frame.

    Everything that can be checked before the first frame is (source, calibration, ego speed,
    detector model, video path); the sinks are built on the first frame (the default camera
    needs its size), before anything is written.

    Raises:
        SourceError, CalibrationError, EgoSpeedError, ModelError, OutputError, StoreError: one line.
    """
    from lookahead.tools.sinks.rundir import RunDirWriter

    if max_frames is not None and max_frames < 1:
        raise ValueError(f"max_frames: expected >= 1, got {max_frames}")
    src = open_source(source)
    name = src.name
    try:
        cal = load_calibration(calibration) if calibration is not None else None
        speed = open_ego_speed(ego_speed)
        spec = PerceptionSpec(detector=DetectorSpec(kind="onnx", model=None if model is None else str(model)))
        detector = build_detector(spec.detector, seed=0, render=True)
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
            stack = build_stack(spec, camera, fps, detector=detector, render=True)
            no_speed = isinstance(speed, NoSpeed)
            config = WatchConfig(
                name=f"watch {name}", source=name, live=src.live, fps=fps, fps_from_source=src.fps is not None,
                calibration_file=None if calibration is None else str(calibration), camera=how,
                calibration=CameraCalibration.from_camera(cam).model_dump(mode="json", exclude_none=True),
                undistort=not undistort.identity, ego_speed=None if ego_speed is None else str(ego_speed),
                ego_speed_available=not no_speed, ego_speed_note=NO_SPEED_NOTE if no_speed else None,
                detector=spec.detector.model_dump(mode="json", exclude={"noise"}) | {"model": detector_model(spec)},
                max_frames=max_frames,
            )
            sinks.append(RunDirWriter(out, config, source=name))  # type: ignore[arg-type]
            if db is not None:
                from lookahead.tools.sinks.store import SqliteStore

                sinks.append(SqliteStore(db, config, run_dir=out, source=name))  # type: ignore[arg-type]
            if video is not None:
                from lookahead.tools.sinks.video import VideoSink

                sinks.append(VideoSink(video, fps=fps))
            info = {"scenario": config.name, "seed": 0, "ticks": None, "renderer": None, "camera": camera}
            for s in sinks:
                s.on_start(info)
                started.append(s)
            wall0 = time.perf_counter()
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
                v = speed.at(captured.t)
                if v is None:
                    frames_no_speed += 1
                odo = EgoOdometry(speed=0.0 if v is None else float(v))
                frame = Frame(tick=i, t=captured.t, camera=camera, odometry=odo, image=image, index=i)
                dets, tracks, est, assessment, alerts = stack.process(frame, None, timings)
                confirmed.update(tracks.track_id[tracks.state == TrackState.CONFIRMED].tolist())
                n_alerts += len(alerts)
                ego = {**odo.to_dict(), "speed_known": v is not None, "brake": None}
                record = TickRecord(
                    tick=i, frame_index=i, t=captured.t, ego=ego, frame=frame, ground_truth=empty_ground_truth(),
                    detections=dets, tracks=tracks, estimates=est, assessments=assessment, alerts=alerts,
                    timings=timings,
                )
                t0 = time.perf_counter()
                for s in sinks:
                    s.on_tick(record)
                timings["sinks"] = (time.perf_counter() - t0) * 1e3
                timings["tick"] = (time.perf_counter() - t_start) * 1e3
                if t_first is None:
                    t_first = captured.t
                summary["frames"] = i + 1
                summary["t_end"] = captured.t
                if progress is not None:
                    progress(i + 1)
                if max_frames is not None and i + 1 >= max_frames:
                    capture.stop()
                    break
                captured = next(frames, None)
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
                gaps=[{"after_index": g.after_index, "lost_at": round(g.lost_at, 3),
                       "resumed_at": None if g.resumed_at is None else round(g.resumed_at, 3)} for g in src.gaps],
                alerts=n_alerts,
                confirmed_tracks=len(confirmed),
                frames_without_ego_speed=frames_no_speed,
                interrupted=interrupt.fired,
                wall_s=round(wall, 3),
            )
            for s in started:
                s.on_end(summary)
    log.info("watch %s: %d frames at %.1f fps", name, summary["frames"], summary["fps"] or 0.0)
    return summary


def detector_model(spec: PerceptionSpec) -> str:
    """The model file the stack's ONNX detector loads."""
    from lookahead.intent.stack import resolve_detector

    return str(resolve_detector(spec.detector, render=True).model)
