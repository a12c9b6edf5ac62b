"""The renderer backend ``auto`` resolves to: the faster one measured on this machine, per resolution.

EGL (Mesa llvmpipe here, a GPU elsewhere) pays a fixed cost per frame and per body;
TinyRenderer pays per pixel. Which is faster depends on the machine and the image size
(measured on a 2-core machine: EGL 52 ms vs TinyRenderer 110 ms at 640x360; 39 vs
24 ms at 160x96). ``choose_backend`` renders the same busy scene (``urban_mix`` at its
start, ``PROBE_FRAMES`` frames after one warm-up) with each available backend at the
camera's resolution, once per machine and resolution, and keeps the timings in
``cache_path()`` (JSON; ``$LOOKAHEAD_CACHE`` or ``$XDG_CACHE_HOME/lookahead``, default
``~/.cache/lookahead``), keyed by resolution, CPU, core count, the llvmpipe thread setting
and the PyBullet version. TinyRenderer is chosen only when it is faster by
``TINY_MARGIN`` (then the choice does not flip with the machine's load). Without EGL
the answer is ``tiny``.

The choice changes the pixels (the two rasterisers shade differently), so a run records the
backend it used (``run.json``'s ``renderer``); on one machine it is always the same.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import platform
import statistics
import time
from importlib import metadata
from pathlib import Path

from lookahead.perception.camera import CameraModel

log = logging.getLogger(__name__)

PROBE_FRAMES = 3
TINY_MARGIN = 0.8  # TinyRenderer only when this much faster: timings on a shared machine vary by 10-20 %,
# and EGL's shading is what the shipped detector was trained on
PROBE_SCENARIO = "urban_mix.yaml"


def cache_path() -> Path:
    """The JSON file holding this machine's measurements."""
    root = os.environ.get("LOOKAHEAD_CACHE") or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "lookahead"
    return Path(root) / "render_backends.json"


def _machine_key(width: int, height: int) -> str:
    try:
        pybullet = metadata.version("pybullet")
    except metadata.PackageNotFoundError:
        pybullet = "?"
    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return (f"{width}x{height}|{cpu}|{os.cpu_count()}|LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', '')}"
            f"|pybullet {pybullet}")


def _read_cache(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def measure_backends(camera: CameraModel) -> dict[str, float]:
    """Median ms per frame of each available backend rendering the probe scene with ``camera``."""
    from lookahead.sim.catalogue import SCENARIOS
    from lookahead.sim.renderer import Renderer
    from lookahead.sim.scenario import load_scenario
    from lookahead.sim.world import World

    world = World(load_scenario(SCENARIOS / PROBE_SCENARIO))
    poses = world.actor_poses()
    out: dict[str, float] = {}
    for backend in ("egl", "tiny"):
        try:
            renderer = Renderer(camera, world.layout, seed=0, backend=backend)
        except RuntimeError as e:  # EGL unavailable
            log.info("render backend %s unavailable: %s", backend, e)
            continue
        try:
            for a in world.agents:
                renderer.add_actor(a.identity.actor_id, a.identity.shape)
            times = []
            for k in range(PROBE_FRAMES + 1):
                t0 = time.perf_counter()
                renderer.render(world.ego_pose(), poses)
                if k:  # the first frame warms up
                    times.append((time.perf_counter() - t0) * 1e3)
            out[backend] = round(statistics.median(times), 2)
        finally:
            renderer.close()
    return out


def choose_backend(camera: CameraModel) -> str:
    """``egl`` or ``tiny``: the faster for ``camera``'s resolution on this machine (cached);
    ``tiny`` while another EGL renderer is open in this process (PyBullet allows one)."""
    from lookahead.sim.renderer import egl_in_use

    if egl_in_use():
        return "tiny"
    path = cache_path()
    key = _machine_key(camera.width, camera.height)
    cache = _read_cache(path)
    times = cache.get(key)
    if not isinstance(times, dict) or not times:
        times = measure_backends(camera)
        cache = _read_cache(path)  # another process may have written meanwhile
        cache[key] = times
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(json.dumps(cache, indent=1, sort_keys=True))
            tmp.replace(path)
        except OSError as e:
            log.warning("cannot cache render backend timings in %s (%s)", path, e)
        log.info("render backends at %dx%d: %s ms per frame", camera.width, camera.height, times)
    if "egl" in times and "tiny" in times:
        return "tiny" if times["tiny"] < TINY_MARGIN * times["egl"] else "egl"
    return next(iter(times), "tiny")
