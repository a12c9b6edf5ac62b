"""Re-identification after occlusion (issue 33): appearance galleries, the motion-gated re-id
stage and the feature requests (``Tracker.features_needed`` / ``wants_features``); 10 fps.

Features are synthetic: one random unit vector per identity plus a little noise."""

from __future__ import annotations

import numpy as np
import pytest

from lookahead.perception.detections import CLASS_ID, Detections
from lookahead.perception.tracker import Tracker, TrackerConfig, Tracks, TrackState

PED, CAR = CLASS_ID["pedestrian"], CLASS_ID["car"]
DIM = 32


class Identities:
    """Noisy unit features per identity, from a seeded generator."""

    def __init__(self, k: int = 4, noise: float = 0.05, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)
        c = self.rng.normal(size=(k, DIM))
        self.centres = c / np.linalg.norm(c, axis=1, keepdims=True)
        self.noise = noise

    def __call__(self, ids: list[int]) -> np.ndarray:
        f = self.centres[ids] + self.rng.normal(0.0, self.noise, (len(ids), DIM))
        return (f / np.linalg.norm(f, axis=1, keepdims=True)).astype(np.float32).reshape(-1, DIM)


def box(cx: float, cy: float, w: float = 40.0, h: float = 80.0) -> list[float]:
    return [cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2]


def dets(boxes: list[list[float]], cls: int | list[int] = PED, score: float = 0.9) -> Detections:
    n = len(boxes)
    return Detections(
        xyxy=np.array(boxes, dtype=float).reshape(-1, 4),
        score=np.full(n, score),
        class_id=np.broadcast_to(np.asarray(cls), (n,)).copy(),
    )


def occlusion(hide: int, start: int = 10, frames: int = 70, vx: float = 4.0, back: int = 0, cls: int = PED):
    """A walks right vx px/frame and is not detected for ``hide`` frames from ``start``, then
    comes back (identity ``back``); B stands still. Yields (boxes, identities, classes)."""
    for t in range(frames):
        a, b = box(100 + vx * t, 200), box(700, 220)
        if start <= t < start + hide:
            yield [b], [1], [PED]
        else:
            yield [a, b], [0 if t < start else back, 1], [PED if t < start else cls, PED]


def run(tracker: Tracker, seq, feats: Identities | None, mode: str = "all") -> tuple[list[Tracks], int]:
    """Feed ``seq``; features for every detection ("all"), none, or only where the tracker asks
    ("asked": ``features_needed``, NaN rows elsewhere). Returns the outputs and the frames embedded."""
    outs, embedded = [], 0
    for boxes, ids, cls in seq:
        d = dets(boxes, cls)
        f = None
        if feats is not None:
            f = feats(ids)
            if mode == "asked":
                need = tracker.features_needed(d)
                if np.count_nonzero(need):
                    embedded += 1
                    f[~need] = np.nan
                else:
                    f = None
        outs.append(tracker.update(d, f))
    return outs, embedded


def id_of(out: Tracks, det_row: int) -> int:
    ids = out.track_id[out.det_index == det_row].tolist()
    assert len(ids) == 1, out.to_dict()
    return ids[0]


@pytest.mark.parametrize("hide", [12, 15, 20, 25])
def test_hidden_object_keeps_its_id_age_and_hits(hide: int) -> None:
    """Hidden 1.2-2.5 s (longer than max_lost_s, 1 s), A comes back where its track predicts it."""
    back = 10 + hide
    outs, _ = run(Tracker(), occlusion(hide), Identities())
    before, after = outs[9], outs[back]
    a = id_of(before, 0)
    assert id_of(after, 0) == a
    row = after.det_index == 0
    assert after.state[row].tolist() == [TrackState.CONFIRMED]
    assert after.age[row].tolist() == [back]  # born on frame 0: age continues through the gap
    assert after.hits[row].tolist() == [before.hits[before.det_index == 0][0] + 1]
    assert after.velocity_px[row, 0][0] == pytest.approx(40.0, abs=8.0)  # 4 px/frame at 10 fps
    assert id_of(outs[-1], 0) == a and id_of(outs[-1], 1) == id_of(before, 1)
    # Without features the track is deleted after max_lost_s and A comes back as a new object.
    plain, _ = run(Tracker(), occlusion(hide), None)
    assert id_of(plain[back + 1], 0) not in (id_of(plain[9], 0), id_of(plain[9], 1))


