"""The renderer in a worker process, frames handed back through shared memory.

The runner renders frame k+1 while it perceives frame k (``sim.runner``). In one
process the two would share the GIL: PyBullet releases it while it draws, but the
renderer's Python side (posing a few hundred bodies, compositing) then queues behind
the perceiving thread's Python at every PyBullet call -- measured on the 2-core machine,
a busy Python thread beside it took a 68 ms render to 189 ms. So the renderer lives in
a worker process of its own:

* ``RenderProcess(camera, layout, seed, backend, shapes, scenario)`` starts the worker
  (multiprocessing ``fork``: ~4 ms, nothing imported again, so a script needs no
  ``__main__`` guard; ``forkserver`` and ``spawn`` would import the script's main module
  in the worker). The worker builds a ``Renderer`` with every actor and the scenario's
  ``Weather``, and holds the only EGL context of its process (``auto`` is resolved there,
  so the parent never loads EGL and stays safe to fork).
* ``submit(frame_index, ego_pose, poses)`` asks for a frame; the worker renders it
  (weather applied to the image), writes RGB, depth and segmentation into one of
  ``SLOTS`` shared-memory slots and answers with its ms. ``result()`` waits for the
  oldest frame asked and copies it out of its slot (2.5 MB at 640x360, ~0.05 ms): a
  slot is reused two frames later, and sinks may keep a frame. ``render()`` = both.
* A worker error comes back as ``RenderError`` naming it; a worker that dies is one too.
  The worker ends when ``close()`` says so or the pipe to its parent closes (the
  parent ended, even by SIGKILL: the worker holds no copy of the parent's end), and the
  shared memory is unlinked by ``close()`` (or by multiprocessing's resource tracker
  when the parent was killed).

Ground truth's silhouettes are rendered in the parent (``sim.silhouettes``, TinyRenderer
clients of one actor each): they need no EGL and cost ~0.1 ms each.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import time
import traceback
import warnings
from collections import deque
from collections.abc import Mapping, Sequence
from multiprocessing.connection import Connection
from multiprocessing.shared_memory import SharedMemory
from typing import Any

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.sim.layout import RoadLayout
from lookahead.sim.shapes import ActorShape

log = logging.getLogger(__name__)

SLOTS = 2  # frames in flight: the one being perceived and the one being rendered
START_TIMEOUT_S = 120.0  # the worker builds its scene (and loads EGL) within this
_FORKSERVER: Any = None


class RenderError(RuntimeError):
    """The render worker failed (its error, one line) or died."""


def _context() -> Any:
    """How to start a worker: ``fork`` (~4 ms, nothing imported again, so a script needs no
    ``__main__`` guard) while this process never loaded EGL -- a fork of a process whose GL
    driver threads exist can hang in GL --, else ``forkserver`` (a clean server, this module
    preloaded), else ``spawn``."""
    from lookahead.sim.renderer import egl_loaded

    if not egl_loaded() and "fork" in mp.get_all_start_methods():
        return mp.get_context("fork")
    global _FORKSERVER
    if _FORKSERVER is None:
        if "forkserver" in mp.get_all_start_methods():
            _FORKSERVER = mp.get_context("forkserver")
            _FORKSERVER.set_forkserver_preload([__name__])
        else:
            _FORKSERVER = mp.get_context("spawn")
    return _FORKSERVER


def _slot_arrays(buf: memoryview, height: int, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RGB (H, W, 3) uint8, depth (H, W) float32 and segmentation (H, W) int32 views of one slot."""
    n = height * width
    depth = np.ndarray((height, width), np.float32, buf, 0)
    seg = np.ndarray((height, width), np.int32, buf, 4 * n)
    rgb = np.ndarray((height, width, 3), np.uint8, buf, 8 * n)
    return rgb, depth, seg


def _slot_bytes(height: int, width: int) -> int:
    return 11 * height * width


def _worker(conn: Connection, parent_end: Connection, shm_names: list[str], camera: CameraModel,
            layout: RoadLayout, seed: int, backend: str, shapes: dict[int, ActorShape], scenario: Any,
            gl_threads: int | None) -> None:
    """The worker's loop: build the renderer, then render each frame asked into its slot."""
    parent_end.close()  # a forked copy of the parent's end would keep the pipe open after the parent died
    if gl_threads is not None:  # before the GL driver loads; the user's setting wins
        os.environ.setdefault("LP_NUM_THREADS", str(gl_threads))
    from lookahead.sim.renderer import Renderer
    from lookahead.sim.weather import Weather

    shms = [SharedMemory(name=n) for n in shm_names]
    renderer = None
    slots: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    try:
        if backend == "auto":  # measured here, so the parent never loads EGL
            from lookahead.sim.render_backend import choose_backend

            backend = choose_backend(camera)
        renderer = Renderer(camera, layout, seed=seed, backend=backend)
        for actor_id, shape in shapes.items():
            renderer.add_actor(actor_id, shape)
        weather = None
        if scenario is not None and scenario.weather.kind != "clear":
            weather = Weather.from_scenario(scenario, camera, layout, far=renderer.far)
        conn.send(("ready", renderer.backend, renderer.far))
        slots += [_slot_arrays(s.buf, camera.height, camera.width) for s in shms]
        while True:
            msg = conn.recv()
            if msg[0] == "close":
                break
            _, slot, frame_index, ego_pose, poses = msg
            t0 = time.perf_counter()
            out = renderer.render(ego_pose, poses)
            image = out.rgb if weather is None else weather.apply(out.rgb, out.depth, frame_index, ego_pose)
            for dst, src in zip(slots[slot], (image, out.depth, out.seg), strict=True):
                dst[...] = src
            conn.send(("frame", slot, (time.perf_counter() - t0) * 1e3))
    except (EOFError, KeyboardInterrupt):  # the parent is gone, or interrupted with it
        pass
    except BaseException as e:  # told to the parent, which raises it as a RenderError
        log.debug("render worker failed:\n%s", traceback.format_exc())
        try:
            conn.send(("error", f"{type(e).__name__}: {e}".rstrip(": ")))
        except (OSError, ValueError):
            pass
    finally:
        if renderer is not None:
            renderer.close()
        slots.clear()  # the views first: a segment with views into it cannot close
        for s in shms:
            s.close()


