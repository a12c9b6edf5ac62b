"""``tools.scoring.mot_noise`` and ``lookahead mot-noise``: detections of another kind from a
MOTChallenge sequence's ground truth."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from lookahead.perception.detectors.gt_detector import GtNoiseConfig
from lookahead.perception.geometry import iou_matrix
from lookahead.perception.mot import iter_frames, read_mot
from lookahead.tools.scoring.mot_eval import read_seqinfo
from lookahead.tools.scoring.mot_noise import noisy_detections

SEQ = Path(__file__).resolve().parents[2] / "data" / "mot15" / "KITTI-17"


def _sequence() -> tuple:
    info = read_seqinfo(SEQ / "seqinfo.ini")
    return read_mot(SEQ / "gt.txt"), info.width, info.height, info.length


def _recall(gt, dets, n: int) -> float:
    """Share of counted GT boxes with a detection at IoU >= 0.5 in their frame."""
    hit = total = 0
    det_frames = dict(iter_frames(dets, n))
    for f, rows in iter_frames(gt[gt.conf > 0], n):
        total += len(rows)
        if len(rows) and len(det_frames[f]):
            hit += int(np.count_nonzero(iou_matrix(rows.xyxy, det_frames[f].xyxy).max(axis=1) >= 0.5))
    return hit / total


def test_noise_is_deterministic_and_levels_differ() -> None:
    gt, w, h, n = _sequence()
    low = noisy_detections(gt, w, h, n, "low", seed=0)
    again = noisy_detections(gt, w, h, n, "low", seed=0)
    other = noisy_detections(gt, w, h, n, "low", seed=1)
    high = noisy_detections(gt, w, h, n, "high", seed=0)
    assert np.array_equal(low.to_array(), again.to_array())
    assert not np.array_equal(low.to_array(), other.to_array())
    assert np.all(low.track_id == -1) and low.frame.min() >= 1 and low.frame.max() <= n
    for dets in (low, high):
        assert dets.conf.min() >= 0.0 and dets.conf.max() <= 1.0
        x1, y1, x2, y2 = dets.xyxy.T
        assert np.all((x1 >= 0) & (y1 >= 0) & (x2 <= w) & (y2 <= h) & (x2 > x1) & (y2 > y1))
    # low: most counted people found, few false boxes; high: fewer found, more false boxes
    r_low, r_high = _recall(gt, low, n), _recall(gt, high, n)
    assert r_low > 0.85 and r_high < r_low - 0.1
    assert len(high) - r_high * np.count_nonzero(gt.conf > 0) > len(low) - r_low * np.count_nonzero(gt.conf > 0)


def test_ignored_ground_truth_is_never_seen() -> None:
    gt, w, h, n = _sequence()
    ignored = gt[gt.conf == 0]
    assert len(ignored)  # KITTI-17 has rows not to be counted
    dets = noisy_detections(gt, w, h, n, GtNoiseConfig.perfect())
    assert len(dets) == np.count_nonzero(gt.conf > 0)
    with pytest.raises(ValueError, match="unknown noise level 'mid'"):
        noisy_detections(gt, w, h, n, "mid")


def test_cli_writes_what_the_function_makes(tmp_path: Path, lookahead, capsys) -> None:
    seq = tmp_path / "KITTI-17"
    (seq / "gt").mkdir(parents=True)
    shutil.copy(SEQ / "gt.txt", seq / "gt" / "gt.txt")
    shutil.copy(SEQ / "seqinfo.ini", seq / "seqinfo.ini")
    out = tmp_path / "det" / "det.txt"
    assert lookahead("mot-noise", seq / "gt" / "gt.txt", "--out", out, "--level", "high", "--seed", "3") == 0
    gt, w, h, n = _sequence()
    written, made = read_mot(out), noisy_detections(gt, w, h, n, "high", seed=3)
    assert np.array_equal(written.frame, made.frame)
    assert np.allclose(written.xyxy, made.xyxy, atol=1e-3) and np.allclose(written.conf, made.conf, rtol=1e-5)
    assert f"wrote {out}: {len(made)} detections" in capsys.readouterr().out


def test_cli_refuses_without_image_size(tmp_path: Path, lookahead, capsys) -> None:
    shutil.copy(SEQ / "gt.txt", tmp_path / "gt.txt")
    assert lookahead("mot-noise", tmp_path / "gt.txt", "--out", tmp_path / "det.txt") == 2
    err = capsys.readouterr().err
    assert "no seqinfo.ini with imWidth and imHeight" in err and "Traceback" not in err
    assert not (tmp_path / "det.txt").exists()
    assert lookahead("mot-noise", tmp_path / "gt.txt", "--out", tmp_path / "det.txt", "--level", "mid") == 2
    assert "--level 'mid': choose one of low, high" in capsys.readouterr().err