def test_hidden_track_is_not_output_and_expires_after_reid_max_lost_s() -> None:
    tr = Tracker(TrackerConfig(reid_max_lost_s=2.0))
    outs, _ = run(tr, occlusion(hide=25), Identities())
    assert [len(o) for o in outs[12:35]] == [1] * 23  # B only: A coasts unreported (output_lost_s 0.2)
    assert id_of(outs[36], 0) not in (1, 2)  # gone after 2 s: a new track (confirmed on its second hit)
    assert tr.reidentifications == 0


def test_reappearing_with_another_identity_gets_a_new_id() -> None:
    outs, _ = run(Tracker(), occlusion(hide=15, back=2), Identities())
    assert id_of(outs[26], 0) not in (1, 2)


def test_reappearing_outside_the_motion_gate_gets_a_new_id() -> None:
    """Right feature, wrong place: 400 px right of, 300 px below the prediction after 1.5 s."""
    seq = [(([box(b[0][0] + 420, 500)] + b[1:], i, c) if len(b) == 2 and t >= 25 else (b, i, c))
           for t, (b, i, c) in enumerate(occlusion(hide=15))]
    outs, _ = run(Tracker(), seq, Identities())
    assert id_of(outs[26], 0) not in (1, 2)


def test_reappearing_as_another_class_gets_a_new_id_without_class_switch_cost() -> None:
    seq = list(occlusion(hide=15, cls=CAR))
    outs, _ = run(Tracker(TrackerConfig(class_switch_cost=None)), seq, Identities())
    assert id_of(outs[26], 0) not in (1, 2)


def test_crossing_objects_keep_ids_with_features_and_swap_without() -> None:
    """Two pedestrians meet and turn back: the constant-velocity predictions carry each track
    onto the other object, so IoU alone swaps the ids; appearance in stage 1 keeps them."""
    seq = []
    for t in range(60):
        s = t if t <= 30 else 60 - t
        seq.append(([box(300 + 6 * s, 200), box(660 - 6 * s, 204)], [0, 1], [PED, PED]))
    cfg = TrackerConfig(reid_weight=0.5)
    with_f, _ = run(Tracker(cfg), seq, Identities())
    asked, embedded = run(Tracker(cfg), seq, Identities(), mode="asked")
    without, _ = run(Tracker(cfg), seq, None)
    start = [id_of(with_f[5], 0), id_of(with_f[5], 1)]
    assert [id_of(with_f[-1], 0), id_of(with_f[-1], 1)] == start
    assert [id_of(asked[-1], 0), id_of(asked[-1], 1)] == start
    assert [id_of(without[-1], 0), id_of(without[-1], 1)] == start[::-1]  # swapped
    assert embedded < 20  # the meeting frames and the refreshes, not all 60


def test_features_only_when_asked_give_the_same_tracks() -> None:
    seq = list(occlusion(hide=20))
    always, _ = run(Tracker(), seq, Identities())
    asked, embedded = run(Tracker(), seq, Identities(), mode="asked")
    assert [o.track_id.tolist() for o in asked] == [o.track_id.tolist() for o in always]
    assert embedded <= 12, embedded  # of 70 frames: refreshes every 1 s and the frames after A reappears


