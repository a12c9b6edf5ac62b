"""``lookahead watch``: the perception stack on a video made from a simulated run (issue 32, first slice)."""

from __future__ import annotations

import os
import signal
import sqlite3
from pathlib import Path

import cv2
import numpy as np
import pytest

from lookahead.perception.calibration import CameraCalibration, load_calibration, write_calibration
from lookahead.perception.detections import CLASS_ID
from lookahead.sim.catalogue import resolve_path
from lookahead.sim.records import RecordCollector
from lookahead.sim.runner import Runner
from lookahead.sim.scenario import load_scenario, with_detector
from lookahead.tools.runs.watch import watch
from lookahead.tools.sinks.rundir import RunDir

FRAMES = 30  # 3 s at the scenario's 10 Hz camera, 640 x 360: the pedestrian from ~44 m to ~11 m


@pytest.fixture(scope="module")
def clip(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """An MP4 of FRAMES rendered frames of ped_crossing_nearside, the simulator camera's calibration
    file, and each frame's ground truth (pedestrian range, whether it is visible)."""
    d = tmp_path_factory.mktemp("watch_clip")
    scenario = with_detector(load_scenario(resolve_path("ped_crossing_nearside")), "gt", None)  # gt: fast
    col = RecordCollector()
    runner = Runner(scenario, sinks=[col], render=True)
    try:
        for _ in range(FRAMES):
            runner.step()
    finally:
        runner.close()
    path = d / "clip.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), scenario.camera.rate, (640, 360))
    for rec in col.records:
        writer.write(cv2.cvtColor(rec.frame.image, cv2.COLOR_RGB2BGR))
    writer.release()
    cal = write_calibration(CameraCalibration.from_camera(runner.camera), d / "camera.yaml")
    visible = [bool(np.any(rec.ground_truth.visible_fraction > 0.5)) for rec in col.records]
    ped_range = [float(rec.ground_truth.range[0]) for rec in col.records]
    return {"video": path, "calibration": cal, "visible": visible, "range": ped_range}


def _video_frames(path: Path) -> int:
    cap = cv2.VideoCapture(str(path))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    return n


def test_watch_rendered_clip_all_outputs(clip: dict, tmp_path: Path, lookahead, capsys) -> None:
    out, db, video = tmp_path / "run", tmp_path / "watch.sqlite", tmp_path / "run" / "annotated.mp4"
    code = lookahead("watch", clip["video"], "--out", out, "--calibration", clip["calibration"],
                     "--ego-speed", "11.1", "--video", video, "--db", db)
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert f"{FRAMES} frames" in printed.err and "0 dropped" in printed.err

    run = RunDir(out)
    assert run.run["complete"] is True
    summary = run.run["summary"]
    assert summary["frames"] == FRAMES and summary["dropped"] == 0 and summary["gaps"] == []
    assert summary["fps"] > 0 and summary["frames_without_ego_speed"] == 0 and summary["interrupted"] is False
    config = run.run["scenario"]
    assert config["kind"] == "watch" and config["ego_speed_available"] is True
    assert config["calibration_file"] == str(clip["calibration"]) and config["undistort"] is False
    ticks = run.ticks
    assert [t["frame"] for t in ticks] == list(range(FRAMES)) and len(run.timings) == FRAMES
    assert all(t["ground_truth"]["actor_id"] == [] for t in ticks)
    assert all(t["ego"]["speed"] == 11.1 and t["ego"]["speed_known"] for t in ticks)
    assert ticks[1]["t"] == pytest.approx(0.1)

    # the pedestrian: one confirmed pedestrian track over the frames it is visible in (after a
    # frame or two of birth), ranged through the calibration within 15 % once it is near
    ped = CLASS_ID["pedestrian"]
    visible = [i for i, v in enumerate(clip["visible"]) if v]
    assert len(visible) >= FRAMES - 2
    held = 0
    for i in visible[2:]:
        tr = ticks[i]["tracks"]
        confirmed = [k for k, (c, s) in enumerate(zip(tr["class_id"], tr["state"], strict=True))
                     if c == ped and s == "confirmed"]
        if confirmed:
            held += 1
            if clip["range"][i] < 30.0:
                rng = min(tr["range"][k] for k in confirmed)
                assert rng == pytest.approx(clip["range"][i], rel=0.15), (i, rng, clip["range"][i])
    assert held >= 0.9 * len(visible[2:])
    assert summary["confirmed_tracks"] >= 1

    with sqlite3.connect(db) as conn:
        runs = conn.execute("SELECT id, complete FROM runs").fetchall()
        assert runs == [(runs[0][0], 1)]
        assert conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0] == FRAMES
        assert conn.execute("SELECT COUNT(*) FROM ground_truth").fetchone()[0] == 0
        assert conn.execute("SELECT COUNT(DISTINCT frame) FROM tracks WHERE cls = 'pedestrian'").fetchone()[0] \
            >= 0.9 * len(visible[2:])
    assert _video_frames(video) == FRAMES


