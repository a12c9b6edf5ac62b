"""A gymnasium environment around the closed-loop ``Runner``.

One env step is one camera frame: ``Runner.step(accel)`` applies the agent's
longitudinal acceleration for ``runner.frame_every`` world ticks, then the camera
(if on), ground truth and the perception stack run and the observation is built from
the perception *tracks* (not ground truth, which is only in ``info``).

Action: ``Box(-8, 3, (1,), float32)``, the ego's longitudinal acceleration
(m/s^2); with ``discrete=True`` a ``Discrete(5)`` index into
``DISCRETE_ACCELS`` = [-8, -4, 0, 1.5, 3]. The action replaces the scenario's
ego controller (``EgoVehicle.accel_command``); ``EgoVehicle.act`` still applies
``brake_command`` (AEB) on top, never lets braking reverse the ego, and keeps lane-centring
steering. An agent that wants actions in [-1, 1] (as many RL libraries advise) wraps the env
with gymnasium's ``RescaleAction(env, np.float32(-1), np.float32(1))``: -1 brakes at -8, 1
accelerates at 3.

Observation (``Dict``):

- ``tracks``: ``(max_objects, 8)`` float32 rows ``[range, lateral, range_rate,
  lateral_rate, class_id, risk, label, valid]`` of the perception tracks,
  sorted by range (m, m, m/s, m/s; class / risk / label as numbers); padding
  rows are zero with ``valid`` 0, unknown (NaN) values are 0. Values are
  clipped to ``[-TRACK_BOUND, TRACK_BOUND]``.
- ``ego``: ``(3,)`` float32 ``[speed m/s, accel m/s^2, yaw_rate rad/s]``.
- ``image`` (``render_camera=True`` only): the camera frame, ``(H, W, 3)`` uint8.

``render()`` (``render_mode="rgb_array"``): the camera frame with the tracks boxed or,
without a camera, a top-down view of the tracks (``sim.birdseye``), RGB uint8.

Reward per step (``dt`` = the frame period, s)::

    r = speed * dt / 10                      # progress
      - 0.02 * |jerk|                        # comfort, jerk = d(accel)/dt of the ego, m/s^3
      - (1 - thw)   if thw < 1 s             # time headway to the nearest in-path track,
                                             # thw = range / speed (perception estimate)
      - 10          on a collision           # new ego collision in this step

``terminated`` on an ego collision (whatever the scenario's ``end_on_collision``: the
env's runner ends on one); ``truncated`` when the scenario's ``duration`` is reached.
``info``: ``t``, ``ground_truth`` (``GroundTruth.to_dict()``), ``assessment``
(``Assessment.to_dict()``), ``alerts`` (list of ``Alert.to_dict()``), ``collisions`` (list
of ``Collision.to_dict()``), ``aeb_braking`` (the AEB's own brake is on at the step's last
world tick; a scenario driver model's braking does not count) and ``reward_terms``.

Choices through ``gym.make(id, ...)``: ``scenario`` (YAML path or ``Scenario``),
``render_camera``, ``detector`` (``gt`` noise model; ``onnx``, the shipped model on the
camera image; ``scenario``, whatever the scenario says), ``weather`` (a kind such as
``"fog"`` or a ``WeatherSpec`` mapping), ``aeb`` (bool or ``AebConfig`` fields),
``max_objects``, ``discrete``, ``render_mode``.

``reset(seed=s)`` rebuilds the ``Runner`` with the scenario's seed replaced by ``s`` (same
seed + same actions -> identical observations; the first observation is ``Runner.observe()``
at t = 0); ``reset()`` with no seed reuses the last seed (initially the scenario's). The env's
``aeb`` choice replaces the scenario's ``ego.aeb`` in its runner's copy of the scenario.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from lookahead.intent.labels import risk_colour
from lookahead.sim.aeb import AebConfig
from lookahead.sim.birdseye import birdseye
from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.runner import Perceived, Runner
from lookahead.sim.scenario import Scenario, WeatherSpec, load_scenario, with_detector

DEFAULT_SCENARIO = SCENARIOS / "stationary_car.yaml"
ACCEL_LOW, ACCEL_HIGH = -8.0, 3.0
DISCRETE_ACCELS = (-8.0, -4.0, 0.0, 1.5, 3.0)
TRACK_FIELDS = ("range", "lateral", "range_rate", "lateral_rate", "class_id", "risk", "label", "valid")
TRACK_BOUND = 1.0e4
PROGRESS_SCALE = 10.0
JERK_WEIGHT = 0.02
HEADWAY_S = 1.0
COLLISION_PENALTY = 10.0


class LookaheadEnv(gymnasium.Env):
    """Closed-loop longitudinal control of the ego on a ``lookahead`` scenario (see module doc)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Path | Scenario = DEFAULT_SCENARIO,
        render_camera: bool = False,
        detector: str = "gt",
        weather: str | dict | None = None,
        aeb: bool | AebConfig | dict = False,
        max_objects: int = 16,
        discrete: bool = False,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode {render_mode!r} not in {self.metadata['render_modes']}")
        if detector not in ("gt", "onnx", "scenario"):
            raise ValueError("detector: 'gt' (noise model), 'onnx' (the shipped model on the camera "
                             "image; needs render_camera) or 'scenario' (the scenario's detector)")
        if detector == "onnx" and not render_camera:
            raise ValueError("detector 'onnx' runs on camera images: pass render_camera=True")
        sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        if detector != "scenario":
            sc = with_detector(sc, detector)
        if weather is not None:  # a kind ("fog") or a full weather mapping
            spec = WeatherSpec.model_validate({"kind": weather} if isinstance(weather, str) else weather)
            sc = sc.model_copy(update={"weather": spec})
        self.scenario = sc
        self.render_camera = bool(render_camera)
        # AEB on top of the agent: off, on (True: the scenario's ego.aeb settings, else the defaults)
        # or these settings
        self.aeb_config = (
            AebConfig.model_validate(aeb) if isinstance(aeb, AebConfig | dict)
            else (sc.ego.aeb_config or AebConfig()) if aeb else None
        )
        self.use_aeb = self.aeb_config is not None
        self.max_objects = int(max_objects)
        self.discrete = bool(discrete)
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": sc.camera.rate}

        self.action_space = (
            spaces.Discrete(len(DISCRETE_ACCELS)) if self.discrete
            else spaces.Box(ACCEL_LOW, ACCEL_HIGH, shape=(1,), dtype=np.float32)
        )
        obs = {
            "tracks": spaces.Box(-TRACK_BOUND, TRACK_BOUND, shape=(self.max_objects, len(TRACK_FIELDS)),
                                 dtype=np.float32),
            "ego": spaces.Box(-TRACK_BOUND, TRACK_BOUND, shape=(3,), dtype=np.float32),
        }
        if self.render_camera:
            obs["image"] = spaces.Box(0, 255, shape=(sc.camera.height, sc.camera.width, 3), dtype=np.uint8)
        self.observation_space = spaces.Dict(obs)

        self.runner: Runner | None = None
        self._seed = sc.seed
        self._accel_cmd = 0.0
        self._prev_accel = 0.0
        self._last: Perceived | None = None  # the latest observation's frame and tracks, for render()

    # ------------------------------------------------------------------ helpers
    def _build(self, seed: int) -> None:
        self._close_runner()
        # The env's AEB setting replaces the scenario's, and a collision ends the episode.
        ego = self.scenario.ego.model_copy(update={"aeb": self.aeb_config or False})
        sc = self.scenario.model_copy(update={"seed": int(seed), "ego": ego, "end_on_collision": True})
        self.runner = Runner(sc, render=self.render_camera, overlap=False)  # stepped frame by frame

    def _accel_of(self, action: Any) -> float:
        if self.discrete:
            return DISCRETE_ACCELS[int(np.asarray(action).reshape(()))]
        return float(np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[0], ACCEL_LOW, ACCEL_HIGH))

    def _track_rows(self, p: Perceived) -> np.ndarray:
        est, a, tracks = p.est, p.assessment, p.tracks
        out = np.zeros((self.max_objects, len(TRACK_FIELDS)), dtype=np.float32)
        n = len(tracks.track_id)
        if n == 0:
            return out
        rows = np.stack([est.range, est.lateral, est.range_rate, est.lateral_rate,
                         tracks.class_id.astype(np.float64), a.risk.astype(np.float64),
                         a.label.astype(np.float64), np.isfinite(est.range).astype(np.float64)], axis=1)
        key = np.where(np.isfinite(est.range), est.range, np.inf)
        order = np.argsort(key, kind="stable")[: self.max_objects]
        rows = np.clip(np.nan_to_num(rows[order], nan=0.0, posinf=0.0, neginf=0.0), -TRACK_BOUND, TRACK_BOUND)
        out[: len(order)] = rows
        return out

    def _obs(self, p: Perceived) -> dict:
        od = p.frame.odometry
        obs = {
            "tracks": self._track_rows(p),
            "ego": np.clip(np.nan_to_num(np.array([od.speed, od.accel, od.yaw_rate], dtype=np.float32)),
                           -TRACK_BOUND, TRACK_BOUND),
        }
        if self.render_camera:
            img = p.frame.image
            shape = self.observation_space["image"].shape
            obs["image"] = np.zeros(shape, np.uint8) if img is None else np.ascontiguousarray(img, np.uint8)
        return obs

    def _info(self, p: Perceived, collisions: list, terms: dict | None = None) -> dict:
        r = self.runner
        return {
            "t": float(r.world.t),
            "ground_truth": p.gt.to_dict(),
            "assessment": p.assessment.to_dict(),
            "alerts": [al.to_dict() for al in p.alerts],
            "collisions": [c.to_dict() for c in collisions],
            "aeb_braking": r.aeb_brake is not None,  # the AEB's own brake, not a driver model's
            "reward_terms": terms or {},
        }

    @staticmethod
    def nearest_in_path(p: Perceived) -> tuple[float, float]:
        """(range m, ttc s) of the nearest in-path perception track (inf, inf if none)."""
        est, a = p.est, p.assessment
        m = np.asarray(a.in_path, bool) & np.isfinite(est.range)
        if not m.any():
            return float("inf"), float("inf")
        i = np.flatnonzero(m)[np.argmin(est.range[m])]
        return float(est.range[i]), float(a.ttc[i])

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None:
            self._seed = int(seed)
        self._build(self._seed)
        self._accel_cmd = 0.0
        self._prev_accel = 0.0
        p = self._last = self.runner.observe()
        self._prev_accel = float(p.frame.odometry.accel)
        return self._obs(p), self._info(p, [])

    def step(self, action):
        if self.runner is None:
            raise RuntimeError("call reset() before step()")
        r, sc = self.runner, self.scenario
        self._accel_cmd = self._accel_of(action)
        result = r.step(self._accel_cmd)
        # A duration that is no whole number of frames ends between frames: observe the last tick.
        p = self._last = result.perceived if result.perceived is not None else r.observe(result.collisions)
        collisions = result.collisions
        od = p.frame.odometry
        dt = r.frame_every / sc.rate
        jerk = (od.accel - self._prev_accel) / dt
        self._prev_accel = float(od.accel)
        rng, _ = self.nearest_in_path(p)
        thw = rng / od.speed if od.speed > 0.1 else float("inf")
        terms = {
            "progress": od.speed * dt / PROGRESS_SCALE,
            "comfort": -JERK_WEIGHT * abs(jerk),
            "headway": -(HEADWAY_S - max(thw, 0.0)) if thw < HEADWAY_S else 0.0,
            "collision": -COLLISION_PENALTY if collisions else 0.0,
        }
        reward = float(sum(terms.values()))
        terminated = bool(collisions)
        truncated = not terminated and r.world.tick >= r.n_ticks
        return self._obs(p), reward, terminated, truncated, self._info(p, collisions, terms)

    def render(self):
        """With ``render_mode="rgb_array"``: the camera frame with the tracks boxed in their risk's
        colour or, without a camera, a top-down view of the tracks (``sim.birdseye``)."""
        if self.render_mode != "rgb_array" or self._last is None:
            return None
        p = self._last
        frame, tracks, a = p.frame, p.tracks, p.assessment
        if frame.image is None:
            stack = self.runner.perception
            cfg = stack.intent_config
            return birdseye(p.est.range, p.est.lateral, p.est.half_width,
                            stack.estimator.prior_of(tracks.class_id, "length"), a.risk,
                            cfg.ego_half_width + cfg.corridor_margin)
        import cv2

        img = np.ascontiguousarray(frame.image, dtype=np.uint8).copy()
        for i, box in enumerate(np.asarray(tracks.xyxy)):
            if not np.all(np.isfinite(box)):
                continue
            x0, y0, x1, y1 = (int(round(v)) for v in box)
            colour = risk_colour(int(a.risk[i]) if i < len(a.risk) else 0)
            cv2.rectangle(img, (x0, y0), (x1, y1), colour, 1)
        return img

    def _close_runner(self) -> None:
        if self.runner is not None:
            self.runner.close()
            self.runner = None

    def close(self) -> None:
        self._close_runner()
        self._last = None
