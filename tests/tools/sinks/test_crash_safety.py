"""A rendered `lookahead run` with the SQLite store and the annotated video, SIGKILLed at
several moments: the MP4 opens and holds every frame it was handed up to the kill (less at
most the encoder's queue), and the store holds every frame the loop finished but at most one.

What can be observed after a kill, with the CLI's sink order (run dir, store, video): the
store commits frame k-1 when frame k arrives, so it holds S >= (frames it was handed) - 2
(-2 only while that commit runs, when the last finished frame is the only one lost); the
video is handed each frame after the store and lacks at most ``QUEUE_FRAMES + 1`` of them
(queued or being encoded). So the video's frame count V is a witness for the store and
the store for the video: V <= S + 2 and V >= S - (QUEUE_FRAMES + 1) - 1 (the store may
hold one frame the video was not yet handed). The store used to commit every 20 frames
(V - S up to 19 then), and the MP4 had no index until the end (unreadable after a kill).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import cv2
import pytest
from support.video import read_frames

from lookahead.tools.sinks.video import QUEUE_FRAMES

ROOT = Path(__file__).resolve().parents[3]
SCENARIO = "ped_crossing_nearside"  # 10 fps, 640x360
#: One launcher imports the loop once, then forks one ``lookahead run`` per output directory
#: (``sys.argv[1:]``): the runs' start-up (rendering set up in each child) overlaps and the
#: imports (seconds) are paid once. It prints the children's pids, then each one's wait status.
LAUNCHER = f"""
import os, sys
from lookahead.tools.cli import main
import lookahead.sim.runner, lookahead.tools.sinks.store, lookahead.tools.sinks.video  # noqa: F401
pids = []
for out in sys.argv[1:]:
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            sys.argv = ["lookahead", "run", "{SCENARIO}", "--out", out, "--render", "--sqlite",
                        "--video", os.path.join(out, "annotated.mp4"), "--detector", "gt"]
            code = main() or 0
        finally:
            os._exit(code)
    pids.append(pid)
print(*pids, flush=True)
for pid in pids:
    print(pid, os.waitpid(pid, 0)[1], flush=True)
"""
#: When each run is killed: the store's committed frame count to wait for, then a delay (s).
KILLS = ((1, 0.0), (3, 0.3), (6, 0.6))  # the run has 40 frames (a collision ends it at 4 s)
START_TIMEOUT_S = 120.0  # slow, shared machines: rendering set up, first frames written


def committed_frames(db: Path) -> int:
    """Frames committed in the store so far (0 before it exists or while it is being created)."""
    if not db.exists():
        return 0
    try:
        conn = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=0.5)
        try:
            return conn.execute("SELECT COUNT(*) FROM frames").fetchone()[0]
        finally:
            conn.close()
    except sqlite3.Error:
        return 0





@pytest.mark.skipif(not hasattr(os, "fork") or not hasattr(signal, "SIGKILL"), reason="needs fork and SIGKILL")
def test_sigkilled_rendered_run_keeps_a_playable_video_and_all_but_one_frame_in_the_store(tmp_path):
    outs = [tmp_path / f"run{k}" for k in range(len(KILLS))]
    log = (tmp_path / "stderr.txt").open("w")  # a file, not a pipe: nobody reads it while they run
    launcher = subprocess.Popen([sys.executable, "-c", LAUNCHER, *map(str, outs)], cwd=tmp_path,
                                stdout=subprocess.PIPE, stderr=log, text=True)
    pids = [int(p) for p in launcher.stdout.readline().split()]
    try:
        assert len(pids) == len(KILLS), (tmp_path / "stderr.txt").read_text()[-3000:]
        pending = list(zip(pids, outs, KILLS, strict=True))
        deadline = time.monotonic() + START_TIMEOUT_S
        while pending:
            for run in list(pending):
                pid, run_dir, (frames, delay) = run
                if committed_frames(run_dir / "run.sqlite") >= frames:
                    time.sleep(delay)
                    os.kill(pid, signal.SIGKILL)
                    pending.remove(run)
            assert launcher.poll() is None, (tmp_path / "stderr.txt").read_text()[-3000:]
            assert time.monotonic() < deadline, "no frames in the store in time"
            time.sleep(0.02)
        statuses = launcher.communicate(timeout=60)[0]
    finally:
        log.close()
        for pid in pids:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        if launcher.poll() is None:
            launcher.kill()
            launcher.communicate()
    status = dict(map(int, line.split()) for line in statuses.splitlines())
    assert all(os.WIFSIGNALED(status[p]) and os.WTERMSIG(status[p]) == signal.SIGKILL for p in pids), status

    seen = []
    for run_dir, (frames, _) in zip(outs, KILLS, strict=True):
        conn = sqlite3.connect(run_dir / "run.sqlite")
        try:
            assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
            stored = [r[0] for r in conn.execute("SELECT frame FROM frames ORDER BY frame")]
            assert conn.execute("SELECT complete, ended FROM runs").fetchall() == [(0, None)]
            n_timings = conn.execute("SELECT COUNT(DISTINCT frame) FROM timings").fetchone()[0]
        finally:
            conn.close()
        s = len(stored)
        assert stored == list(range(s)) and s >= frames and n_timings == s  # whole frames, in order
        video = read_frames(run_dir / "annotated.mp4")
        v = len(video)
        assert all(f.shape == (360, 640, 3) for f in video)
        assert v <= s + 2, f"the store lost more than one finished frame: {s} frames, video {v}"
        assert v >= s - (QUEUE_FRAMES + 1) - 1, f"the video lost more than the encoder's queue: {v} vs store {s}"
        seen.append((s, v))
        print(f"killed after {frames}+ frames: store {s} frames, video {v}")
    assert len({s for s, _ in seen}) > 1  # the kills landed at different moments


def test_a_truncated_video_reads_up_to_its_last_whole_frame(tmp_path):
    """The fragmented MP4 cut anywhere (a kill mid-write, a copy of a growing file) reads back
    every whole fragment; a clean close also gives the frame count and rate in the header."""
    from lookahead.tools.sinks.video import FragmentedMjpegWriter

    path, n = tmp_path / "a.mp4", 12
    w = FragmentedMjpegWriter(path, 12.5, (96, 64))
    ends = [path.stat().st_size]  # the header's end, then each fragment's
    for k in range(n):
        w.write(np_full((64, 96, 3), 20 * k))
        ends.append(path.stat().st_size)
    w.release()
    cap = cv2.VideoCapture(str(path))
    assert cap.get(cv2.CAP_PROP_FRAME_COUNT) == n and cap.get(cv2.CAP_PROP_FPS) == 12.5
    cap.release()
    data = path.read_bytes()
    for cut in (ends[0], ends[1], ends[1] + 20, ends[5] - 1, ends[5], ends[-1] - 3):
        part = tmp_path / f"cut{cut}.mp4"
        part.write_bytes(data[:cut])
        whole = sum(e <= cut for e in ends[1:])
        frames = read_frames(part) if whole else []
        # a frame cut short may still decode (a JPEG missing its last bytes): never one less
        assert len(frames) in (whole, whole + 1), cut
        assert [round(float(f.mean()) / 20) for f in frames[:whole]] == list(range(whole))  # in order


def np_full(shape: tuple[int, ...], value: int):
    import numpy as np

    return np.full(shape, value, np.uint8)