def test_watch_sigint_ends_run_flushed_without_ego_speed(clip: dict, tmp_path: Path) -> None:
    """SIGINT (from the consumer, at frame 3) stops the capture; every output is complete with
    the frames done. Default camera (no calibration) and no ego speed: recorded as such."""
    out = tmp_path / "run"

    def progress(n: int) -> None:
        if n == 3:
            os.kill(os.getpid(), signal.SIGINT)

    old = signal.getsignal(signal.SIGINT)
    summary = watch(str(clip["video"]), out, video=out / "annotated.mp4", db=out / "run.sqlite", progress=progress)
    assert signal.getsignal(signal.SIGINT) is old  # the handler is restored
    assert summary["interrupted"] is True and summary["frames"] == 3 and summary["error"] is None
    assert summary["frames_without_ego_speed"] == 3
    run = RunDir(out)
    assert run.run["complete"] is True and len(run.ticks) == 3
    config = run.run["scenario"]
    assert config["ego_speed_available"] is False and "not meaningful" in config["ego_speed_note"]
    assert config["calibration_file"] is None and config["camera"].startswith("default: 90 deg")
    assert all(t["ego"]["speed_known"] is False for t in run.ticks)
    with sqlite3.connect(out / "run.sqlite") as conn:
        assert conn.execute("SELECT complete FROM runs").fetchall() == [(1,)]
        assert conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0] == 3
    assert _video_frames(out / "annotated.mp4") == 3


def test_watch_missing_source_one_line(tmp_path: Path, lookahead, capsys) -> None:
    missing = tmp_path / "nope.mp4"
    assert lookahead("watch", missing, "--out", tmp_path / "run") == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("error:") and str(missing) in err
    assert not (tmp_path / "run").exists()


def test_watch_bad_calibration_one_line(clip: dict, tmp_path: Path, lookahead, capsys) -> None:
    bad = tmp_path / "camera.yaml"
    bad.write_text("version: 1\nimage: {width: 640, height: 360}\nintrinsics: {fx: -3.0, fy: 320.0}\n"
                   "mount: {x: -1.5, height: 1.4}\n", encoding="utf-8")
    assert lookahead("watch", clip["video"], "--out", tmp_path / "run", "--calibration", bad) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("error:") and str(bad) in err and "fx" in err
    assert not (tmp_path / "run").exists()


def test_watch_undistorts_a_distorted_calibration(clip: dict, tmp_path: Path) -> None:
    """A calibration with distortion: frames are undistorted to the pinhole camera (recorded), and
    ``max_frames`` ends the run complete."""
    data = load_calibration(clip["calibration"]).model_dump()
    cal = CameraCalibration.model_validate({**data, "distortion": {**data["distortion"], "k1": -0.05}})
    path = write_calibration(cal, tmp_path / "distorted.yaml")
    summary = watch(str(clip["video"]), tmp_path / "run", calibration=path, ego_speed="11.1", max_frames=3)
    assert summary["frames"] == 3 and summary["interrupted"] is False and summary["frames_without_ego_speed"] == 0
    run = RunDir(tmp_path / "run")
    assert run.run["complete"] is True and run.run["scenario"]["undistort"] is True and len(run.ticks) == 3
    assert all("undistort" in t for t in run.timings)
