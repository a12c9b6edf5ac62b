"""Frame sources for real video, and a capture thread that reads one ahead of the consumer.

``open_source(spec)`` opens a video file, a folder of images, a camera index or a stream URL
(``rtsp://``, ``http(s)://``, ... ``URL_SCHEMES``) as a ``FrameSource``: an iterable of
``CapturedFrame`` (RGB uint8). Live sources (camera, stream URL) reconnect with exponential
backoff (``ReconnectPolicy``: bounded, configurable) when a read fails or times out, and record
each outage as a ``SourceGap``; the frames before it were already handed on, and the indices
continue after it. Files (an ``http(s)://`` URL whose capture reports a frame count is a file)
never reconnect, and a corrupt or truncated file simply ends.

``CaptureThread(source)`` reads a source in a daemon thread into a bounded queue: a live source
drops the oldest queued frame when the consumer falls behind (latest wins), a file source never
drops (the reader waits). Errors in the reader are re-raised in the consumer.

    with CaptureThread(open_source("drive.mp4")) as capture:
        for frame in capture:
            ...
"""

from __future__ import annotations

import logging
import math
import os
import queue
import re
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, Self
from urllib.parse import urlsplit, urlunsplit

import cv2
import numpy as np

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")
#: Stream URL schemes (read through FFmpeg); all live except ``FILE_OR_LIVE_SCHEMES``.
URL_SCHEMES = ("rtsp", "rtsps", "rtmp", "rtmps", "rtp", "srt", "udp", "tcp", "http", "https")
#: URL schemes that are live only if the capture reports no frame count (else a video file on a server).
FILE_OR_LIVE_SCHEMES = ("http", "https")
#: Frame rate assumed when neither the container nor the caller gives one (frames/s).
DEFAULT_FPS = 30.0


class SourceError(ValueError):
    """A source that cannot be opened; ``str()`` is one line naming the source."""

    def __init__(self, message: str) -> None:
        super().__init__(message.replace("\r", " ").replace("\n", " "))


@dataclass(frozen=True)
class CapturedFrame:
    """One frame as read: ``index`` (0-based, contiguous), ``t`` stream time (s; file: index / fps,
    live: monotonic time since the source opened), ``image`` RGB uint8 (H, W, 3) and
    ``captured_at`` (``time.monotonic()`` when read, s)."""

    index: int
    t: float
    image: np.ndarray
    captured_at: float


@dataclass(frozen=True)
class ReconnectPolicy:
    """Exponential backoff for live sources: wait ``initial_s`` before the first reopen, times
    ``factor`` each further attempt, at most ``max_s`` (s); give up after ``max_attempts``
    reopens of one outage (a reconnect that works starts the next outage from ``initial_s``).

    An outage therefore ends within ``total_wait_s()`` plus ``max_attempts`` open timeouts
    (``STREAM_TIMEOUTS_MS``) for a stream."""

    initial_s: float = 0.5
    factor: float = 2.0
    max_s: float = 8.0
    max_attempts: int = 10

    def __post_init__(self) -> None:
        if not (self.initial_s >= 0 and self.factor >= 1 and self.max_s >= 0 and self.max_attempts >= 0):
            raise ValueError(f"invalid reconnect policy: {self}")

    def delay(self, attempt: int) -> float:
        """Wait before reopen attempt ``attempt`` (0-based), s."""
        return min(self.initial_s * self.factor**attempt, self.max_s)

    def total_wait_s(self) -> float:
        """The sum of the waits before giving up, s."""
        return sum(self.delay(k) for k in range(self.max_attempts))


@dataclass
class SourceGap:
    """A live-source outage: frames stopped after ``after_index`` (-1: before the first frame) at
    ``lost_at`` and resumed at ``resumed_at`` (``time.monotonic()``, s), None if they never did."""

    after_index: int
    lost_at: float
    resumed_at: float | None = None

    @property
    def duration(self) -> float | None:
        """How long frames stopped (s), None while (or if) they did not resume."""
        return None if self.resumed_at is None else self.resumed_at - self.lost_at


