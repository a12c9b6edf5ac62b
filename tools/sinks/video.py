"""``VideoSink``: an annotated MP4 of the camera frames, English or Chinese.

Each frame shows the output tracks coloured by risk (SAFE green -> CRITICAL
red) with id, class, intent label, range (m), speed over ground (km/h) and TTC
(s); the last ``trail_s`` seconds of each track's box bottom-centre (image
space, not ego-motion compensated); a banner while an alert >= HIGH is active
(the latest alert's reason) or after a collision; a header with t, ego speed
and brake. Shapes and English text are drawn with OpenCV; Chinese text
(``lang="zh"``) needs a CJK font and is drawn with Pillow in one pass per
frame. Without a CJK font the sink warns once and falls back to English.

The file is a fragmented MP4 of Motion-JPEG frames (``FragmentedMjpegWriter``:
``ftyp`` + an empty ``moov`` first, then one ``moof`` + ``mdat`` fragment per frame,
each written with one ``write`` call), so it stays playable up to the last frame
written when the process is killed (SIGKILL, OOM) -- a plain MP4's index (``moov``)
is only written at the end. OpenCV's ``VideoWriter`` cannot give that: its FFmpeg
muxer takes no ``movflags`` and buffers 256 KB before writing. Reads back with
OpenCV/FFmpeg, VLC and QuickTime; not in browsers (nor did the MPEG-4 Part 2 it
replaces). JPEG encoding runs on a background thread, in frame order, behind a
queue of ``QUEUE_FRAMES`` frames: a killed run's video lacks at most the frames in
that queue plus the one being encoded (``QUEUE_FRAMES + 1``; in practice 0-1, the
encoder is much faster than a tick). A clean end patches the durations into the
header. Frames without an image (rendering off) are skipped with one warning.

The drawing and its frame-to-frame state is ``Overlay`` (``VideoSink`` is an
``Overlay`` that also writes); the demo's key-frame PNGs use the same class, so
key frames and video look alike. The output path is checked when the sink is
made (``check_video_path``: parent created, not a directory, writable, the
directory takes a file), so a bad ``--video`` fails before any sink has written.
"""

from __future__ import annotations

import contextlib
import fnmatch
import logging
import os
import queue
import shutil
import struct
import subprocess
import threading
from collections import OrderedDict, deque
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from lookahead.intent.alerts import Alert
from lookahead.intent.labels import LABEL_NAMES, LABEL_NAMES_ZH, NEVER, Label, Risk, risk_colour
from lookahead.perception.detections import CLASSES
from lookahead.perception.tracker import TrackState
from lookahead.sim.records import TickRecord
from lookahead.tools.sinks.rundir import OutputError

log = logging.getLogger(__name__)

#: The video format: Motion-JPEG in fragmented MP4 (``VideoSink.fourcc``).
FOURCC = "mjpg"
JPEG_QUALITY = 80  # about the MPEG-4 Part 2 it replaces (PSNR ~36 dB), ~29 KB a 640x360 frame
RAW_JPEG_QUALITY = 95  # a raw (unannotated) camera video, the input of ``lookahead watch``
#: Frames queued for the encoding thread at most (a killed run loses at most this + 1).
QUEUE_FRAMES = 2
CLASS_NAMES_ZH = {
    "pedestrian": "行人", "cyclist": "骑车人", "motorcyclist": "摩托车", "tricycle": "三轮车",
    "car": "轿车", "truck": "卡车", "bus": "公交车", "animal": "动物", "obstacle": "障碍物",
}
CJK_FONT_ENV = "LOOKAHEAD_CJK_FONT"
CJK_FONT_DIRS = (
    "/usr/share/fonts", "/usr/local/share/fonts", "~/.local/share/fonts", "~/.fonts",
    "/System/Library/Fonts", "/Library/Fonts", "C:/Windows/Fonts",
)
CJK_FONT_PATTERNS = (
    "NotoSansCJK*", "NotoSans*SC*", "NotoSerifCJK*", "SourceHanSans*", "wqy-*", "DroidSansFallback*",
    "uming*", "ukai*", "msyh*", "simhei*", "simsun*", "PingFang*", "Hiragino Sans GB*",
)
_FONT_SUFFIXES = (".ttf", ".ttc", ".otf", ".otc")
_FONT_WARNED = False
_BG = (0, 0, 0)
_FG = (255, 255, 255)


