"""The tracker's batched Kalman filter against filterpy's ``KalmanFilter``, one filter per track.

The reference builds F, H, Q, R itself (as the tracker documents them) and runs
filterpy's ``predict``/``update`` per filter; the batched code must agree to 1e-9.
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from lookahead.perception.detections import Detections
from lookahead.perception.geometry import iou_matrix
from lookahead.perception.tracker import (
    _MIN_SIZE_PX,
    _STATE_TO_XYXY,
    KF_F,
    KF_H,
    Tracker,
    TrackerConfig,
    _cxcywh,
    _iou,
    box_block_initial_state,
    box_filters_predict,
    box_filters_update,
    box_predict,
    box_update,
    cxcywh_to_xyxy,
    kf_block,
    kf_initial_state,
    kf_measurement_noise,
    kf_predict,
    kf_process_noise,
    kf_unblock,
    kf_update,
    xyxy_to_cxcywh,
)

TOL = {"rtol": 1e-9, "atol": 1e-9}
WP, WC, WV, V0 = 1.0 / 20.0, 0.05, 1.0 / 80.0, 0.5
Q_WEIGHTS = np.array([WP] * 4 + [WC, WC, WV, WV])
P_WEIGHTS = np.array([2.0 * WP] * 4 + [V0] * 4)

F = np.block([[np.eye(4), np.eye(4)], [np.zeros((4, 4)), np.eye(4)]])
H = np.hstack([np.eye(4), np.zeros((4, 4))])


class RefBox:
    """The per-track box filter: filterpy ``KalmanFilter`` with size-scaled Q and R and the size guards."""

    def __init__(self, cxcywh: np.ndarray) -> None:
        self.kf = KalmanFilter(dim_x=8, dim_z=4)
        self.kf.F, self.kf.H = F.copy(), H.copy()
        self.kf.x = np.concatenate([cxcywh, np.zeros(4)]).reshape(8, 1)
        w, h = cxcywh[2], cxcywh[3]
        size = np.array([w, h, w, h])
        self.kf.P = np.diag(np.concatenate([2.0 * WP * size, V0 * size]) ** 2)
        self.hits = 1

    def _size(self) -> np.ndarray:
        w, h = np.maximum(self.kf.x[2:4, 0], 1.0)
        return np.array([w, h, w, h])

    def predict(self) -> None:
        x = self.kf.x
        for i in (2, 3):
            if x[i, 0] + x[i + 4, 0] <= _MIN_SIZE_PX:
                x[i + 4, 0] = 0.0
        size = self._size()
        self.kf.Q = np.diag(np.concatenate([WP * size, np.array([WC, WC, WV, WV]) * size]) ** 2)
        self.kf.predict()
        self.kf.x[2:4, 0] = np.maximum(self.kf.x[2:4, 0], _MIN_SIZE_PX)

    def update(self, cxcywh: np.ndarray) -> None:
        self.kf.R = np.diag((WP * self._size()) ** 2)
        self.kf.update(cxcywh.reshape(4, 1))
        self.kf.x[2:4, 0] = np.maximum(self.kf.x[2:4, 0], _MIN_SIZE_PX)
        self.hits += 1


def random_boxes(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.column_stack([rng.uniform(0, 1000, (n, 2)), rng.uniform(2.0, 300.0, (n, 2))])



def noisy_sightings(rng: np.random.Generator, boxes: np.ndarray, frames: int = 60):
    """Per frame, the rows seen (60 %) and their noisy cxcywh boxes, for boxes moving at random
    rates; the first three shrink and are seen for 5 frames only, then coast (the size guards)."""
    n = len(boxes)
    rate = np.column_stack([rng.normal(0, 8, (n, 2)), rng.normal(0, 3, (n, 2))])
    rate[:3, 2:] = -boxes[:3, 2:] / 6.0
    truth = boxes.copy()
    for t in range(frames):
        truth += rate
        truth[:, 2:] = np.maximum(truth[:, 2:], 0.5)
        seen = rng.random(n) < 0.6
        seen[:3] = t < 5
        rows = np.flatnonzero(seen)
        z = truth[rows] + rng.normal(0, 2, (len(rows), 4))
        z[:, 2:] = np.abs(z[:, 2:]) + 0.1
        yield rows, z

def test_fast_box_helpers_are_bit_identical() -> None:
    """The tracker's internal box conversions and IoU give exactly the public helpers' results."""
    rng = np.random.default_rng(3)
    x = np.column_stack([random_boxes(rng, 200), rng.normal(size=(200, 4))])
    x[:5, 2:4] = _MIN_SIZE_PX  # tiny boxes
    x[5:10, :2] = rng.uniform(-1e6, 1e6, (5, 2))  # far out
    tracks = x @ _STATE_TO_XYXY
    np.testing.assert_array_equal(tracks, cxcywh_to_xyxy(x[:, :4]))
    dets = cxcywh_to_xyxy(random_boxes(rng, 50))
    dets[:10] = tracks[:10]  # identical boxes
    dets[10:12, 2:] = dets[10:12, :2] + 1e-300  # (nearly) zero area
    meas = _cxcywh(dets)
    np.testing.assert_array_equal(meas, xyxy_to_cxcywh(dets))
    np.testing.assert_array_equal(_iou(tracks, dets, meas[:, 2] * meas[:, 3]), iou_matrix(tracks, dets))


def test_matrices_are_the_documented_ones() -> None:
    np.testing.assert_array_equal(KF_F, F)
    np.testing.assert_array_equal(KF_H, H)
    x = np.array([[10.0, 20.0, 40.0, 0.5, 1, 2, 3, 4]])
    size = np.array([40.0, 1.0] * 4)  # sizes floored at 1 px
    np.testing.assert_array_equal(kf_process_noise(x, Q_WEIGHTS), (Q_WEIGHTS * size)[None] ** 2)
    np.testing.assert_array_equal(kf_measurement_noise(x, WP), (WP * size[:4])[None] ** 2)


@pytest.mark.parametrize("seed", range(5))
def test_generic_predict_update_match_filterpy(seed: int) -> None:
    """kf_predict / kf_update with arbitrary diagonal Q, R and a random subset updated each step."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 12))
    x = rng.normal(0, 50, (n, 8))
    A = rng.normal(size=(n, 8, 8))
    P = A @ A.transpose(0, 2, 1) + np.eye(8)
    refs = []
    for i in range(n):
        kf = KalmanFilter(dim_x=8, dim_z=4)
        kf.F, kf.H, kf.x, kf.P = F.copy(), H.copy(), x[i].reshape(8, 1).copy(), P[i].copy()
        refs.append(kf)
    for _ in range(40):
        q = rng.uniform(0.01, 5.0, (n, 8))
        kf_predict(x, P, q)
        for kf, qi in zip(refs, q, strict=True):
            kf.predict(Q=np.diag(qi))
        rows = np.flatnonzero(rng.random(n) < 0.7)
        z = x[rows, :4] + rng.normal(0, 3, (len(rows), 4))
        r = rng.uniform(0.1, 10.0, (len(rows), 4))
        if len(rows):
            x[rows], P[rows] = kf_update(x[rows], P[rows], z, r)
        for j, i in enumerate(rows):
            refs[i].update(z[j].reshape(4, 1), R=np.diag(r[j]))
        np.testing.assert_allclose(x, np.array([kf.x[:, 0] for kf in refs]), **TOL)
        np.testing.assert_allclose(P, np.array([kf.P for kf in refs]), **TOL)


