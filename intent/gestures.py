"""Pedestrian gestures from a track's history: falling, waving, loitering.

The design's behaviours that no single frame's kinematics show (``intent.labels`` decides the
others frame by frame). ``GestureRecognizer`` keeps, per pedestrian track, the last
``LOITER_WINDOW_S`` seconds of its box aspect (height / width, px) and estimated ground
velocity (ego axes, m/s), and overrides the track's behaviour, in this order:

* ``FALLING`` -- the box is lying: height / width < ``FALLEN_ASPECT`` (1.3; a standing or
  walking person's box is 2-7 times as tall as wide, whichever way they face; a falling one
  passes 1.3 about two thirds of the way down, and a person on the ground is wider than tall
  from any side but straight along the body).
* ``WAVING`` -- the box's shape beats while the person stays put (this frame's kinematics
  say standing, stopped or unknown, and): over the last
  ``WAVE_WINDOW_S`` (1.5 s) the median frame-to-frame change of the aspect is at least
  ``WAVE_BEAT`` (0.17) of its mean (a raised arm swinging overhead at 1.5 Hz takes it from
  ~2.5 to ~6 and back: 0.16-0.21 measured; a still person's box, with the detector's edge
  noise, or one turning or partly hidden, changes 0.05-0.10 a frame, a walker's gait up to
  0.14), and the mean ground velocity is under
  ``WAVE_STILL_SPEED`` (1.0 m/s: a walker's gait beats the box too, but a walker moves on;
  the waving box itself makes the estimated velocity wander by up to 0.8 m/s).
* ``LOITERING`` -- pacing to and fro: over the last ``LOITER_WINDOW_S`` (4 s) the velocity
  less its mean over the window, along its main direction, has gone each way faster than
  ``LOITER_SPEED`` (0.4 m/s) for at least ``LOITER_RUN_S`` (1 s) on end while the mean
  velocity stays under ``LOITER_STILL_SPEED`` (0.6 m/s). The mean is taken out because a
  bias common to the window -- a range scale error times the ego's speed -- shifts both legs
  alike: measured with the ground map, the pacer's legs read +1.5 and -0.5 m/s.

A gesture, once seen, is held ``HOLD_S`` (1 s) after its last sign (a wave's aspect dips
between beats, a pacer stops to turn). Tracks of other classes, and pedestrians with too
little history, keep their behaviour. The
rules were set on the gesture scenarios (``scenarios/ped_waving.yaml``, ``ped_falling.yaml``,
``ped_loitering.yaml``) and checked not to fire on the walking and standing pedestrians of
the others (``behaviour`` section of metrics.json).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from lookahead.intent.labels import Assessment, Behaviour
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.estimator import Estimates
from lookahead.perception.tracker import Tracks

FALLEN_ASPECT = 1.3
WAVE_WINDOW_S = 1.5
WAVE_BEAT = 0.17
WAVE_MIN_SAMPLES = 8
WAVE_STILL_SPEED = 1.0  # m/s
LOITER_WINDOW_S = 4.0
LOITER_SPEED = 0.4  # m/s
LOITER_STILL_SPEED = 0.6  # m/s
LOITER_MIN_SAMPLES = 25
LOITER_RUN_S = 1.0  # s each way the pacing must last (noise flips sign frame to frame)
HOLD_S = 1.0  # s a gesture is held after its last sign
_PEDESTRIAN = CLASS_ID["pedestrian"]
_STILL = {int(Behaviour.STANDING), int(Behaviour.STOPPED), int(Behaviour.STATIONARY), int(Behaviour.UNKNOWN)}


class GestureRecognizer:
    """Per pedestrian track, its recent box aspect and ground velocity (module docstring)."""

    def __init__(self) -> None:
        self._history: dict[int, deque[tuple[float, float, float, float]]] = {}  # id -> (t, aspect, vx, vy)
        self._held: dict[int, tuple[Behaviour, float]] = {}  # id -> last gesture seen, held until (s)

    def update(self, t: float, tracks: Tracks, est: Estimates, a: Assessment) -> None:
        """Record frame ``t`` (s) of ``tracks`` and override the behaviour of the first
        ``len(tracks)`` rows of ``a`` (rows aligned with ``tracks``) where a gesture shows."""
        seen = set()
        for i, (tid, cls, box) in enumerate(zip(tracks.track_id.tolist(), tracks.class_id.tolist(),
                                                tracks.xyxy, strict=True)):
            if cls != _PEDESTRIAN:
                continue
            seen.add(tid)
            w, h = float(box[2] - box[0]), float(box[3] - box[1])
            if not (w > 0 and h > 0):
                continue
            vx, vy = float(est.ground_vx[i]), float(est.ground_vy[i])
            hist = self._history.setdefault(tid, deque())
            hist.append((t, h / w, vx if np.isfinite(vx) else 0.0, vy if np.isfinite(vy) else 0.0))
            while hist and hist[0][0] < t - LOITER_WINDOW_S:
                hist.popleft()
            gesture = self._gesture(hist, t, still=int(a.behaviour[i]) in _STILL)
            if gesture is not None:
                self._held[tid] = (gesture, t + HOLD_S)
            elif tid in self._held and self._held[tid][1] >= t:
                gesture = self._held[tid][0]  # a wave's box beats, a pacer stops to turn: hold it a while
            if gesture is not None:
                a.behaviour[i] = int(gesture)
        for tid in list(self._history):  # tracks gone: forget them
            if tid not in seen:
                del self._history[tid]
                self._held.pop(tid, None)

    @staticmethod
    def _gesture(hist: deque, t: float, still: bool) -> Behaviour | None:
        """The gesture ``hist`` shows at ``t``; ``still``: this frame's kinematics found the
        person standing (only a still person is seen to wave)."""
        h = np.array(hist)
        if h[-1, 1] < FALLEN_ASPECT:
            return Behaviour.FALLING
        recent = h[h[:, 0] >= t - WAVE_WINDOW_S]
        if still and len(recent) >= WAVE_MIN_SAMPLES:
            aspect = recent[:, 1]
            still = np.hypot(*recent[:, 2:4].mean(axis=0)) < WAVE_STILL_SPEED
            if still and np.median(np.abs(np.diff(aspect))) / aspect.mean() >= WAVE_BEAT:
                return Behaviour.WAVING
        if len(h) >= LOITER_MIN_SAMPLES and h[-1, 0] - h[0, 0] >= LOITER_WINDOW_S - 0.5:
            v = h[:, 2:4]
            mean = v.mean(axis=0)
            if np.hypot(*mean) < LOITER_STILL_SPEED:
                # to and fro about the mean: a bias common to the window (a range scale error
                # times the ego's speed) shifts both legs alike and is no pacing
                _, _, vt = np.linalg.svd(v - mean, full_matrices=False)
                along = (v - mean) @ vt[0]  # the velocity along its main direction
                period = (h[-1, 0] - h[0, 0]) / max(len(h) - 1, 1)
                need = max(int(round(LOITER_RUN_S / period)), 1)
                if _longest_run(along > LOITER_SPEED) >= need and _longest_run(along < -LOITER_SPEED) >= need:
                    return Behaviour.LOITERING
        return None


def _longest_run(flags: np.ndarray) -> int:
    """The longest run of consecutive True in ``flags``."""
    best = run = 0
    for f in flags.tolist():
        run = run + 1 if f else 0
        best = max(best, run)
    return best
