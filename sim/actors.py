"""Scripted actors: vulnerable road users, obstacles and scripted vehicles.

They subclass highway-env's ``Vehicle`` so that they live in the same
``Road``: IDM traffic brakes for them and highway-env's collision checks see
them. Their motion is kinematic (unicycle), driven by the scenario script; all
script quantities are in the world frame (x along the road, y left, rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from highway_env.road.road import Road
from highway_env.vehicle.kinematics import Vehicle

from lookahead.intent.labels import Behaviour
from lookahead.perception.geometry import rotation_2d
from lookahead.sim.road import to_hw
from lookahead.sim.scenario import DEFAULT_ACCEL, ActionSpec, ActorSpec, StepSpec

DEFAULT_TURN_RATE = {"pedestrian": 3.0, "animal": 3.0, "car": 0.6, "truck": 0.4, "bus": 0.4}
LATERAL_SPEED_MAX = 1.2  # m/s during a scripted lane change or lateral move


def wrap(a: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


#: Gestures (``ActionSpec.gesture``): the arm's pitch overhead and its wave (rad, Hz), the
#: time to raise it (s); the time a fall takes to lie flat (s) and the stop it forces (m/s^2);
#: a loiter's default pacing speed (m/s).
WAVE_ARM, WAVE_SWING, WAVE_HZ, WAVE_RAISE_S = -2.7, 0.35, 1.5, 0.4
FALL_S, FALL_DECEL = 0.8, 6.0
LOITER_SPEED = 0.8
GESTURE_BEHAVIOUR = {"loiter": int(Behaviour.LOITERING), "wave": int(Behaviour.WAVING), "fall": int(Behaviour.FALLING)}


@dataclass
class Identity:
    """Who an agent is: integer id (ego = 0), scenario name, class, subtype, shape."""

    actor_id: int
    name: str
    cls: str
    subtype: str
    shape: object
    scripted: bool = True
    extra: dict = field(default_factory=dict)


class ScriptedActor(Vehicle):
    """A kinematic agent following a scenario script (world-frame commands)."""

    def __init__(
        self,
        road: Road,
        identity: Identity,
        spec: ActorSpec,
        position_world: np.ndarray,
        heading_world: float,
        to_world,
    ) -> None:
        length, width = identity.shape.footprint
        super().__init__(road, [position_world[0], -position_world[1]], -heading_world, spec.speed)
        self.LENGTH, self.WIDTH = float(length), float(width)
        self.diagonal = float(np.hypot(length, width))
        self.identity = identity
        self.steps: list[StepSpec] = list(spec.script)
        self.next_step = 0
        self.pending: tuple[float, ActionSpec] | None = None
        self.target_speed = float(spec.speed)
        self.accel_limit = DEFAULT_ACCEL[identity.cls]
        self.turn_rate = DEFAULT_TURN_RATE.get(identity.cls, 1.5)
        self.target_heading: float | None = None
        self.waypoints: list[np.ndarray] = []
        self.target_y: float | None = None
        self.to_world = to_world  # maps ego-relative-at-t0 xy -> world xy
        self.lane_y = None  # callable lane -> world y, set by the world
        self.gait_phase = 0.0
        self.started = False
        self.gesture = "none"  # wave | fall | loiter | none (``ActionSpec.gesture``)
        self.gesture_t = 0.0  # s since the gesture began
        self.arm = 0.0  # rad, the gesture arm's pitch (sim.shapes.Pose)
        self.body = 0.0  # rad, the whole body's pitch: pi / 2 lying on the road
        self.loiter: tuple[np.ndarray, np.ndarray, float] | None = None  # centre, axis (world), half length (m)

    # -------------------------------------------------------------- world-frame state
    @property
    def xy(self) -> np.ndarray:
        return np.array([self.position[0], -self.position[1]])

    @property
    def yaw(self) -> float:
        return -float(self.heading)

    def polygon(self) -> np.ndarray:
        """Collision footprint (highway-env frame, closed ring of 5 points): the rest box, or for a
        body pitched by a fall the posed body's ground box -- a fallen pedestrian lies on the road
        along its heading, its head up to a body length ahead of its feet."""
        if not self.body:
            return super().polygon()
        (cx, cy, _), (length, width, _) = self.identity.shape.local_box((self.gait_phase, self.arm, self.body))
        corners = np.array([[-1.0, -1.0], [-1.0, 1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]]) * [length / 2, width / 2]
        return to_hw(self.xy + (corners + [cx, cy]) @ rotation_2d(self.yaw).T)

    # -------------------------------------------------------------- script
    def apply(self, action: ActionSpec) -> None:
        """Start executing one script action."""
        self.started = True
        if action.accel is not None:
            self.accel_limit = action.accel
        if action.turn_rate is not None:
            self.turn_rate = np.radians(action.turn_rate)
        if action.speed is not None:
            self.target_speed = action.speed
        if action.stop:
            self.target_speed = 0.0
        if action.heading is not None:
            self.target_heading = np.radians(action.heading)
            self.waypoints, self.target_y = [], None
        if action.waypoints:
            self.waypoints = [np.asarray(self.to_world(np.array(p)), dtype=np.float64) for p in action.waypoints]
            self.target_heading, self.target_y = None, None
        if action.lane is not None:
            self.target_y = float(self.lane_y(action.lane))
            self.target_heading, self.waypoints = None, []
        if action.lateral is not None:
            self.target_y = float(self.to_world(np.array([0.0, action.lateral]))[1])
            self.target_heading, self.waypoints = None, []
        if action.gesture is not None:
            self._start_gesture(action)

    def _start_gesture(self, action: ActionSpec) -> None:
        self.gesture, self.gesture_t = action.gesture, 0.0
        self.loiter = None
        if action.gesture == "fall":
            self.target_speed = 0.0
            self.accel_limit = max(self.accel_limit, FALL_DECEL)
        elif action.gesture == "loiter":
            axis = np.array([np.cos(self.yaw), np.sin(self.yaw)])
            self.loiter = (self.xy.copy(), axis, float(action.loiter_m))
            if action.speed is None:
                self.target_speed = LOITER_SPEED
            self.target_heading, self.waypoints, self.target_y = None, [], None
        elif action.gesture == "none":
            self.arm = 0.0

    @property
    def gesture_code(self) -> int:
        """The gesture as ground truth's behaviour code (``intent.labels.Behaviour``), 0 none."""
        return GESTURE_BEHAVIOUR.get(self.gesture, 0)

    def _gesture_step(self, dt: float, yaw: float, xy: np.ndarray) -> float:
        """Advance the gesture by ``dt`` s: the arm's wave, the body's fall; a loiter turns round
        at the ends of its pacing. Returns the yaw to move along."""
        self.gesture_t += dt
        t = self.gesture_t
        if self.gesture == "wave":
            raised = min(1.0, t / WAVE_RAISE_S)
            self.arm = raised * (WAVE_ARM + WAVE_SWING * np.sin(2.0 * np.pi * WAVE_HZ * t))
        elif self.gesture == "fall":
            self.body = min(np.pi / 2, np.pi / 2 * (t / FALL_S) ** 2)  # a toppling body speeds up
            # the collision check's coarse test reaches the fallen body's far end
            reach = float(np.linalg.norm(self.polygon() - self.position, axis=1).max())
            self.diagonal = max(self.diagonal, 2.0 * reach)
        elif self.loiter is not None:
            centre, axis, half = self.loiter
            along = float(np.dot(xy - centre, axis))
            heading = np.array([np.cos(yaw), np.sin(yaw)])
            if abs(along) >= half and np.sign(along) == np.sign(np.dot(heading, axis)):
                yaw = wrap(yaw + np.pi)  # a pedestrian turns round on the spot
        return yaw

    def update_script(self, t: float, holds) -> None:
        """Fire the next script step when its trigger holds; ``holds(trigger, actor)`` decides."""
        while True:
            if self.pending is not None:
                due, action = self.pending
                if t + 1e-9 < due:
                    return
                self.pending = None
                self.apply(action)
                continue
            if self.next_step >= len(self.steps):
                return
            step = self.steps[self.next_step]
            if not holds(step.when, self):
                return
            self.next_step += 1
            self.pending = (t + step.delay, step.do)

    # -------------------------------------------------------------- dynamics
    def act(self, action: dict | str | None = None) -> None:
        """Scripted actors decide in ``step``; highway-env's act() is a no-op here."""

    def step(self, dt: float) -> None:
        speed = float(self.speed)
        if self.crashed:
            self.target_speed = 0.0
            self.accel_limit = max(self.accel_limit, 6.0)
        dv = np.clip(self.target_speed - speed, -self.accel_limit * dt, self.accel_limit * dt)
        speed = max(0.0, speed + dv)
        yaw, xy = self.yaw, self.xy
        desired = None
        if not self.crashed:
            if self.waypoints:
                d = self.waypoints[0] - xy
                if np.hypot(*d) < max(0.3, 1.5 * speed * dt):
                    self.waypoints.pop(0)
                    d = self.waypoints[0] - xy if self.waypoints else None
                if d is not None:
                    desired = float(np.arctan2(d[1], d[0]))
            elif self.target_y is not None:
                err = self.target_y - xy[1]
                if abs(err) < 0.05:
                    self.target_y, desired = None, 0.0
                else:
                    v_lat = np.sign(err) * np.clip(abs(err), 0.3, LATERAL_SPEED_MAX)
                    desired = float(np.arctan2(v_lat, max(speed, 0.5)))
            elif self.target_heading is not None:
                desired = self.target_heading
        if desired is not None and speed > 1e-3:
            yaw = yaw + float(np.clip(wrap(desired - yaw), -self.turn_rate * dt, self.turn_rate * dt))
        if self.gesture != "none":
            yaw = self._gesture_step(dt, yaw, xy)
        xy = xy + speed * dt * np.array([np.cos(yaw), np.sin(yaw)])
        if self.impact is not None and np.any(self.impact):
            xy = xy + np.array([self.impact[0], -self.impact[1]])
            self.crashed = True
            self.impact = None
        stride = getattr(self.identity.shape, "stride", 0.0)
        if stride > 0:
            self.gait_phase = (self.gait_phase + 2.0 * np.pi * speed * dt / stride) % (2.0 * np.pi)
        self.position = np.array([xy[0], -xy[1]])
        self.heading = -yaw
        self.speed = speed
