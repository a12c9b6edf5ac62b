"""``lookahead drive SCENARIO``: drive the ego from the keyboard and watch the stack live.

A pygame window shows the ego camera with the overlay of the annotated video
(``tools.sinks.video``: boxes, ids, labels, range, TTC, the alert banner; Chinese with
``--lang zh``) and a bird's-eye inset of the tracks (``sim.birdseye``), over a status line.
The keyboard drives, one camera frame per step (``Runner.step``):

* Up: accelerate (``ACCEL`` m/s^2); Down: brake (``BRAKE`` m/s^2); neither: hold the speed
  (no throttle, no brake: the ego's acceleration command 0);
* Left / Right: change lane (one lane per press, within the road);
* Esc or closing the window: stop.

The AEB (``--aeb on``) overrides the keyboard's acceleration as it does a script's. The session
is an ordinary run: a ``RunDirWriter`` writes the run directory (scored by ``lookahead
score``, replayed by ``lookahead replay``) and the annotated video goes to
``RUN_DIR/annotated.mp4``. Frames are paced to the camera rate (``realtime``) unless rendering
and perception are slower.

``DriveSession`` holds the runner and what the window shows; ``drive`` runs the window loop.
Key presses are read from pygame's event queue, so a test under Xvfb posts them there.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from lookahead.sim.birdseye import birdseye
from lookahead.sim.records import TickRecord
from lookahead.sim.road import MAIN_FROM, MAIN_TO
from lookahead.sim.runner import Runner, RunSummary
from lookahead.sim.scenario import Scenario
from lookahead.tools.sinks.rundir import RunDirWriter
from lookahead.tools.sinks.video import VideoSink

log = logging.getLogger(__name__)

ACCEL = 2.5  # m/s^2 while Up is held
BRAKE = 6.0  # m/s^2 while Down is held
STATUS_H = 28  # px, the status line under the pictures
VIDEO_FILE = "annotated.mp4"
HEADLESS_DRIVERS = ("offscreen", "dummy")  # SDL's drivers without a screen: refused unless asked for


class DriveError(RuntimeError):
    """The window cannot open (no display): one line for the CLI."""


def check_display() -> None:
    """``DriveError`` unless pygame can open a window here (an X display or another video driver)."""
    import os

    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    hint = "run it on a desktop, or under xvfb-run to test"
    if not any(os.environ.get(k) for k in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")):
        raise DriveError(f"drive: no display to open a window on (DISPLAY is not set); {hint}")
    try:
        pygame.display.init()
        driver = pygame.display.get_driver()
    except pygame.error as e:
        raise DriveError(f"drive: cannot open a window ({e}); {hint}") from None
    finally:
        pygame.display.quit()
    if driver in HEADLESS_DRIVERS and os.environ.get("SDL_VIDEODRIVER") != driver:
        raise DriveError(f"drive: no display to open a window on (SDL found only its {driver!r} driver); {hint}")


@dataclass
class Controls:
    """What the driver asks for in one frame."""

    accel: float = 0.0  # m/s^2 (negative: braking)
    lane_change: int = 0  # -1 left, +1 right, 0 none (one lane per press)
    quit: bool = False


class _LiveVideo(VideoSink):
    """The annotated video sink, keeping each frame it draws for the window."""

    last: np.ndarray | None = None

    def annotate(self, record: TickRecord) -> np.ndarray:
        self.last = super().annotate(record)
        return self.last


class DriveSession:
    """A run the keyboard drives (module docstring): the runner, its run directory and video,
    and the picture of the latest frame (``picture``)."""

    def __init__(self, scenario: Scenario, out: Path, render: bool = True, lang: str = "en",
                 renderer: str | None = None, source: str | None = None) -> None:
        self.scenario = scenario
        self.out = Path(out)
        self.video = _LiveVideo(self.out / VIDEO_FILE, fps=scenario.camera.rate, lang=lang)
        self.runner = Runner(scenario, render=render, renderer_backend=renderer, overlap=False)
        self.runner.sinks = [RunDirWriter(self.out, scenario, source=source), self.video]
        self.lane = scenario.ego.lane
        self.last: TickRecord | None = None
        self.runner.sinks.append(_Last(self))
        self.summary = self.runner.start()
        self.runner.observe()  # the first frame, before any key
        self.done = False

    def step(self, c: Controls) -> bool:
        """One camera frame with the driver's ``c``; False once the run is over."""
        if self.done:
            return False
        if c.lane_change:
            self.lane = int(np.clip(self.lane + c.lane_change, 0, self.scenario.road.lanes - 1))
            self.runner.world.ego.target_lane_index = (MAIN_FROM, MAIN_TO, self.lane)
        result = self.runner.step(accel=c.accel)
        self.done = result.done or c.quit
        return not self.done

    def picture(self) -> np.ndarray:
        """RGB: the annotated camera frame, the bird's-eye inset at its right, the status line."""
        rec = self.last
        assert rec is not None
        cam = self.video.last if self.video.last is not None else np.zeros(
            (self.runner.camera.height, self.runner.camera.width, 3), np.uint8)
        h = cam.shape[0]
        stack, est, a = self.runner.perception, rec.estimates, rec.assessments
        cfg = stack.intent_config
        inset = birdseye(est.range, est.lateral, est.half_width,
                         stack.estimator.prior_of(rec.tracks.class_id, "length"), a.risk,
                         cfg.ego_half_width + cfg.corridor_margin, size=(h, h * 4 // 9))
        pic = np.zeros((h + STATUS_H, cam.shape[1] + inset.shape[1], 3), np.uint8)
        pic[:h, :cam.shape[1]] = cam
        pic[:h, cam.shape[1]:] = inset
        ego = rec.ego
        brake = ego.get("aeb_brake")
        text = (f"t {rec.t:5.1f} s   {ego['speed'] * 3.6:5.1f} km/h   lane {self.lane}   "
                f"AEB {'off' if self.runner.aeb is None else ('BRAKING' if brake else 'on')}   "
                "Up/Down: speed  Left/Right: lane  Esc: stop")
        cv2.putText(pic, text, (8, h + 19), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (230, 230, 230), 1, cv2.LINE_AA)
        return pic

    def finish(self, error: BaseException | None = None) -> RunSummary:
        """End the run: every sink's ``on_end`` with the summary, the runner closed."""
        s = self.summary
        s.ended_on_collision = bool(self.runner.world.collisions) and self.scenario.end_on_collision
        if error is not None:
            s.error = f"{type(error).__name__}: {error}".rstrip(": ")
        return self.runner.finish(s)


class _Last:
    """A sink that hands each record to the session (what the window draws)."""

    def __init__(self, session: DriveSession) -> None:
        self.session = session

    def on_start(self, info: dict) -> None:
        pass

    def on_tick(self, record: TickRecord) -> None:
        self.session.last = record

    def on_end(self, summary: dict) -> None:
        pass


def read_keys(pygame, held: dict[int, bool]) -> Controls:
    """The driver's controls from pygame's event queue (presses since the last call; Up / Down
    act while held)."""
    c = Controls()
    for ev in pygame.event.get():
        if ev.type == pygame.QUIT:
            c.quit = True
        elif ev.type == pygame.KEYDOWN:
            held[ev.key] = True
            if ev.key == pygame.K_ESCAPE:
                c.quit = True
            elif ev.key == pygame.K_LEFT:
                c.lane_change -= 1
            elif ev.key == pygame.K_RIGHT:
                c.lane_change += 1
        elif ev.type == pygame.KEYUP:
            held[ev.key] = False
    c.lane_change = int(np.clip(c.lane_change, -1, 1))
    if held.get(pygame.K_UP):
        c.accel = ACCEL
    elif held.get(pygame.K_DOWN):
        c.accel = -BRAKE
    return c


def drive(session: DriveSession, realtime: bool = True, on_frame: Callable[[int], None] | None = None,
          screenshot: Path | None = None) -> RunSummary:
    """The window loop: draw the latest frame, read the keys, step; until the run ends or the
    driver stops. ``on_frame(k)`` is called before frame k's keys are read (tests post key
    events there); ``screenshot``: the window saved as PNG at the end."""
    import os

    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    pygame.display.init()
    error: BaseException | None = None
    try:
        first = session.picture()
        screen = pygame.display.set_mode((first.shape[1], first.shape[0]))
        pygame.display.set_caption(f"lookahead drive: {session.scenario.name}")
        held: dict[int, bool] = {}
        period = 1.0 / session.scenario.camera.rate
        k = 0
        while True:
            t0 = time.perf_counter()
            pic = session.picture()
            surface = pygame.surfarray.make_surface(np.ascontiguousarray(pic.transpose(1, 0, 2)))
            screen.blit(surface, (0, 0))
            pygame.display.flip()
            if on_frame is not None:
                on_frame(k)
            if not session.step(read_keys(pygame, held)):
                break
            k += 1
            if realtime:
                time.sleep(max(0.0, period - (time.perf_counter() - t0)))
        if screenshot is not None:
            screen.blit(pygame.surfarray.make_surface(np.ascontiguousarray(session.picture().transpose(1, 0, 2))),
                        (0, 0))
            pygame.image.save(screen, str(screenshot))
    except BaseException as e:
        error = e
        raise
    finally:
        pygame.display.quit()
        summary = session.finish(error)
    return summary
