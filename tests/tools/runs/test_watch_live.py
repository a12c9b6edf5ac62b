"""``lookahead watch`` while it runs (issue 32): a live configuration re-read between frames,
SIGTERM / SIGKILL on the real command, capture-to-alert latency and the status line."""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import cv2
import pytest
from support.clips import render_records

from lookahead.intent.alerts import AlertConfig
from lookahead.intent.config import IntentConfig
from lookahead.intent.live_config import ConfigWatcher, LiveConfigError, load_live_config
from lookahead.intent.stack import PerceptionStack
from lookahead.perception.config import SettingsError
from lookahead.perception.detectors.gt_detector import GtNoiseConfig, GtNoiseDetector
from lookahead.tools.cli import _watch_status
from lookahead.tools.runs.watch import WatchStatus, default_camera, watch
from lookahead.tools.sinks.rundir import RunDir

FRAMES = 12  # rendered frames of ped_crossing_nearside (640 x 360): the pedestrian, and low-score clutter
LOOPS = 25  # the kill tests' clip: the frames this many times (300 frames, several seconds of work)
EXE = Path(sys.executable).parent / "lookahead"
LIVE_LOG = "lookahead.intent.live_config"
STACK_STAGES = ("preprocess", "detect", "track", "estimate", "intent")


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A folder of FRAMES rendered PNGs, and an MP4 of them looped LOOPS times."""
    d = tmp_path_factory.mktemp("watch_live")
    records, _ = render_records(FRAMES)
    folder = d / "frames"
    folder.mkdir()
    images = [cv2.cvtColor(rec.frame.image, cv2.COLOR_RGB2BGR) for rec in records]
    for k, img in enumerate(images):
        cv2.imwrite(str(folder / f"f{k:03d}.png"), img)
    clip = d / "long.mp4"
    writer = cv2.VideoWriter(str(clip), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (640, 360))
    for _ in range(LOOPS):
        for img in images:
            writer.write(img)
    writer.release()
    return {"folder": folder, "clip": clip}


def _scores(run: RunDir) -> list[list[float]]:
    return [t["detections"]["score"] for t in run.ticks]


def test_config_edit_applies_from_the_next_frame(frames: dict, tmp_path: Path, caplog) -> None:
    """The score threshold (and an alert and a risk setting) edited while frame 2 is processed
    (from ``progress``): frames 0-2 ran with the old threshold, frame 3 on with the new one."""
    cfg = tmp_path / "live.yaml"
    cfg.write_text("detector: {conf: 0.45}\n", encoding="utf-8")
    statuses: list[WatchStatus] = []

    def progress(status: WatchStatus) -> None:
        statuses.append(status)
        if status.frames == 3:
            cfg.write_text("detector: {conf: 0.1}\nalerts: {on_frames_high: 3}\n"
                           "intent:\n  risk:\n    pedestrian: {high_ttc: 3.5}\n", encoding="utf-8")

    caplog.set_level(logging.INFO)
    out = tmp_path / "run"
    summary = watch(str(frames["folder"]), out, config=cfg, ego_speed="11.1", max_frames=6, progress=progress)
    run = RunDir(out)
    scores = _scores(run)
    assert len(scores) == 6
    assert all(s >= 0.45 for f in scores[:3] for s in f)  # the old threshold: the pedestrian at most
    assert any(0.1 <= s < 0.45 for s in scores[3])  # the new one at once, on frame 3
    assert all(s >= 0.1 for f in scores[3:] for s in f)
    assert summary["config_reloads"] == [{"frame": 3, "t": pytest.approx(0.1), "changed": {
        "alerts.on_frames_high": {"from": 2, "to": 3}, "detector.conf": {"from": 0.45, "to": 0.1},
        "intent.risk.pedestrian.high_ttc": {"from": 3.0, "to": 3.5}}}]
    assert summary["config_rejected"] == 0
    reloads = [r for r in caplog.records if r.name == "lookahead.tools.runs.watch.config"]
    assert len(reloads) == 1 and "frame 3" in reloads[0].getMessage() and "detector.conf 0.45 -> 0.1" in \
        reloads[0].getMessage()
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    # the configuration in force at start is the run's
    config = run.run["scenario"]
    assert config["config_file"] == str(cfg) and config["config"]["detector"] == {"conf": 0.45, "iou": 0.45}
    assert config["detector"]["conf"] == 0.45

    # latency: from capture to alerts, so at least the stack's stages; summarised
    for tim in run.timings:
        assert tim["latency"] >= sum(tim[k] for k in STACK_STAGES) > 0
    lat = summary["latency_ms"]
    assert set(lat) == {"p50", "p95", "max"} and 0 < lat["p50"] <= lat["p95"] <= lat["max"] < 60_000
    assert set(STACK_STAGES) | {"undistort", "config", "sinks", "tick"} == set(summary["stage_ms"])
    assert summary["stage_ms"]["detect"] > 0 and summary["stage_ms"]["tick"] >= summary["stage_ms"]["detect"]
    # the status each frame
    assert [s.frames for s in statuses] == list(range(1, 7)) and statuses[-1].total == 6
    assert statuses[-1].config_reloads == 1 and statuses[-1].latency_ms == pytest.approx(run.timings[-1]["latency"], abs=1e-3)
    line = _watch_status(statuses[-1])
    assert line.startswith("6/6 frames, ") and "0 dropped" in line and "1 reloads/0 rejected" in line


def test_invalid_edits_are_one_warning_each_and_the_run_goes_on(frames: dict, tmp_path: Path, caplog) -> None:
    """A half-written file (bad YAML) after frame 1, a schema error after frame 2: one warning line
    each (not one a frame), the old threshold stays; a valid edit after frame 3 applies at frame 4."""
    cfg = tmp_path / "live.yaml"
    cfg.write_text("detector: {conf: 0.45}\n", encoding="utf-8")
    edits = {2: "detector: {conf: 0.", 3: "detector:\n  conf: 1.5\n", 4: "detector: {conf: 0.1}\n"}

    def progress(status: WatchStatus) -> None:
        if status.frames in edits:
            cfg.write_text(edits[status.frames], encoding="utf-8")

    caplog.set_level(logging.INFO)
    summary = watch(str(frames["folder"]), tmp_path / "run", config=cfg, max_frames=6, progress=progress)
    assert summary["frames"] == 6 and summary["error"] is None
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING and r.name == LIVE_LOG]
    assert len(warnings) == 2, warnings
    assert all("\n" not in w and "the configuration in force stays" in w for w in warnings)
    assert re.match(rf"{re.escape(str(cfg))}:\d+: malformed YAML", warnings[0])  # libyaml: where the input ended
    assert warnings[1].startswith(f"{cfg}:2: detector.conf: ") and "1.5" in warnings[1]
    scores = _scores(RunDir(tmp_path / "run"))
    assert all(s >= 0.45 for f in scores[:4] for s in f)
    assert any(0.1 <= s < 0.45 for s in scores[4])
    assert [r["frame"] for r in summary["config_reloads"]] == [4] and summary["config_rejected"] == 2


def test_missing_or_invalid_config_at_start_is_one_line(frames: dict, tmp_path: Path, lookahead, capsys) -> None:
    bad = tmp_path / "live.yaml"
    for path, text, expect in ((tmp_path / "nope.yaml", None, "no such live configuration file"),
                               (bad, "alerts:\n  off_frame: 2\n", ":2: alerts.off_frame: unknown field"),
                               (bad, "intent: {horizon: .inf}\n", ":1: intent.horizon: expected a finite number")):
        if text is not None:
            path.write_text(text, encoding="utf-8")
        assert lookahead("watch", frames["folder"], "--out", tmp_path / "run", "--config", path) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and err.startswith("error:") and str(path) in err and expect in err, err
        assert not (tmp_path / "run").exists()


def test_config_watcher_polls_cheaply_and_survives_a_vanished_file(tmp_path: Path, caplog) -> None:
    cfg = tmp_path / "live.yaml"
    cfg.write_text("detector: {conf: 0.3}\n", encoding="utf-8")
    old = time.time_ns() - 10**10
    os.utime(cfg, ns=(old, old))  # not "racy": an unchanged stamp is not re-read
    applied = []
    w = ConfigWatcher(cfg, apply=applied.append)
    assert w.config.detector.conf == 0.3 and w.poll() is None
    cfg.write_text("detector: {conf: 0.35}\n", encoding="utf-8")
    os.utime(cfg, ns=(old + 1, old + 1))
    assert w.poll() == {"detector.conf": {"from": 0.3, "to": 0.35}} and w.poll() is None
    assert [c.detector.conf for c in applied] == [0.35] and w.config.detector.conf == 0.35
    cfg.write_text("# a comment\ndetector: {conf: 0.35, iou: 0.45}\n", encoding="utf-8")  # nothing changes
    assert w.poll() is None and w.config.detector.iou == 0.45 and len(applied) == 1
    cfg.unlink()
    caplog.set_level(logging.WARNING)
    assert w.poll() is None and w.poll() is None
    assert [r.getMessage() for r in caplog.records] == [f"{cfg}: the live configuration file is gone; "
                                                       "the configuration in force stays"]
    cfg.write_text("intent: {corridor_margin: 0.8}\n", encoding="utf-8")  # back: all defaults but the margin
    assert w.poll() == {"detector.conf": {"from": 0.35, "to": 0.25},
                        "intent.corridor_margin": {"from": 0.5, "to": 0.8}}
    w.apply = lambda new: (_ for _ in ()).throw(SettingsError("refused"))  # apply may refuse
    cfg.write_text("intent: {corridor_margin: 0.9}\n", encoding="utf-8")
    assert w.poll() is None and w.config.intent == {"corridor_margin": 0.8} and w.rejected == 2
    assert load_live_config(cfg).intent == {"corridor_margin": 0.9}
    with pytest.raises(LiveConfigError, match="no such live configuration file"):
        ConfigWatcher(tmp_path / "none.yaml")


def test_reconfigure_changes_thresholds_and_refuses_what_the_detector_lacks() -> None:
    stack = PerceptionStack(GtNoiseDetector(GtNoiseConfig(), seed=0), default_camera(640, 360), 10.0, IntentConfig())
    intent = IntentConfig().with_overrides({"corridor_margin": 0.9})
    stack.reconfigure(intent_config=intent, alert_config=AlertConfig(off_frames=5))
    assert stack.intent_config.corridor_margin == 0.9 and stack.alerts.config.off_frames == 5
    with pytest.raises(SettingsError, match="detector_conf"):
        stack.reconfigure(intent_config=IntentConfig(), detector_conf=0.5)
    assert stack.intent_config.corridor_margin == 0.9  # refused whole


@pytest.mark.skipif(not EXE.exists() or not hasattr(signal, "SIGKILL"), reason="console script or SIGKILL missing")
def test_sigterm_and_sigkill_mid_run_leave_a_sound_store(frames: dict, tmp_path: Path) -> None:
    """The real command with --db, SIGTERMed and SIGKILLed after a few frames: the store passes
    PRAGMA integrity_check and holds every frame of ticks.jsonl (the killed one: all but at most
    the last line); the SIGTERMed run ends complete and interrupted, with its summary."""
    runs = {}
    for name in ("term", "kill"):
        out = tmp_path / name
        cmd = [str(EXE), "watch", str(frames["clip"]), "--out", str(out), "--db", str(out / "run.sqlite"),
               "--ego-speed", "11.1"]
        err = (tmp_path / f"{name}.err").open("w")
        runs[name] = (out, subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True), err)
    try:
        deadline = time.monotonic() + 90.0
        pending = {"term": signal.SIGTERM, "kill": signal.SIGKILL}
        while pending:
            for name, sig in list(pending.items()):
                out, proc, _ = runs[name]
                assert proc.poll() is None, (tmp_path / f"{name}.err").read_text()[-2000:]
                ticks = out / "ticks.jsonl"
                if ticks.exists() and ticks.read_bytes().count(b"\n") >= 3:
                    proc.send_signal(sig)
                    del pending[name]
            assert time.monotonic() < deadline, "no frames in time"
            time.sleep(0.02)
        codes = {name: proc.wait(timeout=60) for name, (_, proc, _) in runs.items()}
    finally:
        for _, proc, err in runs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            err.close()
    assert codes == {"term": 0, "kill": -signal.SIGKILL}, (tmp_path / "term.err").read_text()[-2000:]

    for name, (out, _, _) in runs.items():
        raw = (out / "ticks.jsonl").read_bytes()
        whole = raw.split(b"\n")[:-1]  # a torn last line (no newline yet) is not a frame
        ticks = [json.loads(line)["frame"] for line in whole]
        assert ticks == list(range(len(ticks))) and len(ticks) >= 3
        with sqlite3.connect(out / "run.sqlite") as conn:
            assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
            stored = [r[0] for r in conn.execute("SELECT frame FROM frames ORDER BY frame")]
            complete = conn.execute("SELECT complete FROM runs").fetchall()
            timed = conn.execute("SELECT COUNT(DISTINCT frame) FROM timings WHERE stage = 'latency'").fetchone()[0]
        assert stored == ticks[:len(stored)] and len(ticks) - len(stored) <= (0 if name == "term" else 1), \
            (name, len(ticks), len(stored))
        assert timed == len(stored)
        if name == "term":
            run = RunDir(out)
            s = run.run["summary"]
            assert run.run["complete"] is True and complete == [(1,)] and raw.endswith(b"\n")
            assert s["interrupted"] is True and s["interrupted_by"] == "SIGTERM" and s["frames"] == len(ticks)
            assert len(ticks) < FRAMES * LOOPS and s["latency_ms"]["p50"] > 0
            assert len(run.timings) == len(ticks)
        else:
            assert complete == [(0,)]


def test_status_line_names_gaps_and_reloads() -> None:
    st = WatchStatus(frames=7, total=None, t=0.7, fps=None, dropped=2, alerts=1, gaps=1, reconnects=1,
                     latency_ms=41.6, config_reloads=0, config_rejected=1)
    assert _watch_status(st) == ("7 frames, — fps, latency 42 ms, 2 dropped, 1 alerts, 1 gaps/1 reconnects, "
                                 "0 reloads/1 rejected")