class RenderProcess:
    """A ``Renderer`` in a worker process (see the module docstring).

    Args:
        camera, layout, seed: as ``Renderer``; backend: "egl", "tiny" or "auto" (resolved in the
            worker by ``sim.render_backend.choose_backend``: the faster on this machine).
        shapes: actor id -> shape of every actor to draw.
        scenario: its ``weather`` is applied to the image (None: none).
        gl_threads: the worker's llvmpipe rasteriser threads (``LP_NUM_THREADS`` unless the
            environment sets it; None: the driver's default, one per core).
    """

    def __init__(self, camera: CameraModel, layout: RoadLayout, seed: int, backend: str,
                 shapes: Mapping[int, ActorShape], scenario: Any = None, gl_threads: int | None = None) -> None:
        self.camera = camera
        h, w = camera.height, camera.width
        self._shms = [SharedMemory(create=True, size=_slot_bytes(h, w)) for _ in range(SLOTS)]
        self._slots = [_slot_arrays(s.buf, h, w) for s in self._shms]
        self._pending: deque[int] = deque()  # slots asked for, oldest first
        self._next_slot = 0
        ctx = _context()
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(
            target=_worker, name="lookahead-render",
            args=(child, self._conn, [s.name for s in self._shms], camera, layout, int(seed), backend, dict(shapes),
                  scenario, gl_threads),
        )
        try:
            with warnings.catch_warnings():  # Python >= 3.12 warns of forking with threads: the worker
                warnings.simplefilter("ignore", DeprecationWarning)  # touches no lock of theirs
                self._proc.start()
            child.close()
            reply = self._receive(START_TIMEOUT_S)
            if reply[0] != "ready":
                raise RenderError(f"render worker sent {reply[0]!r} before it was ready")
        except BaseException:
            self.close()
            raise
        _, self.backend, self.far = reply

    def _receive(self, timeout: float | None = None) -> tuple:
        """The worker's next message; ``RenderError`` for its error, its death or a timeout."""
        while not self._conn.poll(1.0 if timeout is None else min(timeout, 1.0)):
            if not self._proc.is_alive():
                raise RenderError(f"render worker died (exit code {self._died()})")
            if timeout is not None:
                timeout -= 1.0
                if timeout <= 0:
                    raise RenderError("render worker did not answer in time")
        try:
            msg = self._conn.recv()
        except (EOFError, OSError):
            raise RenderError(f"render worker died (exit code {self._died()})") from None
        if msg[0] == "error":
            raise RenderError(f"render worker: {msg[1]}")
        return msg

    def _died(self) -> int | None:
        """The dead worker's exit code (waits a moment for the OS to report it)."""
        self._proc.join(1.0)
        return self._proc.exitcode

    def submit(self, frame_index: int, ego_pose: Sequence[float],
               poses: Mapping[int, Sequence[float]]) -> None:
        """Ask for a frame (at most ``SLOTS`` in flight); collect it with ``result``."""
        if len(self._pending) >= SLOTS:
            raise RuntimeError(f"at most {SLOTS} frames in flight")
        slot = self._next_slot
        self._next_slot = (slot + 1) % SLOTS
        try:
            self._conn.send(("render", slot, int(frame_index), tuple(ego_pose), dict(poses)))
        except OSError:
            raise RenderError(f"render worker died (exit code {self._died()})") from None
        self._pending.append(slot)

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The oldest frame asked for: RGB (with weather), depth, segmentation (copies) and the
        worker's ms for it."""
        slot = self._pending.popleft()
        _, done, ms = self._receive()
        if done != slot:
            raise RenderError(f"render worker answered slot {done}, expected {slot}")
        rgb, depth, seg = self._slots[slot]
        return rgb.copy(), depth.copy(), seg.copy(), ms

    def close(self) -> None:
        """Stop the worker and free the shared memory (idempotent)."""
        proc = getattr(self, "_proc", None)
        if proc is not None and proc.is_alive():
            try:
                self._conn.send(("close",))
            except (OSError, ValueError):
                pass
            proc.join(10.0)
            if proc.is_alive():
                proc.terminate()
                proc.join(5.0)
        if getattr(self, "_conn", None) is not None:
            self._conn.close()
        self._slots = []  # the views first: a segment with views into it cannot close
        for s in getattr(self, "_shms", []):
            s.close()
            try:
                s.unlink()
            except FileNotFoundError:
                pass
        self._shms = []
        self._proc = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass
