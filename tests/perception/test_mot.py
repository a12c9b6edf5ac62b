"""MOTChallenge file I/O."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from lookahead.perception.detections import Detections
from lookahead.perception.mot import (
    MAX_FRAME,
    MotFileError,
    MotRecords,
    from_boxes,
    from_detections,
    group_by_frame,
    iter_frames,
    read_mot,
    to_detections,
    write_mot,
)


def _records() -> MotRecords:
    return MotRecords(
        frame=[2, 1, 1, 4],
        track_id=[7, 3, 5, 3],
        xywh=[[10.5, 20.25, 30, 40], [0, 0, 5, 5], [100, 50, 20.125, 60], [1, 2, 3, 4]],
        conf=[0.9, 1.0, 0.25, 0.5],
    )


def test_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "tracks.txt"
    rec = _records()
    write_mot(path, rec)
    back = read_mot(path)
    order = np.lexsort((rec.track_id, rec.frame))
    np.testing.assert_allclose(back.to_array(), rec[order].to_array(), atol=1e-3)
    assert path.read_text().splitlines()[0] == "1,3,0.000,0.000,5.000,5.000,1,-1,-1,-1"


def test_short_rows_get_defaults_and_comments_are_skipped(tmp_path: Path) -> None:
    path = tmp_path / "gt.txt"
    path.write_text("# comment\n\n1,1,10,20,30,40\n1, 2, 1, 1, 2, 2, 0, 7, 0.5\n")
    rec = read_mot(path)
    assert rec.frame.tolist() == [1, 1] and rec.track_id.tolist() == [1, 2]
    assert rec.conf.tolist() == [1.0, 0.0]
    np.testing.assert_array_equal(rec.extra, [[-1, -1, -1], [7, 0.5, -1]])
    np.testing.assert_array_equal(rec.xyxy[0], [10, 20, 40, 60])


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("1,2,3,4,5", "expected 6 to 10"),
        ("1,2,3,4,5,6,7,8,9,10,11", "expected 6 to 10"),
        ("1,2,a,4,5,6", "non-numeric"),
        ("0,2,3,4,5,6", "frame must be an integer >= 1"),
        ("1.5,2,3,4,5,6", "frame must be an integer"),
        ("1,2.5,3,4,5,6", "id must be an integer"),
        ("1,2,nan,4,5,6", "non-finite"),
        ("1e10,-1,1,1,5,5", "frame must be an integer >= 1 and <= 100000"),
        ("100001,-1,1,1,5,5", "frame must be an integer >= 1 and <= 100000"),
        ("1,1e12,1,1,5,5", "id must be an integer within"),
        ("1,-1,1,1,1e300,5", "a value beyond"),
        ("1,1,10,10,-20,-20", "width and height must be >= 0"),
    ],
)
def test_malformed_line_names_file_and_line(tmp_path: Path, line: str, message: str) -> None:
    path = tmp_path / "det.txt"
    path.write_text(f"1,-1,1,1,5,5,0.9,-1,-1,-1\n{line}\n")
    with pytest.raises(ValueError, match=message) as err:
        read_mot(path)
    assert f"{path}:2" in str(err.value)


def test_huge_frame_number_is_refused_before_allocating(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    path.write_text("1,-1,1,1,5,5,0.9\n10000000000,-1,1,1,5,5,0.9\n")  # 1e10 frames: 75 GiB to iterate
    t0 = time.perf_counter()
    with pytest.raises(MotFileError, match="frame must be an integer") as err:
        read_mot(path)
    assert time.perf_counter() - t0 < 2.0
    assert f"{path}:2" in str(err.value) and "\n" not in str(err.value)


def test_iter_frames_refuses_a_huge_sequence_length() -> None:
    with pytest.raises(ValueError, match="more than"):
        next(iter_frames(_records(), num_frames=10**10))
    assert len(list(iter_frames(_records(), num_frames=MAX_FRAME // 1000))) == MAX_FRAME // 1000


def test_binary_file_names_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    path.write_bytes(b"1,-1,1,1,5,5,0.9\n\x00\xff\xfe\x80garbage\n")
    with pytest.raises(MotFileError, match="not UTF-8 text") as err:
        read_mot(path)
    assert f"{path}:2" in str(err.value)


def test_missing_file_raises_file_not_found(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        read_mot(tmp_path / "nope.txt")


def test_empty_file(tmp_path: Path) -> None:
    path = tmp_path / "empty.txt"
    path.write_text("")
    rec = read_mot(path)
    assert len(rec) == 0 and rec.num_frames == 0
    write_mot(tmp_path / "out.txt", rec)
    assert (tmp_path / "out.txt").read_text() == ""


def test_group_and_iter_frames() -> None:
    rec = _records()
    groups = group_by_frame(rec)
    assert sorted(groups) == [1, 2, 4]
    assert groups[1].track_id.tolist() == [3, 5]
    frames = list(iter_frames(rec))
    assert [f for f, _ in frames] == [1, 2, 3, 4]
    assert [len(r) for _, r in frames] == [2, 1, 0, 1]
    assert len(list(iter_frames(rec, num_frames=6))) == 6


def test_detections_conversion() -> None:
    dets = Detections(xyxy=[[10, 20, 40, 60], [0, 0, 1, 2]], score=[0.9, 0.3], class_id=[0, 0])
    rec = from_detections(3, dets)
    assert rec.frame.tolist() == [3, 3] and rec.track_id.tolist() == [-1, -1]
    np.testing.assert_array_equal(rec.xywh[0], [10, 20, 30, 40])
    back = to_detections(rec, class_id=4)
    np.testing.assert_array_equal(back.xyxy, dets.xyxy)
    np.testing.assert_array_equal(back.score, dets.score)
    assert back.class_id.tolist() == [4, 4]


def test_from_boxes_and_array() -> None:
    rec = from_boxes(1, [4], [[1, 2, 4, 6]], [0.5])
    np.testing.assert_array_equal(rec.to_array(), [[1, 4, 1, 2, 3, 4, 0.5, -1, -1, -1]])
    again = MotRecords.from_array(rec.to_array()[:, :6])
    assert again.conf.tolist() == [1.0]
    with pytest.raises(ValueError, match="disagree"):
        MotRecords(frame=[1, 2], track_id=[1], xywh=np.zeros((2, 4)))
