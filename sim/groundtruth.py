"""Exact ground truth per actor per camera frame.

3D boxes come from each actor's shape at its current gait phase (tight), so
the amodal 2D box is the projection of the 8 corners through the one camera
model, clipped at the near plane. Visible boxes and visible fractions come from
the renderer's segmentation (``with_visibility``): visible fraction = visible
pixels / pixels of the actor's unoccluded silhouette (rendered alone, only where
something nearer may hide it). Without rendering they are estimated from box
overlap (``world_truth``; documented as an approximation). Labels, behaviour and
risk come from ``intent.labels.assess``, the same code that labels predictions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import linear_sum_assignment

from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import NEVER, Kinematics, assess
from lookahead.perception.camera import CameraModel, truncation
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.geometry import (
    box_area,
    box_corners,
    clip_boxes,
    grow_boxes,
    iou_matrix,
    mask_boxes,
)
from lookahead.sim.layout import ego_frame

if TYPE_CHECKING:
    from lookahead.sim.world import Viewpoint, World

Silhouettes = Callable[[list[int], tuple[int, int, int, int]], np.ndarray]
"""``(actor ids, pixel window (u0, v0, u1, v1)) -> (H, W) segmentation of those actors alone``."""

GROUND_LEVEL = 0.85  # depth / flat-ground depth above which a pixel is ground level (~0.2 m high for a camera at 1.4 m)
GT_MAX_RANGE = 200.0  # m; actors farther than this (or > 10 m behind) are left out
TRUTH_IOU = 0.3  # least IoU of a track's box with an actor's for ``truth_ids``


@dataclass
class GroundTruth:
    """Struct of arrays over the actors near the ego in one camera frame (ego frame, SI)."""

    actor_id: np.ndarray  # (N,) int
    name: list[str]
    cls: list[str]
    subtype: list[str]
    class_id: np.ndarray  # (N,) int, perception.detections.CLASS_ID
    box3d: np.ndarray  # (N, 7) x, y, z (centre), length, width, height, yaw (ego frame)
    velocity: np.ndarray  # (N, 2) ground velocity in ego axes (m/s)
    amodal: np.ndarray  # (N, 4) xyxy, union of the projected part boxes (full silhouette), unclipped
    projected: np.ndarray  # (N, 4) xyxy, the 8 projected corners of the 3D box, unclipped
    visible: np.ndarray  # (N, 4) xyxy, tight box of visible pixels (NaN if none)
    visible_fraction: np.ndarray  # (N,)
    pixels: np.ndarray  # (N,) visible pixel count (render) or -1
    truncation: np.ndarray  # (N,)
    range: np.ndarray  # (N,) nearest point's x (m)
    lateral: np.ndarray  # (N,) centre y (m)
    range_rate: np.ndarray  # (N,)
    lateral_rate: np.ndarray  # (N,)
    accel: np.ndarray  # (N,)
    yaw_rate: np.ndarray  # (N,)
    ttc: np.ndarray  # (N,)
    in_path: np.ndarray  # (N,) bool
    label: np.ndarray  # (N,) intent.labels.Label
    behaviour: np.ndarray  # (N,) intent.labels.Behaviour
    risk: np.ndarray  # (N,) intent.labels.Risk
    ettc: np.ndarray | None = None  # (N,) enhanced TTC (s), intent.collision
    decel_req: np.ndarray | None = None  # (N,) the ego's required deceleration (m/s^2)

    @classmethod
    def empty(cls) -> GroundTruth:
        """Ground truth of a frame without any (real video: ``lookahead watch``)."""
        f = np.zeros(0)
        i = np.zeros(0, dtype=np.int64)
        return cls(
            actor_id=i, name=[], cls=[], subtype=[], class_id=i, box3d=np.zeros((0, 7)), velocity=np.zeros((0, 2)),
            amodal=np.zeros((0, 4)), projected=np.zeros((0, 4)), visible=np.zeros((0, 4)), visible_fraction=f,
            pixels=i, truncation=f, range=f, lateral=f, range_rate=f, lateral_rate=f, accel=f, yaw_rate=f, ttc=f,
            in_path=np.zeros(0, dtype=bool), label=i, behaviour=i, risk=i,
        )

    def __len__(self) -> int:
        return len(self.actor_id)

    def to_dict(self) -> dict:
        def r(a: np.ndarray, nd: int) -> list:
            return np.round(np.asarray(a, dtype=np.float64), nd).tolist()

        return {
            "actor_id": self.actor_id.tolist(),
            "name": self.name,
            "cls": self.cls,
            "subtype": self.subtype,
            "class_id": self.class_id.tolist(),
            "box3d": r(self.box3d, 3),
            "velocity": r(self.velocity, 3),
            "amodal": r(self.amodal, 2),
            "projected": r(self.projected, 2),
            "visible": r(self.visible, 2),
            "visible_fraction": r(self.visible_fraction, 3),
            "pixels": self.pixels.tolist(),
            "truncation": r(self.truncation, 3),
            "range": r(self.range, 3),
            "lateral": r(self.lateral, 3),
            "range_rate": r(self.range_rate, 3),
            "lateral_rate": r(self.lateral_rate, 3),
            "accel": r(self.accel, 3),
            "yaw_rate": r(self.yaw_rate, 4),
            "ttc": r(np.minimum(self.ttc, NEVER), 3),
            "in_path": self.in_path.tolist(),
            "label": self.label.tolist(),
            "behaviour": self.behaviour.tolist(),
            "risk": self.risk.tolist(),
            **{name: r(np.minimum(getattr(self, name), NEVER), 3)
               for name in ("ettc", "decel_req") if getattr(self, name) is not None},
        }


def occlusion_from_boxes(boxes: np.ndarray, depth: np.ndarray, width: int, height: int, grid: int = 12) -> np.ndarray:
    """Approximate visible fraction (N,) from box overlap: share of each box's
    in-image area not covered by the boxes of nearer objects (sampled on a grid)."""
    n = len(boxes)
    if n == 0:
        return np.zeros(0)
    b = clip_boxes(np.nan_to_num(boxes, nan=0.0), width, height)
    g = (np.arange(grid) + 0.5) / grid
    xs = b[:, 0:1] + g[None] * (b[:, 2:3] - b[:, 0:1])  # (N, G)
    ys = b[:, 1:2] + g[None] * (b[:, 3:4] - b[:, 1:2])
    px = np.broadcast_to(xs[:, None, :], (n, grid, grid))
    py = np.broadcast_to(ys[:, :, None], (n, grid, grid))
    nearer = depth[None, :] < depth[:, None]  # (N, M): M nearer than N
    inside = (
        (px[:, None] >= b[None, :, 0, None, None]) & (px[:, None] < b[None, :, 2, None, None])
        & (py[:, None] >= b[None, :, 1, None, None]) & (py[:, None] < b[None, :, 3, None, None])
    )  # (N, M, G, G)
    covered = np.any(inside & nearer[:, :, None, None], axis=1)
    frac = 1.0 - covered.mean(axis=(1, 2))
    return np.where(box_area(b) > 0, frac, 0.0)


def _rotate_z(v: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Vectors (N, 3) rotated by yaw (N,) about z."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]])


def silhouette_boxes(
    camera: CameraModel, shapes: list, phases: list, base: np.ndarray, yaw: np.ndarray
) -> np.ndarray:
    """Amodal 2D boxes (N, 4): the box of the projections of every part's surface points.

    ``base`` (N, 3) is each actor's local origin and ``yaw`` (N,) its heading in
    the ego frame. Tighter than projecting the whole 3D box (a walking person's
    box has empty corners): exact for box parts, 16-gon rims for cylinders.
    Parts that cross the near plane use their bounding box clipped there, so
    actors partly behind the camera are right too.
    """
    n = len(shapes)
    if n == 0:
        return np.zeros((0, 4))
    corners = [sh.part_corners(ph) for sh, ph in zip(shapes, phases, strict=True)]
    points = np.concatenate([sh.part_points(ph) for sh, ph in zip(shapes, phases, strict=True)])
    counts = np.array([len(c) for c in corners])
    owner = np.repeat(np.arange(n), counts)

    def to_ego(local: np.ndarray) -> np.ndarray:
        c, s = np.cos(yaw[owner])[:, None], np.sin(yaw[owner])[:, None]
        x = c * local[..., 0] - s * local[..., 1]
        y = s * local[..., 0] + c * local[..., 1]
        return np.stack([x, y, local[..., 2]], -1) + base[owner][:, None, :]

    near = 0.05
    boxes = camera.project_boxes(to_ego(np.concatenate(corners)), near=near)  # handles the near plane
    pts_cam = camera.ego_to_camera(to_ego(points))
    in_front = np.all(pts_cam[..., 2] > near, axis=1)
    if in_front.any():
        uv = camera.project_camera(pts_cam[in_front])
        boxes[in_front] = np.column_stack([uv[..., 0].min(1), uv[..., 1].min(1), uv[..., 0].max(1), uv[..., 1].max(1)])
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return np.column_stack([
        np.fmin.reduceat(boxes[:, 0], starts), np.fmin.reduceat(boxes[:, 1], starts),
        np.fmax.reduceat(boxes[:, 2], starts), np.fmax.reduceat(boxes[:, 3], starts),
    ])


def compute_ground_truth(
    world: World,
    camera: CameraModel,
    config: IntentConfig,
    seg: np.ndarray | None = None,
    silhouettes: Silhouettes | None = None,
    depth: np.ndarray | None = None,
    ground_depth: np.ndarray | None = None,
) -> GroundTruth:
    """Ground truth for the world's current state: ``world_truth``, then, with a render,
    ``with_visibility`` (its arguments ``seg``, ``depth``, ``ground_depth``, ``silhouettes``)."""
    gt = world_truth(world, camera, config)
    return gt if seg is None else with_visibility(gt, camera, seg, depth, silhouettes, ground_depth)


def world_truth(world: World, camera: CameraModel, config: IntentConfig,
                viewpoint: Viewpoint | None = None) -> GroundTruth:
    """Ground truth of the world's current state without a render: visible boxes are the
    in-image amodal boxes, visible fractions estimated from box overlap
    (``occlusion_from_boxes``), ``pixels`` -1; ``with_visibility`` measures them on a render.

    ``viewpoint``: of a camera other than the ego's (``sim.world.Viewpoint``), in its frame;
    it sees the ego (actor ``EGO_ACTOR_ID``) and not its carrier."""
    with_ego = viewpoint is not None
    viewed = world.viewed_agents(with_ego)
    st = world.agent_states(with_ego)
    if viewpoint is None:
        (ox, oy, oyaw), speed = world.ego_pose(), float(world.ego.speed)
        w, accel = world.odometry.yaw_rate, world.odometry.accel
        seen = np.ones(len(st.ids), dtype=bool)
    else:
        (ox, oy, oyaw), speed, w, accel = viewpoint.pose, viewpoint.speed, viewpoint.yaw_rate, viewpoint.accel
        seen = st.ids != (viewpoint.carrier if viewpoint.carrier is not None else -1)
    rel = ego_frame(np.array([ox, oy]), oyaw, st.xy)
    idx = np.nonzero(seen & (rel[:, 0] > -10.0) & (rel[:, 0] < GT_MAX_RANGE + 20.0))[0]
    shapes = [viewed[i].identity.shape for i in idx]
    all_poses = st.poses()
    phases = [all_poses[i] for i in idx]  # sim.shapes.Pose: gait phase, or with a gesture
    # Actor-local origin in the ego frame: on the surface it stands on (pavements are raised).
    base = np.column_stack([rel[idx], world.layout.surface_height(st.xy[idx])])
    ryaw = st.yaw[idx] - oyaw
    # Tight 3D boxes at the current gait phase.
    local = [sh.local_box(ph) for sh, ph in zip(shapes, phases, strict=True)]
    lc = np.array([c for c, _ in local]).reshape(-1, 3)
    size = np.array([z for _, z in local]).reshape(-1, 3)
    centre = base + _rotate_z(lc, ryaw)
    corners = box_corners(centre, size, ryaw)
    rng = corners[..., 0].min(axis=1)
    ranged = rng < GT_MAX_RANGE
    idx, base, ryaw, centre, size, corners, rng = (
        idx[ranged], base[ranged], ryaw[ranged], centre[ranged], size[ranged], corners[ranged], rng[ranged]
    )
    shapes = [sh for sh, k in zip(shapes, ranged, strict=True) if k]
    phases = [ph for ph, k in zip(phases, ranged, strict=True) if k]
    agents = [viewed[i] for i in idx]
    n = len(idx)
    half_w = (corners[..., 1].max(axis=1) - corners[..., 1].min(axis=1)) / 2.0

    projected = camera.project_boxes(corners)
    amodal = silhouette_boxes(camera, shapes, phases, base, ryaw)
    trunc = truncation(amodal, camera.width, camera.height)
    ids = st.ids[idx]

    # Kinematics in the ego frame.
    spd = st.speed[idx]
    vg = np.column_stack([spd * np.cos(ryaw), spd * np.sin(ryaw)])
    rr = vg[:, 0] - speed + w * centre[:, 1]
    lr = vg[:, 1] - w * centre[:, 0]

    cam_depth = camera.ego_to_camera(centre)[:, 2] if n else np.zeros(0)
    visible = clip_boxes(np.nan_to_num(amodal), camera.width, camera.height)
    visible[trunc >= 1.0] = np.nan
    pixels = np.full(n, -1, dtype=np.int64)
    vis_frac = occlusion_from_boxes(amodal, cam_depth, camera.width, camera.height)
    vis_frac[trunc >= 1.0] = 0.0

    cls = [a.identity.cls for a in agents]
    class_id = np.array([CLASS_ID[k] for k in cls], dtype=np.int64)
    kin = Kinematics(
        class_id=class_id,
        range=rng,
        lateral=centre[:, 1],
        half_width=half_w,
        range_rate=rr,
        lateral_rate=lr,
        ground_vx=vg[:, 0],
        ground_vy=vg[:, 1],
        accel=st.accel[idx],
        yaw_rate=st.yaw_rate[idx],
        accel_x=st.accel[idx] * np.cos(ryaw),
        height=size[:, 2],
    )
    a = assess(kin, config, ego_speed=speed, ego_yaw_rate=w, ego_accel=accel)
    gesture = st.gesture[idx]  # a scripted wave, fall or loiter is that behaviour, whatever the motion
    a.behaviour = np.where(gesture > 0, gesture, a.behaviour)
    return GroundTruth(
        actor_id=ids,
        name=[ag.identity.name for ag in agents],
        cls=cls,
        subtype=[ag.identity.subtype for ag in agents],
        class_id=class_id,
        box3d=np.column_stack([centre, size, ryaw]) if n else np.zeros((0, 7)),
        velocity=vg,
        amodal=amodal,
        projected=projected,
        visible=visible,
        visible_fraction=vis_frac,
        pixels=pixels,
        truncation=trunc,
        range=rng,
        lateral=centre[:, 1],
        range_rate=rr,
        lateral_rate=lr,
        accel=st.accel[idx],
        yaw_rate=st.yaw_rate[idx],
        ttc=a.ttc,
        in_path=a.in_path,
        label=a.label,
        behaviour=a.behaviour,
        risk=a.risk,
        ettc=a.ettc,
        decel_req=a.decel_req,
    )


def detector_truth(gt: GroundTruth, camera: CameraModel) -> DetectorTruth:
    """What a simulated detector may see: visible boxes of detection-class actors."""
    keep = (gt.class_id >= 0) & np.all(np.isfinite(gt.visible), axis=1) & (gt.visible_fraction > 0)
    return DetectorTruth(
        width=camera.width,
        height=camera.height,
        xyxy=gt.visible[keep],
        class_id=gt.class_id[keep],
        source_id=gt.actor_id[keep],
        range_m=gt.range[keep],
        visible_fraction=gt.visible_fraction[keep],
        truncation=gt.truncation[keep],
    )


def truth_ids(xyxy: np.ndarray, gt: GroundTruth, camera: CameraModel, min_iou: float = TRUTH_IOU,
              visible: bool = False, min_size: float = 0.0) -> np.ndarray:
    """(N,) the ground-truth actor of each box (a track's), -1 none: the assignment of largest
    total IoU among pairs of at least ``min_iou``, with the actors' in-image amodal boxes (a
    coasting track's box is where its hidden object is) or, with ``visible``, their visible
    boxes (the scorer's rule, ``tools.scoring.matching``); both sides grown to ``min_size`` px
    first when given. For scoring only."""
    out = np.full(len(xyxy), -1, dtype=np.int64)
    if not len(xyxy) or not len(gt):
        return out
    if visible:
        boxes = np.asarray(gt.visible, dtype=np.float64).reshape(-1, 4)
        seen = np.all(np.isfinite(boxes), axis=1)
    else:
        boxes = clip_boxes(np.nan_to_num(gt.amodal), camera.width, camera.height)
        seen = gt.truncation < 1.0
    a = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
    finite = np.all(np.isfinite(a), axis=1)[:, None] & seen[None, :]
    a, boxes = np.nan_to_num(a), np.nan_to_num(boxes)
    if min_size > 0:
        a, boxes = grow_boxes(a, min_size), grow_boxes(boxes, min_size)
    iou = np.where(finite, iou_matrix(a, boxes), 0.0)
    gain = np.where(iou >= min_iou, iou, 0.0)
    rows, cols = linear_sum_assignment(gain, maximize=True)
    ok = gain[rows, cols] > 0
    out[rows[ok]] = gt.actor_id[cols[ok]]
    return out
    boxes = clip_boxes(np.nan_to_num(gt.amodal), camera.width, camera.height)
    boxes[gt.truncation >= 1.0] = 0.0
    iou = iou_matrix(np.nan_to_num(np.asarray(xyxy, dtype=np.float64)), boxes)
    rows, cols = linear_sum_assignment(-iou)
    ok = iou[rows, cols] >= min_iou
    out[rows[ok]] = gt.actor_id[cols[ok]]
    return out


def with_visibility(
    gt: GroundTruth,
    camera: CameraModel,
    seg: np.ndarray,
    depth: np.ndarray | None = None,
    silhouettes: Silhouettes | None = None,
    ground_depth: np.ndarray | None = None,
) -> GroundTruth:
    """``gt`` with visible boxes, pixel counts and visible fractions measured on a render.

    Visible box and pixel count: the actor's pixels in ``seg`` (H, W) (actor ids).
    Visible fraction = visible pixels / pixels of the actor's unoccluded silhouette, for
    actors overlapped by a nearer actor's box or whose visible box is clearly smaller
    than their in-image amodal box (IoU < 0.9); else 1 (0 without pixels).

    The silhouette is the visible pixels plus those the actor covers when rendered alone
    (``silhouettes(ids, window) -> seg``) where the frame shows something else that may
    hide it: nearer than the actor's far side (``depth`` (H, W), m along the optical axis)
    and above ground level (nearer than ``GROUND_LEVEL`` x ``ground_depth``, the flat
    ground's depth, ``CameraModel.ground_depth``: road, kerbs and pavements never hide an
    actor standing on them). Elsewhere the actor alone covers exactly its visible pixels,
    so only the window of those pixels is rendered, and none when there are none. Without
    ``depth`` every other pixel of the box may hide the actor; without ``ground_depth`` the
    ground may too (more is rendered, and kerbs count as occluders); without
    ``silhouettes`` the fractions stay 1.
    """
    n = len(gt)
    amodal = np.nan_to_num(gt.amodal)
    visible, pixels = mask_boxes(seg, gt.actor_id)
    vis_frac = np.where(pixels > 0, 1.0, 0.0)
    if n and silhouettes is not None:
        in_img = gt.truncation < 1.0
        cam_depth = camera.ego_to_camera(gt.box3d[:, :3])[:, 2]
        ov = iou_matrix(amodal, amodal) > 0
        nearer = cam_depth[None, :] < cam_depth[:, None]
        occluded = in_img & (pixels > 0) & np.any(ov & nearer & in_img[None, :], axis=1)
        clipped = clip_boxes(amodal, camera.width, camera.height)
        shrunk = (pixels > 0) & (iou_matrix(np.nan_to_num(visible), clipped).diagonal() < 0.9)
        corners = box_corners(gt.box3d[:, :3], gt.box3d[:, 3:6], gt.box3d[:, 6])
        # the actor's far side (m along the optical axis), with room for EGL's 16-bit depth steps
        far_side = camera.ego_to_camera(corners)[..., 2].max(axis=1) * 1.02 + 0.1
        for k in np.nonzero(occluded | shrunk)[0]:
            u0, v0 = (max(int(np.floor(c)) - 2, 0) for c in clipped[k, :2])
            u1, v1 = int(np.ceil(clipped[k, 2])) + 2, int(np.ceil(clipped[k, 3])) + 2
            others = seg[v0:v1, u0:u1] != gt.actor_id[k]
            if depth is not None:
                hider = depth[v0:v1, u0:u1] < far_side[k]
                if ground_depth is not None:
                    hider &= depth[v0:v1, u0:u1] < GROUND_LEVEL * ground_depth[v0:v1, u0:u1]
                others &= hider
            rows, cols = np.nonzero(others)
            hidden = 0
            if len(rows):  # the actor alone is drawn only in this window: count there
                a0, b0 = max(u0 + int(cols.min()) - 1, 0), max(v0 + int(rows.min()) - 1, 0)
                a1, b1 = u0 + int(cols.max()) + 2, v0 + int(rows.max()) + 2
                alone = silhouettes([int(gt.actor_id[k])], (a0, b0, a1, b1))[b0:b1, a0:a1]
                hidden = np.count_nonzero((alone == gt.actor_id[k]) & (seg[b0:b1, a0:a1] != gt.actor_id[k]))
            vis_frac[k] = pixels[k] / (pixels[k] + hidden)
    return replace(gt, visible=visible, pixels=pixels, visible_fraction=vis_frac)
