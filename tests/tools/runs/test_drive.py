"""``lookahead drive``: the pygame window under a real X server (Xvfb), driven by key presses.

The keys go through pygame's event queue, as a keyboard's do; the session is recorded as an
ordinary run directory, whose ego speed and lane show what the keys did.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
from system_deps import require_command

from lookahead.sim.scenario import parse_scenario
from lookahead.tools.runs.drive import ACCEL, DriveSession, drive

SCENARIO = """
name: drive_test
seed: 3
duration: 3.0
road: {kind: straight, lanes: 2, lane_width: 3.5, sidewalks: true}
ego: {lane: 1, speed: 10.0, controller: cruise}
actors:
  - {id: lead, type: car, start: {lane: 1, s: 60}, speed: 10.0}
perception: {detector: {kind: gt}}
"""


@pytest.fixture
def xvfb(monkeypatch):
    """A private X display (Xvfb) for the test's window."""
    exe = require_command("Xvfb")
    r, w = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(w), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    with os.fdopen(r) as f:
        display = f.readline().strip()
    monkeypatch.setenv("DISPLAY", f":{display}")
    monkeypatch.setenv("SDL_VIDEODRIVER", "x11")
    yield f":{display}"
    proc.terminate()
    proc.wait(timeout=10)


def test_key_presses_drive_the_ego_and_the_session_is_a_run(xvfb, tmp_path: Path):
    import pygame

    out = tmp_path / "drive"
    session = DriveSession(parse_scenario(SCENARIO), out)

    def keys(k: int) -> None:  # Up held for frames 0-9, a Left press at 12, Down held from 20
        for frame, kind, key in ((0, pygame.KEYDOWN, pygame.K_UP), (10, pygame.KEYUP, pygame.K_UP),
                                 (12, pygame.KEYDOWN, pygame.K_LEFT), (12, pygame.KEYUP, pygame.K_LEFT),
                                 (20, pygame.KEYDOWN, pygame.K_DOWN)):
            if k == frame:
                pygame.event.post(pygame.event.Event(kind, key=key))

    shot = tmp_path / "window.png"
    summary = drive(session, realtime=False, on_frame=keys, screenshot=shot)
    assert summary.error is None and summary.frames == 31  # t = 0 .. 3.0 s at 10 Hz
    ticks = [json.loads(line) for line in (out / "ticks.jsonl").read_text().splitlines()]
    speed = [r["ego"]["speed"] for r in ticks]
    y = [r["ego"]["y"] for r in ticks]
    assert speed[10] == pytest.approx(10.0 + ACCEL * 1.0, abs=0.3)  # Up for 1 s
    assert speed[19] == pytest.approx(speed[10], abs=0.2)  # neither key: the speed held
    assert speed[30] < speed[20] - 4.0  # Down: braking
    assert y[11] == pytest.approx(y[0], abs=0.1) and y[30] - y[0] == pytest.approx(3.5, abs=0.3)  # one lane left
    assert (out / "annotated.mp4").stat().st_size > 0 and json.loads((out / "run.json").read_text())
    assert pygame.image.load(str(shot)).get_size() == (640 + 160, 360 + 28)


def test_without_a_display_drive_is_one_line_and_writes_nothing(tmp_path: Path, monkeypatch):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("SDL_VIDEODRIVER", "x11")
    res = CliRunner().invoke(app, ["drive", "stationary_car", "--out", str(tmp_path / "d")])
    assert res.exit_code == 2 and "cannot open a window" in res.output
    assert not (tmp_path / "d").exists()
