"""MOT metrics on hand-computed tiny cases, the MOT tracking run and the CLI bodies."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from lookahead.perception.mot import MotRecords, read_mot, write_mot
from lookahead.tools.scoring.mot_eval import evaluate_mot, run_tracker_on_mot


def rows(*r: tuple) -> np.ndarray:
    """(frame, id, x, y, w, h[, conf, c8, c9]) tuples -> (N, 6..9) array."""
    return np.array(r, dtype=float)


def two_objects(frames: int = 5) -> np.ndarray:
    return rows(
        *[(f, 1, 0, 0, 10, 10) for f in range(1, frames + 1)],
        *[(f, 2, 100, 0, 10, 10) for f in range(1, frames + 1)],
    )


def test_perfect_tracking() -> None:
    gt = two_objects()
    trk = gt.copy()
    trk[:, 1] += 10  # ids need not be equal, only consistent
    m = evaluate_mot(gt, trk)
    assert m["mota"] == 1.0 and m["idf1"] == 1.0 and m["motp"] == 1.0
    assert m["hota"] == pytest.approx(1.0)
    assert (m["fp"], m["fn"], m["id_switches"], m["fragmentations"]) == (0, 0, 0, 0)
    assert (m["mostly_tracked"], m["mostly_lost"]) == (2, 0)
    assert (m["num_gt_ids"], m["num_tracker_ids"], m["num_frames"]) == (2, 2, 5)


def test_one_id_switch() -> None:
    gt = rows(*[(f, 1, 0, 0, 10, 10) for f in range(1, 5)])
    trk = gt.copy()
    trk[2:, 1] = 2  # frames 3-4 carry a new id
    m = evaluate_mot(gt, trk)
    assert m["id_switches"] == 1
    assert m["mota"] == pytest.approx((4 - 0 - 1) / 4)
    # Best id mapping keeps 2 of 4 frames: IDTP 2, IDFP 2, IDFN 2.
    assert m["idf1"] == pytest.approx(2 * 2 / (2 * 2 + 2 + 2))
    # DetA 1, AssA = (2 * 0.5 + 2 * 0.5) / 4 = 0.5.
    assert m["hota"] == pytest.approx(np.sqrt(0.5))


def test_known_fp_fn_counts() -> None:
    gt = two_objects()
    keep = ~((gt[:, 1] == 2) & np.isin(gt[:, 0], [2, 3]))  # object 2 missed in frames 2-3
    fps = rows(*[(f, 90 + f, 500, 500, 10, 10) for f in (1, 2, 3)])
    trk = np.concatenate([gt[keep], fps])
    m = evaluate_mot(gt, trk)
    assert (m["tp"], m["fn"], m["fp"], m["id_switches"]) == (8, 2, 3, 0)
    assert m["mota"] == pytest.approx((8 - 3 - 0) / 10)
    assert m["fragmentations"] == 1
    assert (m["mostly_tracked"], m["partially_tracked"], m["mostly_lost"]) == (1, 1, 0)
    assert m["precision"] == pytest.approx(8 / 11) and m["recall"] == pytest.approx(0.8)


def test_iou_threshold_and_motp() -> None:
    gt = rows((1, 1, 0, 0, 10, 10), (1, 2, 100, 0, 10, 10))
    trk = rows((1, 1, 2.5, 0, 10, 10), (1, 2, 105, 0, 10, 10))  # IoU 0.6 and 1/3
    m = evaluate_mot(gt, trk)
    assert (m["tp"], m["fp"], m["fn"]) == (1, 1, 1)
    assert m["motp"] == pytest.approx(0.6)
    assert m["mota"] == pytest.approx((1 - 1) / 2)


def test_min_box_grows_boxes_a_few_pixels_wide_before_iou() -> None:
    # 2 x 13 px boxes one pixel apart: plain IoU 1/3 (MOTChallenge, the default) misses;
    # grown to 8 px wide they overlap 7/9. A 20 x 20 box is scored the same either way.
    gt = rows((1, 1, 100, 100, 2, 13), (1, 2, 300, 100, 20, 20))
    trk = rows((1, 1, 101, 100, 2, 13), (1, 2, 305, 100, 20, 20))
    plain, grown = evaluate_mot(gt, trk), evaluate_mot(gt, trk, min_box=8.0)
    assert (plain["tp"], plain["fp"], plain["fn"]) == (1, 1, 1)
    assert (grown["tp"], grown["fp"], grown["fn"]) == (2, 0, 0)
    assert grown["motp"] == pytest.approx((7 / 9 + 15 / 25) / 2)


def test_mot16_gt_distractors_and_zero_marked() -> None:
    # frame, id, x, y, w, h, consider, class, visibility
    gt = rows(
        (1, 1, 0, 0, 10, 10, 1, 1, 1.0),  # pedestrian
        (1, 2, 100, 0, 10, 10, 0, 8, 1.0),  # distractor: matching output is removed
        (1, 3, 200, 0, 10, 10, 0, 3, 1.0),  # car: ignored GT, matching output stays FP
        (1, 4, 300, 0, 10, 10, 0, 1, 0.1),  # zero-marked pedestrian: ignored
    )
    trk = rows(
        (1, 1, 0, 0, 10, 10), (1, 2, 100, 0, 10, 10), (1, 3, 200, 0, 10, 10), (1, 4, 300, 0, 10, 10)
    )
    m = evaluate_mot(gt, trk)
    assert (m["tp"], m["fp"], m["fn"], m["num_gt_dets"]) == (1, 2, 0, 1)
    plain = evaluate_mot(gt, trk, mot16_preprocess=False)
    assert (plain["tp"], plain["fp"]) == (1, 3)


def test_empty_inputs() -> None:
    gt = two_objects(3)
    m = evaluate_mot(gt, np.zeros((0, 6)))
    assert (m["fn"], m["fp"], m["mota"], m["mostly_lost"]) == (6, 0, 0.0, 2)
    m = evaluate_mot(np.zeros((0, 6)), gt)
    assert (m["fp"], m["fn"]) == (6, 0)


def test_duplicate_ids_in_a_frame_raise() -> None:
    gt = two_objects(2)
    trk = gt.copy()
    trk[:, 1] = 1
    with pytest.raises(ValueError, match="duplicate ids in frame 1"):
        evaluate_mot(gt, trk)


def _linear_scene(tmp_path: Path, frames: int = 10) -> tuple[Path, Path]:
    gt_rows, det_rows = [], []
    for f in range(1, frames + 1):
        for k, (x0, vx) in enumerate(((100.0, 5.0), (600.0, -4.0)), start=1):
            box = (x0 + vx * f, 200.0, 40.0, 90.0)
            gt_rows.append((f, k, *box, 1, -1, -1, -1))
            det_rows.append((f, -1, *box, 0.9, -1, -1, -1))
    gt_path, det_path = tmp_path / "gt.txt", tmp_path / "det.txt"
    write_mot(gt_path, MotRecords.from_array(np.array(gt_rows)))
    write_mot(det_path, MotRecords.from_array(np.array(det_rows)))
    return gt_path, det_path


def test_run_tracker_on_mot_files(tmp_path: Path) -> None:
    gt_path, det_path = _linear_scene(tmp_path)
    out = tmp_path / "out" / "tracks.txt"
    summary = run_tracker_on_mot(det_path, out, frame_rate=10.0)
    assert summary["frames"] == 10 and summary["tracks"] == 2 and summary["dropped_detections"] == 0
    assert len(read_mot(out)) == summary["track_rows"] == 18
    m = evaluate_mot(gt_path, out)
    # One frame of confirmation delay per object (min_hits 2) is the only miss.
    assert (m["fn"], m["fp"], m["id_switches"]) == (2, 0, 0)
    assert m["mota"] == pytest.approx(1 - 2 / 20)
    assert m["idf1"] == pytest.approx(2 * 18 / (2 * 18 + 2))


def test_cli_commands_success(lookahead, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gt_path, det_path = _linear_scene(tmp_path)
    out = tmp_path / "tracks.txt"
    assert lookahead("track", "--det", det_path, "--out", out, "--frame-rate", 10.0) == 0
    assert "2 tracks" in capsys.readouterr().out
    assert lookahead("eval-mot", "--gt", gt_path, "--tracks", out, "--format", "json") == 0
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["mota"] == pytest.approx(0.9)
    assert lookahead("eval-mot", "--gt", gt_path, "--tracks", out, "--format", "table") == 0
    assert "MOTA" in capsys.readouterr().out


def test_cli_bad_input_exit_code_2_one_line(
    lookahead, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.txt"
    bad.write_text("1,1,0,0,10,10\n1,1,zero,0,10,10\n")
    missing = tmp_path / "missing.txt"
    cases = [
        (lambda: lookahead("track", "--det", missing, "--out", tmp_path / "o.txt", "--frame-rate", 10.0), "missing.txt"),
        (lambda: lookahead("track", "--det", bad, "--out", tmp_path / "o.txt", "--frame-rate", 10.0), f"{bad}:2"),
        (lambda: lookahead("track", "--det", bad, "--out", tmp_path / "o.txt", "--frame-rate", 0.0), "frame-rate"),
        (lambda: lookahead("eval-mot", "--gt", missing, "--tracks", bad, "--format", "table"), "missing.txt"),
        (lambda: lookahead("eval-mot", "--gt", bad, "--tracks", bad, "--format", "json"), f"{bad}:2"),
        (lambda: lookahead("eval-mot", "--gt", bad, "--tracks", bad, "--format", "xml"), "--format"),
    ]
    for call, needle in cases:
        assert call() == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and needle in err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


# ------------------------------------------------- frame rate from seqinfo.ini
def _gap_sequence(seq_dir: Path, frame_rate: int | None, det_subdir: str = "det") -> Path:
    """A standard MOTChallenge layout: one pedestrian seen in frames 1-5 and 11-15, 20 frames.

    ``<seq>/seqinfo.ini`` (no file when ``frame_rate`` is None) and ``<seq>/<det_subdir>/det.txt``.
    The 5-frame gap outlives ``max_lost_s`` (0.3 s) at 10 fps (3 frames) but not at
    25 fps (8 frames): the rate the tracker really used shows in the ids.
    """
    det_rows = [(f, -1, 100.0, 200.0, 40.0, 90.0, 0.9, -1, -1, -1) for f in (*range(1, 6), *range(11, 16))]
    det_path = seq_dir / det_subdir / "det.txt"
    write_mot(det_path, MotRecords.from_array(np.array(det_rows)))
    if frame_rate is not None:
        (seq_dir / "seqinfo.ini").write_text(
            f"[Sequence]\nname={seq_dir.name}\nimDir=img1\nframeRate={frame_rate}\nseqLength=20\n"
            "imWidth=640\nimHeight=480\nimExt=.jpg\n"
        )
    return det_path


def _cli_track(*args: str):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    return CliRunner().invoke(app, ["track", *args])


def test_track_cli_reads_frame_rate_from_seqinfo(tmp_path: Path) -> None:
    det = _gap_sequence(tmp_path / "SEQ-25", 25)
    out = tmp_path / "out25.txt"
    res = _cli_track("--det", str(det), "--out", str(out))  # no --frame-rate
    assert res.exit_code == 0, res.output
    assert f"frame rate: 25 fps (from {(tmp_path / 'SEQ-25' / 'seqinfo.ini').resolve()})" in res.output
    assert "over 20 frames" in res.output  # seqLength, trailing empty frames included
    tracks = read_mot(out)
    assert set(tracks.track_id) == {1}  # recovered after the gap: 8-frame budget at 25 fps

    det10 = _gap_sequence(tmp_path / "SEQ-10", 10)
    res = _cli_track("--det", str(det10), "--out", str(tmp_path / "out10.txt"))
    assert res.exit_code == 0, res.output
    assert "frame rate: 10 fps (from " in res.output
    assert set(read_mot(tmp_path / "out10.txt").track_id) == {1, 2}  # 3-frame budget: a new id

    # --frame-rate wins over seqinfo.ini, with a warning.
    res = _cli_track("--det", str(det), "--out", str(tmp_path / "o.txt"), "--frame-rate", "10")
    assert res.exit_code == 0, res.output
    assert "frame rate: 10 fps (from --frame-rate)" in res.output and "overrides frameRate=25" in res.output
    assert set(read_mot(tmp_path / "o.txt").track_id) == {1, 2}


def test_track_seqinfo_beside_det_and_default_rate(lookahead, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    det = _gap_sequence(tmp_path / "flat", 25, det_subdir=".")  # det.txt next to seqinfo.ini
    assert lookahead("track", "--det", det, "--out", tmp_path / "a.txt") == 0
    assert "frame rate: 25 fps (from " in capsys.readouterr().out

    bare = _gap_sequence(tmp_path / "bare", None)  # no seqinfo.ini anywhere near
    assert lookahead("track", "--det", bare, "--out", tmp_path / "b.txt") == 0
    captured = capsys.readouterr()
    assert "frame rate: 30 fps (default)" in captured.out
    warning = captured.err.strip().splitlines()
    assert len(warning) == 1 and warning[0].startswith("warning: ") and "no seqinfo.ini" in warning[0]
    assert "--frame-rate" in warning[0]
    summary = run_tracker_on_mot(bare, tmp_path / "c.txt")
    assert (summary["frame_rate"], summary["frame_rate_source"], summary["frames"]) == (30.0, "default", 15)


def test_track_bad_seqinfo_is_one_line_error(lookahead, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    det = _gap_sequence(tmp_path / "SEQ", 25)
    ini = tmp_path / "SEQ" / "seqinfo.ini"
    ini.write_text(ini.read_text().replace("frameRate=25", "frameRate=fast"))
    assert lookahead("track", "--det", det, "--out", tmp_path / "o.txt") == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "seqinfo.ini: frameRate='fast'" in err
    assert len(err.strip().splitlines()) == 1
    ini.write_text("[Sequence]\nname=SEQ\n")  # no frameRate: default rate, with a warning
    assert lookahead("track", "--det", det, "--out", tmp_path / "o.txt") == 0
    captured = capsys.readouterr()
    assert "has no frameRate" in captured.err and "30 fps (default)" in captured.out


@pytest.mark.parametrize(("content", "needle"), [
    (b"1,-1,1,1,10,10,0.9\n10000000000,-1,1,1,10,10,0.9\n", ":2: frame must be an integer >= 1 and <= 100000"),
    (b"1,-1,1,1,10,10,0.9\n1e10,-1,1,1,10,10,0.9\n", ":2: frame must be an integer"),
    (b"1,-1,1,1,10,10,0.9\n\x00\xff\xfe\x80\x81garbage\n", ":2: not UTF-8 text"),
    (b"\x89PNG\r\n\x1a\n\x00\x00", ":1: not UTF-8 text"),
])
def test_a_hostile_det_file_is_one_line_fast(lookahead, tmp_path: Path, capsys, content: bytes, needle: str) -> None:
    """A frame number of 1e10 would ask for 75 GiB of frame slots: refused before allocating."""
    import time

    det = tmp_path / "det.txt"
    det.write_bytes(content)
    for args in (("track", "--det", det, "--out", tmp_path / "o.txt", "--frame-rate", 10.0),
                 ("eval-mot", "--gt", det, "--tracks", det)):
        t0 = time.perf_counter()
        code = lookahead(*args)
        assert time.perf_counter() - t0 < 2.0
        err = capsys.readouterr().err
        lines = [x for x in err.splitlines() if x.strip()]
        assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
        assert lines[0].startswith("error: ") and f"{det}{needle}" in lines[0], lines[0]
    assert not (tmp_path / "o.txt").exists()
