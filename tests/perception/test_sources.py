"""Frame sources and the capture thread, on real files written here and on fake live captures."""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np
import pytest

import lookahead.perception.sources as sources
from lookahead.perception.sources import (
    STREAM_FFMPEG_OPTIONS,
    CaptureThread,
    ImageFolderSource,
    ReconnectPolicy,
    SourceError,
    SourceGap,
    VideoSource,
    default_capture,
    open_source,
)

W, H = 64, 64
N = 40  # frames in the test videos
FPS = 20.0
TINY = ReconnectPolicy(initial_s=0.01, factor=2.0, max_s=0.02, max_attempts=3)


def numbered(i: int) -> np.ndarray:
    """RGB frame: the 8 bits of ``i`` as white/black blocks on top, a red band below."""
    img = np.zeros((H, W, 3), np.uint8)
    for bit in range(8):
        if i >> bit & 1:
            img[:32, bit * 8:(bit + 1) * 8] = 255
    img[32:] = (255, 0, 0)
    return img


def number_of(rgb: np.ndarray) -> int:
    """The index drawn by ``numbered`` (block centres, robust to lossy codecs)."""
    return sum(1 << bit for bit in range(8) if rgb[8:24, bit * 8 + 2:bit * 8 + 6].mean() > 127)


def write_video(path: Path, fourcc: str, n: int = N) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), FPS, (W, H))
    assert writer.isOpened(), f"this OpenCV cannot write {fourcc}"
    for i in range(n):
        writer.write(cv2.cvtColor(numbered(i), cv2.COLOR_RGB2BGR))
    writer.release()
    return path