class Capture(Protocol):
    """What a source needs of ``cv2.VideoCapture`` (tests inject fakes through this)."""

    def isOpened(self) -> bool: ...
    def read(self) -> tuple[bool, np.ndarray | None]: ...
    def get(self, prop: int) -> float: ...
    def release(self) -> None: ...


#: Creates the capture for a target (a path, a URL or a camera index); ``default_capture`` by default.
CaptureFactory = Callable[[str | int], Capture]

#: Stream open and read timeouts (ms), so a dead camera or a stalled stream fails a read (and
#: is reconnected) instead of hanging it. A server that goes away closes the connection, which
#: fails the read at once.
STREAM_TIMEOUTS_MS = (10_000, 5_000)

#: FFmpeg options for a stream URL, in ``OPENCV_FFMPEG_CAPTURE_OPTIONS`` syntax, used unless that
#: variable is set (then it is used as it is): RTSP over TCP when the server offers it (OpenCV's
#: own default), and no frame-rate probing (``fpsprobesize``), which would otherwise hold back
#: the first 20 frames (2 s at 10 frames/s) at every (re)connect and then hand them on at once,
#: where a live ``CaptureThread`` would drop all but the last few. The frame rate still comes
#: from the stream's description when it has one.
STREAM_FFMPEG_OPTIONS = "rtsp_flags;prefer_tcp|fpsprobesize;0"
_FFMPEG_OPTIONS_VAR = "OPENCV_FFMPEG_CAPTURE_OPTIONS"
_env_lock = threading.Lock()


def is_url(target: str | int | os.PathLike[str]) -> bool:
    """Whether ``target`` is a stream URL (``URL_SCHEMES``)."""
    return isinstance(target, str) and urlsplit(target).scheme.lower() in URL_SCHEMES


