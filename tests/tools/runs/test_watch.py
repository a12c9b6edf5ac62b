"""``lookahead watch``: the perception stack on a video made from a simulated run (issue 32, first slice)."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
from pathlib import Path

import cv2
import numpy as np
import pytest
from support.clips import render_records
from support.video import count_frames
from system_deps import vtest_avi

from lookahead.perception.calibration import CameraCalibration, load_calibration, write_calibration
from lookahead.perception.detections import CLASS_ID
from lookahead.tools.runs.watch import WatchStatus, watch
from lookahead.tools.sinks.rundir import RunDir

FRAMES = 30  # 3 s at the scenario's 10 Hz camera, 640 x 360: the pedestrian from ~44 m to ~11 m


@pytest.fixture(scope="module")
def clip(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """An MP4 of FRAMES rendered frames of ped_crossing_nearside, the simulator camera's calibration
    file, and each frame's ground truth (pedestrian range, whether it is visible)."""
    d = tmp_path_factory.mktemp("watch_clip")
    records, camera = render_records(FRAMES)
    path = d / "clip.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (640, 360))
    for rec in records:
        writer.write(cv2.cvtColor(rec.frame.image, cv2.COLOR_RGB2BGR))
    writer.release()
    cal = write_calibration(CameraCalibration.from_camera(camera), d / "camera.yaml")
    visible = [bool(np.any(rec.ground_truth.visible_fraction > 0.5)) for rec in records]
    ped_range = [float(rec.ground_truth.range[0]) for rec in records]
    return {"video": path, "calibration": cal, "visible": visible, "range": ped_range}





def test_watch_rendered_clip_all_outputs(clip: dict, tmp_path: Path, lookahead, capsys) -> None:
    out, db, video = tmp_path / "run", tmp_path / "watch.sqlite", tmp_path / "run" / "annotated.mp4"
    code = lookahead("watch", clip["video"], "--out", out, "--calibration", clip["calibration"],
                     "--ego-speed", "11.1", "--video", video, "--db", db, "--rerun", out / "run.rrd", "--narrate")
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert f"{FRAMES} frames" in printed.err and "0 dropped" in printed.err
    assert f"report: {out / 'report.html'}" in printed.err

    # the report of a run without ground truth: what the stack produced, nothing scored
    metrics = json.loads((out / "metrics.json").read_text())
    observed = metrics["observed"]
    assert "detection" not in metrics and "tracking" not in metrics
    assert observed["frames"] == FRAMES and observed["confirmed_tracks"] >= 1
    assert observed["detections_per_class"]["pedestrian"] >= FRAMES - 3 and observed["frames_without_ego_speed"] == 0
    html = (out / "report.html").read_text()
    assert "observed" in html and "confirmed_tracks" in html
    assert (out / "run.rrd").stat().st_size > 10_000

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
    assert count_frames(video) == FRAMES

    # narration on real video: a sentence in each language per warning, no ground truth to check against
    warnings = [a for t in ticks for a in t["alerts"] if a["kind"] in ("fcw", "critical") and a["level"] >= 3]
    lines = [json.loads(line) for line in (out / "narration.jsonl").read_text().splitlines()]
    assert len(warnings) >= 1 and len(lines) == len(warnings)
    for line, alert in zip(lines, warnings, strict=True):
        assert (line["track_id"], line["kind"], line["t"]) == (alert["track_id"], alert["kind"], alert["t"])
        assert line["facts"]["class"] == "pedestrian" and "pedestrian" in line["en"] and "行人" in line["zh"]
        assert line["truth_actor"] is None and line["truth_facts"] is None and line["source"] == "template"


def test_watch_sigint_ends_run_flushed_without_ego_speed(clip: dict, tmp_path: Path) -> None:
    """SIGINT (from the consumer, at frame 3) stops the capture; every output is complete with
    the frames done. Default camera (no calibration) and no ego speed: recorded as such."""
    out = tmp_path / "run"

    def progress(status: WatchStatus) -> None:
        if status.frames == 3:
            os.kill(os.getpid(), signal.SIGINT)

    old = signal.getsignal(signal.SIGINT)
    summary = watch(str(clip["video"]), out, video=out / "annotated.mp4", db=out / "run.sqlite", progress=progress)
    assert signal.getsignal(signal.SIGINT) is old  # the handler is restored
    assert summary["interrupted"] is True and summary["frames"] == 3 and summary["error"] is None
    assert summary["interrupted_by"] == "SIGINT"
    assert summary["frames_without_ego_speed"] == 3
    run = RunDir(out)
    assert run.run["complete"] is True and len(run.ticks) == 3
    config = run.run["scenario"]
    assert config["ego_speed_available"] is False and "unavailable" in config["ego_speed_note"]
    assert config["calibration_file"] is None and config["camera_from"].startswith("default: 90 deg")
    assert all(t["ego"]["speed_known"] is False for t in run.ticks)
    tracked = [t["tracks"] for t in run.ticks if t["tracks"]["track_id"]]
    assert tracked  # ... ranged, with the ground speed unavailable (null), not guessed from speed 0
    assert all(v is None for tr in tracked for v in tr["ground_vx"])
    assert all(r is not None and r > 0 for tr in tracked for r in tr["range"])
    with sqlite3.connect(out / "run.sqlite") as conn:
        assert conn.execute("SELECT complete FROM runs").fetchall() == [(1,)]
        assert conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0] == 3
    assert count_frames(out / "annotated.mp4") == 3


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


def test_watch_real_footage_hog_tracks_pedestrians(tmp_path: Path, lookahead, capsys) -> None:
    """OpenCV's sample clip vtest.avi (real pedestrians, 768 x 576 at 10 fps) through
    ``watch --detector hog``: several pedestrians, each held by one confirmed track for seconds."""
    clip = vtest_avi()
    out = tmp_path / "vtest"
    code = lookahead("watch", clip, "--out", out, "--detector", "hog", "--max-frames", "60", "--no-report",
                     "--video", out / "annotated.mp4")
    assert code == 0, capsys.readouterr().err
    run = RunDir(out)
    assert run.run["scenario"]["detector"]["kind"] == "hog" and run.run["scenario"]["detector"]["model"] == "hog"
    frames_of: dict[int, int] = {}
    for t in run.ticks:
        tr = t["tracks"]
        for tid, state, cls in zip(tr["track_id"], tr["state"], tr["class_id"], strict=True):
            if state == "confirmed":
                assert cls == CLASS_ID["pedestrian"]
                frames_of[tid] = frames_of.get(tid, 0) + 1
    held = [n for n in frames_of.values() if n >= 20]  # 2 s or more under one id
    assert len(held) >= 3, frames_of
    assert count_frames(out / "annotated.mp4") == 60


def test_watch_and_the_run_files_load_no_simulator() -> None:
    """Real video needs no simulator: watch, the run-directory writer and the scorers import
    neither highway-env, PyBullet nor matplotlib (start-up, and a one-line refusal, stay light;
    gymnasium comes with ``import lookahead.sim``, which registers the envs)."""
    import subprocess
    import sys

    code = ("import sys\nimport lookahead.tools.runs.watch, lookahead.tools.sinks.rundir, lookahead.tools.scoring.run\n"
            "print(','.join(m for m in ('highway_env', 'pybullet', 'matplotlib') if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