# ----------------------------------------------------------------------------- fonts
@lru_cache(maxsize=4)
def find_cjk_font(dirs: tuple[str, ...] = CJK_FONT_DIRS, use_fc: bool = True) -> tuple[str, int] | None:
    """(font file, face index) of an installed font with Chinese glyphs, or None.

    Order: ``$LOOKAHEAD_CJK_FONT``; ``fc-list :lang=zh`` (Simplified Chinese faces
    first); file names matching ``CJK_FONT_PATTERNS`` under ``dirs``.
    """
    env = os.environ.get(CJK_FONT_ENV)
    if env and Path(env).is_file():
        return env, 0
    fc = shutil.which("fc-list") if use_fc else None
    if fc:
        try:
            out = subprocess.run([fc, "-f", "%{file}|%{index}|%{family}\n", ":lang=zh"],
                                 capture_output=True, text=True, timeout=10, check=False).stdout
        except (OSError, subprocess.SubprocessError):
            out = ""
        faces = []
        for line in out.splitlines():
            parts = line.split("|", 2)
            if len(parts) == 3 and Path(parts[0]).is_file():
                fam = parts[2]
                rank = (0 if any(k in fam for k in ("SC", "CN", "Hans", "WenQuanYi")) else 1,
                        0 if any(k in fam for k in ("Sans", "Hei")) else 1, "Mono" in fam, parts[0])
                faces.append((rank, parts[0], int(parts[1] or 0)))
        if faces:
            _, path, index = min(faces)
            return path, index
    for d in dirs:
        root = Path(d).expanduser()
        if not root.is_dir():
            continue
        for dirpath, _, files in os.walk(root):
            for pat in CJK_FONT_PATTERNS:
                for f in sorted(files):
                    if f.lower().endswith(_FONT_SUFFIXES) and fnmatch.fnmatch(f, pat):
                        return str(Path(dirpath) / f), 0
    return None


def _font_places(dirs: tuple[str, ...] = CJK_FONT_DIRS) -> str:
    fc = "fc-list :lang=zh, " if shutil.which("fc-list") else ""
    return f"${CJK_FONT_ENV}, {fc}{', '.join(dirs)}"


# ----------------------------------------------------------------------------- text
class _CvText:
    """English text with OpenCV's Hershey font, drawn immediately."""

    font = cv2.FONT_HERSHEY_SIMPLEX

    def __init__(self, scale: float) -> None:
        self.scale = scale
        self.thickness = 1
        (_, h), base = cv2.getTextSize("Ag", self.font, scale, self.thickness)
        self.ascent = h
        self.line_h = h + base + 3

    def width(self, text: str) -> int:
        return cv2.getTextSize(text, self.font, self.scale, self.thickness)[0][0]

    def put(self, img: np.ndarray, text: str, x: int, y: int, colour: tuple[int, int, int]) -> None:
        """Draw ``text`` with its line box's top-left corner at (x, y)."""
        cv2.putText(img, text, (x, y + self.ascent + 1), self.font, self.scale, colour, self.thickness, cv2.LINE_AA)


class _PilText:
    """Any Unicode text with a TrueType font: glyphs rasterised once by Pillow, composed and
    alpha-blended with numpy (no kerning), so a frame costs no full-image PIL round trip."""

    def __init__(self, font_file: str, index: int, size_px: int) -> None:
        from PIL import ImageFont

        self.font = ImageFont.truetype(font_file, size_px, index=index)
        ascent, descent = self.font.getmetrics()
        self.height = ascent + descent
        self.line_h = self.height + 2
        self._glyphs: dict[str, tuple[np.ndarray, int, float]] = {}
        self._masks: OrderedDict[str, np.ndarray] = OrderedDict()

    def _glyph(self, ch: str) -> tuple[np.ndarray, int, float]:
        """(alpha mask (H, w) float32 in [0, 1], x offset from the pen, advance) of one character."""
        g = self._glyphs.get(ch)
        if g is None:
            from PIL import Image, ImageDraw

            adv = self.font.getlength(ch)
            left, _, right, _ = self.font.getbbox(ch) if ch.strip() else (0, 0, 0, 0)
            x_off = min(0, int(np.floor(left)))
            w = max(int(np.ceil(max(right, adv))) - x_off, 1)
            im = Image.new("L", (w, self.height))
            ImageDraw.Draw(im).text((-x_off, 0), ch, font=self.font, fill=255)
            g = (np.asarray(im, dtype=np.float32) / 255.0, x_off, adv)
            self._glyphs[ch] = g
        return g

    def width(self, text: str) -> int:
        return int(np.ceil(sum(self._glyph(c)[2] for c in text)))

    def _mask(self, text: str) -> np.ndarray:
        m = self._masks.get(text)
        if m is not None:
            self._masks.move_to_end(text)
            return m
        glyphs = [self._glyph(c) for c in text]
        pens = np.concatenate([[0.0], np.cumsum([g[2] for g in glyphs])])
        starts = [int(round(p)) + g[1] for p, g in zip(pens, glyphs, strict=False)]
        shift = -min(starts + [0])
        m = np.zeros((self.height, max(s + shift + g[0].shape[1] for s, g in zip(starts, glyphs, strict=True))
                      if glyphs else 1), np.float32)
        for s, g in zip(starts, glyphs, strict=True):
            sl = m[:, s + shift: s + shift + g[0].shape[1]]
            np.maximum(sl, g[0], out=sl)
        self._masks[text] = m
        if len(self._masks) > 1024:
            self._masks.popitem(last=False)
        return m

    def put(self, img: np.ndarray, text: str, x: int, y: int, colour: tuple[int, int, int]) -> None:
        """Blend ``text`` with its line box's top-left corner at (x, y)."""
        m = self._mask(text)
        h, w = img.shape[:2]
        y += 1
        x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + m.shape[1], w), min(y + m.shape[0], h)
        if x0 >= x1 or y0 >= y1:
            return
        a = m[y0 - y: y1 - y, x0 - x: x1 - x, None]
        roi = img[y0:y1, x0:x1]
        roi[...] = roi + (np.asarray(colour, np.float32) - roi) * a + 0.5