def test_without_features_reid_changes_nothing() -> None:
    """features=None: the re-id settings are inert and no gallery exists."""
    rng = np.random.default_rng(3)
    frames = []
    for t in range(80):
        k = rng.integers(0, 6)
        xy = rng.uniform(0, 600, (k, 2)) + 3 * t
        frames.append(Detections(xyxy=np.hstack([xy, xy + rng.uniform(10, 80, (k, 2))]),
                                 score=rng.uniform(0.05, 1.0, k), class_id=rng.integers(0, 3, k)))
    configs = [TrackerConfig(gallery_size=0), TrackerConfig(), TrackerConfig(reid_max_lost_s=10.0, gallery_size=50,
                                                                             reid_max_distance=2.0, reid_gate=1e9)]
    runs = []
    for cfg in configs:
        tr = Tracker(cfg)
        runs.append([tr.update(d).to_dict() for d in frames])
        assert tr._gal is None and tr.reidentifications == 0
    assert runs[0] == runs[1] == runs[2]
    # Features passed with appearance off (gallery_size 0, reid_weight 0) are ignored.
    tr = Tracker(TrackerConfig(gallery_size=0))
    assert [tr.update(d, np.ones((len(d), 4))).to_dict() for d in frames] == runs[0]


def test_gallery_is_bounded_and_keeps_the_latest_features() -> None:
    ids = Identities()
    tr = Tracker(TrackerConfig(gallery_size=3, min_hits=1))
    given = []
    for t in range(12):
        f = ids([0])
        given.append(f[0])
        tr.update(dets([box(100 + 2 * t, 200)]), f)
    assert tr._gal.shape[1:] == (3, DIM)
    count, head, _ = tr._gal_meta[0]
    assert count == 3
    stored = np.roll(tr._gal[0], -head, axis=0)  # oldest first
    np.testing.assert_allclose(stored, np.array(given[-3:]), atol=1e-6)


def test_occluded_or_low_score_detections_do_not_enter_the_gallery() -> None:
    ids = Identities()
    tr = Tracker(TrackerConfig(min_hits=1, gallery_max_overlap=0.2))
    tr.update(dets([box(100, 200), box(400, 200)]), ids([0, 1]))
    assert tr._gal_meta[:2, 0].tolist() == [1, 1]
    tr.update(dets([box(100, 200), box(410, 200), box(430, 210)]), ids([0, 1, 2]))  # 1 and 2 overlap
    assert tr._gal_meta[:2, 0].tolist() == [2, 1]
    tr.update(dets([box(100, 200)], score=0.3), ids([0]))  # low score: stage 2, no gallery entry
    assert tr._gal_meta[0, 0] == 2


def test_wants_features_for_gallery_refresh() -> None:
    ids = Identities()
    tr = Tracker()  # gallery_refresh_s 1.0: every 10 frames
    seq = list(occlusion(hide=20, start=40))
    assert not tr.wants_features(dets(seq[0][0]))  # no tracks
    run(tr, seq[:1], None)
    assert not tr.wants_features(dets(seq[1][0]))  # tentative tracks only
    run(tr, seq[1:2], None)  # confirmed, no gallery yet
    assert tr.features_needed(dets(seq[2][0])).tolist() == [True, True]
    run(tr, seq[2:3], ids)
    for t in range(3, 12):  # easy frames: fresh galleries, nothing lost, no ambiguity
        assert not tr.wants_features(dets(seq[t][0]))
        run(tr, seq[t : t + 1], None)
    assert tr.features_needed(dets(seq[12][0])).tolist() == [True, True]  # 1 s old


def test_wants_features_for_a_lost_track_with_a_gallery() -> None:
    ids = Identities()
    tr = Tracker(TrackerConfig(gallery_refresh_s=1e3))  # no refreshes after the first features
    seq = list(occlusion(hide=20))
    run(tr, seq[:10], ids)
    assert not tr.wants_features(dets(seq[10][0]))  # A hidden, not yet lost
    run(tr, seq[10:11], None)
    for t in range(11, 30):  # A lost with a gallery, hidden: B's detection is IoU-matched, not needed
        assert tr.features_needed(dets(seq[t][0])).tolist() == [False]
        run(tr, seq[t : t + 1], None)
    back = dets(seq[30][0])  # A back at its prediction: a re-id candidate; B's detection is not
    assert tr.features_needed(back).tolist() == [True, False]
    assert id_of(tr.update(back, ids([0, 1])), 0) == 1
    # Far from A's prediction: not a candidate.
    tr2 = Tracker(TrackerConfig(gallery_refresh_s=1e3))
    run(tr2, seq[:30], ids)
    assert tr2.features_needed(dets([box(900, 600), box(700, 220)])).tolist() == [False, False]


