"""Property tests: arbitrary (also invalid) input never raises and is counted when dropped."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from lookahead.perception.detections import Detections
from lookahead.perception.tracker import Tracker, TrackerConfig

coord = st.one_of(
    st.floats(-50.0, 1000.0),
    st.sampled_from([np.nan, np.inf, -np.inf, 1e300, -1e300, 1e7]),
    st.floats(allow_nan=True, allow_infinity=True),
)
score = st.one_of(st.floats(0.0, 1.0), st.sampled_from([np.nan, np.inf, -1.0, 2.0]))
row = st.tuples(coord, coord, coord, coord, score, st.integers(0, 2))
frame = st.lists(row, max_size=8)


def _rows_to_dets(rows: list[tuple]) -> Detections:
    a = np.array([r[:5] for r in rows], dtype=float).reshape(-1, 5)
    return Detections(xyxy=a[:, :4], score=a[:, 4], class_id=[r[5] for r in rows])


def _expected_invalid(d: Detections, max_abs: float) -> int:
    b = d.xyxy
    with np.errstate(invalid="ignore", over="ignore"):
        ok = np.all(np.isfinite(b), axis=1) & np.isfinite(d.score)
        ok &= (b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1]) & np.all(np.abs(b) <= max_abs, axis=1)
    return int(np.count_nonzero(~ok))


def _check_output(out, n_dets: int) -> None:
    assert np.all(np.isfinite(out.xyxy))
    assert np.all(out.xyxy[:, 2:] > out.xyxy[:, :2])
    assert np.all(np.isfinite(out.velocity_px))
    assert np.all((out.det_index >= -1) & (out.det_index < n_dets))
    assert len(np.unique(out.track_id)) == len(out)
    assert np.all(out.track_id >= 1)


@settings(max_examples=60, deadline=None)
@given(frames=st.lists(frame, max_size=12), use_features=st.booleans())
def test_arbitrary_frames_never_raise_and_invalid_rows_are_counted(frames, use_features) -> None:
    cfg = TrackerConfig(min_hits=1, reid_weight=0.3 if use_features else 0.0, output_lost=True)
    tracker = Tracker(cfg)
    rng = np.random.default_rng(0)
    expected = 0
    for rows in frames:
        dets = _rows_to_dets(rows)
        feats = None
        if use_features:
            feats = rng.normal(size=(len(dets), 4))
            feats[::3] = np.nan
        expected += _expected_invalid(dets, cfg.max_abs_coord)
        out = tracker.update(dets, feats)
        _check_output(out, len(dets))
    assert tracker.dropped_detections == expected


@settings(max_examples=40, deadline=None)
@given(
    w0=st.floats(1.0, 200.0),
    shrink=st.floats(0.0, 80.0),
    vx=st.floats(-300.0, 300.0),
    coast=st.integers(0, 40),
)
def test_degenerate_predictions_never_crash(w0, shrink, vx, coast) -> None:
    """Boxes shrinking or racing away, then coasting for many frames without detections."""
    tracker = Tracker(TrackerConfig(min_hits=1, max_lost_s=5.0, output_lost=True))
    for t in range(5):
        w = max(w0 - shrink * t, 0.5)
        x = 500.0 + vx * t
        tracker.update(
            Detections(xyxy=[[x, 100.0, x + w, 100.0 + 2 * w]], score=[0.9], class_id=[0])
        )
    for _ in range(coast):
        _check_output(tracker.update(Detections.empty()), 0)
    assert tracker.dropped_detections == 0


def test_empty_frames_only() -> None:
    tracker = Tracker()
    for _ in range(5):
        assert len(tracker.update(Detections.empty())) == 0
    assert tracker.dropped_detections == 0
