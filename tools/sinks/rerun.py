"""``RerunSink``: the closed loop as a Rerun recording (``.rrd`` file and/or a live viewer).

Timelines: ``sim_time`` (duration, s since scenario start) and ``frame`` (camera
frame index). Entities, all in the ego frame (ISO 8855: x forward, y left, z up):

* ``ego`` -- 3D bird's-eye space; ``ego/body`` the ego's outline (static).
* ``ego/camera`` -- the camera (mount transform + pinhole, static), with
  ``ego/camera/image`` (JPEG, or raw RGB with ``jpeg_quality=None``),
  ``ego/camera/gt`` (visible GT boxes), ``ego/camera/detections`` and
  ``ego/camera/tracks`` (2D boxes, XYXY, class ids + labels; tracks coloured by risk).
* ``ego/gt`` -- GT 3D boxes; ``ego/tracks`` -- estimated positions (range, lateral, 0)
  coloured by risk; ``ego/track_velocity`` -- their ground velocity (m/s, 1 s arrows).
* ``plots/range/{track_N,gt_NAME}``, ``plots/ttc/{...}`` (finite TTC up to
  ``TTC_PLOT_MAX`` only), ``plots/ego/{speed,brake}`` -- scalar time series,
  buffered and sent as columns every ``series_every`` frames and at the end
  (one call per series instead of one per value: the cheap path).
* ``alerts`` -- one text-log entry per alert event (CRITICAL / WARN / INFO);
  ``events`` -- collisions and the run summary.
* Cooperative runs (a record with ``cooperative``, ``sim.cooperation.cooperative_record``):
  ``ego/coop/fused`` -- the fused objects (points at 0.5 m, labels ``#track`` / ``rN`` for
  remote ids) coloured by source (own blue, other-only orange, both green; as
  ``tools.sinks.cooperative_view``) and ``ego/coop/fused_cov`` their 2-sigma position
  covariance as flat ellipsoids; ``ego/coop/received/<sender>`` -- each message's objects in
  the ego frame in the sender's colour (the ones fusion dropped as the ego itself grey,
  labelled ``self``); ``ego/coop/senders/<sender>`` -- the sender's pose as it reported it, in
  the ego frame, as a transform with a 5 m arrow along its heading (x) and its name; a
  rendered sender's camera (pinhole) and image under it, ``.../camera/image``.

Memory stays flat in run length: the ``.rrd`` is written without rerun's footer
(``write_footer=False``; rerun keeps every chunk's manifest entry in memory until the
footer is written at the end, about 13 KB per frame here), and the scalar series are
sent every ``series_every`` frames. A footerless file is a valid RRD (the viewer, and
``rerun.chunk.RrdReader(path).stream()``, read it whole; a killed run's file is one
too); ``rerun rrd optimize`` adds the manifest afterwards, and ``footer=True`` writes
it (for short runs).

Needs rerun-sdk >= 0.23 (``rr.Scalars``, ``set_time(duration=...)``); ``write_footer``
needs a recent one (tested with 0.41; older ones are called without it).
Class ids follow ``perception.detections.CLASSES`` (obstacles included); class id -1, which
runs recorded before obstacles were a detection class carry for them, is ``OBSTACLE_CLASS``
(an annotation context names and colours them all).
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from lookahead.intent.labels import LABEL_NAMES, RISK_COLOURS, Label, Risk
from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import CLASSES
from lookahead.sim.records import TickRecord
from lookahead.tools.sinks import cooperative_view as cv
from lookahead.tools.sinks.draw import CLASS_COLOURS
from lookahead.tools.sinks.rundir import OutputError

log = logging.getLogger(__name__)

OBSTACLE_CLASS = 255
TTC_PLOT_MAX = 10.0  # s; larger (or infinite) TTCs are not plotted
EGO_BODY = (4.6, 1.85, 1.5)  # m, indicative length, width, height (the ego's front bumper is at x = 0)
_LEVELS = {"critical": "CRITICAL", "fcw": "WARN", "downgrade": "WARN", "clear": "INFO"}
_RISK_RGB = np.asarray(RISK_COLOURS, dtype=np.uint8)



@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence C-level stderr (rerun's Rust log warns, on stderr, when a file has no footer)."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def _file_sink(path: Path, footer: bool) -> rr.FileSink:
    try:
        return rr.FileSink(str(path), write_footer=footer)
    except TypeError:  # pragma: no cover - a rerun-sdk without the option (it writes a footer)
        return rr.FileSink(str(path))


def _class_ids(cid: np.ndarray) -> np.ndarray:
    cid = np.asarray(cid, dtype=np.int64)
    return np.where((cid >= 0) & (cid < len(CLASSES)), cid, OBSTACLE_CLASS).astype(np.uint16)


def _class_names(cid: np.ndarray) -> list[str]:
    return [CLASSES[c] if 0 <= c < len(CLASSES) else "obstacle" for c in np.asarray(cid).tolist()]


def default_blueprint() -> rrb.Blueprint:
    """Camera with boxes | bird's-eye 3D ; range and TTC plots, alerts."""
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(
                rrb.Spatial2DView(origin="ego/camera", name="camera"),
                rrb.Spatial3DView(origin="ego", name="bird's-eye (ego frame)"),
            ),
            rrb.Horizontal(
                rrb.TimeSeriesView(origin="plots/range", name="range (m)"),
                rrb.TimeSeriesView(origin="plots/ttc", name="TTC (s)"),
                rrb.TextLogView(origin="alerts", name="alerts"),
            ),
            row_shares=[3, 2],
        ),
        collapse_panels=True,
    )