@pytest.mark.parametrize("seed", range(5))
def test_box_filter_matches_filterpy_per_track(seed: int) -> None:
    """The tracker's box steps (size guards, size-scaled Q and R) against filterpy per track."""
    rng = np.random.default_rng(100 + seed)
    n = 10
    boxes = random_boxes(rng, n)
    x, P = kf_initial_state(boxes, P_WEIGHTS)
    refs = [RefBox(b) for b in boxes]
    np.testing.assert_array_equal(x, np.array([r.kf.x[:, 0] for r in refs]))
    np.testing.assert_array_equal(P, np.array([r.kf.P for r in refs]))
    for rows, z in noisy_sightings(rng, boxes):
        box_predict(x, P, Q_WEIGHTS)
        for r in refs:
            r.predict()
        if len(rows):
            x[rows], P[rows] = box_update(x[rows], P[rows], z, WP)
        for j, i in enumerate(rows):
            refs[i].update(z[j])
        np.testing.assert_allclose(x, np.array([r.kf.x[:, 0] for r in refs]), **TOL)
        np.testing.assert_allclose(P, np.array([r.kf.P for r in refs]), **TOL)
    assert np.all(x[:, 2:4] >= _MIN_SIZE_PX)
    assert np.count_nonzero(x[:3, 6:8] == 0.0) >= 2  # coasting, shrunk boxes had size rates zeroed


