"""``lookahead watch`` on a real RTSP stream (issue 32, "Must show: Stream"): a GStreamer RTSP
server on loopback (``support/rtsp_server.py``) streams a numbered clip, is killed (SIGKILL)
mid-stream and restarted on the same port; ``watch`` reconnects and continues, the frames before
the drop are in every output, and the gap is recorded in the run."""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from pathlib import Path

import pytest
from support.rtsp_server import CHECK_ARGS, NEEDS, RtspServer, frame_number, write_numbered_frames
from support.video import iter_frames
from system_deps import require_system_python

from lookahead.perception.sources import ReconnectPolicy
from lookahead.tools.runs import watch as watch_module
from lookahead.tools.runs.watch import WatchStatus, watch
from lookahead.tools.sinks.rundir import RunDir

W, H = 320, 240
FPS = 5  # the server's frame rate (frames/s)
FRAMES = 300  # numbered frames the server serves (looping)
BEFORE = 10  # frames processed when the server is killed
RESTART_S = 0.5  # the server is restarted this long after it was killed (s)
RESTART_AT = 200  # ... serving from this frame number on
AFTER = 8  # frames processed after the reconnect when the server is killed for good
#: the run's backoff: 0.25, 0.5, 1, 1 s, then it gives up (the default would wait 55 s)
POLICY = ReconnectPolicy(initial_s=0.25, factor=2.0, max_s=1.0, max_attempts=4)


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    require_system_python(CHECK_ARGS, NEEDS)
    return write_numbered_frames(tmp_path_factory.mktemp("rtsp_frames"), FRAMES, (W, H))


def video_numbers(path: Path) -> list[int]:
    return [frame_number(image) for image in iter_frames(path)]


def increasing(xs: list[int]) -> bool:
    return all(a < b for a, b in zip(xs, xs[1:], strict=False))


def test_watch_rtsp_server_crash_reconnects_keeps_frames_and_records_the_gap(
        frames_dir: Path, tmp_path: Path) -> None:
    """Killed after BEFORE frames, back RESTART_S later from frame RESTART_AT; killed for good
    AFTER frames after the reconnect, when the run ends as the backoff gives up. Every frame the
    server sent is in every output (run directory, store, annotated video) or counted in
    ``dropped`` (a live source drops its oldest frame when the stack falls behind), the last one
    before each drop is in all of them, and both gaps are in the run's summary."""
    out = tmp_path / "run"
    db, video = out / "run.sqlite", out / "annotated.mp4"
    statuses: list[WatchStatus] = []
    killed_at: list[float] = []
    resumed_from: list[int] = []  # frames done when the reconnect was first seen
    with RtspServer(frames_dir, fps=FPS) as server:
        restart = threading.Timer(RESTART_S, server.start, kwargs={"start": RESTART_AT})

        def progress(status: WatchStatus) -> None:
            statuses.append(status)
            if not killed_at and status.frames == BEFORE:  # the crash
                killed_at.append(time.monotonic())
                server.kill()
                restart.start()
            elif len(killed_at) == 1 and status.reconnects:
                resumed_from.append(status.frames)
                if status.frames >= resumed_from[0] + AFTER:  # the end
                    killed_at.append(time.monotonic())
                    server.kill()

        server.start()
        try:
            summary = watch(server.url, out, db=db, video=video, progress=progress, reconnect=POLICY)
        finally:
            restart.cancel()
            if restart.ident is not None:
                restart.join()
    assert len(killed_at) == 2, summary

    # the run ended normally when the stream did not come back the second time
    assert summary["error"] is None and summary["interrupted"] is False
    n = summary["frames"]
    # the gaps, in the run's summary: the first after the last frame the server sent, resumed after
    # the restart; the second never resumed
    first, second = summary["gaps"]
    assert first["lost_at"] >= round(killed_at[0], 3) - 0.001 and first["resumed_at"] is not None
    assert first["resumed_at"] - first["lost_at"] >= RESTART_S - 0.1
    assert second["lost_at"] >= round(killed_at[1], 3) - 0.001 and second["resumed_at"] is None
    assert (statuses[-1].gaps, statuses[-1].reconnects) == (2, 1)
    a, b = first["after_index"], second["after_index"]  # the source's frame indices

    # the frames in the outputs: the server's 0..a before the first drop, RESTART_AT.. after it
    numbers = video_numbers(video)
    assert len(numbers) == n
    pre = [x for x in numbers if x < RESTART_AT]
    post = numbers[len(pre):]
    assert increasing(pre) and pre[-1] == a  # the last frame before the drop made it
    assert increasing(post) and post[0] >= RESTART_AT and all(x >= RESTART_AT for x in post)
    assert post[-1] == RESTART_AT + (b - a - 1)  # ... and the last one before the second drop
    assert len(post) >= AFTER - watch_module.QUEUE_FRAMES  # (the queue may have held frames before the drop)
    # every frame the server sent is in the outputs or was dropped (and counted)
    assert (a + 1 - len(pre)) + (b - a - len(post)) == summary["dropped"]

    run = RunDir(out)
    assert run.run["complete"] is True and run.run["summary"]["gaps"] == summary["gaps"]
    assert run.run["scenario"]["live"] is True and run.run["scenario"]["fps"] == FPS
    ticks = run.ticks
    frame_ids = [t["frame"] for t in ticks]
    assert len(frame_ids) == n and increasing(frame_ids)
    times = [t["t"] for t in ticks]
    assert all(x < y for x, y in zip(times, times[1:], strict=False))
    assert times[len(pre)] - times[len(pre) - 1] >= RESTART_S - 0.1  # the gap shows in the stream time
    # ... where the summary puts it: lost after the last frame before it, resumed before the next one
    assert times[len(pre) - 1] - 0.002 <= first["t_lost"] < first["t_resumed"] <= times[len(pre)] + 0.002
    assert first["duration_s"] == pytest.approx(first["t_resumed"] - first["t_lost"], abs=0.002)
    with sqlite3.connect(db) as conn:
        (complete, stored), = conn.execute("SELECT complete, summary FROM runs").fetchall()
        assert complete == 1 and json.loads(stored)["gaps"] == summary["gaps"]
        assert [f for f, in conn.execute("SELECT frame FROM frames ORDER BY frame")] == frame_ids
