"""``lookahead bench fusion``: what cooperative fusion costs the ego per tick.

A synthetic street, seeded: ``objects`` road users (a third pedestrians, a third cyclists, a
third cars) spread over 60 m x 30 m ahead of the ego, moving; the ego's camera and each of
``senders`` other cameras (vehicles and roadside units around the scene) see a random 80 %
of them, with range-dependent position noise, and report them in their own frames with a
noisy pose, 0.1 s old. Per tick, the ego's fusion stage (``intent.cooperative.FusionStage``:
its tracks into an ``ObjectList``, every message into the ego's frame, self-detection
check, gated Hungarian matching sender by sender, information-form fusion, the union's
kinematics for intent) is timed over ``frames`` ticks.

Cases: ``fusion`` (ms per tick), ``fusion_node`` (the node alone, without the stage's
conversions). ``matching_precision`` / ``matching_recall`` against the synthetic identities
check that the timed work is the real thing. Ratio ``fusion_over_frame_period``: the
median tick over the 100 ms of a 10 Hz camera.
"""

from __future__ import annotations

import time

import numpy as np

from lookahead.intent.cooperative import FusionStage
from lookahead.intent.labels import Kinematics
from lookahead.perception.camera import CameraModel
from lookahead.perception.cooperative import FusionNode, ObjectList, SharedObjects, range_covariance
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.estimator import Estimates, Estimator
from lookahead.perception.frame import EgoOdometry, Frame
from lookahead.perception.geometry import rotation_2d
from lookahead.perception.tracker import Tracks
from lookahead.tools.bench.common import case, machine

CLASSES = (CLASS_ID["pedestrian"], CLASS_ID["cyclist"], CLASS_ID["car"])
SEEN = 0.8  # share of the objects each camera sees
AGE = 0.1  # s, age of every message
POSE_SIGMA = (0.2, np.radians(0.3))  # m, rad