def test_wants_features_flags_ambiguous_matches_with_reid_weight() -> None:
    ids = Identities()
    for w, expected in ((0.5, [True, True]), (0.0, [False, False])):
        tr = Tracker(TrackerConfig(reid_weight=w))
        run(tr, [([box(100, 200), box(300, 200)], [0, 1], [PED, PED])] * 3, ids)
        assert tr.features_needed(dets([box(100, 200), box(300, 200)])).tolist() == [False, False]
        assert tr.features_needed(dets([box(100, 200), box(115, 205)])).tolist() == expected


# --------------------------------------------- reappearance seen partly first, spoilt predictions, veto
def near(centre: np.ndarray, dist: float, seed: int = 1) -> np.ndarray:
    """A unit vector at cosine distance ``dist`` from the unit vector ``centre``."""
    r = np.random.default_rng(seed).normal(size=centre.shape)
    r -= (r @ centre) * centre
    r /= np.linalg.norm(r)
    return (1.0 - dist) * centre + np.sqrt(1.0 - (1.0 - dist) ** 2) * r


def test_reappearance_first_unrecognised_is_merged_back_into_the_lost_track() -> None:
    """A comes back half hidden with an unrecognisable feature (identity 3): that detection starts a
    tentative track. On the next frame, seen whole, the lost track takes the detection over: A keeps
    its id, the tentative track is dropped unconfirmed and unreported, and no id is spent on it."""
    seq = list(occlusion(hide=15))
    a_back = seq[25][0][0]
    seq[25] = ([[a_back[0], a_back[1], a_back[0] + 20, a_back[3]]] + seq[25][0][1:], [3, 1], [PED, PED])
    seq.append(([box(400, 500)] + seq[-1][0], [2] + seq[-1][1], [PED] + seq[-1][2]))  # a newcomer, for its id
    seq.append(seq[-1])
    for mode in ("all", "asked"):
        tr = Tracker()
        outs, _ = run(tr, seq, Identities(), mode=mode)
        a, b = id_of(outs[9], 0), id_of(outs[9], 1)
        assert sorted(outs[25].track_id.tolist()) == [b]  # the tentative track is not output
        assert tr.reidentifications == 1
        assert id_of(outs[26], 0) == a
        assert outs[26].hits[outs[26].det_index == 0].tolist() == [outs[9].hits[outs[9].det_index == 0][0] + 1]
        assert sorted(outs[-1].track_id.tolist()) == [1, 2, 3]  # the newcomer: the next id, none was skipped
    # Without features A comes back as a new object.
    plain, _ = run(Tracker(), seq[:27], None)
    assert id_of(plain[26], 0) not in (1, 2)


def test_box_shrinking_behind_an_occluder_does_not_spoil_the_reid_gate() -> None:
    """A walks behind an occluder: for a few frames only its shrinking visible part is detected,
    which drives the filter's width (and its covariance) towards zero. Coming out at full size it
    is far outside the gate of that prediction, but inside the gate of the anchor (the filter as it
    was at its last gallery feature, predicted since): re-identified, asked for, and the track
    continues from the anchor's state (full width, walking speed)."""
    edge, seq = 150.0, []
    for t in range(60):
        x1, x2 = 80 + 4 * t, 120 + 4 * t
        b = [box(700, 220)]
        ids = [1]
        if t < 22 and min(x2, edge) - x1 >= 4:
            b.insert(0, [x1, 160, min(x2, edge), 240])
            ids.insert(0, 0 if x2 <= edge else 3)  # partial views: another (unrecognisable) look
        elif t >= 32:
            b.insert(0, [x1, 160, x2, 240])
            ids.insert(0, 0)
        seq.append((b, ids, [PED] * len(b)))
    for mode in ("all", "asked"):
        tr = Tracker()
        outs, _ = run(tr, seq, Identities(), mode=mode)
        a = id_of(outs[5], 0)
        assert id_of(outs[32], 0) == a and id_of(outs[-1], 0) == a
        row = outs[33].det_index == 0
        assert outs[33].xyxy[row, 2][0] - outs[33].xyxy[row, 0][0] == pytest.approx(40.0, abs=4.0)
        assert outs[40].velocity_px[outs[40].det_index == 0, 0][0] == pytest.approx(40.0, abs=10.0)
        assert tr.reidentifications == 1


