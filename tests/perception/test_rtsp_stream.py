"""A live source on a real RTSP server on loopback (GStreamer's, ``support/rtsp_server.py``):
the server is killed mid-stream and restarted, and the source reconnects and continues."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from support.rtsp_server import CHECK_ARGS, NEEDS, RtspServer, frame_number, write_numbered_frames
from system_deps import require_system_python

from lookahead.perception.sources import CaptureThread, ReconnectPolicy, VideoSource, open_source

W, H = 320, 240
FPS = 10  # the server's frame rate (frames/s)
FRAMES = 400  # numbered frames the server serves (looping)
BEFORE = 15  # frames read before the server is killed
RESTART_S = 1.0  # the server is restarted this long after it was killed (s)
RESTART_AT = 200  # ... serving from this frame number on
AFTER = 15  # frames read after the reconnect


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    require_system_python(CHECK_ARGS, NEEDS)
    return write_numbered_frames(tmp_path_factory.mktemp("rtsp_frames"), FRAMES, (W, H))


def test_rtsp_server_killed_mid_stream_then_restarted_reconnects_and_continues(frames_dir: Path) -> None:
    policy = ReconnectPolicy(initial_s=0.25, factor=2.0, max_s=1.0, max_attempts=8)  # gives up after ~6 s
    with RtspServer(frames_dir, fps=FPS) as server:
        server.start()
        source = open_source(server.url, reconnect=policy)
        assert isinstance(source, VideoSource) and source.live and source.frame_count is None
        assert (source.fps, source.size) == (FPS, (W, H))
        capture = CaptureThread(source, maxsize=1024)  # big enough to keep every frame for the checks
        restart = threading.Timer(RESTART_S, server.start, kwargs={"start": RESTART_AT})
        frames = []
        killed_at = None
        try:
            for frame in capture:
                frames.append((frame.index, frame_number(frame.image), frame.t))
                if len(frames) == BEFORE:
                    killed_at = time.monotonic()
                    server.kill()
                    restart.start()
                if sum(n >= RESTART_AT for _, n, _ in frames) == AFTER:
                    break
        finally:
            capture.close()
            restart.cancel()
            if restart.ident is not None:
                restart.join()
    assert not capture.running
    assert killed_at is not None and capture.dropped == 0

    indices, numbers, times = zip(*frames, strict=True)
    assert list(indices) == list(range(len(frames)))  # contiguous across the gap
    (gap,) = capture.gaps
    last = gap.after_index
    # every frame served before the drop arrived, in order; the stream resumed where the server did
    assert last >= BEFORE - 1
    assert list(numbers[:last + 1]) == list(range(last + 1))
    assert list(numbers[last + 1:]) == list(range(RESTART_AT, RESTART_AT + AFTER))
    # the gap: lost after the kill, resumed after the restart, within the backoff's bound
    assert gap.lost_at >= killed_at and gap.resumed_at is not None
    assert RESTART_S <= gap.resumed_at - killed_at < RESTART_S + policy.max_s + 5.0  # (+ server start-up)
    assert gap.duration == pytest.approx(gap.resumed_at - gap.lost_at)
    assert times[last + 1] - times[last] >= RESTART_S - 0.2  # stream time runs on through the gap
    assert all(a < b for a, b in zip(times, times[1:], strict=False))


def test_rtsp_server_gone_for_good_gives_up_after_the_bounded_backoff(frames_dir: Path) -> None:
    policy = ReconnectPolicy(initial_s=0.1, factor=2.0, max_s=0.4, max_attempts=4)
    with RtspServer(frames_dir, fps=FPS) as server:
        server.start()
        capture = CaptureThread(open_source(server.url, reconnect=policy), maxsize=1024)
        got = 0
        start = time.monotonic()
        for _ in capture:
            got += 1
            if got == 5:
                killed_at = time.monotonic()
                server.kill()
        ended = time.monotonic()
    (gap,) = capture.gaps
    assert gap.after_index == got - 1 and gap.resumed_at is None and gap.duration is None
    # four refused reopens after 0.1 + 0.2 + 0.4 + 0.4 s, then the source ends
    assert policy.total_wait_s() == pytest.approx(1.1)
    assert policy.total_wait_s() <= ended - killed_at < policy.total_wait_s() + 3.0
    assert ended - start < 10