# ----------------------------------------------------------------------------- writer
def _box(kind: bytes, *parts: bytes) -> bytes:
    body = b"".join(parts)
    return struct.pack(">I4s", 8 + len(body), kind) + body


def _full(kind: bytes, version: int, flags: int, *parts: bytes) -> bytes:
    return _box(kind, struct.pack(">I", (version << 24) | flags), *parts)


def _descriptor(tag: int, body: bytes) -> bytes:
    """An MPEG-4 descriptor (ISO 14496-1) with a 4-byte size field."""
    n = len(body)
    size = bytes([0x80 | (n >> 21) & 0x7F, 0x80 | (n >> 14) & 0x7F, 0x80 | (n >> 7) & 0x7F, n & 0x7F])
    return bytes([tag]) + size + body


_MATRIX = struct.pack(">9I", 0x10000, 0, 0, 0, 0x10000, 0, 0, 0, 0x40000000)


class FragmentedMjpegWriter:
    """Motion-JPEG frames in a fragmented MP4 (ISO 14496-12): ``ftyp`` and a ``moov``
    with no samples (``mvex``) written at once, then one ``moof`` + ``mdat`` per frame in
    one ``os.write`` each, so the file is readable up to the last whole fragment however
    the process ends. Every frame is a sync sample; the sample entry is ``mp4v`` with
    object type 0x6C (JPEG), as FFmpeg writes MJPEG in MP4. ``release`` patches the
    durations into ``mvhd``/``tkhd``/``mdhd``/``mehd`` (a killed run's stay 0; readers
    take the fragments). Constant frame rate: ``fps`` (timescale ``round(fps * 1000)``).
    """

    def __init__(self, path: Path, fps: float, size: tuple[int, int], quality: int = JPEG_QUALITY) -> None:
        self.path = Path(path)
        self.size = (int(size[0]), int(size[1]))
        self.quality = int(quality)
        self.timescale = max(1, round(float(fps) * 1000))
        self.frames = 0
        self._durations: list[tuple[int, bool]] = []  # (file offset, in media units) of each duration
        header = self._header()
        flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_BINARY", 0)
        self._fd: int | None = os.open(self.path, flags, 0o666)
        try:
            self._write(header)
        except OSError:
            self.release()
            raise

    def isOpened(self) -> bool:  # noqa: N802 - cv2.VideoWriter's name
        return self._fd is not None

    def _header(self) -> bytes:
        w, h = self.size
        ftyp = _box(b"ftyp", b"isom", struct.pack(">I", 0x200), b"isomiso2iso5iso6mp41")
        mvhd_pre = struct.pack(">III", 0, 0, 1000)
        mvhd = _full(b"mvhd", 0, 0, mvhd_pre, struct.pack(">I", 0), struct.pack(">IH", 0x10000, 0x100),
                     bytes(10), _MATRIX, bytes(24), struct.pack(">I", 2))
        tkhd_pre = struct.pack(">IIII", 0, 0, 1, 0)
        tkhd = _full(b"tkhd", 0, 3, tkhd_pre, struct.pack(">I", 0), bytes(8), struct.pack(">hhhH", 0, 0, 0, 0),
                     _MATRIX, struct.pack(">II", w << 16, h << 16))
        mdhd_pre = struct.pack(">III", 0, 0, self.timescale)
        mdhd = _full(b"mdhd", 0, 0, mdhd_pre, struct.pack(">I", 0), struct.pack(">HH", 0x55C4, 0))
        hdlr = _full(b"hdlr", 0, 0, struct.pack(">I4s", 0, b"vide"), bytes(12), b"VideoHandler\0")
        esds = _full(b"esds", 0, 0, _descriptor(3, struct.pack(">HB", 1, 0) + _descriptor(
            4, struct.pack(">BB", 0x6C, 0x11) + bytes(3) + struct.pack(">II", 0, 0)) + _descriptor(6, b"\x02")))
        name = (bytes([11]) + b"Motion JPEG").ljust(32, b"\0")  # compressorname: a Pascal string
        entry = _box(b"mp4v", bytes(6), struct.pack(">H", 1), bytes(16), struct.pack(">HHII", w, h, 0x480000, 0x480000),
                     struct.pack(">IH", 0, 1), name, struct.pack(">Hh", 0x18, -1), esds)
        stbl = _box(b"stbl", _full(b"stsd", 0, 0, struct.pack(">I", 1), entry), _full(b"stts", 0, 0, bytes(4)),
                    _full(b"stsc", 0, 0, bytes(4)), _full(b"stsz", 0, 0, bytes(8)), _full(b"stco", 0, 0, bytes(4)))
        minf = _box(b"minf", _full(b"vmhd", 0, 1, bytes(8)),
                    _box(b"dinf", _full(b"dref", 0, 0, struct.pack(">I", 1), _full(b"url ", 0, 1))), stbl)
        mdia = _box(b"mdia", mdhd, hdlr, minf)
        mehd = _full(b"mehd", 0, 0, struct.pack(">I", 0))
        mvex = _box(b"mvex", mehd, _full(b"trex", 0, 0, struct.pack(">IIIII", 1, 1, 0, 0, 0)))
        moov = _box(b"moov", mvhd, _box(b"trak", tkhd, mdia), mvex)
        out = ftyp + moov
        # the duration fields, patched at release: after the box type, version/flags and ``pre``
        for kind, pre in ((b"mvhd", mvhd_pre), (b"tkhd", tkhd_pre), (b"mdhd", mdhd_pre), (b"mehd", b"")):
            self._durations.append((out.index(kind) + 8 + len(pre), kind == b"mdhd"))
        return out

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            n = os.write(self._fd, view)
            view = view[n:]

    def write(self, bgr: np.ndarray) -> None:
        """Append one frame (BGR, ``size``) as a fragment."""
        if self._fd is None:
            raise OSError(f"{self.path}: the video is closed")
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, self.quality])
        if not ok:
            raise OSError(f"{self.path}: OpenCV could not encode frame {self.frames} as JPEG")
        jpeg = buf.tobytes()
        k = self.frames
        tfhd = _full(b"tfhd", 0, 0x020000, struct.pack(">I", 1))  # default-base-is-moof
        tfdt = _full(b"tfdt", 1, 0, struct.pack(">Q", k * 1000))
        # trun: data offset, sample duration and size given; one sync sample (trex default flags 0)
        trun_len = 8 + 4 + 4 + 4 + 8
        moof_len = 8 + 16 + 8 + len(tfhd) + len(tfdt) + trun_len
        trun = _full(b"trun", 0, 0x000301, struct.pack(">IiII", 1, moof_len + 8, 1000, len(jpeg)))
        moof = _box(b"moof", _full(b"mfhd", 0, 0, struct.pack(">I", k + 1)), _box(b"traf", tfhd, tfdt, trun))
        self._write(moof + struct.pack(">I4s", 8 + len(jpeg), b"mdat") + jpeg)
        self.frames += 1

    def release(self) -> None:
        """Patch the durations into the header and close (idempotent)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            media = self.frames * 1000  # timescale units (1000 per frame)
            movie = media * 1000 // self.timescale  # ms (mvhd's timescale)
            for at, in_media in self._durations:
                os.lseek(fd, at, os.SEEK_SET)
                os.write(fd, struct.pack(">I", min(media if in_media else movie, 0xFFFFFFFF)))
        finally:
            os.close(fd)


def open_mp4_writer(
    path: Path, fps: float, size: tuple[int, int], quality: int = JPEG_QUALITY,
) -> tuple[FragmentedMjpegWriter, str]:
    """An opened writer for ``path`` (W, H) and its FOURCC; ``OutputError`` (one line) if the file
    cannot be created."""
    try:
        return FragmentedMjpegWriter(path, fps, size, quality), FOURCC
    except OSError as e:
        raise OutputError(f"{path}: cannot write the video ({e.strerror or e})") from None


def check_video_path(path: Path) -> None:
    """Fail now (``OutputError``, one line) if an MP4 cannot be written at ``path``: creates the
    parent directory; refuses a directory or a read-only file; checks that the directory takes
    a file (a probe file, removed at once). ``path`` itself is not touched."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path}: is a directory, not a video file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{path}: cannot create the video's directory ({e.strerror or e})") from None
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputError(f"{path}: the video file is not writable")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise OutputError(f"{path}: the video's directory is not writable")
    probe = path.parent / f".{path.stem}.probe-{os.getpid()}{path.suffix or '.mp4'}"
    try:
        probe.write_bytes(b"")
    except OSError as e:
        raise OutputError(f"{path}: cannot write in the video's directory ({e.strerror or e})") from None
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()