@pytest.fixture(scope="module")
def videos(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("videos")
    return {"mp4v": write_video(folder / "clip.mp4", "mp4v"), "MJPG": write_video(folder / "clip.avi", "MJPG")}


class FakeCapture:
    """A scripted ``cv2.VideoCapture``: yields ``frames`` (BGR; an exception is raised), then fails reads."""

    def __init__(self, frames: Iterable[np.ndarray | Exception] = (), opened: bool = True,
                 fps: float = 0.0, read_s: float = 0.0, count: float = 0.0) -> None:
        self.frames, self.opened, self.fps, self.read_s, self.count = iter(frames), opened, fps, read_s, count
        self.released = False

    def isOpened(self) -> bool:
        return self.opened and not self.released

    def read(self) -> tuple[bool, np.ndarray | None]:
        time.sleep(self.read_s)
        item = next(self.frames, None)
        if isinstance(item, Exception):
            raise item
        return (item is not None, item)

    def get(self, prop: int) -> float:
        return {cv2.CAP_PROP_FPS: self.fps, cv2.CAP_PROP_FRAME_WIDTH: W, cv2.CAP_PROP_FRAME_HEIGHT: H,
                cv2.CAP_PROP_FRAME_COUNT: self.count}.get(prop, 0.0)

    def release(self) -> None:
        self.released = True


class FakeFactory:
    """Hands out the given captures in turn, then captures that do not open; records each call."""

    def __init__(self, *captures: FakeCapture) -> None:
        self.captures = list(captures)
        self.calls: list[tuple[str | int, float]] = []

    def __call__(self, target: str | int) -> FakeCapture:
        self.calls.append((target, time.monotonic()))
        return self.captures.pop(0) if self.captures else FakeCapture(opened=False)


def bgr(indices: Iterable[int]) -> list[np.ndarray]:
    return [cv2.cvtColor(numbered(i), cv2.COLOR_RGB2BGR) for i in indices]


def endless(start: int = 0) -> Iterable[np.ndarray]:
    i = start
    while True:
        yield cv2.cvtColor(numbered(i % 256), cv2.COLOR_RGB2BGR)
        i += 1


# --- files and folders ------------------------------------------------------------------------


@pytest.mark.parametrize("fourcc", ["mp4v", "MJPG"])
def test_file_source_reads_all_frames_in_order_with_time(videos: dict[str, Path], fourcc: str) -> None:
    with open_source(str(videos[fourcc])) as source:
        assert isinstance(source, VideoSource)
        assert (source.live, source.fps, source.size) == (False, FPS, (W, H))
        frames = list(source)
    assert [f.index for f in frames] == list(range(N))
    assert [number_of(f.image) for f in frames] == list(range(N))
    assert [f.t for f in frames] == pytest.approx([i / FPS for i in range(N)])
    image = frames[0].image
    assert image.dtype == np.uint8 and image.shape == (H, W, 3)
    assert image[48, 32, 0] > 200 and image[48, 32, 2] < 60  # the red band came out RGB, not BGR
    assert all(a.captured_at <= b.captured_at for a, b in zip(frames, frames[1:], strict=False))
    assert source.gaps == []


def test_folder_source_in_natural_order(tmp_path: Path) -> None:
    for i, name in enumerate(["img_1.png", "img_2.jpg", "img_10.bmp", "IMG_11.JPEG"]):
        assert cv2.imwrite(str(tmp_path / name), cv2.cvtColor(numbered(i), cv2.COLOR_RGB2BGR))
    (tmp_path / "notes.txt").write_text("not an image")
    with open_source(tmp_path, fps=5) as source:
        assert isinstance(source, ImageFolderSource) and not source.live and source.fps == 5
        frames = list(source)
    assert [number_of(f.image) for f in frames] == [0, 1, 2, 3]
    assert [f.t for f in frames] == pytest.approx([0, 0.2, 0.4, 0.6])
    assert source.size == (W, H)


@pytest.mark.parametrize("case", ["missing.mp4", "empty_folder", "garbage.mp4"])
def test_unusable_source_is_a_one_line_error_naming_it(tmp_path: Path, case: str) -> None:
    path = tmp_path / case
    if case == "empty_folder":
        path.mkdir()
        (path / "readme.txt").write_text("no images here")
    elif case == "garbage.mp4":
        path.write_bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    with pytest.raises(SourceError) as err:
        open_source(str(path))
    assert "\n" not in str(err.value) and str(path) in str(err.value)
    assert isinstance(err.value, ValueError)


def test_truncated_file_ends_cleanly_with_the_frames_before_the_cut(
        videos: dict[str, Path], tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    data = videos["MJPG"].read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[:int(len(data) * 0.6)])
    with caplog.at_level(logging.WARNING), open_source(cut) as source:
        frames = list(source)
    assert 1 < len(frames) < N
    # every frame before the cut is intact; the one the cut went through may decode partially
    assert [number_of(f.image) for f in frames[:-1]] == list(range(len(frames) - 1))
    assert [f.index for f in frames] == list(range(len(frames)))
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and str(cut) in warnings[0] and f"{len(frames)} of {N}" in warnings[0]


# --- capture thread ---------------------------------------------------------------------------


def test_capture_thread_on_a_file_with_a_slow_consumer_drops_nothing(videos: dict[str, Path]) -> None:
    capture = CaptureThread(open_source(videos["mp4v"]), maxsize=2)
    numbers = []
    for frame in capture:
        time.sleep(0.002)
        numbers.append(number_of(frame.image))
    assert numbers == list(range(N))
    assert (capture.frames_read, capture.dropped) == (N, 0)
    assert not capture.running


def live(factory: FakeFactory, policy: ReconnectPolicy = TINY) -> VideoSource:
    source = open_source("rtsp://cam.local/stream", reconnect=policy, capture_factory=factory)
    assert isinstance(source, VideoSource) and source.live
    return source


def test_live_source_with_a_slow_consumer_drops_the_oldest_and_counts_them() -> None:
    n = 60
    source = live(FakeFactory(FakeCapture(bgr(range(n)), read_s=0.001)), ReconnectPolicy(max_attempts=0))
    capture = CaptureThread(source, maxsize=4)
    got = []
    for frame in capture:
        time.sleep(0.02)
        got.append(frame.index)
    assert capture.frames_read == n and capture.dropped > 0
    assert len(got) + capture.dropped == n
    assert got == sorted(got) and got[-1] == n - 1  # the newest survive, order is kept
    assert len(capture.gaps) == 1 and capture.gaps[0].resumed_at is None  # the end, with no reconnect


def test_live_stream_drop_reconnects_with_backoff_and_records_the_gaps() -> None:
    factory = FakeFactory(
        FakeCapture(bgr(range(5)), fps=25),  # 5 frames, then the stream drops
        FakeCapture(opened=False),  # reopen 1: refused
        FakeCapture(),  # reopen 2: opens but delivers nothing
        FakeCapture(bgr(range(5, 10))),  # reopen 3: back, 5 more frames, then drops for good
    )
    source = live(factory)
    assert source.fps == 25 and source.size == (W, H)
    capture = CaptureThread(source, maxsize=32)
    frames = list(capture)
    assert [f.index for f in frames] == list(range(10))
    assert [number_of(f.image) for f in frames] == list(range(10))
    assert all(a.t <= b.t for a, b in zip(frames, frames[1:], strict=False))
    first, last = capture.gaps
    assert (first.after_index, last.after_index) == (4, 9)
    assert first.resumed_at is not None and last.resumed_at is None
    assert first.resumed_at - first.lost_at >= 0.01 + 0.02 + 0.02  # the backoff waits
    assert len(factory.calls) == 1 + 3 + 3  # the first open, 3 reopens, 3 failed reopens before giving up
    waits = np.diff([t for _, t in factory.calls[1:4]])
    assert waits.min() >= 0.02 * 0.9


def test_reconnect_policy_backs_off_exponentially_to_a_cap() -> None:
    policy = ReconnectPolicy()
    assert [policy.delay(k) for k in range(7)] == [0.5, 1, 2, 4, 8, 8, 8]
    assert policy.total_wait_s() == 0.5 + 1 + 2 + 4 + 8 * 6  # bounded: 10 attempts
    assert ReconnectPolicy(initial_s=1, factor=3, max_s=5, max_attempts=3).total_wait_s() == 1 + 3 + 5
    with pytest.raises(ValueError):
        ReconnectPolicy(factor=0.5)
    assert SourceGap(3, lost_at=10.0).duration is None
    assert SourceGap(3, lost_at=10.0, resumed_at=12.5).duration == 2.5


def test_a_reader_exception_is_raised_in_the_consumer() -> None:
    source = live(FakeFactory(FakeCapture([*bgr(range(3)), RuntimeError("device on fire")])))
    got = []
    with pytest.raises(RuntimeError, match="device on fire"):
        for frame in CaptureThread(source, maxsize=8):
            got.append(frame.index)
    assert got == [0, 1, 2]


def test_stop_from_another_thread_ends_iteration_promptly() -> None:
    capture = CaptureThread(live(FakeFactory(FakeCapture(endless(), read_s=0.001))))
    threading.Timer(0.2, capture.stop).start()
    start = time.monotonic()
    count = sum(1 for _ in capture)
    assert count > 0 and time.monotonic() - start < 0.2 + 0.3
    assert not capture.running


def test_stop_from_a_signal_handler_during_backoff_ends_promptly() -> None:
    slow = ReconnectPolicy(initial_s=30.0, max_attempts=5)  # the reader would wait 30 s to reopen
    capture = CaptureThread(live(FakeFactory(FakeCapture(bgr(range(3)))), slow))
    previous = signal.signal(signal.SIGALRM, lambda *_: capture.stop())
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.2)
        start = time.monotonic()
        got = [f.index for f in capture]
        elapsed = time.monotonic() - start
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert got == [0, 1, 2] and elapsed < 1.0
    assert not capture.running  # the reader left its backoff wait too
    assert capture.gaps[0].after_index == 2 and capture.gaps[0].resumed_at is None


