"""Ego speed sources: fixed, none, and logs from CSV/JSON, with one-line located errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lookahead.perception import ego_speed
from lookahead.perception.ego_speed import (
    EgoSpeedError,
    EgoSpeedSource,
    FixedSpeed,
    NoSpeed,
    SpeedLog,
    load_speed_log,
    open_ego_speed,
)

CSV = "t,speed\n0.0,10.0\n1.0,12.0\n2.0,12.0\n"


def write(tmp_path: Path, name: str, text: str | bytes) -> Path:
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


def test_fixed_and_no_speed() -> None:
    assert FixedSpeed(13.9).at(0.0) == 13.9 and FixedSpeed(13.9).at(1e6) == 13.9
    assert NoSpeed().at(3.0) is None
    for src in (FixedSpeed(1.0), NoSpeed(), SpeedLog([0.0], [1.0])):
        assert isinstance(src, EgoSpeedSource)
    for bad in (-1.0, 101.0, float("nan"), float("inf")):
        with pytest.raises(EgoSpeedError, match="within 0..100"):
            FixedSpeed(bad)


def test_csv_log_interpolates_inside_and_holds_within_the_tolerance(tmp_path: Path) -> None:
    log = load_speed_log(write(tmp_path, "s.csv", CSV))
    assert len(log) == 3
    assert log.at(0.0) == 10.0
    assert log.at(0.25) == pytest.approx(10.5)
    assert log.at(1.0) == 12.0
    assert log.at(2.0) == 12.0
    assert log.at(-0.4) == 10.0 and log.at(2.5) == 12.0  # held within 0.5 s
    assert log.at(-0.6) is None and log.at(2.6) is None
    assert log.at(float("nan")) is None
    strict = load_speed_log(tmp_path / "s.csv", hold=0.0)
    assert strict.at(-0.01) is None and strict.at(2.01) is None


def test_csv_columns_in_any_order_extra_columns_comments_and_blank_lines(tmp_path: Path) -> None:
    text = "# from the CAN bus\nspeed, gear ,T\n\n10.0,3,0.0\n# pause\n14.0,4,2.0\n"
    log = load_speed_log(write(tmp_path, "s.txt", text))
    assert log.at(1.0) == pytest.approx(12.0)


def test_json_log(tmp_path: Path) -> None:
    p = write(tmp_path, "s.json", json.dumps([{"t": 0, "speed": 5}, {"t": 0.5, "speed": 6.0}], indent=1))
    log = load_speed_log(p)
    assert log.at(0.25) == pytest.approx(5.5)


def test_open_ego_speed(tmp_path: Path) -> None:
    p = write(tmp_path, "s.csv", CSV)
    assert isinstance(open_ego_speed(None), NoSpeed)
    assert isinstance(open_ego_speed("none"), NoSpeed) and isinstance(open_ego_speed(" NONE "), NoSpeed)
    assert isinstance(open_ego_speed(""), NoSpeed)
    assert open_ego_speed(8).at(0) == 8.0
    assert open_ego_speed("13.9").at(0) == 13.9
    assert isinstance(open_ego_speed(str(p)), SpeedLog) and isinstance(open_ego_speed(p), SpeedLog)
    with pytest.raises(EgoSpeedError, match="within 0..100"):
        open_ego_speed("-3")
    with pytest.raises(EgoSpeedError, match="no such speed log file"):
        open_ego_speed(str(tmp_path / "missing.csv"))
    with pytest.raises(EgoSpeedError, match="expected a number"):
        open_ego_speed(True)  # type: ignore[arg-type]


MALFORMED = [
    # (file name, content, pieces of the one-line message after the path)
    ("s.csv", "t,speed\n0,1\n1,nan\n", [":3:", "speed must be finite"]),
    ("s.csv", "t,speed\n0,1\n1,inf\n", [":3:", "finite"]),
    ("s.csv", "t,speed\n0,1\n2,1\n1,1\n", [":4:", "not after"]),
    ("s.csv", "t,speed\n0,1\n0,1\n", [":3:", "not after"]),
    ("s.csv", "time,speed\n0,1\n", [":1:", "missing t"]),
    ("s.csv", "t,velocity\n0,1\n", [":1:", "missing speed"]),
    ("s.csv", "t,speed\n0,1,2\n", [":2:", "3 columns"]),
    ("s.csv", "t,speed\n0,fast\n", [":2:", "speed is not a number", "'fast'"]),
    ("s.csv", "t,speed\n0,-1\n", [":2:", "outside 0..100"]),
    ("s.csv", "t,speed\n0,150\n", [":2:", "outside 0..100"]),
    ("s.csv", "t,speed\n", ["no samples"]),
    ("s.csv", "\n# nothing\n", ["empty"]),
    ("s.csv", b"t,speed\n0,1\n\x00\x01\x02", [":3:", "not text"]),
    ("s.csv", b"t,speed\n0,1\n\xff\xfe1,2\n", [":3:", "not UTF-8"]),
    ("s.json", '[\n {"t": 0, "speed": 1},\n {"t": 1, "speed": NaN}\n]', [":3:", "[1].speed", "finite"]),
    ("s.json", '[\n {"t": 1, "speed": 1},\n {"t": 0, "speed": 1}\n]', [":3:", "[1]", "not after"]),
    ("s.json", '[\n {"t": 0, "speed": 1},\n {"t": 1}\n]', [":3:", "missing field 'speed'"]),
    ("s.json", '[\n {"t": 0, "speed": 1, "gear": 3}\n]', [":2:", "unknown field 'gear'"]),
    ("s.json", '[\n {"t": 0, "speed": "1"}\n]', [":2:", "expected a number"]),
    ("s.json", '[\n {"t": 0, "speed": true}\n]', [":2:", "expected a number"]),
    ("s.json", '[\n {"t": 0, "speed": 1},\n 5\n]', [":3:", "expected an object"]),
    ("s.json", '{"t": [0], "speed": [1]}', [":1:", "expected a JSON list"]),
    ("s.json", '[\n {"t": 0, "speed": 1}\n\n {"t": 1, "speed": 1}]', [":4:", "expected ',' or ']'"]),
    ("s.json", '[\n {"t": 0, "speed": 1},\n {"t": 1, "speed": }\n]', [":3:", "malformed JSON"]),
    ("s.json", '[{"t": 0, "speed": 1}]\n]', [":2:", "extra data"]),
    ("s.json", "[]", ["no samples"]),
]


@pytest.mark.parametrize(("name", "content", "pieces"), MALFORMED, ids=range(len(MALFORMED)))
def test_malformed_log_is_one_line_naming_the_file(tmp_path: Path, name: str, content: str | bytes,
                                                   pieces: list[str]) -> None:
    p = write(tmp_path, name, content)
    with pytest.raises(EgoSpeedError) as info:
        load_speed_log(p)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(str(p)), msg
    for piece in pieces:
        assert piece in msg, msg


def test_oversized_log_is_refused_before_reading(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(ego_speed, "MAX_SPEED_LOG_BYTES", 100)
    p = write(tmp_path, "s.csv", "t,speed\n" + "".join(f"{i},1\n" for i in range(50)))
    with pytest.raises(EgoSpeedError, match=rf"^{p}: \d+ bytes, more than the 100"):
        load_speed_log(p)


def test_speed_log_checks_its_arrays() -> None:
    with pytest.raises(EgoSpeedError, match="not after"):
        SpeedLog([0.0, 1.0, 1.0], [1.0, 1.0, 1.0], "x")
    with pytest.raises(EgoSpeedError, match="outside 0..100"):
        SpeedLog([0.0, 1.0], [1.0, -2.0], "x")
    with pytest.raises(EgoSpeedError, match="finite"):
        SpeedLog([0.0, float("nan")], [1.0, 1.0], "x")
    with pytest.raises(EgoSpeedError, match="at least one sample"):
        SpeedLog([], [], "x")