class _AsyncWriter:
    """Converts to BGR and encodes on a background thread (OpenCV releases the GIL), in order.

    At most ``maxsize`` frames wait in the queue: with the one being encoded, what a killed
    process has handed over but not yet written."""

    def __init__(self, writer: FragmentedMjpegWriter, maxsize: int = QUEUE_FRAMES) -> None:
        self._writer = writer
        self._queue: queue.Queue[np.ndarray | None] = queue.Queue(maxsize)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="video-writer", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while (rgb := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._writer.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
                except BaseException as e:  # noqa: BLE001 - re-raised in the caller's thread
                    self._error = e

    def write(self, rgb: np.ndarray) -> None:
        if self._error is not None:
            raise self._error
        self._queue.put(rgb)

    def close(self) -> None:
        self._queue.put(None)
        self._thread.join()
        self._writer.release()
        if self._error is not None:
            raise self._error


# ----------------------------------------------------------------------------- layout
def _place(box: tuple[int, int, int, int], cw: int, ch: int, placed: np.ndarray, w: int, h: int,
           min_y: int) -> tuple[int, int]:
    """Top-left of a cw x ch caption for ``box``: inside the image below ``min_y``, least overlap
    with the ``placed`` (P, 4) captions, then nearest to the preferred spot (above the box)."""
    x0, y0, x1, y1 = box
    xs = np.array([x0, x1 - cw, x0 - cw - 2, x1 + 2, (x0 + x1 - cw) // 2])
    ys = np.array([y0 - ch, y1 + 1, y0 + 1, *(y0 - (k + 2) * ch for k in range(3)), *(y1 + 1 + (k + 1) * ch for k in range(2))])
    cand = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)  # preferred order: ys major, xs minor
    cand[:, 0] = np.clip(cand[:, 0], 0, max(w - cw, 0))
    cand[:, 1] = np.clip(cand[:, 1], min(min_y, max(h - ch, 0)), max(h - ch, 0))
    if len(placed):
        ox = np.clip(np.minimum(cand[:, None, 0] + cw, placed[None, :, 2]) - np.maximum(cand[:, None, 0], placed[None, :, 0]), 0, None)
        oy = np.clip(np.minimum(cand[:, None, 1] + ch, placed[None, :, 3]) - np.maximum(cand[:, None, 1], placed[None, :, 1]), 0, None)
        overlap = (ox * oy).sum(axis=1)
    else:
        overlap = np.zeros(len(cand))
    k = int(np.lexsort((np.arange(len(cand)), overlap))[0])
    return int(cand[k, 0]), int(cand[k, 1])


# ----------------------------------------------------------------------------- overlay and sink
@dataclass
class _Style:
    text: _CvText | _PilText
    box_thickness: int
    trail_thickness: int
    pad: int


class Overlay:
    """The annotation drawn on each frame (see the module doc) and the state it carries from
    frame to frame (trails, active alerts, a recent collision). ``VideoSink`` is one; the demo's
    key frames (``tools.sinks.keyframes.KeyFrameSink``) and the report draw with one too.

    Feed every frame in order: ``annotate`` (draw) or ``observe`` (state only, no drawing).
    """

    def __init__(self, lang: str = "en", trail_s: float = 2.0) -> None:
        global _FONT_WARNED
        if lang not in ("en", "zh"):
            raise ValueError(f"lang: expected 'en' or 'zh', got {lang!r}")
        self.trail_s = float(trail_s)
        self.lang = lang
        self.font: tuple[str, int] | None = None
        if lang == "zh":
            self.font = find_cjk_font()
            if self.font is None:
                self.lang = "en"
                if not _FONT_WARNED:
                    log.warning("no CJK font found (looked in %s); install fonts-noto-cjk; falling back to English",
                                _font_places())
                    _FONT_WARNED = True
        self._style: _Style | None = None
        self._reset()

    def _reset(self) -> None:
        self._trails: dict[int, deque[tuple[float, float, float]]] = {}
        self._alerts: dict[int, Alert] = {}
        self._collision: tuple[float, str] | None = None

    def reset(self) -> None:
        """Forget trails, alerts and collisions (a new run starts)."""
        self._reset()

    def observe(self, record: TickRecord) -> dict[str, np.ndarray]:
        """Advance the trail and alert state by one frame without drawing; returns the track rows."""
        rows = self._track_rows(record)
        self._update_trails(record.t, rows)
        self._update_alerts(record, rows)
        return rows

    def annotate(self, record: TickRecord) -> np.ndarray:
        """The record's camera image (RGB) with the overlay drawn (the input is not modified).

        Advances the trail and alert state: call once per frame, in order (or ``observe``)."""
        img = np.array(record.frame.image, dtype=np.uint8, copy=True)
        st = self._style_for(img.shape[0])
        rows = self.observe(record)
        banner = self._banner(record)
        header_h = st.text.line_h + st.pad
        banner_h = st.text.line_h + st.pad + 2 if banner else 0
        self._draw_trails(img, rows, st)
        self._draw_tracks(img, rows, st, min_y=header_h + banner_h + 1)
        self._draw_header(img, record, st, header_h)
        if banner:
            self._draw_banner(img, st, header_h, *banner)
        return img

    # -- drawing
    def _style_for(self, h: int) -> _Style:
        if self._style is None:
            k = max(h / 360.0, 0.5)
            text = _PilText(*self.font, size_px=round(13 * k)) if self.lang == "zh" and self.font else _CvText(0.4 * k)
            self._style = _Style(text, max(1, round(2 * k)), max(1, round(2 * k)), max(2, round(3 * k)))
        return self._style

    def _track_rows(self, record: TickRecord) -> dict[str, np.ndarray]:
        tr, est, a = record.tracks, record.estimates, record.assessments
        n = 0 if tr is None else len(tr.track_id)
        nan = np.full(n, np.nan)
        rows = {
            "id": tr.track_id if n else np.zeros(0, np.int64),
            "xyxy": tr.xyxy if n else np.zeros((0, 4)),
            "cls": tr.class_id if n else np.zeros(0, np.int64),
            "lost": (tr.state == TrackState.LOST) if n else np.zeros(0, bool),
            "range": est.range if est is not None and n else nan,
            "speed": np.hypot(est.ground_vx, est.ground_vy) * 3.6 if est is not None and n else nan,
            "ttc": a.ttc if a is not None and n else nan,
            "risk": a.risk.astype(np.int64) if a is not None and n else np.zeros(n, np.int64),
            "label": a.label.astype(np.int64) if a is not None and n else np.zeros(n, np.int64),
        }
        return rows

    def _update_trails(self, t: float, rows: dict[str, np.ndarray]) -> None:
        b = rows["xyxy"]
        bx, by = 0.5 * (b[:, 0] + b[:, 2]), b[:, 3]
        ok = np.isfinite(bx) & np.isfinite(by)
        alive = set()
        for tid, x, y, good in zip(rows["id"].tolist(), bx.tolist(), by.tolist(), ok.tolist(), strict=True):
            alive.add(tid)
            dq = self._trails.setdefault(tid, deque())
            if good:
                dq.append((t, x, y))
            while dq and dq[0][0] < t - self.trail_s - 1e-9:
                dq.popleft()
        for tid in [k for k in self._trails if k not in alive]:
            del self._trails[tid]

    def _update_alerts(self, record: TickRecord, rows: dict[str, np.ndarray]) -> None:
        for al in record.alerts:
            if al.level >= Risk.HIGH:
                self._alerts[al.track_id] = al
            else:
                self._alerts.pop(al.track_id, None)
        alive = set(rows["id"].tolist())
        for tid in [k for k in self._alerts if k not in alive]:
            del self._alerts[tid]
        for c in record.collisions:
            if self.lang == "zh":
                msg = f"碰撞：{c.name}（{CLASS_NAMES_ZH.get(c.cls, c.cls)}），相对速度 {c.relative_speed * 3.6:.0f} km/h"
            else:
                msg = f"COLLISION with {c.name} ({c.cls}) at {c.relative_speed * 3.6:.0f} km/h"
            self._collision = (record.t, msg)

    def _draw_trails(self, img: np.ndarray, rows: dict[str, np.ndarray], st: _Style) -> None:
        risk = dict(zip(rows["id"].tolist(), rows["risk"].tolist(), strict=True))
        for tid, dq in self._trails.items():
            if len(dq) < 2:
                continue
            pts = np.round(np.asarray(dq)[:, 1:]).astype(np.int32)
            colour = risk_colour(risk.get(tid, 0))
            cv2.polylines(img, [pts], False, colour, st.trail_thickness, cv2.LINE_AA)
            for x, y in pts[:-1].tolist():
                cv2.circle(img, (x, y), st.trail_thickness + 1, colour, -1, cv2.LINE_AA)

    def _captions(self, rows: dict[str, np.ndarray], i: int) -> tuple[str, str]:
        cid = int(rows["cls"][i])
        cls = CLASSES[cid] if 0 <= cid < len(CLASSES) else "obstacle"
        lab = Label(int(rows["label"][i]))
        if self.lang == "zh":
            line1 = f"#{rows['id'][i]} {CLASS_NAMES_ZH.get(cls, cls)} {LABEL_NAMES_ZH[lab]}"
        else:
            line1 = f"#{rows['id'][i]} {cls} {LABEL_NAMES[lab]}"
        r, v, ttc = rows["range"][i], rows["speed"][i], rows["ttc"][i]
        rng = f"{r:.1f}m" if np.isfinite(r) else "-m"
        spd = f"{v:.0f}km/h" if np.isfinite(v) else "-km/h"
        ttc_s = f"TTC {ttc:.1f}s" if np.isfinite(ttc) and ttc < NEVER else "TTC -"
        return line1, f"{rng} {spd} {ttc_s}"

    def _draw_tracks(self, img: np.ndarray, rows: dict[str, np.ndarray], st: _Style, min_y: int) -> None:
        """Boxes, then captions placed greedily (riskiest first) to avoid overlaps and the top strips."""
        h, w = img.shape[:2]
        tx = st.text
        ok = np.all(np.isfinite(rows["xyxy"]), axis=1)
        boxes = np.clip(np.round(np.nan_to_num(rows["xyxy"])), -4 * w, 5 * w).astype(int)
        by_risk = [int(i) for i in np.argsort(rows["risk"], kind="stable") if ok[i]]
        for i in by_risk:  # riskiest drawn last, on top
            x0, y0, x1, y1 = boxes[i].tolist()
            risk = int(rows["risk"][i])
            thick = 1 if rows["lost"][i] else st.box_thickness + (1 if risk >= Risk.HIGH else 0)
            cv2.rectangle(img, (x0, y0), (x1 - 1, y1 - 1), risk_colour(risk), thick, cv2.LINE_AA)
        placed = np.zeros((0, 4))
        captions = {}
        for i in reversed(by_risk):
            x0, y0, x1, y1 = boxes[i].tolist()
            lines = self._captions(rows, i)
            cw = max(tx.width(s) for s in lines) + 2 * st.pad
            ch = len(lines) * tx.line_h + st.pad
            cx, cy = _place((x0, y0, x1, y1), cw, ch, placed, w, h, min_y)
            placed = np.vstack([placed, [cx, cy, cx + cw, cy + ch]])
            captions[i] = (cx, cy, cw, ch, lines)
        for i in by_risk:
            cx, cy, cw, ch, lines = captions[i]
            risk = int(rows["risk"][i])
            x0, y0, x1, y1 = boxes[i].tolist()
            if cx > x1 or cx + cw < x0 or cy > y1 + 1 or cy + ch < y0 - 1:  # detached: a leader line
                cv2.line(img, (cx + cw // 2, cy + ch if cy + ch < y0 else cy), ((x0 + x1) // 2, y0 if cy < y0 else y1),
                         risk_colour(risk), 1, cv2.LINE_AA)
            cv2.rectangle(img, (cx, cy), (cx + cw, cy + ch), risk_colour(risk), -1)
            ink = _FG if risk >= Risk.CRITICAL else _BG
            for k, s in enumerate(lines):
                tx.put(img, s, cx + st.pad, cy + k * tx.line_h + st.pad // 2, ink)

    def _draw_header(self, img: np.ndarray, record: TickRecord, st: _Style, bottom: int) -> None:
        """The header strip (rows 0..bottom): t, frame, ego speed, brake."""
        ego = record.ego
        v = float(ego.get("speed", np.nan)) * 3.6 if ego.get("speed_known", True) else np.nan
        v_s = f"{v:5.1f}" if np.isfinite(v) else "  -- "  # no ego speed: unknown, not 0
        brake = ego.get("brake")
        if self.lang == "zh":
            head = f"时间 {record.t:5.2f}s  帧 {record.frame_index}  自车 {v_s} km/h"
            brk = f"  制动 {brake:.1f} m/s²" if brake else "  未制动"
        else:
            head = f"t {record.t:5.2f}s  frame {record.frame_index}  ego {v_s} km/h"
            brk = f"  BRAKE {brake:.1f} m/s2" if brake else "  brake off"
        tx = st.text
        hw, bw = tx.width(head), tx.width(brk)
        roi = img[0:bottom, 0:min(hw + bw + 2 * st.pad, img.shape[1])]
        np.right_shift(roi, 2, out=roi)  # darken to a quarter
        tx.put(img, head, st.pad, st.pad // 2, _FG)
        tx.put(img, brk, st.pad + hw, st.pad // 2, (255, 90, 90) if brake else (190, 190, 190))

    def _banner(self, record: TickRecord) -> tuple[str, int] | None:
        """(text, level) of the banner: a recent collision, else the latest active alert >= HIGH."""
        if self._collision is not None and record.t - self._collision[0] <= self.trail_s:
            return self._collision[1], int(Risk.CRITICAL)
        if not self._alerts:
            return None
        al = max(self._alerts.values(), key=lambda a: (a.t, a.level))
        cls = CLASSES[al.class_id] if 0 <= al.class_id < len(CLASSES) else "obstacle"
        level = max(a.level for a in self._alerts.values())
        if self.lang == "zh":
            return f"#{al.track_id} {CLASS_NAMES_ZH.get(cls, cls)} {al.reason_zh}（{al.t:.1f}秒起）", level
        return f"#{al.track_id} {cls} {al.reason} (since {al.t:.1f}s)", level

    def _draw_banner(self, img: np.ndarray, st: _Style, top: int, text: str, level: int) -> None:
        tx = st.text
        y0, y1 = top + 2, top + 2 + tx.line_h + st.pad
        cv2.rectangle(img, (0, y0), (img.shape[1] - 1, y1), risk_colour(level), -1)
        tx.put(img, text, st.pad, y0 + st.pad // 2, _FG if level >= Risk.CRITICAL else _BG)


class VideoSink(Overlay):
    """A runner sink writing an annotated MP4 (see the module doc).

    ``fps`` is the camera rate; ``lang`` ``"en"`` or ``"zh"``; ``trail_s`` the
    trajectory length (s). ``frames_written`` counts frames in the file. ``raw``: the camera
    frames as rendered, without annotation, at JPEG quality ``RAW_JPEG_QUALITY`` (what
    ``lookahead watch`` reads back: ``lookahead run --raw-video``).
    The output is checked here (``check_video_path``), before any sink starts,
    so a bad ``path`` fails before the run directory is touched.
    """

    def __init__(self, path: Path, fps: float, lang: str = "en", trail_s: float = 2.0, raw: bool = False) -> None:
        if fps <= 0:
            raise ValueError(f"fps: expected > 0, got {fps}")
        super().__init__(lang, trail_s)
        self.raw = raw
        self.path = Path(path)
        self.fps = float(fps)
        check_video_path(self.path)
        self.fourcc: str | None = None
        self.frames_written = 0
        self._writer: _AsyncWriter | None = None
        self._size: tuple[int, int] | None = None
        self._warned_no_image = False

    # -- sink protocol
    def on_start(self, info: dict) -> None:
        self._reset()

    def on_tick(self, record: TickRecord) -> None:
        img = record.frame.image
        if img is None:
            if not self._warned_no_image:
                log.warning("%s: frames without an image (rendering off) are not written to the video", self.path)
                self._warned_no_image = True
            return
        out = img.copy() if self.raw else self.annotate(record)  # the writer's thread owns what it gets
        h, w = out.shape[:2]
        if self._writer is None:
            writer, self.fourcc = open_mp4_writer(self.path, self.fps, (w, h),
                                                  RAW_JPEG_QUALITY if self.raw else JPEG_QUALITY)
            self._writer = _AsyncWriter(writer)
            self._size = (w, h)
            log.info("%s: writing %dx%d @ %.3g fps (%s)", self.path, w, h, self.fps, self.fourcc)
        if (w, h) != self._size:
            out = cv2.resize(out, self._size, interpolation=cv2.INTER_AREA)
        self._writer.write(out)
        self.frames_written += 1

    def on_end(self, summary: dict) -> None:
        self.close()

    def close(self) -> None:
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()
            log.info("%s: %d frames", self.path, self.frames_written)
