"""A real RTSP server on loopback for the stream tests (GStreamer's RTSP server, Debian packages).

Run by the *system* Python (``/usr/bin/python3``: Debian's ``python3-gi`` and
``gir1.2-gst-rtsp-server-1.0``, not the venv) as a subprocess::

    /usr/bin/python3 tests/support/rtsp_server.py FOLDER --port 0 --fps 10 --start 0

It serves the JPEG files ``FOLDER/00000.jpg``, ``00001.jpg``, ... (from ``--start``, looping)
as motion JPEG over RTP at ``rtsp://127.0.0.1:PORT/clip``, time-stamped and paced at ``--fps``,
each client from ``--start``. Once listening it prints ``ready PORT`` (the bound port:
``--port 0`` picks a free one) and serves until killed. Restarting it with ``--port PORT``
serves the same URL again. ``rtsp_server.py --check`` exits 0 if GStreamer and the elements it
needs are there, else names what is missing.

From the tests (venv): ``RtspServer`` starts, kills and restarts it, ``write_numbered_frames``
writes the frames, each with its number drawn as blocks, and ``frame_number`` reads it back.
This module's top level imports only the standard library so both sides can import it.
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SYSTEM_PYTHON = "/usr/bin/python3"
MOUNT = "/clip"
FRAME_NAME = "%05d.jpg"  # the frame files' names (printf style, the frame's number)
ELEMENTS = ("appsrc", "jpegparse", "rtpjpegpay")  # plugins-base, -bad, -good
#: What ``rtsp_server.py --check`` checks, for a test's skip (or failure) message.
NEEDS = ("GStreamer's RTSP server for /usr/bin/python3 (Debian python3-gi, gir1.2-gst-rtsp-server-1.0, "
         "gstreamer1.0-plugins-base, -good, -bad)")
CHECK_ARGS = [__file__, "--check"]  # the system Python's arguments for the check
BITS = 10  # frame numbers 0..1023, drawn as blocks in a band at the bottom of the frame


def check() -> None:
    """Exit 0 if GStreamer's RTSP server and ``ELEMENTS`` are there, else 1 naming what is not."""
    try:
        import gi

        gi.require_version("Gst", "1.0")
        gi.require_version("GstRtspServer", "1.0")
        from gi.repository import Gst, GstRtspServer  # noqa: F401
    except (ImportError, ValueError) as exc:
        raise SystemExit(f"no GStreamer RTSP server for Python: {exc}") from None
    Gst.init(None)
    missing = [e for e in ELEMENTS if Gst.ElementFactory.find(e) is None]
    if missing:
        raise SystemExit(f"no GStreamer elements {', '.join(missing)}")


def serve(folder: Path, port: int, fps: int, start: int) -> None:
    import gi

    gi.require_version("Gst", "1.0")
    gi.require_version("GstRtspServer", "1.0")
    from gi.repository import GLib, Gst, GstRtspServer

    Gst.init(None)
    count = len(list(folder.glob("*.jpg")))
    frame_s = Gst.SECOND // fps

    def configure(factory: object, media: GstRtspServer.RTSPMedia) -> None:
        # each client's media: the frames from ``start`` (looping), time-stamped at ``fps``, so the
        # server's sinks pace them in real time
        src = media.get_element().get_child_by_name("src")
        state = {"n": 0}

        def need_data(appsrc: Gst.Element, length: int) -> None:
            n = state["n"]
            state["n"] += 1
            data = (folder / (FRAME_NAME % ((start + n) % count))).read_bytes()
            buf = Gst.Buffer.new_wrapped(data)
            buf.pts = buf.dts = n * frame_s
            buf.duration = frame_s
            appsrc.emit("push-buffer", buf)

        src.connect("need-data", need_data)

    server = GstRtspServer.RTSPServer()
    server.set_address("127.0.0.1")
    server.set_service(str(port))
    factory = GstRtspServer.RTSPMediaFactory()
    factory.set_launch(
        f"( appsrc name=src is-live=true format=time caps=image/jpeg,framerate={fps}/1 "
        "! jpegparse ! rtpjpegpay name=pay0 pt=26 )"
    )
    factory.connect("media-configure", configure)
    server.get_mount_points().add_factory(MOUNT, factory)
    if server.attach(None) == 0:
        raise SystemExit(f"rtsp_server: cannot listen on 127.0.0.1:{port}")
    print(f"ready {server.get_bound_port()}", flush=True)
    GLib.MainLoop().run()


