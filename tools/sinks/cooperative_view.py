"""Pictures of cooperative perception: what the ego saw, what others sent, what fusion made of it.

The fourth source design's fusion visualiser (a 2x2 figure: own / other / fused detections and
the lines between matched pairs, plus a global map), drawn with OpenCV from a tick record's
``cooperative`` entry (``sim.cooperation.cooperative_record``), so it runs per frame:

* ``panels`` -- four bird's-eye panels of the ego frame (x forward up the image, y left to the
  left, ``PANEL_PX_PER_M`` px/m, ``PANEL_X`` m ahead/behind and ``PANEL_Y`` m each side, the same
  scale in every frame): (1) the ego's own objects; (2) the received objects in the ego frame,
  coloured by sender, the ones fusion dropped as a detection of the ego itself crossed out
  (``self``), each sender's reported pose as a triangle; (3) the fused objects coloured by
  source (own / other / both) with their 2-sigma covariance ellipses, a red ring on the ones an
  alert names this frame; (4) own and received objects with a line between each matched pair
  (a received object to the own object, or an earlier sender's object, it joined). Every panel
  shows the ground-truth actors' footprints (``box3d``) as faint outlines, the ego's footprint
  (``EGO_SIZE``, front bumper at the origin), grid lines every 10 m and a title with the frame
  time, the newest message's age and the counts.
* ``global map`` -- the world frame (x right, y up, ``MAP_PX_PER_M`` px/m): the ego's and every
  sender's (true) trajectory so far, their current poses with the camera's field of view as a
  wedge (``cameras``: field of view and mount yaw per camera; a ray without), the fused objects
  placed in the world (the ego's pose + their ego-frame position, source colours) and the
  ground-truth footprints. The window keeps its scale; it is centred on the ego and the senders
  at the first frame and re-centred only when the ego nears its edge.

``CooperativeVideoSink`` writes the composite (2x2 left, map right) as an MP4 of one frame per
camera frame with a ``cooperative`` entry (the annotated video's format and writer,
``tools.sinks.video.open_mp4_writer``: Motion-JPEG in fragmented MP4, each frame written as it
comes, so a killed run's file plays up to its last frame) and, into the run directory's ``cooperative/``, the key
frame as ``panels.png`` and ``map.png`` with ``key_frame.json`` (frame, t, why): the first frame
an alert names an object only others see (a remote id), else the middle frame of the run. To
know the middle of a run that may end early (a collision), the sink keeps the records of the
second half seen so far (a few KB each) until a remote alert makes them unnecessary.

Works on live ``TickRecord`` objects and on ``ticks.jsonl`` lines alike (``CoopFrame.of``).
"""

from __future__ import annotations

import json
import logging
import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from lookahead.perception.cooperative import REMOTE_ID_BASE
from lookahead.perception.geometry import box_corners
from lookahead.sim.layout import ego_frame
from lookahead.tools.sinks.draw import save_rgb
from lookahead.tools.sinks.rundir import OutputError, prepare_dir
from lookahead.tools.sinks.video import (
    JPEG_QUALITY,
    FragmentedMjpegWriter,
    check_video_path,
    open_mp4_writer,
)

log = logging.getLogger(__name__)

PANEL_PX_PER_M = 7.0
PANEL_X = (-10.0, 50.0)  # m, ego frame: behind .. ahead (the design's plot range: 50 m)
PANEL_Y = 20.0  # m each side
TITLE_H = 40  # px above each panel's plot
MAP_PX_PER_M = 6.0
MAP_WIDTH = 360  # px; its height is the panels'
MAP_HEAD = 58  # px: title and legend
EGO_SIZE = (4.6, 1.85)  # m, indicative length and width (front bumper at x = 0), as in the rerun sink
SENDER_SIZE = (4.5, 1.8)
FOV_RAY_M = 40.0  # length of a camera's field-of-view wedge on the map
SUBDIR = "cooperative"
PANELS_PNG, MAP_PNG, KEY_FRAME_JSON = "panels.png", "map.png", "key_frame.json"