def test_appearance_veto_keeps_a_lost_track_from_taking_another_objects_detection() -> None:
    """A (lost, hidden) and B (standing at 300 px) look alike: their features are 0.2 apart, under
    reid_max_distance (0.3). B's detection on frame 25 is displaced (the detector boxes only part of
    it) beyond B's track's reach, onto A's predicted path. Jointly B's track is no candidate (it only
    just missed), and A's gallery would accept the feature -- but it is nearer to B's gallery: vetoed."""
    ids = Identities(noise=0.01)
    ids.centres[1] = near(ids.centres[0], 0.2)
    seq = []
    for t in range(30):
        a, b = box(100 + 4 * t, 200), box(300, 200)
        if t < 10:
            seq.append(([a, b], [0, 1], [PED, PED]))
        elif t == 25:  # A lost for 1.5 s: the re-id stage only
            seq.append(([box(215, 200)], [1], [PED]))  # B's look, near A's prediction (200, 200)
        else:
            seq.append(([b], [1], [PED]))
    tr = Tracker()
    outs, _ = run(tr, seq[:26], ids)
    a, b = id_of(outs[9], 0), id_of(outs[9], 1)
    assert len(outs[25]) == 1 and outs[25].track_id.tolist() == [b]  # B coasting; nothing took the detection
    assert tr.reidentifications == 0
    # The control: without B's track (B never seen before), A takes that detection back.
    solo = [([bx[0]], [i[0]], [c[0]]) if t < 10 else ([], [], []) for t, (bx, i, c) in enumerate(seq[:25])]
    tr = Tracker()
    outs, _ = run(tr, solo + [seq[25]], ids)
    assert id_of(outs[25], 0) == a and tr.reidentifications == 1


def test_partial_view_of_another_class_is_reidentified_and_keeps_the_class() -> None:
    """The detector often names a reappearing object's first, partial views wrongly (a car's front as a
    tricycle). A comes back as a "cyclist" that looks 0.15 from its gallery (0.15 + class_switch_cost 0.2
    is over reid_max_distance, 0.3). Coming out from behind O -- its box overlaps O's detection, whose
    bottom edge is lower (O is in front) -- it is a partial view: the distance alone decides, and A keeps
    its id and its class (its votes, not one detection's). Seen whole (no O), or without class switches
    (class_switch_cost null), another class's look-alike is another object."""
    ids = Identities(noise=0.01)
    ids.centres[3] = near(ids.centres[0], 0.15)
    base = list(occlusion(hide=15, back=3, cls=CLASS_ID["cyclist"]))
    occluder = [130.0, 100.0, 185.0, 260.0]  # A's box on frame 25 is [180, 160, 220, 240]
    seq = [(b + [occluder], i + [2], c + [CAR]) for b, i, c in base]
    tr = Tracker()
    outs, _ = run(tr, seq, ids)
    a = id_of(outs[5], 0)
    assert id_of(outs[25], 0) == a and tr.reidentifications == 1
    assert outs[25].class_id[outs[25].det_index == 0].tolist() == [PED]
    for tracker, s in ((Tracker(), base), (Tracker(TrackerConfig(class_switch_cost=None)), seq)):
        outs, _ = run(tracker, s, ids)
        assert id_of(outs[26], 0) != a and tracker.reidentifications == 0


def passing(frames: int = 50):
    """A (far: bottom edge 230) stands; B (nearer: bottom edge 244), as wide, drives left in front of it
    at 6 px/frame. While B overlaps A the detector sees one box spanning both, placed like A's; for a
    few frames B hides A wholly. Yields (boxes, identities, classes)."""
    a = [280.0, 170.0, 320.0, 230.0]
    for t in range(frames):
        cx = 420.0 - 6.0 * t
        b = [cx - 24.0, 184.0, cx + 24.0, 244.0]
        if min(a[2], b[2]) <= max(a[0], b[0]):
            yield [a, b], [0, 1], [CAR, CAR]
        elif b[0] <= a[0] and b[2] >= a[2]:
            yield [b], [1], [CAR]
        else:
            yield [[min(a[0], b[0]) + 2.0, 172.0, max(a[2], b[2]) - 2.0, 232.0]], [1], [CAR]