def write_numbered_frames(folder: Path, n: int, size: tuple[int, int] = (320, 240)) -> Path:
    """Write frames ``0..n-1`` as ``folder/FRAME_NAME`` JPEGs (venv side: numpy, OpenCV): grey,
    with a diagonal gradient, and the frame's number as ``BITS`` black/white blocks in a band
    at the bottom (away from an annotated video's header)."""
    import cv2
    import numpy as np

    w, h = size
    folder.mkdir(parents=True, exist_ok=True)
    base = np.clip(60 + np.add.outer(np.arange(h), np.arange(w)) * 0.2, 0, 255).astype(np.uint8)
    for i in range(n):
        img = np.repeat(base[:, :, None], 3, axis=2)
        for bit in range(BITS):
            x0, x1 = bit * w // BITS, (bit + 1) * w // BITS
            img[h - 40:h - 8, x0:x1] = 255 if i >> bit & 1 else 0
        cv2.imwrite(str(folder / (FRAME_NAME % i)), img, [cv2.IMWRITE_JPEG_QUALITY, 90])
    return folder


def frame_number(image: object) -> int:
    """The number ``write_numbered_frames`` drew in ``image`` (H, W, 3; RGB or BGR), read from the
    blocks' centres so that lossy coding does not matter."""
    import numpy as np

    img = np.asarray(image)
    h, w = img.shape[:2]
    cells = [img[h - 32:h - 16, (4 * bit + 1) * w // (4 * BITS):(4 * bit + 3) * w // (4 * BITS)] for bit in range(BITS)]
    return sum(1 << bit for bit, cell in enumerate(cells) if cell.mean() > 127)


class RtspServer:
    """``rtsp_server.py`` in a subprocess of the system Python: ``start()``, ``kill()`` (SIGKILL,
    as a crash), ``start()`` again on the same port; ``url`` once started."""

    def __init__(self, folder: Path, *, fps: int = 10, python: str = SYSTEM_PYTHON) -> None:
        self.folder, self.fps, self.python = Path(folder), fps, python
        self.port = 0  # 0 until the first start: the server picks a free port, kept for restarts
        self.proc: subprocess.Popen[str] | None = None

    @property
    def url(self) -> str:
        return f"rtsp://127.0.0.1:{self.port}{MOUNT}"

    def start(self, start: int = 0, timeout: float = 10.0) -> RtspServer:
        """Start serving from frame ``start``; returns once it listens (raises if it does not)."""
        assert self.proc is None, "already running"
        cmd = [self.python, __file__, str(self.folder), "--port", str(self.port), "--fps", str(self.fps),
               "--start", str(start)]
        self._stderr = tempfile.TemporaryFile()  # a file, not a pipe: the server never blocks on it
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self._stderr, text=True)
        deadline = time.monotonic() + timeout
        line = ""
        while time.monotonic() < deadline and not line:
            ready, _, _ = select.select([self.proc.stdout], [], [], 0.1)
            if ready:
                line = self.proc.stdout.readline()  # type: ignore[union-attr]
                if not line:  # EOF: it exited
                    break
        if not line.startswith("ready "):
            err = self.stop()
            raise RuntimeError(f"RTSP server did not start ({' '.join(cmd)}): {err.strip()}")
        self.port = int(line.split()[1])
        return self

    def kill(self) -> None:
        """SIGKILL (no goodbye to the clients, as a crash) and wait for it."""
        self.stop(signal.SIGKILL)

    def stop(self, sig: int = signal.SIGTERM) -> str:
        """End the server (if running) with ``sig``; returns what it wrote to stderr."""
        proc, self.proc = self.proc, None
        if proc is None:
            return ""
        if proc.poll() is None:
            proc.send_signal(sig)
        try:
            proc.communicate(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
        self._stderr.seek(0)
        err = self._stderr.read().decode(errors="replace")
        self._stderr.close()
        return err

    def __enter__(self) -> RtspServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop(signal.SIGKILL)


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if argv == ["--check"]:
        return check()
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help=f"folder of JPEG frames named {FRAME_NAME}, from 0")
    parser.add_argument("--port", type=int, default=0, help="TCP port on 127.0.0.1 (0: a free one)")
    parser.add_argument("--fps", type=int, default=10, help="frames per second")
    parser.add_argument("--start", type=int, default=0, help="number of the first frame served")
    args = parser.parse_args(argv)
    if not (args.folder / (FRAME_NAME % 0)).is_file():
        raise SystemExit(f"rtsp_server: no frame {FRAME_NAME % 0} in {args.folder}")
    signal.signal(signal.SIGTERM, lambda *_: os._exit(0))
    serve(args.folder.resolve(), args.port, args.fps, args.start)


if __name__ == "__main__":
    sys.exit(main())