def default_capture(target: str | int) -> Capture:
    """``cv2.VideoCapture(target)``; for a URL through FFmpeg with ``STREAM_TIMEOUTS_MS`` and
    ``STREAM_FFMPEG_OPTIONS``.

    FFmpeg's own log lines ("moov atom not found", ...) would reach the user's terminal beside
    our one-line errors and warnings: they are silenced unless ``OPENCV_FFMPEG_LOGLEVEL`` is set
    (e.g. 24 to see them; OpenCV reads it when its FFmpeg backend first opens a file)."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    # OpenCV takes FFmpeg's options only from the environment, when it opens: they are set for
    # a stream's open alone, under a lock that the other opens here wait for (a capture opened
    # elsewhere in the process at that moment would see them too)
    with _env_lock:
        if not (isinstance(target, str) and is_url(target)):
            return cv2.VideoCapture(target)
        open_ms, read_ms = STREAM_TIMEOUTS_MS
        params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, open_ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, read_ms]
        own = _FFMPEG_OPTIONS_VAR not in os.environ
        if own:
            os.environ[_FFMPEG_OPTIONS_VAR] = STREAM_FFMPEG_OPTIONS
        try:
            return cv2.VideoCapture(target, cv2.CAP_FFMPEG, params)
        finally:
            if own:
                os.environ.pop(_FFMPEG_OPTIONS_VAR, None)


def to_rgb(image: np.ndarray) -> np.ndarray:
    """An OpenCV image (BGR, BGRA or gray) as RGB uint8 (H, W, 3)."""
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def display_name(target: str | int) -> str:
    """``target`` as shown in logs and errors: one line, a URL without its password."""
    if isinstance(target, int):
        return f"camera {target}"
    name = str(target)
    parts = urlsplit(name)
    if is_url(name) and parts.password is not None:
        host = parts.hostname or ""
        netloc = f"{parts.username}:***@{host}" + (f":{parts.port}" if parts.port else "")
        name = urlunsplit(parts._replace(netloc=netloc))
    return name


def valid_fps(fps: float | None) -> float | None:
    """``fps`` if it is a plausible frame rate (0, 1000] frames/s, else None."""
    return float(fps) if fps is not None and math.isfinite(fps) and 0 < fps <= 1000 else None


class FrameSource(ABC):
    """An iterable of ``CapturedFrame``, read once from start to end.

    ``live`` (camera/stream: True, file/folder: False), ``fps`` (frames/s, None if unknown),
    ``size`` ((width, height) px, None if unknown), ``gaps`` (live outages). ``stop()`` asks a
    running iteration to end (thread-safe); ``close()`` also releases the device.
    """

    live: bool = False

    def __init__(self, name: str, *, fps: float | None = None, size: tuple[int, int] | None = None) -> None:
        self.name = name
        self.fps = fps
        self.size = size
        self.gaps: list[SourceGap] = []
        self._stop = threading.Event()

    @abstractmethod
    def frames(self) -> Iterator[CapturedFrame]:
        """The frames, in order, until the source ends or ``stop()`` is called."""

    def __iter__(self) -> Iterator[CapturedFrame]:
        return self.frames()

    def stop(self) -> None:
        """Ask a running iteration to end after the current read; safe from any thread."""
        self._stop.set()

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def close(self) -> None:
        """Stop and release the device; idempotent. Call it from the thread that iterates (or after)."""
        self.stop()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, live={self.live}, fps={self.fps}, size={self.size})"


class VideoSource(FrameSource):
    """A video file, camera or stream read through ``cv2.VideoCapture``.

    The capture comes from ``capture_factory(target)`` (``default_capture``), so tests
    and other backends can supply their own. A live source that fails a read reopens per
    ``reconnect``; a file ends at its first failed read (with a warning if the container promised
    more frames). ``live=None`` decides from the capture: a file if it reports a frame count.
    ``fps`` is the fallback frame rate when the container does not give one.
    """

    def __init__(
        self,
        target: str | int,
        *,
        live: bool | None,
        fps: float | None = None,
        reconnect: ReconnectPolicy | None = None,
        capture_factory: CaptureFactory | None = None,
    ) -> None:
        super().__init__(display_name(target))
        self.target = target
        self.reconnect = reconnect or ReconnectPolicy()
        self._factory = capture_factory or default_capture
        self._cap: Capture | None = self.open_capture()
        self.opened_at = time.monotonic()
        if not self._cap.isOpened():
            self._cap.release()
            self._cap = None
            kind = "camera" if isinstance(target, int) else "stream" if live or is_url(target) else "video file"
            raise SourceError(f"cannot open {kind} {self.name}: OpenCV could not open or decode it")
        count = self._cap.get(cv2.CAP_PROP_FRAME_COUNT)
        has_count = math.isfinite(count) and count > 0  # a live stream reports none (0, -1 or garbage)
        self.live = live = (not has_count) if live is None else live
        container_fps = valid_fps(self._cap.get(cv2.CAP_PROP_FPS))
        self.fps = container_fps or valid_fps(fps) or (None if live else DEFAULT_FPS)
        if not live and container_fps is None and valid_fps(fps) is None:
            log.warning("%s: no frame rate in the file; assuming %.0f frames/s", self.name, DEFAULT_FPS)
        w, h = (int(self._cap.get(p)) for p in (cv2.CAP_PROP_FRAME_WIDTH, cv2.CAP_PROP_FRAME_HEIGHT))
        self.size = (w, h) if w > 0 and h > 0 else None
        self.frame_count = int(count) if not live and has_count else None

    def open_capture(self) -> Capture:
        """A new capture of ``target`` (override or pass ``capture_factory`` to change it)."""
        return self._factory(self.target)

    def read(self) -> np.ndarray | None:
        """The next decoded image (as OpenCV gives it), or None if the read failed."""
        if self._cap is None:
            return None
        try:
            ok, image = self._cap.read()
        except cv2.error as exc:
            log.debug("%s: read failed: %s", self.name, exc)
            return None
        return image if ok and image is not None and image.size else None

    def frames(self) -> Iterator[CapturedFrame]:
        index = 0
        while not self.stopped:
            image = self.read()
            if image is None and self.live and not self.stopped:
                image = self.reconnect_after(index - 1)
            if image is None:
                break
            now = time.monotonic()
            t = now - self.opened_at if self.live else index / self.fps
            yield CapturedFrame(index=index, t=t, image=to_rgb(image), captured_at=now)
            index += 1
        if not self.live and not self.stopped and self.frame_count is not None and index < self.frame_count:
            log.warning("%s: decoded %d of %d frames; the file is truncated or corrupt", self.name, index, self.frame_count)

    def reconnect_after(self, after_index: int) -> np.ndarray | None:
        """Reopen per the policy after a failed read; the first image read, or None if it gave up."""
        gap = SourceGap(after_index=after_index, lost_at=time.monotonic())
        self.gaps.append(gap)
        self.release()
        policy = self.reconnect
        for attempt in range(policy.max_attempts):
            delay = policy.delay(attempt)
            log.warning("%s: stream lost after frame %d; reconnecting in %.1f s (attempt %d of %d)",
                        self.name, after_index, delay, attempt + 1, policy.max_attempts)
            if self._stop.wait(delay):
                return None
            try:
                self._cap = self.open_capture()
            except Exception as exc:  # a backend that raises instead of reporting "not opened"
                log.debug("%s: reopen failed: %s", self.name, exc)
                continue
            image = self.read() if self._cap.isOpened() else None
            if image is not None:
                gap.resumed_at = time.monotonic()
                log.info("%s: reconnected after %.1f s", self.name, gap.resumed_at - gap.lost_at)
                return image
            self.release()
        log.error("%s: gave up after %d reconnect attempts", self.name, policy.max_attempts)
        return None

    def release(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None

    def close(self) -> None:
        super().close()
        self.release()


def natural_key(path: Path) -> list[Any]:
    """Sort key putting ``img2`` before ``img10``."""
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", path.name)]


class ImageFolderSource(FrameSource):
    """The images of a folder (``IMAGE_SUFFIXES``) in natural order, at ``fps`` (frames/s).

    An image that cannot be decoded is skipped with a warning; ``index`` stays contiguous.
    """

    def __init__(self, folder: str | os.PathLike[str], *, fps: float | None = None) -> None:
        folder = Path(folder)
        super().__init__(str(folder), fps=valid_fps(fps) or DEFAULT_FPS)
        self.paths = sorted((p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES),
                            key=natural_key)
        if not self.paths:
            raise SourceError(f"no images ({', '.join(IMAGE_SUFFIXES)}) in folder {self.name}")

    def frames(self) -> Iterator[CapturedFrame]:
        index = 0
        for path in self.paths:
            if self.stopped:
                return
            image = cv2.imread(str(path), cv2.IMREAD_COLOR)
            if image is None:
                log.warning("%s: cannot decode %s; skipped", self.name, path.name)
                continue
            if self.size is None:
                self.size = (image.shape[1], image.shape[0])
            yield CapturedFrame(index=index, t=index / self.fps, image=to_rgb(image), captured_at=time.monotonic())
            index += 1


def open_source(
    spec: str | int | os.PathLike[str],
    *,
    fps: float | None = None,
    reconnect: ReconnectPolicy | None = None,
    capture_factory: CaptureFactory | None = None,
) -> FrameSource:
    """Open ``spec``: a camera index (int or digits), a stream URL, a folder of images or a video file.

    ``fps`` is the frame rate (frames/s) used when the container gives none (folders: always).
    Raises ``SourceError`` (one line, naming ``spec``) if it does not exist or cannot be opened.
    """
    if isinstance(spec, str) and spec.strip().isdigit():
        spec = int(spec)
    if isinstance(spec, int):
        return VideoSource(spec, live=True, fps=fps, reconnect=reconnect, capture_factory=capture_factory)
    text = os.fspath(spec)
    if is_url(text):
        live = None if urlsplit(text).scheme.lower() in FILE_OR_LIVE_SCHEMES else True
        return VideoSource(text, live=live, fps=fps, reconnect=reconnect, capture_factory=capture_factory)
    path = Path(text).expanduser()
    if path.is_dir():
        return ImageFolderSource(path, fps=fps)
    if not path.is_file():
        raise SourceError(f"no such video file or image folder: {display_name(text)}")
    return VideoSource(str(path), live=False, fps=fps, capture_factory=capture_factory)


@dataclass
class _End:
    """Queued after the last frame; carries the reader's exception, if any."""

    error: BaseException | None = None