BG, GRID, GRID_TEXT, GT_OUTLINE = (22, 24, 28), (52, 56, 62), (120, 124, 130), (110, 114, 120)
TEXT, MUTED, EGO_FILL = (235, 235, 235), (160, 164, 170), (200, 200, 200)
SOURCE_COLOURS = {0: (66, 153, 255), 1: (255, 152, 0), 2: (60, 200, 100)}  # own, other-only, both (RGB)
SOURCE_NAMES = {0: "own", 1: "other", 2: "both"}
OWN = SOURCE_COLOURS[0]
SENDER_COLOURS = ((255, 152, 0), (220, 90, 230), (0, 210, 210), (250, 230, 60), (255, 110, 110), (160, 230, 120))
SELF_DROP = (150, 150, 150)
ALERT = (255, 40, 40)
FONT = cv2.FONT_HERSHEY_SIMPLEX


def _get(obj, key: str, default=None):
    if obj is None:
        return default
    if isinstance(obj, dict):
        return obj.get(key, default)
    return getattr(obj, key, default)


def _xy(a) -> np.ndarray:
    a = np.asarray(a if a is not None else [], dtype=float)
    return a.reshape(-1, 2) if a.size else np.zeros((0, 2))


def _ints(a) -> np.ndarray:
    return np.asarray(a if a is not None else [], dtype=np.int64).reshape(-1)


def id_label(i: int) -> str:
    """``#3`` for the ego's track 3, ``r1`` for remote id 1_000_001 (an object only others see)."""
    return f"r{i - REMOTE_ID_BASE}" if i >= REMOTE_ID_BASE else f"#{i}"