def test_tracker_outputs_follow_per_track_filterpy() -> None:
    """Many well-separated objects (more than the initial table capacity) with dropouts: births,
    lost tracks, removals and re-births; every matched output box is its own filterpy filter's state."""
    rng = np.random.default_rng(7)
    k = 40
    start = np.column_stack([np.arange(k) % 8 * 150.0 + 60, np.arange(k) // 8 * 150.0 + 60])
    size = rng.uniform(20.0, 60.0, (k, 2))
    vel = rng.uniform(-0.4, 0.4, (k, 2))  # boxes never come near each other
    cfg = TrackerConfig(std_weight_accel=WC * 10.0**2, max_lost_s=0.3, output_lost=False)
    tracker = Tracker(cfg, frame_rate=10.0)
    refs: dict[int, RefBox] = {}  # object -> reference filter of its current track
    last_seen = np.full(k, -100)
    for t in range(80):
        for r in refs.values():
            r.predict()
        seen = rng.random(k) < (0.3 if 20 <= t < 30 else 0.9)
        c = start + vel * t + rng.normal(0, 1.0, (k, 2))
        cxcywh = np.column_stack([c, size])[seen]
        obj = np.flatnonzero(seen)
        xyxy = np.column_stack([cxcywh[:, :2] - cxcywh[:, 2:] / 2, cxcywh[:, :2] + cxcywh[:, 2:] / 2])
        perm = rng.permutation(len(obj))
        out = tracker.update(Detections(xyxy=xyxy[perm], score=np.full(len(obj), 0.9), class_id=np.zeros(len(obj))))
        det_obj = obj[perm]
        for o in obj:
            # Missed frames a track survives: tentative (one hit) 1, confirmed max_lost_frames;
            # it is matched again if seen on the frame after the last one it survives.
            if o in refs:
                limit = tracker.max_lost_frames if refs[o].hits >= cfg.min_hits else cfg.tentative_max_lost_frames
                if t - last_seen[o] > limit + 1:
                    del refs[o]  # its track was removed; this detection starts a new one
        for d, o in enumerate(det_obj):
            box = xyxy[perm][d]
            z = np.concatenate([(box[:2] + box[2:]) / 2, box[2:] - box[:2]])
            if o in refs:
                refs[o].update(z)
            else:
                refs[o] = RefBox(z)
        last_seen[obj] = t
        assert len(np.unique(out.track_id)) == len(out)
        for i, d in zip(range(len(out)), out.det_index, strict=True):
            ref = refs[det_obj[d]].kf
            c, wh = ref.x[:2, 0], ref.x[2:4, 0]
            np.testing.assert_allclose(out.xyxy[i], np.concatenate([c - wh / 2, c + wh / 2]), **TOL)
            np.testing.assert_allclose(out.velocity_px[i], ref.x[4:, 0] * 10.0, **TOL)
    assert tracker.num_tracks > 16  # the track table grew past its initial capacity


@pytest.mark.parametrize("seed", range(3))
def test_block_filters_are_bit_identical_to_box_filters(seed: int) -> None:
    """The tracker's filters (covariance blocks, one filter per column) give exactly the results of
    box_predict / box_update on full (8, 8) covariances, size guards included."""
    rng = np.random.default_rng(200 + seed)
    n = 12
    boxes = random_boxes(rng, n)
    x, P = kf_initial_state(boxes, P_WEIGHTS)
    xb, Pb = box_block_initial_state(boxes, P_WEIGHTS)
    np.testing.assert_array_equal(xb, x)
    np.testing.assert_array_equal(kf_unblock(Pb), P)
    np.testing.assert_array_equal(kf_block(P), Pb)
    T = np.concatenate([xb, Pb.reshape(n, 16)], axis=1).T.copy()  # filters as columns
    for rows, z in noisy_sightings(rng, boxes):
        box_predict(x, P, Q_WEIGHTS)
        box_filters_predict(T, Q_WEIGHTS)
        np.testing.assert_array_equal(T[:8].T, x)
        np.testing.assert_array_equal(kf_unblock(T[8:].T.reshape(n, 2, 2, 4)), P)
        if len(rows):
            x[rows], P[rows] = box_update(x[rows], P[rows], z, WP)
            cols = T[:, rows]
            box_filters_update(cols, z.T.copy(), WP)
            T[:, rows] = cols
        np.testing.assert_array_equal(T[:8].T, x)
        np.testing.assert_array_equal(kf_unblock(T[8:].T.reshape(n, 2, 2, 4)), P)
    assert np.count_nonzero(x[:3, 6:8] == 0.0) >= 2  # the size guards acted


def test_cxcywh_from_a_transposed_copy() -> None:
    rng = np.random.default_rng(5)
    dets = cxcywh_to_xyxy(random_boxes(rng, 20))
    np.testing.assert_array_equal(_cxcywh(dets, dets.T.copy()), xyxy_to_cxcywh(dets))


def test_copied_tracker_continues_like_the_original() -> None:
    """A pickled or deep-copied tracker (galleries and anchors included) carries on exactly as the
    original: its views into the track arrays are remade, not copied apart."""
    rng = np.random.default_rng(11)
    k = 6
    centre = rng.uniform(100.0, 900.0, (k, 2))
    size = rng.uniform(20.0, 60.0, (k, 2))
    feats = rng.normal(size=(k, 8))

    def frame(t: int) -> tuple[Detections, np.ndarray]:
        seen = np.flatnonzero(rng.random(k) < 0.8)
        c = centre[seen] + t * 2.0 + rng.normal(0, 1.0, (len(seen), 2))
        xyxy = np.column_stack([c - size[seen] / 2, c + size[seen] / 2])
        return Detections(xyxy=xyxy, score=np.full(len(seen), 0.9), class_id=np.zeros(len(seen))), feats[seen]

    tracker = Tracker(TrackerConfig(), frame_rate=10.0)
    for t in range(30):
        tracker.update(*frame(t))
    copies = [copy.deepcopy(tracker), pickle.loads(pickle.dumps(tracker))]
    for t in range(30, 60):
        dets, f = frame(t)
        out = tracker.update(dets, f)
        for c in copies:
            got = c.update(dets, f)
            np.testing.assert_array_equal(got.track_id, out.track_id)
            np.testing.assert_array_equal(got.xyxy, out.xyxy)
