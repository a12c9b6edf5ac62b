"""Tracker lifecycle, association and output tests (10 fps unless stated)."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.tracker import Tracker, TrackerConfig, Tracks, TrackState

PED, CAR = CLASS_ID["pedestrian"], CLASS_ID["car"]


def box(cx: float, cy: float, w: float = 40.0, h: float = 80.0) -> list[float]:
    return [cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2]


def dets(boxes: list[list[float]], score: float | list[float] = 0.9, cls: int | list[int] = PED):
    n = len(boxes)
    return Detections(
        xyxy=np.array(boxes, dtype=float).reshape(-1, 4),
        score=np.broadcast_to(np.asarray(score, dtype=float), (n,)).copy(),
        class_id=np.broadcast_to(np.asarray(cls), (n,)).copy(),
    )


def run_linear(tracker: Tracker, frames: int, x0: float = 100.0, vx: float = 5.0, t0: int = 0):
    """Feed one pedestrian moving vx px/frame; return the outputs."""
    return [tracker.update(dets([box(x0 + vx * (t0 + t), 200.0)])) for t in range(frames)]


def test_tentative_until_min_hits_then_confirmed() -> None:
    tr = Tracker(TrackerConfig(min_hits=3))
    out = run_linear(tr, 3)
    assert [len(o) for o in out] == [0, 0, 1]
    assert tr.num_tracks == 1
    t = out[2]
    assert t.track_id.tolist() == [1]
    assert t.state.tolist() == [TrackState.CONFIRMED]
    assert t.hits.tolist() == [3] and t.age.tolist() == [2]


def test_min_hits_one_confirms_on_birth() -> None:
    tr = Tracker(TrackerConfig(min_hits=1))
    assert len(tr.update(dets([box(100, 100)]))) == 1


def test_tentative_removed_after_misses() -> None:
    tr = Tracker(TrackerConfig(tentative_max_lost_frames=1))
    tr.update(dets([box(100, 200)]))
    tr.update(Detections.empty())  # first miss tolerated
    assert tr.num_tracks == 1
    tr.update(Detections.empty())
    assert tr.num_tracks == 0


def test_lost_then_recovered_within_buffer() -> None:
    tr = Tracker(TrackerConfig(max_lost_s=1.0, output_lost=True, output_lost_s=None), frame_rate=10.0)
    run_linear(tr, 5)
    for t in range(5, 15):  # 10 missed frames = max_lost_s at 10 fps
        out = tr.update(Detections.empty())
        assert out.state.tolist() == [TrackState.LOST]
        assert out.det_index.tolist() == [-1]
        assert out.xyxy[0, 0] == pytest.approx(box(100 + 5 * t, 200)[0], abs=3.0)
    out = tr.update(dets([box(100 + 5 * 15, 200)]))
    assert out.track_id.tolist() == [1]
    assert out.state.tolist() == [TrackState.CONFIRMED]
    assert out.det_index.tolist() == [0]


def test_lost_tracks_output_briefly_by_default() -> None:
    tr = Tracker()  # coasting tracks are output for output_lost_s = 0.2 s: 2 frames at 10 fps
    run_linear(tr, 5)
    for _ in range(2):
        out = tr.update(Detections.empty())
        assert out.state.tolist() == [TrackState.LOST] and out.det_index.tolist() == [-1]
    assert len(tr.update(Detections.empty())) == 0
    assert tr.num_tracks == 1  # still kept (max_lost_s), just not reported
    tr = Tracker(TrackerConfig(output_lost=False))
    run_linear(tr, 5)
    assert len(tr.update(Detections.empty())) == 0


def test_removed_after_max_lost_s() -> None:
    tr = Tracker(TrackerConfig(max_lost_s=0.5), frame_rate=10.0)  # 5 frames
    run_linear(tr, 5)
    for _ in range(6):
        tr.update(Detections.empty())
    assert tr.num_tracks == 0
    out = run_linear(tr, 3, t0=11)
    assert out[-1].track_id.tolist() == [2]


def test_max_lost_converted_with_frame_rate() -> None:
    assert Tracker(TrackerConfig(max_lost_s=1.0), frame_rate=30.0).max_lost_frames == 30


def test_ids_stable_through_five_frame_occlusion() -> None:
    tr = Tracker()
    a = lambda t: box(100 + 6 * t, 200)  # noqa: E731
    b = lambda t: box(900 - 4 * t, 400, 60, 120)  # noqa: E731
    ids = {}
    for t in range(40):
        boxes = [a(t)] + ([] if 15 <= t < 20 else [b(t)])
        out = tr.update(dets(boxes))
        for tid, idx in zip(out.track_id, out.det_index, strict=True):
            if idx >= 0:  # matched this frame (coasting tracks are output too)
                ids.setdefault(int(idx) if len(boxes) == 2 else 0, set()).add(int(tid))
    assert ids == {0: {1}, 1: {2}}


def test_strict_per_class_cross_class_pairs_never_match() -> None:
    tr = Tracker(TrackerConfig(min_hits=1, class_switch_cost=None))
    tr.update(dets([box(300, 300)], cls=PED))
    out = tr.update(dets([box(300, 300)], cls=CAR))
    out = out[out.state == TrackState.CONFIRMED]
    assert out.track_id.tolist() == [2] and out.class_id.tolist() == [CAR]
    assert tr.num_tracks == 2  # the pedestrian track is lost, not taken over


CYC = 1  # cyclist: the class a walking pedestrian is most often mistaken for


def test_class_switch_cost_keeps_the_identity_through_a_class_flicker() -> None:
    flicker = [PED] * 5 + [CYC] * 2 + [PED] * 5
    ids: dict[float | None, set[int]] = {}
    for cost in (None, 0.2):
        tr = Tracker(TrackerConfig(min_hits=1, class_switch_cost=cost))
        ids[cost] = set()
        for t, c in enumerate(flicker):
            out = tr.update(dets([box(100 + 5 * t, 200)], cls=c))
            ids[cost] |= set(out.track_id[out.state == TrackState.CONFIRMED].tolist())
    assert len(ids[None]) >= 2  # strict per-class: a new track at each flip
    assert ids[0.2] == {1}


def test_class_switch_cost_prefers_the_same_class() -> None:
    # two objects 6 px apart (IoU 0.74): as duplicates they would merge, so that is off here
    tr = Tracker(TrackerConfig(min_hits=1, class_switch_cost=0.2, duplicate_iou=None))
    tr.update(dets([box(300, 300), box(330, 300)], cls=[PED, CYC]))
    # both detections overlap both tracks; the cyclist one overlaps the pedestrian track more
    out = tr.update(dets([box(318, 300), box(312, 300)], cls=[PED, CYC]))
    by_det = dict(zip(out.det_index.tolist(), out.track_id.tolist(), strict=True))
    assert by_det == {0: 1, 1: 2}


def test_class_memory_votes_the_class_by_score() -> None:
    tr = Tracker(TrackerConfig(min_hits=1, class_switch_cost=0.2, class_memory=0.9))
    seq = [PED] * 10 + [CYC] * 3
    classes = [int(tr.update(dets([box(100 + 5 * t, 200)], cls=c)).class_id[0]) for t, c in enumerate(seq)]
    assert classes == [PED] * 13  # three cyclist frames do not outvote ten pedestrian ones
    for t in range(13, 40):
        out = tr.update(dets([box(100 + 5 * t, 200)], cls=CYC))
    assert out.class_id.tolist() == [CYC] and out.track_id.tolist() == [1]  # a lasting change wins
    plain = Tracker(TrackerConfig(min_hits=1, class_switch_cost=0.2, class_memory=0.0))
    last = [int(plain.update(dets([box(100 + 5 * t, 200)], cls=c)).class_id[0]) for t, c in enumerate(seq)]
    assert last == seq  # memory 0: the latest detection's class


def test_duplicate_of_another_class_joins_the_track_and_votes_for_its_class() -> None:
    # A cyclist track; then the detector sees the same object twice every frame, as
    # pedestrian 0.4 and cyclist 0.3 (per-class NMS keeps both; both below high_score).
    seen = {}
    for dup in (None, 0.55):
        tr = Tracker(TrackerConfig(min_hits=1, class_switch_cost=0.2, class_memory=0.9, duplicate_iou=dup,
                                   class_hysteresis=1.0))
        ids, classes = set(), []
        for t in range(10):
            out = tr.update(dets([box(100 + 5 * t, 200)], score=0.6, cls=CYC))
        for t in range(10, 30):
            b = box(100 + 5 * t, 200)
            out = tr.update(dets([b, [b[0] + 2, b[1] + 1, b[2] + 2, b[3] + 1]], score=[0.3, 0.4], cls=[CYC, PED]))
            live = out[out.state == TrackState.CONFIRMED]
            ids |= set(live.track_id.tolist())
            classes.append(int(live.class_id[0]))
        seen[dup] = (ids, classes, tr.merged_duplicates)
    ids, classes, merged = seen[None]
    # the class gate picks the cyclist box of the two every frame: the track never changes class
    assert ids == {1} and set(classes) == {CYC} and merged == 0
    ids, classes, merged = seen[0.55]
    assert ids == {1} and merged == 20
    assert classes[0] == CYC and classes[-1] == PED  # both boxes vote: the pedestrian evidence wins


def test_class_hysteresis_holds_the_class_through_near_even_evidence() -> None:
    # the detector alternates between pedestrian and cyclist at the same score
    seq = [(PED, 0.5), (CYC, 0.5)] * 8
    out_classes = {}
    for h in (1.0, 1.25):
        tr = Tracker(TrackerConfig(min_hits=1, class_memory=0.9, class_hysteresis=h))
        out_classes[h] = [int(tr.update(dets([box(100 + 5 * t, 200)], score=s, cls=c)).class_id[0])
                          for t, (c, s) in enumerate(seq)]
    assert out_classes[1.0] == [c for c, _ in seq]  # the plain argmax flips every frame
    assert out_classes[1.25] == [PED] * len(seq)
    tr = Tracker(TrackerConfig(min_hits=1, class_memory=0.9, class_hysteresis=1.25))
    for t in range(30):  # a lasting change still wins
        out = tr.update(dets([box(100 + 5 * t, 200)], cls=PED if t < 5 else CYC))
    assert out.class_id.tolist() == [CYC]


def test_duplicates_do_not_merge_separate_objects() -> None:
    tr = Tracker(TrackerConfig(min_hits=1))
    for _ in range(5):  # side by side, IoU 0.33; and a low-score box on one of them that the tracker ignores
        out = tr.update(dets([box(100, 200), box(120, 200), box(101, 200)], score=[0.9, 0.8, 0.05], cls=[PED, CYC, CAR]))
    assert sorted(out.class_id.tolist()) == [PED, CYC] and tr.merged_duplicates == 0


def test_match_buffer_follows_a_box_that_outruns_its_prediction() -> None:
    # Standing still for five frames, then 28 px to the right at once: IoU with the
    # prediction 12/68 (< match_iou 0.3), but 0.39 with sides buffered by 0.3 of the size.
    ids = {}
    for buffer in (0.0, 0.3):
        tr = Tracker(TrackerConfig(min_hits=1, match_buffer=buffer))
        for _ in range(5):
            tr.update(dets([box(100, 200, 40, 40)]))
        out = tr.update(dets([box(128, 200, 40, 40)]))
        ids[buffer] = out.track_id[out.state == TrackState.CONFIRMED].tolist()
    assert ids[0.0] == [2]  # a new track; the first coasts as lost
    assert ids[0.3] == [1]


def test_pedestrian_and_car_crossing_keep_ids() -> None:
    tr = Tracker()
    seen: dict[int, set[int]] = {PED: set(), CAR: set()}
    for t in range(30):
        ped = box(300 + 8 * t, 300, 40, 90)  # walking right
        car = box(600 - 8 * t, 310, 120, 70)  # driving left, crossing at t ~ 19
        d = dets([ped, car], cls=[PED, CAR])
        if t in (17, 19):
            d = d[np.array([True, False])]  # car missed while overlapping the pedestrian
        out = tr.update(d)
        for tid, c in zip(out.track_id, out.class_id, strict=True):
            seen[int(c)].add(int(tid))
    assert len(seen[PED]) == 1 and len(seen[CAR]) == 1
    assert seen[PED] != seen[CAR]


def test_det_index_points_into_input_detections() -> None:
    rng = np.random.default_rng(0)
    tr = Tracker()
    centres = np.array([[100.0, 100.0], [500.0, 300.0], [900.0, 500.0]])
    for t in range(8):
        boxes = [box(cx + 3 * t, cy) for cx, cy in centres]
        perm = rng.permutation(3)
        rows = [[np.nan, 0, 10, 10]] + [boxes[i] for i in perm] + [box(50, 650)]
        d = dets(rows, score=[0.9, 0.9, 0.9, 0.9, 0.05])
        out = tr.update(d)
    assert len(out) == 3
    assert np.all(out.det_index >= 1) and np.all(out.det_index <= 3)
    np.testing.assert_allclose(out.xyxy, d.xyxy[out.det_index], atol=1.0)
    assert tr.dropped_detections == 8


def test_two_stage_association_keeps_track_through_low_scores() -> None:
    tr = Tracker()
    run_linear(tr, 5)
    for t in range(5, 12):  # partly occluded: score 0.3 in [low_score, high_score)
        out = tr.update(dets([box(100 + 5 * t, 200)], score=0.3))
        assert out.track_id.tolist() == [1]
        assert out.det_index.tolist() == [0]
    out = tr.update(dets([box(100 + 5 * 12, 200)], score=0.9))
    assert out.track_id.tolist() == [1] and out.hits.tolist() == [13]


def test_low_score_detections_never_start_tracks() -> None:
    tr = Tracker(TrackerConfig(min_hits=1))
    for _ in range(5):
        assert len(tr.update(dets([box(100, 100)], score=0.4))) == 0
    assert tr.num_tracks == 0


def test_without_second_stage_low_scores_lose_the_track() -> None:
    tr = Tracker(TrackerConfig(low_score=0.45))  # low band empty (low_score = high_score)
    run_linear(tr, 5)
    out = tr.update(dets([box(125, 200)], score=0.3))
    assert out.state.tolist() == [TrackState.LOST] and out.det_index.tolist() == [-1]


def test_velocity_in_px_per_second() -> None:
    tr = Tracker(frame_rate=10.0)
    out = run_linear(tr, 20, vx=5.0)[-1]
    assert out.velocity_px[0, 0] == pytest.approx(50.0, abs=2.0)
    assert abs(out.velocity_px[0, 1]) < 2.0


def test_reid_recovers_lost_track_by_appearance() -> None:
    cfg = TrackerConfig(reid_weight=0.5)
    feat_a, feat_b = np.eye(8)[0], np.eye(8)[1]
    for use_features, expected in ((True, 1), (False, 3)):
        tr = Tracker(cfg)
        for t in range(4):
            d = dets([box(100 + 2 * t, 200), box(1000, 500)])
            tr.update(d, np.stack([feat_a, feat_b]) if use_features else None)
        for _ in range(3):
            tr.update(dets([box(1000, 500)]), feat_b[None] if use_features else None)
        # Object A reappears far from where it was lost (IoU 0 with its prediction).
        for _ in range(3):
            out = tr.update(
                dets([box(600, 600), box(1000, 500)]),
                np.stack([feat_a, feat_b]) if use_features else None,
            )
        assert out.track_id[out.det_index == 0].tolist() == [expected]


def test_bad_features_are_ignored_not_raised() -> None:
    tr = Tracker(TrackerConfig(reid_weight=0.5, min_hits=1))
    out = tr.update(dets([box(100, 100)]), np.zeros((3, 4)))
    assert len(out) == 1
    out = tr.update(dets([box(100, 100)]), np.full((1, 4), np.nan))
    assert out.track_id.tolist() == [1]


def test_reset_restarts_ids_and_counters() -> None:
    tr = Tracker()
    run_linear(tr, 3)
    tr.update(dets([[0, 0, -1, 5]]))
    assert tr.dropped_detections == 1
    tr.reset()
    assert tr.num_tracks == 0 and tr.dropped_detections == 0
    assert run_linear(tr, 3)[-1].track_id.tolist() == [1]


def test_shrinking_box_predicts_without_degenerating() -> None:
    tr = Tracker(TrackerConfig(output_lost=True))
    for t in range(6):
        w = 60.0 - 10.0 * t
        tr.update(dets([box(300, 300, w, 2 * w)]))
    for _ in range(9):
        out = tr.update(Detections.empty())
        assert np.all(np.isfinite(out.xyxy))
        assert np.all(out.xyxy[:, 2:] > out.xyxy[:, :2])


def test_tracks_struct_of_arrays() -> None:
    tr = Tracker(TrackerConfig(min_hits=1))
    out = tr.update(dets([box(100, 100), box(400, 100)]))
    assert len(out) == 2
    sub = out[out.track_id == 2]
    assert isinstance(sub, Tracks) and len(sub) == 1 and sub.det_index.tolist() == [1]
    d = out.to_dict()
    assert d["state"] == ["confirmed", "confirmed"]
    assert set(d) == {
        "track_id",
        "xyxy",
        "class_id",
        "score",
        "age",
        "hits",
        "state",
        "det_index",
        "velocity_px",
    }
    assert len(Tracks()) == 0


def test_invalid_config_and_frame_rate_raise() -> None:
    with pytest.raises(ValueError, match="min_hits"):
        TrackerConfig(min_hits=0)
    with pytest.raises(ValueError, match="frame_rate"):
        Tracker(frame_rate=0.0)