class RerunSink:
    """A runner sink logging every frame to a dedicated ``rr.RecordingStream``.

    ``path``: ``.rrd`` file to write (None: none); ``spawn``: also stream to a
    newly spawned viewer. ``jpeg_quality``: images are JPEG-encoded at this
    quality (about 3x smaller .rrd than raw RGB, which Rerun LZ4-compresses), None logs raw RGB.
    ``footer``: write rerun's footer (chunk manifest) at the end; it costs memory that grows
    with the run (see the module doc), so it is off by default.
    """

    def __init__(
        self, path: Path | None = None, spawn: bool = False, app_id: str = "lookahead",
        jpeg_quality: int | None = 85, recording_id: str | None = None, series_every: int = 10,
        footer: bool = False,
    ) -> None:
        if path is None and not spawn:
            raise ValueError("RerunSink: give a path, spawn=True, or both")
        self.path = None if path is None else Path(path)
        self.jpeg_quality = jpeg_quality
        self.rec = rr.RecordingStream(app_id, recording_id=recording_id)
        blueprint = default_blueprint()
        if spawn and self.path is None:
            self.rec.spawn(default_blueprint=blueprint)
        else:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                sinks = [_file_sink(self.path, footer)]
                if spawn:
                    rr.spawn(connect=False)
                    sinks.append(rr.GrpcSink())
                with contextlib.nullcontext() if footer else _quiet_stderr():
                    self.rec.set_sinks(*sinks, default_blueprint=blueprint)
            except (OSError, RuntimeError) as e:
                raise OutputError(f"{self.path}: cannot write the Rerun recording ({e})") from None
        self._camera_logged = False
        self._sender_cameras: set[str] = set()  # rendered senders whose camera is logged
        self.frames = 0
        self.series_every = max(1, int(series_every))
        self._series: dict[str, tuple[list[float], list[int], list[float]]] = {}
        self._now = (0.0, 0)

    # -- sink protocol
    def on_start(self, info: dict) -> None:
        rec = self.rec
        name = info.get("scenario")
        if name:
            rec.send_recording_name(f"{name} (seed {info.get('seed')})")
        classes = [rr.AnnotationInfo(id=i, label=n, color=CLASS_COLOURS.get(n, (255, 255, 255)))
                   for i, n in enumerate(CLASSES)]
        classes.append(rr.AnnotationInfo(id=OBSTACLE_CLASS, label="obstacle", color=CLASS_COLOURS["obstacle"]))
        rec.log("/", rr.AnnotationContext(classes), static=True)
        rec.log("ego", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        ln, _, ht = EGO_BODY
        rec.log("ego/body", rr.Boxes3D(centers=[(-ln / 2, 0.0, ht / 2)], sizes=[EGO_BODY], labels=["ego"],
                                       colors=[(200, 200, 200)]), static=True)

    def _log_camera(self, cam: CameraModel) -> None:
        self.rec.log("ego/camera", rr.Transform3D(translation=cam.mount, mat3x3=cam.R_cam_from_ego.T), static=True)
        self.rec.log("ego/camera", rr.Pinhole(image_from_camera=cam.K, resolution=[cam.width, cam.height],
                                              camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=2.0),
                     static=True)
        self._camera_logged = True

    def on_tick(self, record: TickRecord) -> None:
        rec = self.rec
        rec.set_time("frame", sequence=record.frame_index)
        rec.set_time("sim_time", duration=record.t)
        self._now = (float(record.t), int(record.frame_index))
        frame = record.frame
        if not self._camera_logged:
            self._log_camera(frame.camera)
        if frame.image is not None:
            rec.log("ego/camera/image", self._image(frame.image))
        self._log_ground_truth(record)
        self._log_detections(record)
        self._log_tracks(record)
        if getattr(record, "cooperative", None) is not None:
            self._log_cooperative(record)
        ego = record.ego
        self._scalar("plots/ego/speed", float(ego.get("speed", np.nan)))
        self._scalar("plots/ego/brake", float(ego.get("brake") or 0.0))
        for al in record.alerts:
            rec.log("alerts", rr.TextLog(f"t={al.t:.2f}s #{al.track_id} {al.kind}: {al.reason}",
                                         level=_LEVELS.get(al.kind, "INFO")))
        for c in record.collisions:
            rec.log("events", rr.TextLog(f"t={c.t:.2f}s collision with {c.name} ({c.cls}), "
                                         f"relative speed {c.relative_speed:.1f} m/s", level="CRITICAL"))
        self.frames += 1
        if self.frames % self.series_every == 0:
            self._flush_series()

    def on_end(self, summary: dict) -> None:
        self.rec.log("events", rr.TextLog(f"run ended: {summary}", level="INFO"))
        self.close()

    def close(self) -> None:
        """Flush and finalise the recording (the .rrd footer is written); a viewer that went away
        is logged, not raised, so the run still ends cleanly."""
        self._flush_series()
        try:
            self.rec.flush()
        except RuntimeError as e:
            log.warning("rerun: could not flush every sink (%s)", e)
        self.rec.disconnect()

    # -- pieces
    def _scalar(self, path: str, value: float) -> None:
        ts, fs, vs = self._series.setdefault(path, ([], [], []))
        ts.append(self._now[0])
        fs.append(self._now[1])
        vs.append(value)

    def _flush_series(self) -> None:
        for path, (ts, fs, vs) in self._series.items():
            if vs:
                self.rec.send_columns(path, indexes=[rr.TimeColumn("sim_time", duration=ts),
                                                     rr.TimeColumn("frame", sequence=fs)],
                                      columns=rr.Scalars.columns(scalars=vs))
        self._series.clear()

    def _image(self, img: np.ndarray) -> rr.AsComponents:
        if self.jpeg_quality is None:
            return rr.Image(img, color_model="RGB")
        ok, buf = cv2.imencode(".jpg", cv2.cvtColor(img, cv2.COLOR_RGB2BGR),
                               [cv2.IMWRITE_JPEG_QUALITY, int(self.jpeg_quality)])
        if not ok:
            return rr.Image(img, color_model="RGB")
        return rr.EncodedImage(contents=buf.tobytes(), media_type="image/jpeg")

    def _log_ground_truth(self, record: TickRecord) -> None:
        gt = record.ground_truth
        rec = self.rec
        vis = gt.visible
        seen = np.all(np.isfinite(vis), axis=1) & (gt.visible_fraction > 0)
        names = np.asarray(gt.name, dtype=object)
        rec.log("ego/camera/gt", rr.Boxes2D(array=vis[seen], array_format=rr.Box2DFormat.XYXY,
                                            class_ids=_class_ids(gt.class_id[seen]),
                                            labels=[f"gt {n}" for n in names[seen]], show_labels=False))
        b = gt.box3d
        yaw = b[:, 6]
        quat = np.stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)], axis=1)
        rec.log("ego/gt", rr.Boxes3D(centers=b[:, :3], sizes=b[:, 3:6], quaternions=quat,
                                     class_ids=_class_ids(gt.class_id), labels=list(gt.name)))
        for name, r, ttc in zip(gt.name, gt.range.tolist(), gt.ttc.tolist(), strict=True):
            name = rr.escape_entity_path_part(name)
            self._scalar(f"plots/range/gt_{name}", r)
            if np.isfinite(ttc) and ttc <= TTC_PLOT_MAX:
                self._scalar(f"plots/ttc/gt_{name}", ttc)

    def _log_detections(self, record: TickRecord) -> None:
        d = record.detections
        self.rec.log("ego/camera/detections", rr.Boxes2D(
            array=d.xyxy, array_format=rr.Box2DFormat.XYXY, class_ids=_class_ids(d.class_id),
            labels=[f"{s:.2f}" for s in d.score.tolist()], show_labels=False, radii=0.5))

    def _log_tracks(self, record: TickRecord) -> None:
        tr, est, a = record.tracks, record.estimates, record.assessments
        rec = self.rec
        if tr is None:
            return
        ids = tr.track_id.tolist()
        risk = np.clip(a.risk.astype(np.int64), 0, len(RISK_COLOURS) - 1) if a is not None else np.zeros(len(ids), int)
        colours = _RISK_RGB[risk]
        labels = [f"#{i} {c} {LABEL_NAMES[Label(int(lab))]} {Risk(int(r)).name}"
                  for i, c, lab, r in zip(ids, _class_names(tr.class_id), a.label.tolist(), risk.tolist(), strict=True)]
        rec.log("ego/camera/tracks", rr.Boxes2D(array=tr.xyxy, array_format=rr.Box2DFormat.XYXY,
                                                class_ids=_class_ids(tr.class_id), colors=colours, labels=labels))
        if est is None:
            return
        pos = np.stack([est.range, est.lateral, np.zeros(len(ids))], axis=1)
        ok = np.all(np.isfinite(pos), axis=1)
        rec.log("ego/tracks", rr.Points3D(pos[ok], colors=colours[ok], radii=0.35,
                                          labels=[f"#{i}" for i, k in zip(ids, ok.tolist(), strict=True) if k],
                                          class_ids=_class_ids(tr.class_id[ok])))
        vel = np.stack([est.ground_vx, est.ground_vy, np.zeros(len(ids))], axis=1)
        okv = ok & np.all(np.isfinite(vel), axis=1)
        rec.log("ego/track_velocity", rr.Arrows3D(origins=pos[okv], vectors=vel[okv], colors=colours[okv]))
        ttc = a.ttc if a is not None else est.ttc
        for i, r, t in zip(ids, est.range.tolist(), ttc.tolist(), strict=True):
            if np.isfinite(r):
                self._scalar(f"plots/range/track_{i}", r)
            if np.isfinite(t) and t <= TTC_PLOT_MAX:
                self._scalar(f"plots/ttc/track_{i}", t)

    def _log_cooperative(self, record: TickRecord) -> None:
        f = cv.CoopFrame.of(record)
        rec = self.rec
        colours = cv.sender_colours(f)
        fu = f.fused()
        n = len(fu["id"])
        pos = np.column_stack([fu["xy"], np.full(n, 0.5)])
        src_rgb = np.array([cv.SOURCE_COLOURS.get(int(k), (255, 255, 255)) for k in fu["source"].tolist()],
                           np.uint8).reshape(-1, 3)
        labels = [f"{cv.id_label(i)} {cv.SOURCE_NAMES.get(int(k), '?')}"
                  for i, k in zip(fu["id"].tolist(), fu["source"].tolist(), strict=True)]
        rec.log("ego/coop/fused", rr.Points3D(pos, colors=src_rgb, radii=0.45, labels=labels))
        ok = np.all(np.isfinite(fu["cov"]), axis=1)
        half, quat = [], []
        for c in fu["cov"][ok]:
            vals, vecs = np.linalg.eigh(np.array([[c[0], c[1]], [c[1], c[2]]]))
            half.append((*(2.0 * np.sqrt(np.clip(vals, 0.0, None))), 0.05))
            yaw = float(np.arctan2(vecs[1, 0], vecs[0, 0]))  # the first axis' direction
            quat.append((0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)))
        rec.log("ego/coop/fused_cov", rr.Ellipsoids3D(centers=pos[ok], half_sizes=np.reshape(half, (-1, 3)),
                                                      quaternions=np.reshape(quat, (-1, 4)), colors=src_rgb[ok]))
        for m in f.received():
            k = len(m["id"])
            drop = m["fused_id"] < 0
            rgb = np.where(drop[:, None], np.array(cv.SELF_DROP, np.uint8), np.array(colours[m["sender"]], np.uint8))
            lab = ["self" if d else f"{m['sender']} {i}" for i, d in zip(m["id"].tolist(), drop.tolist(), strict=True)]
            rec.log(f"ego/coop/received/{rr.escape_entity_path_part(m['sender'])}",
                    rr.Points3D(np.column_stack([m["xy"], np.full(k, 0.3)]), colors=rgb.reshape(-1, 3), radii=0.3,
                                labels=lab))
        for s in f.senders():
            pose = s["reported_pose"]
            x, y = cv.to_frame(np.array(pose[:2])[None], f.ego_pose)[0]
            path = f"ego/coop/senders/{rr.escape_entity_path_part(s['name'])}"
            rec.log(path, rr.Transform3D(translation=(float(x), float(y), 0.0),
                                         rotation=rr.RotationAxisAngle(axis=(0.0, 0.0, 1.0),
                                                                       radians=float(pose[2] - f.ego_pose[2]))))
            rec.log(path, rr.Arrows3D(origins=[(0.0, 0.0, 1.0)], vectors=[(5.0, 0.0, 0.0)],
                                      colors=[colours[s["name"]]], labels=[s["name"]], radii=0.15))
            frame = getattr(record, "sender_frames", {}).get(s["name"])
            if frame is not None and frame.image is not None:  # a rendered sender: its camera and image
                cam = frame.camera
                if s["name"] not in self._sender_cameras:
                    self._sender_cameras.add(s["name"])
                    rec.log(f"{path}/camera", rr.Transform3D(translation=cam.mount, mat3x3=cam.R_cam_from_ego.T),
                            static=True)
                    rec.log(f"{path}/camera", rr.Pinhole(image_from_camera=cam.K, resolution=[cam.width, cam.height],
                                                         camera_xyz=rr.ViewCoordinates.RDF), static=True)
                rec.log(f"{path}/camera/image", self._image(frame.image))
