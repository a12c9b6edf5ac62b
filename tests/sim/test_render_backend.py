"""``auto`` renders with the backend measured fastest on this machine at the camera's size, once."""

from __future__ import annotations

import json

import pytest

from lookahead.perception.camera import CameraModel
from lookahead.sim import render_backend


def test_the_faster_backend_is_measured_once_and_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("LOOKAHEAD_CACHE", str(tmp_path))
    camera = CameraModel.from_fov(160, 90, 90.0, mount=(-1.5, 0.0, 1.4))
    measured = []
    real = render_backend.measure_backends

    def measure(cam):
        measured.append((cam.width, cam.height))
        return real(cam)

    monkeypatch.setattr(render_backend, "measure_backends", measure)
    chosen = render_backend.choose_backend(camera)
    cache = json.loads((tmp_path / "render_backends.json").read_text())
    (key, times), = cache.items()
    assert key.startswith("160x90|") and "tiny" in times and all(v > 0 for v in times.values())
    assert chosen == _fastest(times) and measured == [(160, 90)]
    # the cached answer: nothing measured again
    assert render_backend.choose_backend(camera) == chosen and measured == [(160, 90)]
    # an unreadable cache is measured again, not an error
    (tmp_path / "render_backends.json").write_text("{not json")
    again = render_backend.choose_backend(camera)
    (times,) = json.loads((tmp_path / "render_backends.json").read_text()).values()
    # a new measurement on a noisy machine may pick the other backend; it picks the faster of what it measured
    assert len(measured) == 2 and again == _fastest(times)


def _fastest(times: dict[str, float]) -> str:
    return "tiny" if times.get("egl") is None or times["tiny"] < render_backend.TINY_MARGIN * times["egl"] else "egl"


@pytest.mark.parametrize("times, want", [
    ({"egl": 52.0, "tiny": 110.0}, "egl"),
    ({"egl": 44.0, "tiny": 40.0}, "egl"),  # not faster by the margin: the load may have decided
    ({"egl": 39.0, "tiny": 24.0}, "tiny"),
    ({"tiny": 30.0}, "tiny"),  # no EGL on the machine
])
def test_the_cached_timings_decide(tmp_path, monkeypatch, times, want):
    monkeypatch.setenv("LOOKAHEAD_CACHE", str(tmp_path))
    camera = CameraModel.from_fov(320, 180, 90.0, mount=(-1.5, 0.0, 1.4))
    (tmp_path / "render_backends.json").write_text(json.dumps({render_backend._machine_key(320, 180): times}))
    monkeypatch.setattr(render_backend, "measure_backends", lambda cam: pytest.fail("measured again"))
    assert render_backend.choose_backend(camera) == want
