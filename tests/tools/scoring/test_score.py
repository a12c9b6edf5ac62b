"""Run-directory scoring on tiny hand-computed runs: detection, tracking, estimation, merge, errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.tools.scoring.run import score_run

PED, CAR = 0, 4
A = [0.0, 0.0, 10.0, 20.0]  # pedestrian box, 10 x 20 px
B = [100.0, 0.0, 140.0, 30.0]  # car box, 40 x 30 px
FAR = [300.0, 0.0, 340.0, 30.0]  # overlaps nothing


def gt(*objs: dict) -> dict:
    """Ground-truth struct of arrays from per-object dicts (id, cls, box; optional rest).

    Intent fields (name, label, in_path) get neutral values so every scorer can read the run.
    """
    keys = {
        "actor_id": "id", "class_id": "cls", "visible": "box", "visible_fraction": "vf",
        "truncation": "trunc", "range": "r", "velocity": "v", "ttc": "ttc",
        "name": "name", "label": "label", "in_path": "in_path",
    }
    defaults = {"vf": 1.0, "trunc": 0.0, "r": 20.0, "v": [0.0, 0.0], "ttc": 1e9, "label": 1, "in_path": False}
    return {k: [{**defaults, "name": f"a{o['id']}", **o}[src] for o in objs] for k, src in keys.items()}


def dets(*rows: tuple) -> dict:
    """Detections from (box, score, class_id) tuples."""
    return {
        "xyxy": [r[0] for r in rows], "score": [r[1] for r in rows],
        "class_id": [r[2] for r in rows], "source_id": [-1] * len(rows),
    }


def tracks(*objs: dict) -> dict:
    """Tracks struct of arrays from per-track dicts (id, box, cls; optional state, age,
    kinematics, intent ``label``: 1 = stable, 0 = initializing)."""
    d = {"state": "confirmed", "r": None, "vx": None, "vy": None, "ttc": None, "age": 5, "label": 1}
    o = [{**d, **t} for t in objs]
    return {
        "track_id": [t["id"] for t in o], "xyxy": [t["box"] for t in o],
        "class_id": [t["cls"] for t in o], "score": [0.9] * len(o), "age": [t["age"] for t in o],
        "hits": [5] * len(o), "state": [t["state"] for t in o], "det_index": [-1] * len(o),
        "range": [t["r"] for t in o], "range_sigma": [None] * len(o),
        "ground_vx": [t["vx"] for t in o], "ground_vy": [t["vy"] for t in o],
        "ttc": [t["ttc"] for t in o], "label": [t["label"] for t in o],
    }


def write_run(path: Path, frames: list[dict]) -> Path:
    """A run directory whose ticks.jsonl holds ``frames`` (keys ground_truth, detections, tracks)."""
    path.mkdir(parents=True, exist_ok=True)
    lines = []
    for i, f in enumerate(frames):
        trk = f.get("tracks")
        if trk is not None:  # the intent label lives in the assessments, rows aligned with tracks
            trk = dict(trk)
            asm = {"label": trk.pop("label")}
        rec = {
            "tick": 2 * i, "frame": i, "t": 0.1 * i, "ego": {"speed": 10.0},
            "ground_truth": f.get("ground_truth", gt()), "detections": f.get("detections", dets()),
            "tracks": trk, "assessments": asm if trk is not None else None, "alerts": [], "collisions": [],
        }
        lines.append(json.dumps(rec))
    (path / "ticks.jsonl").write_text("\n".join(lines) + "\n")
    (path / "run.json").write_text("{}\n")
    return path


# --- detection ------------------------------------------------------------------


def test_detection_precision_recall_ap_by_hand(tmp_path):
    ped, car = {"id": 1, "cls": PED, "box": A}, {"id": 2, "cls": CAR, "box": B}
    run = write_run(tmp_path / "r", [
        {"ground_truth": gt(ped, car), "detections": dets((A, 0.9, PED), (B, 0.8, CAR), (FAR, 0.7, CAR))},
        {"ground_truth": gt(ped, car), "detections": dets((A, 0.6, PED), (A, 0.5, PED))},  # duplicate
        {"ground_truth": gt(ped), "detections": dets(([50, 0, 60, 20], 0.95, PED))},  # miss + FP
    ])
    m = score_run(run)["detection"]
    # pedestrian ranking: 0.95 FP, 0.9 TP, 0.6 TP, 0.5 FP over 3 GT
    # -> envelope precision 2/3 up to recall 2/3: AP = 2/3 * 2/3 = 4/9.
    p = m["per_class"]["pedestrian"]
    assert (p["gt"], p["tp"], p["fp"]) == (3, 2, 2)
    assert p["precision"] == pytest.approx(0.5) and p["recall"] == pytest.approx(2 / 3)
    assert p["ap50"] == pytest.approx(4 / 9)
    # car: 0.8 TP, 0.7 FP over 2 GT -> AP = 0.5 * 1.0.
    c = m["per_class"]["car"]
    assert (c["gt"], c["tp"], c["fp"], c["ap50"]) == (2, 1, 1, pytest.approx(0.5))
    assert (m["gt"], m["tp"], m["fp"], m["ignored"]) == (5, 3, 3, 0)
    assert m["precision"] == pytest.approx(0.5) and m["recall"] == pytest.approx(0.6)
    assert m["ap50"] == pytest.approx((4 / 9 + 0.5) / 2)


def test_detection_iou_threshold_and_class(tmp_path):
    # [2.5, 0, 12.5, 20] vs A: IoU 7.5/12.5 = 0.6 -> TP; [5, 0, 15, 20]: 1/3 -> FP.
    run = write_run(tmp_path / "r", [
        {"ground_truth": gt({"id": 1, "cls": PED, "box": A}),
         "detections": dets(([2.5, 0, 12.5, 20], 0.9, PED))},
        {"ground_truth": gt({"id": 1, "cls": PED, "box": A}),
         "detections": dets(([5, 0, 15, 20], 0.9, PED))},
        {"ground_truth": gt({"id": 1, "cls": PED, "box": A}),
         "detections": dets((A, 0.9, CAR))},  # right box, wrong class: FP and a miss
    ])
    m = score_run(run)["detection"]
    assert (m["gt"], m["tp"], m["fp"]) == (3, 1, 2)
    assert m["per_class"]["car"] == {
        "precision": 0.0, "recall": None, "ap50": None, "gt": 0, "tp": 0, "fp": 1,
    }
    assert m["ap50"] == pytest.approx(m["per_class"]["pedestrian"]["ap50"])  # only class with GT


def test_a_box_a_few_pixels_wide_is_matched_by_centre_and_size(tmp_path):
    # A pedestrian side-on far away: 2 x 13 px. A detection one pixel off has plain IoU
    # 1/3, which measures pixel quantisation; boxes are grown to 8 px for the IoU, so it
    # matches (7/9), and one 6 px off (2/14) still does not. The track scores alike.
    thin = [100.0, 100.0, 102.0, 113.0]
    near, off = [101.0, 100.0, 103.0, 113.0], [106.0, 100.0, 108.0, 113.0]
    run = write_run(tmp_path / "r", [
        {"ground_truth": gt({"id": 1, "cls": PED, "box": thin}), "detections": dets((near, 0.9, PED)),
         "tracks": tracks({"id": 5, "box": near, "cls": PED})},
        {"ground_truth": gt({"id": 1, "cls": PED, "box": thin}), "detections": dets((off, 0.9, PED)),
         "tracks": tracks({"id": 5, "box": off, "cls": PED})},
    ])
    m = score_run(run)
    assert (m["detection"]["tp"], m["detection"]["fp"]) == (1, 1)
    assert (m["tracking"]["tp"], m["tracking"]["fp"], m["tracking"]["fn"]) == (1, 1, 1)


def test_dont_care_ground_truth_is_neither_tp_nor_fp(tmp_path):
    occluded = {"id": 3, "cls": PED, "box": [200, 0, 210, 20], "vf": 0.3}
    small = {"id": 4, "cls": PED, "box": [250, 0, 254, 8]}  # 8 px high
    cone = {"id": 5, "cls": -1, "box": [400, 0, 420, 20]}  # no detection class (an obstacle in an older run)
    hidden = {"id": 6, "cls": PED, "box": [None] * 4, "vf": 0.0}  # not visible at all (as the writer writes it)
    run = write_run(tmp_path / "r", [{
        "ground_truth": gt({"id": 1, "cls": PED, "box": A}, occluded, small, cone, hidden),
        "detections": dets(
            (A, 0.9, PED), ([200, 0, 210, 20], 0.8, PED), ([200, 0, 210, 20], 0.7, PED),
            ([250, 0, 254, 8], 0.6, PED),
            ([400, 0, 420, 20], 0.5, CAR),  # of no detection class: FP
        ),
    }])
    m = score_run(run)["detection"]
    assert (m["gt"], m["tp"], m["fp"], m["ignored"]) == (1, 1, 1, 3)
    assert m["per_class"]["pedestrian"] == {
        "precision": 1.0, "recall": 1.0, "ap50": 1.0, "gt": 1, "tp": 1, "fp": 0,
    }


def test_a_detection_of_the_visible_part_of_a_mostly_hidden_object_is_ignored(tmp_path):
    # A car behind a bus shows its roof: visible box 30 x 10 px, visible fraction 0.2.
    # A detection of half that roof (15 x 10, IoU 0.36 with the visible box) lies 4/5 inside
    # it: KITTI's DontCare rule ignores it; one of another class, or mostly outside, stays an FP.
    roof = {"id": 3, "cls": CAR, "box": [300, 100, 330, 110], "vf": 0.2}
    run = write_run(tmp_path / "r", [{
        "ground_truth": gt({"id": 1, "cls": PED, "box": A}, roof),
        "detections": dets(
            (A, 0.9, PED), ([305, 98, 320, 108], 0.8, CAR), ([305, 98, 320, 108], 0.7, PED),
            ([280, 90, 330, 120], 0.6, CAR),
        ),
    }])
    m = score_run(run)["detection"]
    assert (m["tp"], m["fp"], m["ignored"]) == (1, 2, 1)


def test_a_detection_that_is_a_dont_care_object_is_ignored_whatever_its_class(tmp_path):
    # A cyclist 8 px high (under the evaluated 10 px) called a pedestrian: the box is that
    # object, whose class is not scored, so the box is ignored. A pedestrian box lying
    # inside a don't-care car's box without matching it stays an FP (the inside test is
    # per class), and so does a car box on a static obstacle (no detection class).
    far = {"id": 3, "cls": 1, "box": [300, 100, 304, 108]}
    car = {"id": 4, "cls": CAR, "box": [400, 100, 460, 140], "vf": 0.3}
    cone = {"id": 5, "cls": -1, "box": [500, 100, 510, 120]}
    run = write_run(tmp_path / "r", [{
        "ground_truth": gt({"id": 1, "cls": PED, "box": A}, far, car, cone),
        "detections": dets(
            (A, 0.9, PED), ([300, 100, 304, 108], 0.8, PED), ([420, 110, 430, 130], 0.7, PED),
            ([500, 100, 510, 120], 0.6, CAR),
        ),
    }])
    m = score_run(run)["detection"]
    assert (m["tp"], m["fp"], m["ignored"]) == (1, 2, 1)


# --- tracking -------------------------------------------------------------------


def tracking_frames(extra_gt: tuple = (), extra_tracks: tuple = ()) -> list[dict]:
    """4 frames, pedestrian 1 and car 2. Pedestrian: track 7 (frames 0-1) then 8 (2-3),
    one ID switch. Car: track 9 in frames 0, 1, 3 (missed in 2; a tentative track there
    doesn't count). Frame 3: a confirmed false-positive track 11."""
    ped, car = {"id": 1, "cls": PED, "box": A}, {"id": 2, "cls": CAR, "box": B}
    trk = [
        [{"id": 7, "box": A, "cls": PED}, {"id": 9, "box": B, "cls": CAR}],
        [{"id": 7, "box": A, "cls": PED}, {"id": 9, "box": B, "cls": CAR}],
        [{"id": 8, "box": A, "cls": PED}, {"id": 10, "box": B, "cls": CAR, "state": "tentative"}],
        [{"id": 8, "box": A, "cls": PED}, {"id": 9, "box": B, "cls": CAR},
         {"id": 11, "box": FAR, "cls": CAR}],
    ]
    return [
        {"ground_truth": gt(ped, car, *extra_gt), "tracks": tracks(*t, *extra_tracks)}
        for t in trk
    ]


def test_tracking_by_hand(tmp_path):
    m = score_run(write_run(tmp_path / "r", tracking_frames()))["tracking"]
    # 8 GT boxes: TP 7, FN 1, FP 1, IDSW 1 -> MOTA = 1 - 3/8.
    assert (m["n"], m["tp"], m["fn"], m["fp"], m["id_switches"]) == (8, 7, 1, 1, 1)
    assert m["mota"] == pytest.approx(5 / 8)
    assert m["motp"] == pytest.approx(1.0)
    # IDTP = 2 (ped <-> 7 or 8) + 3 (car <-> 9) = 5; IDFN = 8 - 5; IDFP = 8 track boxes - 5.
    assert m["idf1"] == pytest.approx(2 * 5 / (2 * 5 + 3 + 3))
    assert m["fragmentations"] == 1  # the car's gap
    assert (m["mostly_tracked"], m["partially_tracked"]) == (1, 1)  # car tracked 3/4 < 80 %
    assert (m["num_gt_ids"], m["num_tracker_ids"]) == (2, 4)
    assert 0 < m["hota"] < 1


def test_tracking_dont_care_and_class_aware(tmp_path):
    occluded = {"id": 3, "cls": PED, "box": [200, 0, 210, 20], "vf": 0.3}
    on_dont_care = {"id": 12, "box": [200, 0, 210, 20], "cls": 1}  # removed, not FP, whatever its class
    frames = tracking_frames(extra_gt=(occluded,), extra_tracks=(on_dont_care,))
    # frame 0: the car tracked with the wrong class -> one FP and one FN
    frames[0]["tracks"] = tracks({"id": 7, "box": A, "cls": PED}, {"id": 13, "box": B, "cls": PED})
    m = score_run(write_run(tmp_path / "r", frames))["tracking"]
    assert m["n"] == 8  # the don't-care GT is not evaluated
    assert m["dont_care_tracks"] == 3  # frames 1-3 (frame 0's tracks were replaced)
    assert (m["tp"], m["fn"], m["fp"]) == (6, 2, 2)


def test_no_tracks_gives_null_tracking_and_estimation(tmp_path):
    run = write_run(tmp_path / "r", [
        {"ground_truth": gt({"id": 1, "cls": PED, "box": A}), "detections": dets((A, 0.9, PED))},
    ])
    m = score_run(run)
    assert m["detection"]["tp"] == 1
    assert m["tracking"]["n"] == 0
    assert all(m["tracking"][k] is None for k in ("mota", "motp", "idf1", "hota", "id_switches"))
    assert m["estimation"]["n"] == 0
    assert m["estimation"]["range_rel_err_median"] is None and m["estimation"]["ttc_err_median"] is None


# --- estimation -----------------------------------------------------------------


def test_estimation_errors_by_hand(tmp_path):
    frames = [
        {
            "ground_truth": gt(
                {"id": 1, "cls": PED, "box": A, "r": 20.0, "v": [0, 0], "ttc": 2.0},
                {"id": 2, "cls": CAR, "box": B, "r": 40.0, "v": [10, 0], "ttc": 1e9},
            ),
            "tracks": tracks(
                {"id": 7, "box": A, "cls": PED, "r": 22.0, "vx": 3.0, "vy": 4.0, "ttc": 2.5},
                {"id": 9, "box": B, "cls": CAR, "r": 36.0, "vx": 10.0, "vy": 0.0, "ttc": 1e9},
                {"id": 5, "box": [6, 0, 16, 20], "cls": PED, "r": 1.0},  # IoU 1/4 with A: unmatched
            ),
        },
        {
            "ground_truth": gt(
                {"id": 1, "cls": PED, "box": A, "r": 3.0, "v": [0, 0], "ttc": 1.0},  # < 5 m
                {"id": 2, "cls": CAR, "box": B, "r": 30.0, "v": [10, 0], "ttc": 3.0, "vf": 0.5},
            ),
            "tracks": tracks(
                {"id": 7, "box": A, "cls": PED, "r": 4.0, "vx": 0.0, "vy": 1.0, "ttc": 0.5},
                {"id": 9, "box": B, "cls": CAR, "r": 30.0, "vx": 12.0, "vy": 0.0},  # TTC unknown
            ),
        },
    ]
    m = score_run(write_run(tmp_path / "r", frames))["estimation"]
    assert m["n"] == 4
    # range set: frame 0 only (frame 1: ped at 3 m, car occluded): rel 0.1, 0.1; abs 2, 4.
    assert m["n_range"] == 2
    assert m["range_rel_err_median"] == pytest.approx(0.1)
    assert m["range_abs_err_p90"] == pytest.approx(2 + 0.9 * 2)
    # speed errors 5, 0, 1, 2 m/s.
    assert m["n_speed"] == 4 and m["speed_err_median"] == pytest.approx(1.5)
    # TTC < 5 s with an estimate: 0.5/2 and 0.5/1.
    assert m["n_ttc"] == 2 and m["ttc_err_median"] == pytest.approx(0.375)


def test_estimation_uses_hungarian_not_greedy(tmp_path):
    # Track 1 overlaps GT 1 (IoU 7.5/12.5 = 0.6) and GT 2 (8/12 = 0.67); track 2 only
    # GT 2 (9/11 = 0.82; 4.5/15.5 with GT 1). Best-IoU greedy gives track 1 GT 2 and
    # strands track 2; Hungarian matches both, each to its own range.
    g1, g2 = [0, 0, 10, 10], [4.5, 0, 14.5, 10]
    frames = [{
        "ground_truth": gt({"id": 1, "cls": PED, "box": g1, "r": 10.0},
                           {"id": 2, "cls": PED, "box": g2, "r": 20.0}),
        "tracks": tracks({"id": 1, "box": [2.5, 0, 12.5, 10], "cls": PED, "r": 10.0},
                         {"id": 2, "box": [5.5, 0, 15.5, 10], "cls": PED, "r": 20.0}),
    }]
    m = score_run(write_run(tmp_path / "r", frames))["estimation"]
    assert m["n"] == 2 and m["range_abs_err_p90"] == pytest.approx(0.0)


def test_initializing_tracks_are_dont_care_in_estimation(tmp_path):
    """A track labelled ``initializing`` claims its GT box but its errors are not scored."""
    ped = {"id": 1, "cls": PED, "box": A, "r": 20.0, "v": [0, 0], "ttc": 2.0}
    car = {"id": 2, "cls": CAR, "box": B, "r": 40.0, "v": [10, 0]}
    frames = [{
        "ground_truth": gt(ped, car),
        "tracks": tracks(
            {"id": 7, "box": A, "cls": PED, "r": 30.0, "vx": 9.0, "vy": 0.0, "ttc": 9.0, "age": 2, "label": 0},
            {"id": 9, "box": B, "cls": CAR, "r": 44.0, "vx": 10.0, "vy": 0.0},
        ),
    }]
    m = score_run(write_run(tmp_path / "r", frames))["estimation"]
    assert (m["n"], m["n_initializing"]) == (1, 1)
    assert m["range_rel_err_median"] == pytest.approx(0.1) and m["speed_err_median"] == 0.0
    assert m["n_ttc"] == 0
    # Without assessments the track's age decides (IntentConfig.init_frames = 5).
    run = write_run(tmp_path / "r2", frames)
    lines = [json.loads(x) for x in (run / "ticks.jsonl").read_text().splitlines()]
    for rec in lines:
        rec["assessments"] = None
    (run / "ticks.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
    assert score_run(run)["estimation"]["n_initializing"] == 1


def test_never_and_null_ttc_in_estimation(tmp_path):
    """A predicted TTC of "never" (written 1e9, read as inf) counts as the finite NEVER it was
    written as, as before the reader decoded it; a null prediction is left out; GT TTC of
    never or null is outside the scored 0..5 s."""
    ped = {"id": 1, "cls": PED, "box": A, "ttc": 2.0}
    car = {"id": 2, "cls": CAR, "box": B, "ttc": 1e9}
    far = {"id": 3, "cls": CAR, "box": FAR, "ttc": None}
    frames = [
        {"ground_truth": gt(ped, car, far), "tracks": tracks(
            {"id": 7, "box": A, "cls": PED, "ttc": 1e9},  # never, GT 2 s: error (1e9 - 2) / 2
            {"id": 8, "box": B, "cls": CAR, "ttc": 3.0},  # GT never: not scored
            {"id": 9, "box": FAR, "cls": CAR, "ttc": 3.0})},  # GT null: not scored
        {"ground_truth": gt(ped), "tracks": tracks({"id": 7, "box": A, "cls": PED, "ttc": None})},  # left out
        {"ground_truth": gt(ped), "tracks": tracks({"id": 7, "box": A, "cls": PED, "ttc": 2.5})},  # 0.25
    ]
    m = score_run(write_run(tmp_path / "r", frames))["estimation"]
    assert m["n"] == 5 and m["n_ttc"] == 2
    assert m["ttc_err_median"] == pytest.approx(((1e9 - 2.0) / 2.0 + 0.25) / 2)


def test_coasting_tracks_are_scored(tmp_path):
    """Lost (coasting) tracks the tracker outputs count: a hit on target, an FP off it."""
    ped = {"id": 1, "cls": PED, "box": A, "r": 20.0}
    car = {"id": 2, "cls": CAR, "box": B, "r": 40.0}
    frames = [
        {"ground_truth": gt(ped, car), "tracks": tracks({"id": 7, "box": A, "cls": PED, "r": 22.0},
                                                         {"id": 9, "box": B, "cls": CAR, "r": 40.0})},
        {"ground_truth": gt(ped, car), "tracks": tracks(
            {"id": 7, "box": A, "cls": PED, "state": "lost", "r": 22.0},  # coasting on its object
            {"id": 9, "box": FAR, "cls": CAR, "state": "lost"},  # coasting off: FP (and the car FN)
            {"id": 11, "box": B, "cls": CAR, "state": "tentative"},  # never output, never scored
        )},
    ]
    run = write_run(tmp_path / "r", frames)
    m = score_run(run)
    assert (m["tracking"]["tp"], m["tracking"]["fp"], m["tracking"]["fn"]) == (3, 1, 1)
    assert m["estimation"]["n"] == 3 and m["estimation"]["n_range"] == 3


# --- metrics.json merge and errors -------------------------------------------------


def test_merge_keeps_foreign_sections_and_keys(tmp_path):
    run = write_run(tmp_path / "r", [
        {"ground_truth": gt({"id": 1, "cls": PED, "box": A}), "detections": dets((A, 0.9, PED))},
    ])
    foreign = {
        "custom": {"accuracy": 0.7}, "timing": {"tick": {"median": 3.0}},
        "detection": {"ap50_95": 0.42, "precision": 0.0},
    }
    (run / "metrics.json").write_text(json.dumps(foreign))
    returned = score_run(run)
    on_disk = json.loads((run / "metrics.json").read_text())
    assert returned == on_disk
    assert on_disk["custom"] == {"accuracy": 0.7} and on_disk["timing"] == foreign["timing"]
    assert on_disk["detection"]["ap50_95"] == 0.42 and on_disk["detection"]["precision"] == 1.0
    assert {"tracking", "estimation"} <= set(on_disk)
    score_run(run)  # idempotent
    assert json.loads((run / "metrics.json").read_text()) == on_disk


def test_score_command_prints_tables(tmp_path, capsys, lookahead):
    run = write_run(tmp_path / "r", tracking_frames())
    assert lookahead("score", run) == 0
    out = capsys.readouterr().out
    assert "mota" in out and "pedestrian" in out


@pytest.mark.parametrize(
    ("setup", "needle"),
    [
        ("missing_dir", "no such run directory"),
        ("missing_ticks", "ticks.jsonl: no such file"),
        ("bad_json", "ticks.jsonl:2: not valid JSON"),
        ("bad_shape", "ticks.jsonl:1: detections.xyxy: expected 1x4"),
        ("not_object", "ticks.jsonl:2: expected a JSON object"),
        ("bad_metrics", "metrics.json:1: not valid JSON"),
    ],
)
def test_errors_exit_2_with_one_line_and_nothing_overwritten(tmp_path, capsys, lookahead, setup, needle):
    run = tmp_path / "r"
    good = json.dumps({"t": 0.0, "ground_truth": gt(), "detections": dets(), "tracks": None})
    metrics = '{"intent": {"accuracy": 1.0}}'
    if setup != "missing_dir":
        run.mkdir()
        (run / "metrics.json").write_text(metrics)
    if setup == "bad_json":
        (run / "ticks.jsonl").write_text(good + "\n{not json\n")
    elif setup == "bad_shape":
        (run / "ticks.jsonl").write_text(json.dumps(
            {"t": 0.0, "ground_truth": gt(), "detections": dets(([1, 2, 3], 0.5, PED))}) + "\n")
    elif setup == "not_object":
        (run / "ticks.jsonl").write_text(good + "\n[1, 2]\n")
    elif setup == "bad_metrics":
        (run / "ticks.jsonl").write_text(good + "\n")
        metrics = "{oops"
        (run / "metrics.json").write_text(metrics)
    assert lookahead("score", run) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and needle in err[0], err
    if setup != "missing_dir":
        assert (run / "metrics.json").read_text() == metrics
        assert sorted(p.name for p in run.iterdir()) == sorted(
            ["metrics.json"] + ([] if setup == "missing_ticks" else ["ticks.jsonl"]))


BROKEN_RUN_JSON = [  # run.json content, what the one line says after its name
    (b"{not json", "not valid JSON"),
    (b"\x00\xff\xfe\x80binary", "not UTF-8 text"),
    (b"[1, 2]", "expected a JSON object"),
    (b'{"scenario": 5}', "scenario: expected a mapping, got int"),
    (b'{"scenario": {"ego": "fast"}}', "scenario.ego: expected a mapping, got str"),
    (b'{"scenario": {"expect": {"a": 1}}}', "scenario.expect: expected a list, got dict"),
    (b'{"scenario": {"expect": [3]}}', "scenario.expect[0]: expected a mapping, got int"),
    (b'{"scenario": {"name": 7}}', "scenario.name: expected text, got int"),
    (b'{"summary": []}', "summary: expected a mapping, got list"),
]


def _one_error_line(capsys, code: int, *needles: str) -> None:
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, (code, err)
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.mark.parametrize("command", ["score", "report"])
@pytest.mark.parametrize(("content", "needle"), BROKEN_RUN_JSON)
def test_a_broken_run_json_is_one_line_naming_it(tmp_path, capsys, lookahead, command, content, needle):
    run = write_run(tmp_path / "r", [{"ground_truth": gt({"id": 1, "cls": PED, "box": A})}])
    (run / "run.json").write_bytes(content)
    _one_error_line(capsys, lookahead(command, run), f"{run / 'run.json'}", needle)
    assert not (run / "metrics.json").exists() and not (run / "report.html").exists()


@pytest.mark.parametrize("command", ["score", "report"])
def test_a_binary_ticks_file_is_one_line_naming_file_and_line(tmp_path, capsys, lookahead, command):
    run = write_run(tmp_path / "r", [{"ground_truth": gt({"id": 1, "cls": PED, "box": A})}] * 3)
    lines = (run / "ticks.jsonl").read_bytes().splitlines(keepends=True)
    (run / "ticks.jsonl").write_bytes(lines[0] + b"\x00\xff\xfe\x80\x81 garbage\n" + lines[2])
    _one_error_line(capsys, lookahead(command, run), f"{run / 'ticks.jsonl'}:2: not UTF-8 text")


def test_a_run_json_without_the_optional_keys_still_scores(tmp_path, capsys, lookahead):
    run = write_run(tmp_path / "r", [{"ground_truth": gt({"id": 1, "cls": PED, "box": A})}])
    (run / "run.json").write_text('{"scenario": {"name": "x", "expect": []}, "summary": null}')
    assert lookahead("score", run) == 0
    assert lookahead("report", run) == 0 and (run / "report.html").is_file()


@pytest.mark.parametrize(("key", "value"), [("frame", 10**10), ("tick", -1), ("frame", "x"), ("tick", 1.5)])
def test_a_tick_or_frame_number_out_of_range_is_one_line(tmp_path, capsys, lookahead, key, value):
    run = write_run(tmp_path / "r", [{"ground_truth": gt({"id": 1, "cls": PED, "box": A})}] * 2)
    lines = (run / "ticks.jsonl").read_text().splitlines()
    rec = json.loads(lines[1])
    rec[key] = value
    (run / "ticks.jsonl").write_text(lines[0] + "\n" + json.dumps(rec) + "\n")
    _one_error_line(capsys, lookahead("score", run), f"{run / 'ticks.jsonl'}:2: {key}: expected an integer 0..")