def _world(objects: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (ego frame, m), ground velocities (m/s) and classes of the scene's objects."""
    xy = np.column_stack([rng.uniform(5.0, 65.0, objects), rng.uniform(-15.0, 15.0, objects)])
    cls = np.array([CLASSES[i % 3] for i in range(objects)])
    speed = np.where(cls == CLASS_ID["car"], 8.0, np.where(cls == CLASS_ID["cyclist"], 4.0, 1.3))
    heading = rng.uniform(-np.pi, np.pi, objects)
    return xy, speed[:, None] * np.column_stack([np.cos(heading), np.sin(heading)]), cls


def _seen_by(pose: tuple[float, float, float], xy: np.ndarray, vel: np.ndarray, cls: np.ndarray,
             rng: np.random.Generator) -> ObjectList:
    """What a camera at ``pose`` (in the ego frame at t = 0) reports, in its own frame."""
    keep = np.nonzero(rng.random(len(xy)) < SEEN)[0]
    r = rotation_2d(pose[2])
    local = (xy[keep] - np.asarray(pose[:2])) @ r
    cov = range_covariance(local)
    noisy = local + np.einsum("nij,nj->ni", np.linalg.cholesky(cov), rng.normal(size=local.shape))
    return ObjectList(noisy, vel[keep] @ r, cov, cls[keep], np.full(len(keep), 0.9), keep.astype(np.int64),
                      velocity_sigma=np.full((len(keep), 2), 0.3), settled=np.ones(len(keep)),
                      truth=keep.astype(np.int64))


def _own_tracks(seen: ObjectList, priors) -> tuple[Tracks, Estimates]:
    """The ego's view as the stack hands it over: tracks and their estimates (nearest face)."""
    n = len(seen)
    tracks = Tracks(track_id=seen.object_id + 1, xyxy=np.zeros((n, 4)), class_id=seen.class_id, score=seen.score,
                    age=np.full(n, 30), hits=np.full(n, 30), state=np.ones(n, dtype=np.int64),
                    det_index=np.arange(n), velocity_px=np.zeros((n, 4)))
    est = Estimates.empty(n)
    half = 0.5 * priors.of(seen.class_id, "length")
    est.range[:], est.lateral[:] = seen.xy[:, 0] - half, seen.xy[:, 1]
    est.range_sigma[:], est.lateral_sigma[:] = np.sqrt(seen.cov[:, 0, 0]), np.sqrt(seen.cov[:, 1, 1])
    est.ground_vx[:], est.ground_vy[:] = seen.velocity.T
    est.ground_vx_sigma[:] = est.ground_vy_sigma[:] = 0.3
    est.range_rate[:], est.lateral_rate[:] = seen.velocity[:, 0] - 10.0, seen.velocity[:, 1]
    est.half_width[:] = 0.5 * priors.of(seen.class_id, "width")
    est.settled[:], est.accel[:], est.yaw_rate[:], est.accel_x[:] = 1.0, 0.0, 0.0, 0.0
    est.range_rate_sigma[:], est.height[:] = 0.3, priors.of(seen.class_id, "height")
    return tracks, est


def bench_fusion(senders: int = 3, objects: int = 30, frames: int = 200, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    camera = CameraModel.from_fov(640, 360, 90.0)
    priors = Estimator(camera).priors
    poses = [(70.0, 3.5, np.pi), (35.0, -20.0, np.pi / 2), (35.0, 20.0, -np.pi / 2), (80.0, -10.0, 2.5)][:senders]
    fusion_ms, node_ms, correct, pairs, should = [], [], 0, 0, 0
    for f in range(frames):
        xy, vel, cls = _world(objects, rng)
        own_seen = _seen_by((0.0, 0.0, 0.0), xy, vel, cls, rng)
        tracks, est = _own_tracks(own_seen, priors)
        messages = []
        for i, pose in enumerate(poses):
            seen = _seen_by(pose, xy - vel * AGE, vel, cls, rng)  # captured AGE s ago
            reported = (pose[0] + POSE_SIGMA[0] * rng.normal(), pose[1] + POSE_SIGMA[0] * rng.normal(),
                        pose[2] + POSE_SIGMA[1] * rng.normal())
            messages.append(SharedObjects(f"s{i}", 10.0 - AGE, reported, seen, POSE_SIGMA))
        stage = FusionStage(FusionNode(), priors)
        frame = Frame(tick=f, t=10.0, camera=camera, odometry=EgoOdometry(speed=10.0), index=f)
        kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
        stage.receive(messages, (0.0, 0.0, 0.0))
        t0 = time.perf_counter()
        stage(frame, tracks, est, kin)
        fusion_ms.append((time.perf_counter() - t0) * 1e3)
        own = stage.own_objects(tracks, est)
        own.truth = tracks.track_id - 1
        t0 = time.perf_counter()
        result = FusionNode().update(own, messages, (0.0, 0.0, 0.0), 10.0)
        node_ms.append((time.perf_counter() - t0) * 1e3)
        listed = set(own.truth.tolist())
        fused_truth = dict(zip(result.objects.object_id.tolist(), result.objects.truth.tolist(), strict=True))
        for m in result.senders:
            for truth, fid, matched in zip(m.truth.tolist(), m.fused_id.tolist(), m.matched.tolist(), strict=True):
                should += truth in listed
                if matched:
                    pairs += 1
                    correct += fused_truth.get(fid) == truth
            listed |= set(m.truth.tolist())
    fusion = case(fusion_ms)
    return {
        "machine": machine(),
        "senders": senders, "objects": objects, "frames": frames,
        "cases": {"fusion": fusion, "fusion_node": case(node_ms)},
        "matching_precision": round(correct / max(pairs, 1), 4),
        "matching_recall": round(correct / max(should, 1), 4),
        "ratios": {"fusion_over_frame_period": round(fusion["ms_median"] / 100.0, 4)},
    }