def rotate(xy: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """Points of a frame with ``pose`` (x, y, heading in its parent) into the parent frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    xy = _xy(xy)
    return np.column_stack([pose[0] + c * xy[:, 0] - s * xy[:, 1], pose[1] + s * xy[:, 0] + c * xy[:, 1]])


def to_frame(xy: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """Parent-frame points into the frame with ``pose`` (the inverse of ``rotate``: ``sim.layout.ego_frame``)."""
    return ego_frame(np.asarray(pose[:2], float), pose[2], _xy(xy))


def footprints(box3d) -> np.ndarray:
    """(N, 4, 2) ground corners, in order round, of (N, 7) boxes (x, y, z, length, width, height, yaw)."""
    b = np.asarray(box3d if box3d is not None else [], float).reshape(-1, 7)
    return box_corners(b[:, :3], b[:, 3:6], b[:, 6])[:, :4, :2]  # the bottom face


def body(size: tuple[float, float]) -> np.ndarray:
    """(4, 2) footprint of a vehicle in its own frame, front bumper at the origin."""
    ln, w = size
    return np.array([[0.0, w / 2], [0.0, -w / 2], [-ln, -w / 2], [-ln, w / 2]])


def ellipse(cov: np.ndarray, n_sigma: float = 2.0, n: int = 32) -> np.ndarray:
    """(n, 2) points of the ``n_sigma`` ellipse of a 2x2 covariance, around the origin (m)."""
    vals, vecs = np.linalg.eigh(cov)
    vals = np.sqrt(np.clip(vals, 0.0, None)) * n_sigma
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return (vecs @ (vals[:, None] * np.stack([np.cos(t), np.sin(t)]))).T


@dataclass
class CoopFrame:
    """One frame's inputs to the pictures, from a live ``TickRecord`` or a ``ticks.jsonl`` line."""

    t: float
    frame: int
    ego_pose: tuple[float, float, float]
    gt_names: list[str]
    gt_box3d: np.ndarray
    alert_ids: list[int]  # the track ids of this frame's alert events with a level (not ``clear``)
    coop: dict

    @classmethod
    def of(cls, record) -> CoopFrame | None:
        """None when the record has no ``cooperative`` entry."""
        coop = _get(record, "cooperative")
        if coop is None:
            return None
        ego = _get(record, "ego") or {}
        gt = _get(record, "ground_truth")
        frame = _get(record, "frame_index")
        if frame is None:
            frame = _get(record, "frame", 0)
        alerts = _get(record, "alerts") or []
        return cls(t=float(_get(record, "t", 0.0)), frame=int(frame),
                   ego_pose=(float(ego.get("x", 0.0)), float(ego.get("y", 0.0)), float(ego.get("yaw", 0.0))),
                   gt_names=[str(n) for n in (_get(gt, "name") or [])],
                   gt_box3d=np.asarray(_get(gt, "box3d") if _get(gt, "box3d") is not None else [], float).reshape(-1, 7),
                   alert_ids=[int(_get(a, "track_id")) for a in alerts if _get(a, "track_id") is not None
                              and int(_get(a, "level", 0) or 0) > 0 and _get(a, "kind") != "clear"],
                   coop=coop)

    def names(self) -> list[str]:
        """The ground-truth actors' names, one per box (blank where the record has none)."""
        return [self.gt_names[i] if i < len(self.gt_names) else "" for i in range(len(self.gt_box3d))]

    # -- the parts of the cooperative entry, as arrays
    def own(self) -> tuple[np.ndarray, np.ndarray]:
        o = self.coop.get("own") or {}
        return _ints(o.get("id")), _xy(o.get("xy"))

    def fused(self) -> dict[str, np.ndarray]:
        f = self.coop.get("fused") or {}
        ids = _ints(f.get("id"))
        cov = np.asarray(f.get("cov") if f.get("cov") is not None else [], float).reshape(-1, 3)
        src = _ints(f.get("source"))
        return {"id": ids, "xy": _xy(f.get("xy")), "source": src if len(src) == len(ids) else np.zeros(len(ids), int),
                "cov": cov if len(cov) == len(ids) else np.full((len(ids), 3), np.nan)}

    def received(self) -> list[dict]:
        out = []
        for m in self.coop.get("received") or []:
            ids = _ints(m.get("id"))
            n = len(ids)
            fid = _ints(m.get("fused_id"))
            matched = np.asarray(m.get("matched") if m.get("matched") is not None else [], bool).reshape(-1)
            out.append({"sender": str(m.get("sender")), "age": float(m.get("age") or 0.0), "id": ids,
                        "xy": _xy(m.get("xy")), "fused_id": fid if len(fid) == n else np.zeros(n, np.int64),
                        "matched": matched if len(matched) == n else np.zeros(n, bool)})
        return out

    def senders(self) -> list[dict]:
        return [{"name": str(s.get("name")), "pose": tuple(float(v) for v in s.get("pose")),
                 "reported_pose": tuple(float(v) for v in (s.get("reported_pose")
                                                            if s.get("reported_pose") is not None else s.get("pose")))}
                for s in self.coop.get("senders") or []]


# ----------------------------------------------------------------------------- drawing helpers
def _text(img: np.ndarray, s: str, x: int, y: int, colour=TEXT, scale: float = 0.38, halo: bool = False) -> None:
    """ASCII text with its baseline at (x, y); ``halo``: a dark outline so it reads on any colour."""
    if halo:
        cv2.putText(img, s, (x, y), FONT, scale, BG, 3, cv2.LINE_AA)
    cv2.putText(img, s, (x, y), FONT, scale, colour, 1, cv2.LINE_AA)


def _poly(img, pts: np.ndarray, colour, thickness: int = 1, closed: bool = True, fill: bool = False) -> None:
    p = np.round(np.clip(pts, -1e4, 1e4)).astype(np.int32).reshape(-1, 1, 2)
    if fill:
        cv2.fillPoly(img, [p], colour, cv2.LINE_AA)
    else:
        cv2.polylines(img, [p], closed, colour, thickness, cv2.LINE_AA)


def _dot(img, uv, colour, r: int = 4, filled: bool = True, thickness: int = 1) -> None:
    cv2.circle(img, (int(round(uv[0])), int(round(uv[1]))), r, colour, -1 if filled else thickness, cv2.LINE_AA)


def _square(img, uv, colour, r: int = 4) -> None:
    u, v = int(round(uv[0])), int(round(uv[1]))
    cv2.rectangle(img, (u - r, v - r), (u + r, v + r), colour, 1, cv2.LINE_AA)


def _cross(img, uv, colour, r: int = 5) -> None:
    u, v = int(round(uv[0])), int(round(uv[1]))
    cv2.line(img, (u - r, v - r), (u + r, v + r), colour, 2, cv2.LINE_AA)
    cv2.line(img, (u - r, v + r), (u + r, v - r), colour, 2, cv2.LINE_AA)


def _triangle(img, to_px, pose: tuple[float, float, float], colour, size_m: float, filled: bool = True) -> None:
    """A triangle pointing along ``pose``'s heading, tip at the pose (m, through ``to_px``)."""
    tri = rotate(np.array([[0.0, 0.0], [-size_m, size_m * 0.45], [-size_m, -size_m * 0.45]]), pose)
    _poly(img, to_px(tri), colour, 1, fill=filled)


# ----------------------------------------------------------------------------- the 2x2 panels
class Panel:
    """Geometry of one bird's-eye panel of the ego frame: ego (x, y) m -> (u, v) px."""

    width = int(round(2 * PANEL_Y * PANEL_PX_PER_M))
    plot_h = int(round((PANEL_X[1] - PANEL_X[0]) * PANEL_PX_PER_M))
    height = TITLE_H + plot_h

    @classmethod
    def px(cls, xy: np.ndarray) -> np.ndarray:
        """(N, 2) ego-frame metres -> (N, 2) float pixels of the panel image (title included)."""
        xy = _xy(xy)
        return np.column_stack([cls.width / 2 - xy[:, 1] * PANEL_PX_PER_M,
                                TITLE_H + (PANEL_X[1] - xy[:, 0]) * PANEL_PX_PER_M])


_PANEL_GRID: list[np.ndarray] = []  # the panels' static background, drawn once


def _panel_grid() -> np.ndarray:
    if not _PANEL_GRID:
        img = np.empty((Panel.height, Panel.width, 3), np.uint8)
        img[:] = BG
        for x in np.arange(math.ceil(PANEL_X[0] / 10) * 10, PANEL_X[1] + 1e-9, 10.0):
            v = int(round(Panel.px(np.array([[x, 0.0]]))[0, 1]))
            cv2.line(img, (0, v), (Panel.width - 1, v), GRID, 1)
            if x > 0:
                _text(img, f"{x:.0f}", 2, v - 2, GRID_TEXT, 0.32)
        for y in np.arange(-math.floor(PANEL_Y / 10) * 10, PANEL_Y + 1e-9, 10.0):
            u = int(round(Panel.px(np.array([[0.0, y]]))[0, 0]))
            cv2.line(img, (u, TITLE_H), (u, img.shape[0] - 1), GRID, 1)
        _PANEL_GRID.append(img)
    return _PANEL_GRID[0].copy()


def _panel_base(f: CoopFrame, title: str, info: str) -> np.ndarray:
    img = _panel_grid()
    top = TITLE_H
    for name, box in zip(f.names(), footprints(f.gt_box3d), strict=True):
        corners = Panel.px(box)
        _poly(img, corners, GT_OUTLINE, 1)
        _side_label(img, corners, name)
    _poly(img, Panel.px(body(EGO_SIZE)), EGO_FILL, fill=True)
    img[:top] = (12, 13, 16)
    _text(img, title, 6, 15, TEXT, 0.45)
    _text(img, info, 6, 33, MUTED, 0.36)
    return img


def _label(img, uv, s: str, colour) -> None:
    _text(img, s, int(round(uv[0])) + 6, int(round(uv[1])) - 4, colour, 0.34, halo=True)


def sender_colours(f: CoopFrame) -> dict[str, tuple[int, int, int]]:
    names = [s["name"] for s in f.senders()] + [m["sender"] for m in f.received()]
    return {n: SENDER_COLOURS[i % len(SENDER_COLOURS)] for i, n in enumerate(dict.fromkeys(names))}


def panel_own(f: CoopFrame) -> np.ndarray:
    ids, xy = f.own()
    img = _panel_base(f, "1 own (ego camera)", f"{len(ids)} objects")
    for i, uv in zip(ids.tolist(), Panel.px(xy), strict=True):
        _dot(img, uv, OWN)
        _label(img, uv, id_label(i), OWN)
    return img


def panel_received(f: CoopFrame) -> np.ndarray:
    msgs = f.received()
    colours = sender_colours(f)
    n = sum(len(m["id"]) for m in msgs)
    dropped = sum(int((m["fused_id"] < 0).sum()) for m in msgs)
    names = ", ".join(f"{m['sender']} {len(m['id'])}" for m in msgs) or "no message"
    img = _panel_base(f, "2 received (ego frame)", f"{n} objects ({dropped} self): {names}")
    for s in f.senders():  # where each sender says it is, seen from the ego
        pose = s["reported_pose"]
        local = to_frame(np.array(pose[:2])[None], f.ego_pose)[0]
        _triangle(img, Panel.px, (local[0], local[1], pose[2] - f.ego_pose[2]), colours[s["name"]], 2.5)
    for m in msgs:
        c = colours[m["sender"]]
        for oid, uv, fid in zip(m["id"].tolist(), Panel.px(m["xy"]), m["fused_id"].tolist(), strict=True):
            if fid < 0:
                _cross(img, uv, SELF_DROP)
                _label(img, uv, "self", SELF_DROP)
            else:
                _square(img, uv, c)
                _label(img, uv, f"{oid}", c)
    return img


def panel_fused(f: CoopFrame) -> np.ndarray:
    fu = f.fused()
    counts = {k: int((fu["source"] == k).sum()) for k in SOURCE_NAMES}
    info = f"{len(fu['id'])}: " + ", ".join(f"{SOURCE_NAMES[k]} {counts[k]}" for k in SOURCE_NAMES) + "  (2-sigma)"
    img = _panel_base(f, "3 fused", info)
    alerted = set(f.alert_ids)
    for oid, xy, src, cov in zip(fu["id"].tolist(), fu["xy"], fu["source"].tolist(), fu["cov"], strict=True):
        c = SOURCE_COLOURS.get(int(src), TEXT)
        if np.all(np.isfinite(cov)):
            m = np.array([[cov[0], cov[1]], [cov[1], cov[2]]])
            _poly(img, Panel.px(ellipse(m) + xy), c, 1)
        uv = Panel.px(xy[None])[0]
        _dot(img, uv, c)
        if oid in alerted:
            _dot(img, uv, ALERT, 10, filled=False, thickness=2)
        _label(img, uv, id_label(oid), c)
    return img


def match_lines(f: CoopFrame) -> list[tuple[np.ndarray, np.ndarray]]:
    """(received object, object it matched) ego-frame positions of every matched pair: a
    received object to the own object it joined, or to an earlier sender's object with the
    same fused id."""
    own_ids, own_xy = f.own()
    own = dict(zip(own_ids.tolist(), own_xy, strict=True))
    earlier: dict[int, np.ndarray] = {}
    out = []
    for m in f.received():
        for xy, fid, hit in zip(m["xy"], m["fused_id"].tolist(), m["matched"].tolist(), strict=True):
            if fid < 0:
                continue
            target = own.get(fid) if fid in own else earlier.get(fid)
            if hit and target is not None:
                out.append((xy, target))
            earlier.setdefault(fid, xy)
    return out


def panel_matches(f: CoopFrame) -> np.ndarray:
    lines = match_lines(f)
    own_ids, own_xy = f.own()
    msgs = f.received()
    colours = sender_colours(f)
    img = _panel_base(f, "4 own + received, matches", f"{len(lines)} matched pairs")
    for a, b in lines:
        pa, pb = Panel.px(np.array([a, b]))
        cv2.line(img, tuple(int(round(v)) for v in pa), tuple(int(round(v)) for v in pb), TEXT, 1, cv2.LINE_AA)
    for m in msgs:
        for uv, fid in zip(Panel.px(m["xy"]), m["fused_id"].tolist(), strict=True):
            (_cross if fid < 0 else _square)(img, uv, SELF_DROP if fid < 0 else colours[m["sender"]])
    for i, uv in zip(own_ids.tolist(), Panel.px(own_xy), strict=True):
        _dot(img, uv, OWN)
        _label(img, uv, id_label(i), OWN)
    return img


def panels(f: CoopFrame) -> np.ndarray:
    """The 2x2 figure (RGB): own | received / fused | matches, with a header line."""
    tiles = [panel_own(f), panel_received(f), panel_fused(f), panel_matches(f)]
    gap = 2
    h, w = Panel.height, Panel.width
    head = 26
    out = np.zeros((head + 2 * h + gap, 2 * w + gap, 3), np.uint8)
    out[:] = (60, 60, 66)
    out[:head] = (0, 0, 0)
    for k, tile in enumerate(tiles):
        r, c = divmod(k, 2)
        y0, x0 = head + r * (h + gap), c * (w + gap)
        out[y0:y0 + h, x0:x0 + w] = tile
    msgs = f.received()
    age = max((m["age"] for m in msgs), default=None)
    own_n, fused_n = len(f.own()[0]), len(f.fused()["id"])
    recv_n = sum(len(m["id"]) for m in msgs)
    fusion = "" if f.coop.get("fusion", True) else "  (fusion off: intent sees own only)"
    _text(out, f"t {f.t:5.2f} s  frame {f.frame}  msg age {'-' if age is None else f'{age:.2f} s'}  "
               f"own {own_n}  received {recv_n}  fused {fused_n}{fusion}", 6, 18, TEXT, 0.45)
    return out


# ----------------------------------------------------------------------------- the global map
@dataclass
class GlobalMap:
    """The world-frame map and the trajectories it accumulates (feed every frame in order).

    Drawn like the panels, with the world's axes: world x up the image, world y to the left
    (a road along x reads as in the ego's panels)."""

    size: tuple[int, int] = (2 * Panel.height + 28, MAP_WIDTH)  # (H, W): as tall as the 2x2 figure
    cameras: dict[str, tuple[float, float]] = field(default_factory=dict)  # name -> (fov_h deg, yaw deg)
    centre: np.ndarray | None = None
    trails: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    def reset(self) -> None:
        self.centre, self.trails = None, {}

    @property
    def half(self) -> np.ndarray:
        """Half the window's extent along world x and y (m), below the title."""
        h, w = self.size
        return np.array([h - MAP_HEAD, w]) / (2 * MAP_PX_PER_M)

    def px(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) world metres -> (N, 2) float pixels."""
        h, w = self.size
        d = _xy(xy) - self.centre
        return np.column_stack([w / 2 - d[:, 1] * MAP_PX_PER_M, MAP_HEAD + (h - MAP_HEAD) / 2 - d[:, 0] * MAP_PX_PER_M])

    def observe(self, f: CoopFrame) -> None:
        """Extend the trajectories; place the window at the first frame (centred on the ego and the
        senders, the ego kept well inside) and re-centre it only when the ego nears its edge."""
        poses = {"ego": f.ego_pose, **{s["name"]: s["pose"] for s in f.senders()}}
        for name, p in poses.items():
            self.trails.setdefault(name, []).append((p[0], p[1]))
        half = self.half
        ego = np.array(f.ego_pose[:2])
        if self.centre is None or np.any(np.abs(ego - self.centre) > 0.8 * half):
            pts = np.array([p[:2] for p in poses.values()])
            centre = (pts.min(0) + pts.max(0)) / 2
            self.centre = np.clip(centre, ego - 0.5 * half, ego + 0.5 * half)

    def draw(self, f: CoopFrame, colours: dict[str, tuple[int, int, int]]) -> np.ndarray:
        h, w = self.size
        img = np.empty((h, w, 3), np.uint8)
        img[:] = BG
        lo, hi = self.centre - self.half, self.centre + self.half
        step = 20.0
        for x in np.arange(math.ceil(lo[0] / step) * step, hi[0], step):
            v = int(round(self.px(np.array([[x, self.centre[1]]]))[0, 1]))
            cv2.line(img, (0, v), (w - 1, v), GRID, 1)
            _text(img, f"x {x:.0f}", 2, v - 3, GRID_TEXT, 0.32)
        for y in np.arange(math.ceil(lo[1] / step) * step, hi[1], step):
            u = int(round(self.px(np.array([[self.centre[0], y]]))[0, 0]))
            cv2.line(img, (u, 0), (u, h - 1), GRID, 1)
            _text(img, f"y {y:.0f}", u + 2, h - 5, GRID_TEXT, 0.32)
        carriers = {n for n, _, _ in self._poses(f, colours)}
        for name, box in zip(f.names(), footprints(f.gt_box3d), strict=True):
            corners = self.px(rotate(box, f.ego_pose))
            _poly(img, corners, GT_OUTLINE, 1)
            if name not in carriers:
                _side_label(img, corners, name)
        for name, trail in self.trails.items():
            if len(trail) > 1:
                _poly(img, self.px(np.array(trail)), colours.get(name, EGO_FILL), 1, closed=False)
        for name, pose, c in self._poses(f, colours):
            self._camera(img, name, pose, c)
        for name, pose, c in self._poses(f, colours):
            _poly(img, self.px(rotate(body(EGO_SIZE if name == "ego" else SENDER_SIZE), pose)), c, fill=True)
            uv = self.px(np.array([pose[:2]]))[0]
            _text(img, name, int(uv[0]) + 8, int(uv[1]) + 4, c, 0.4, halo=True)
        fu = f.fused()
        for oid, xy, src in zip(fu["id"].tolist(), rotate(fu["xy"], f.ego_pose), fu["source"].tolist(), strict=True):
            uv = self.px(xy[None])[0]
            _dot(img, uv, SOURCE_COLOURS.get(int(src), TEXT), 3)
            if oid in f.alert_ids:
                _dot(img, uv, ALERT, 8, filled=False, thickness=2)
        self._head(img)
        return img

    @staticmethod
    def _poses(f: CoopFrame, colours) -> list[tuple[str, tuple[float, float, float], tuple[int, int, int]]]:
        return [("ego", f.ego_pose, EGO_FILL)] + [(s["name"], s["pose"], colours.get(s["name"], TEXT))
                                                  for s in f.senders()]

    def _camera(self, img, name: str, pose, colour) -> None:
        fov, yaw = self.cameras.get(name, (None, 0.0))
        heading = pose[2] + math.radians(yaw)
        if fov is None:
            ray = rotate(np.array([[0.0, 0.0], [FOV_RAY_M, 0.0]]), (*pose[:2], heading))
            _poly(img, self.px(ray), colour, 1, closed=False)
            return
        half = math.radians(fov) / 2
        arc = [(FOV_RAY_M * math.cos(a), FOV_RAY_M * math.sin(a)) for a in np.linspace(-half, half, 12)]
        wedge = self.px(rotate(np.array([(0.0, 0.0), *arc]), (*pose[:2], heading)))
        h, w = img.shape[:2]
        x0, y0 = np.clip(np.floor(wedge.min(0)).astype(int), 0, [w, h])
        x1, y1 = np.clip(np.ceil(wedge.max(0)).astype(int) + 1, 0, [w, h])
        if x1 > x0 and y1 > y0:  # a faint fill, blended in the wedge's bounding box only
            roi = img[y0:y1, x0:x1]
            mask = np.zeros(roi.shape[:2], np.uint8)
            _poly(mask, wedge - [x0, y0], 255, fill=True)
            tint = cv2.addWeighted(roi, 0.88, np.full_like(roi, colour), 0.12, 0)
            np.copyto(roi, tint, where=mask[..., None] > 127)
        _poly(img, wedge, colour, 1)

    @staticmethod
    def _head(img) -> None:
        img[:MAP_HEAD] = (12, 13, 16)
        _text(img, "global map (world x up, y left)", 6, 15, TEXT, 0.45)
        _text(img, f"grid 20 m; camera views {FOV_RAY_M:.0f} m; trajectories", 6, 32, MUTED, 0.36)
        x = 6
        for k, name in SOURCE_NAMES.items():
            _dot(img, (x + 4, 45), SOURCE_COLOURS[k], 4)
            _text(img, name, x + 12, 49, SOURCE_COLOURS[k], 0.36)
            x += 22 + cv2.getTextSize(name, FONT, 0.36, 1)[0][0]
        _dot(img, (x + 6, 45), ALERT, 6, filled=False)
        _text(img, "alert", x + 16, 49, ALERT, 0.36)
        x += 58
        cv2.rectangle(img, (x, 41), (x + 14, 49), GT_OUTLINE, 1)
        _text(img, "truth", x + 18, 49, GT_OUTLINE, 0.36)


def _side_label(img, corners: np.ndarray, name: str) -> None:
    """A ground-truth actor's name, faint, left of its footprint (px corners)."""
    tw = cv2.getTextSize(name, FONT, 0.3, 1)[0][0]
    u, v = float(corners[:, 0].min()), float(corners[:, 1].mean())
    _text(img, name, int(round(u)) - tw - 3, int(round(v)) + 4, GT_OUTLINE, 0.3)


class CoopView:
    """The pictures of one run, frame after frame (the map's trajectories carry over)."""

    def __init__(self, cameras: dict[str, tuple[float, float]] | None = None) -> None:
        self.map = GlobalMap(cameras=dict(cameras or {}))

    def reset(self) -> None:
        self.map.reset()

    def draw(self, f: CoopFrame) -> tuple[np.ndarray, np.ndarray]:
        """(2x2 panels, global map), RGB; advances the map's trajectories."""
        self.map.observe(f)
        return panels(f), self.map.draw(f, {"ego": EGO_FILL, **sender_colours(f)})

    @staticmethod
    def composite(grid: np.ndarray, world: np.ndarray) -> np.ndarray:
        """The 2x2 left, the map right (same height; a 2 px seam)."""
        h = max(grid.shape[0], world.shape[0])
        out = np.zeros((h, grid.shape[1] + 2 + world.shape[1], 3), np.uint8)
        out[:grid.shape[0], :grid.shape[1]] = grid
        out[:world.shape[0], grid.shape[1] + 2:] = world
        return out


def cameras_of(scenario) -> dict[str, tuple[float, float]]:
    """name -> (horizontal field of view, mount yaw), degrees, of the ego's (``ego``) and every
    sender's camera of a ``sim.scenario.Scenario``."""
    cams = {"ego": (float(scenario.camera.fov_h), float(scenario.camera.mount.yaw))}
    for s in scenario.cooperative.senders if scenario.cooperative is not None else []:
        cams[s.name] = (float(s.camera.fov_h), float(s.camera.mount.yaw))
    return cams


# ----------------------------------------------------------------------------- the sink
class CooperativeVideoSink:
    """A runner sink: the composite MP4 and the key frame's PNGs (module docstring).

    ``path``: the MP4 (checked now, as ``--video`` is); ``run_dir``: where ``cooperative/`` with
    the PNGs goes (None: no PNGs); ``fps``: the camera rate; ``cameras``: ``cameras_of``.
    ``frames_written`` counts the video's frames; ``key`` is (frame, t, why) once written.
    """

    def __init__(self, path: Path | None, run_dir: Path | None, fps: float,
                 cameras: dict[str, tuple[float, float]] | None = None) -> None:
        if fps <= 0:
            raise ValueError(f"fps: expected > 0, got {fps}")
        self.path = None if path is None else Path(path)
        if self.path is not None:
            check_video_path(self.path)
        self.run_dir = None if run_dir is None else Path(run_dir)
        self.fps = float(fps)
        self.view = CoopView(cameras)
        self._cameras = dict(cameras or {})
        self._writer: FragmentedMjpegWriter | None = None
        self.frames_written = 0
        self.key: dict | None = None
        self._seen = 0
        self._pending: deque[tuple[CoopFrame, int]] = deque()  # the second half so far: (frame, trail length)

    def on_start(self, info: dict) -> None:
        self.view.reset()
        self._seen = 0
        self._pending.clear()
        self.key = None

    def on_tick(self, record) -> None:
        f = CoopFrame.of(record)
        if f is None:
            return
        grid, world = self.view.draw(f)
        if self.path is not None:
            frame = CoopView.composite(grid, world)
            if self._writer is None:
                self._writer, _ = open_mp4_writer(self.path, self.fps, (frame.shape[1], frame.shape[0]), JPEG_QUALITY)
            self._writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))  # one fragment per frame, at once
            self.frames_written += 1
        self._seen += 1
        if self.run_dir is None or self.key is not None:
            return
        if any(i >= REMOTE_ID_BASE for i in f.alert_ids):
            self._save(grid, world, f, "first alert on an object only others see")
            self._pending.clear()
            return
        self._pending.append((f, {k: len(v) for k, v in self.view.map.trails.items()}))
        while len(self._pending) > self._seen - self._seen // 2:  # keep frames from the middle on
            self._pending.popleft()

    def on_end(self, summary: dict) -> None:
        try:
            if self.run_dir is not None and self.key is None and self._pending:
                f, lengths = self._pending[0]
                view = CoopView(self._cameras)  # the map as it was then: trails cut to that frame
                view.map.centre = None
                view.map.trails = {k: v[:lengths.get(k, 0) - 1] for k, v in self.view.map.trails.items()}
                grid, world = view.draw(f)
                self._save(grid, world, f, "middle of the run")
            elif self.key is None and self._seen == 0:
                log.warning("cooperative view: no frame had a cooperative record; nothing drawn")
        finally:
            self._pending.clear()
            self.close()

    def close(self) -> None:
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.release()
            log.info("%s: %d frames", self.path, self.frames_written)

    def _save(self, grid: np.ndarray, world: np.ndarray, f: CoopFrame, why: str) -> None:
        try:
            out = prepare_dir(self.run_dir / SUBDIR)
            save_rgb(out / PANELS_PNG, grid)
            save_rgb(out / MAP_PNG, world)
            self.key = {"frame": f.frame, "t": round(f.t, 4), "why": why}
            (out / KEY_FRAME_JSON).write_text(json.dumps(self.key) + "\n")
        except OSError as e:
            raise OutputError(f"{self.run_dir / SUBDIR}: cannot write the cooperative key frame ({e})") from None