def test_one_detection_of_two_overlapping_objects_goes_to_the_nearer() -> None:
    """B passes in front of A and the detector boxes the two as one. By (buffered) IoU alone -- stage 1's
    one pass with appearance -- A's (standing) track takes that box and then follows B: the ids swap. With appearance on, the occlusion cost gives it to the
    track in front -- B's: lower bottom edge, then seen while A's is not -- A's track waits, lost, and
    A keeps its id when it comes out."""
    seq = list(passing())
    for mode in ("all", "asked"):
        outs, _ = run(Tracker(), seq, Identities(), mode=mode)
        a, b = id_of(outs[9], 0), id_of(outs[9], 1)
        assert all(id_of(outs[t], len(seq[t][1]) - 1) == b for t in range(12, 50)), mode  # B's detection
        assert id_of(outs[-1], 0) == a
    # Without appearance the tight-first association (stage 1 on unbuffered IoU, then stage 1b) keeps
    # them apart here as well: the merged box is settled on tight overlaps before buffers reach across.
    plain, _ = run(Tracker(), seq, None)
    assert id_of(plain[-1], 1) == id_of(plain[9], 1)


def test_occlusion_cost_needs_the_detection_to_be_of_the_front_objects_class() -> None:
    """A pedestrian (nearer: bottom edge 184) walks in front of a far parked car (bottom 180). The car is
    missed once, then boxed displaced onto the pedestrian, who is detected with a low score only (stage
    2): the pedestrian's track is in front and could take that box (class switch) -- but it is a car's
    box, so the car's track keeps it (measured on the rendered occlusion_crossing scenario)."""
    ids = Identities()
    tr = Tracker()
    out = []
    for t in range(20):
        ped = [310.0 + 2.0 * t, 165.0, 323.0 + 2.0 * t, 184.0]
        boxes, cls, score, who = [[341.0, 168.0, 356.0, 180.0], ped], [CAR, PED], [0.8, 0.8], [0, 1]
        if t == 14:
            boxes, cls, score, who = [ped], [PED], [0.8], [1]
        elif t == 15:
            boxes, cls, score, who = [[338.0, 167.0, 351.0, 180.0], ped], [CAR, CLASS_ID["motorcyclist"]], [0.5, 0.4], [0, 1]
        d = Detections(xyxy=np.array(boxes), score=np.array(score), class_id=np.array(cls))
        out.append(tr.update(d, ids(who)))
    c, p = id_of(out[9], 0), id_of(out[9], 1)
    assert id_of(out[15], 0) == c and id_of(out[-1], 0) == c and id_of(out[-1], 1) == p


def test_wants_features_of_a_track_going_behind_an_object_in_front() -> None:
    """A walks right towards O, a detected object in front of it (lower bottom edge). The first frame
    A's box touches O's, A is about to go behind it: its feature is asked for then -- the last whole
    view, and the anchor, just before the occlusion -- although its gallery is younger than
    gallery_refresh_s (half of it suffices). Before that only the regular refreshes are asked for."""
    tr, ids = Tracker(), Identities()
    occluder = [340.0, 100.0, 460.0, 300.0]  # A's box is [180 + 4t, 160, 220 + 4t, 240]: touches O from t = 31
    asked = []
    for t in range(32):
        d = dets([box(200.0 + 4.0 * t, 200.0), occluder], [PED, CAR])
        need = tr.features_needed(d)
        f = ids([0, 1])
        f[~need] = np.nan
        tr.update(d, f if np.count_nonzero(need) else None)
        if need[0]:
            asked.append(t)
    assert asked == [2, 12, 22, 31], asked  # refreshes every 10 frames (1 s), then going behind O