# --- open_source dispatch ---------------------------------------------------------------------


def test_camera_index_and_urls_open_live_through_the_factory() -> None:
    factory = FakeFactory(FakeCapture(), FakeCapture())
    assert open_source("0", capture_factory=factory).live
    assert open_source("https://host/feed.mjpg", capture_factory=factory).live
    assert [target for target, _ in factory.calls] == [0, "https://host/feed.mjpg"]
    with pytest.raises(SourceError, match="camera 3"):
        open_source(3, capture_factory=FakeFactory(FakeCapture(opened=False)))


def test_an_http_url_is_live_unless_the_capture_reports_a_frame_count() -> None:
    factory = FakeFactory(FakeCapture(count=-1.0), FakeCapture(fps=25, count=N), FakeCapture(count=N))
    assert open_source("http://cam.local/video.mjpg", capture_factory=factory).live
    clip = open_source("https://host/clip.mp4", capture_factory=factory)
    assert (clip.live, clip.frame_count, clip.fps) == (False, N, 25)
    assert open_source("rtsp://cam.local/stream", capture_factory=factory).live  # RTSP: always live
    for url in ("rtmp://host/app/key", "srt://host:9000", "udp://239.0.0.1:1234"):
        assert open_source(url, capture_factory=FakeFactory(FakeCapture())).live


def test_stream_ffmpeg_options_are_set_for_the_open_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    seen = []

    def capture(target: object, *args: object) -> FakeCapture:
        seen.append((target, args, os.environ.get("OPENCV_FFMPEG_CAPTURE_OPTIONS")))
        return FakeCapture()

    monkeypatch.setattr(sources.cv2, "VideoCapture", capture)
    monkeypatch.delenv("OPENCV_FFMPEG_CAPTURE_OPTIONS", raising=False)
    default_capture("rtsp://cam.local/stream")
    default_capture("clip.mp4")
    assert "OPENCV_FFMPEG_CAPTURE_OPTIONS" not in os.environ
    monkeypatch.setenv("OPENCV_FFMPEG_CAPTURE_OPTIONS", "rtsp_transport;udp")  # the user's own: used as it is
    default_capture("rtsp://cam.local/stream")
    assert os.environ["OPENCV_FFMPEG_CAPTURE_OPTIONS"] == "rtsp_transport;udp"
    (url, url_args, url_env), (path, path_args, path_env), (_, _, user_env) = seen
    assert url_env == STREAM_FFMPEG_OPTIONS and "fpsprobesize;0" in url_env
    assert url_args[0] == cv2.CAP_FFMPEG and cv2.CAP_PROP_READ_TIMEOUT_MSEC in url_args[1]
    assert (path, path_args, path_env) == ("clip.mp4", (), None)
    assert user_env == "rtsp_transport;udp"


def test_an_unreachable_stream_is_an_error_without_its_password() -> None:
    with pytest.raises(SourceError) as err:
        open_source("rtsp://user:secret@127.0.0.1:9/none")
    assert "secret" not in str(err.value) and "rtsp://user:***@127.0.0.1:9/none" in str(err.value)