@dataclass(eq=False)
class CaptureThread:
    """Reads ``source`` in a daemon thread into a queue of ``maxsize`` frames.

    A live source drops the oldest queued frame when the consumer falls behind (``dropped``);
    a file source never drops (the reader waits). Iterate to get the frames in order until the
    source ends; an exception in the reader is re-raised there. ``stop()`` ends the iteration
    within ``poll_s`` and only sets flags, so it is safe from a signal handler; ``close()`` also
    joins the reader. Ending the iteration (or the ``with`` block) closes it, and the reader
    closes the source.
    """

    source: FrameSource
    maxsize: int = 4
    poll_s: float = 0.05
    frames_read: int = field(default=0, init=False)
    dropped: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if self.maxsize < 1:
            raise ValueError(f"maxsize must be >= 1, got {self.maxsize}")
        self._queue: queue.Queue[CapturedFrame | _End] = queue.Queue(self.maxsize)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"capture {self.source.name}", daemon=True)

    @property
    def gaps(self) -> list[SourceGap]:
        return self.source.gaps

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def start(self) -> Self:
        """Start the reader (once; iterating starts it too)."""
        if self._thread.ident is None and not self._stop.is_set():
            self._thread.start()
        return self

    def stop(self) -> None:
        """End the iteration promptly and the reader after its current read; signal-safe."""
        self._stop.set()
        self.source.stop()

    def close(self, timeout: float = 2.0) -> None:
        """Stop and wait up to ``timeout`` (s) for the reader to finish."""
        self.stop()
        if self._thread.ident is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
            if self._thread.is_alive():
                log.warning("%s: capture thread still blocked in a read after %.1f s", self.source.name, timeout)

    def __iter__(self) -> Iterator[CapturedFrame]:
        self.start()
        try:
            while not self._stop.is_set():
                try:
                    item = self._queue.get(timeout=self.poll_s)
                except queue.Empty:
                    continue
                if isinstance(item, _End):
                    if item.error is not None:
                        raise item.error
                    return
                yield item
        finally:
            self.close()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _run(self) -> None:
        end = _End()
        frames = self.source.frames()
        try:
            for frame in frames:
                if self._stop.is_set():
                    break
                self.frames_read += 1
                if self.source.live:
                    self._put_latest(frame)
                elif not self._put_waiting(frame):
                    break
        except BaseException as exc:  # handed to the consumer, not lost
            end = _End(exc)
        finally:
            frames.close()
            self.source.close()
            self._put_waiting(end)

    def _put_waiting(self, item: CapturedFrame | _End) -> bool:
        """Put ``item``, waiting for room; False if stopped first."""
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=self.poll_s)
                return True
            except queue.Full:
                continue
        return False

    def _put_latest(self, frame: CapturedFrame) -> None:
        """Put ``frame``, dropping the oldest queued frame if full (this thread is the only producer)."""
        while True:
            try:
                self._queue.put_nowait(frame)
                return
            except queue.Full:
                try:
                    self._queue.get_nowait()
                    self.dropped += 1
                except queue.Empty:
                    pass
