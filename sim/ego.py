"""The ego vehicle: lane keeping plus a longitudinal controller, and its odometry.

A highway-env ``IDMVehicle`` (lane changes off) so traffic reacts to it and
its collisions are checked by the same code as everyone else's. Longitudinal
control: ``cruise`` (hold the set speed, ignoring others), ``idm`` (IDM car
following) or ``profile`` (track a scripted speed profile). ``accel_command``
(m/s^2, an external controller's, e.g. a gym agent's) replaces the controller while
set; ``brake_command`` (m/s^2, >= 0) overrides both; the AEB sets it.
"""

from __future__ import annotations

import numpy as np
from highway_env.vehicle.behavior import IDMVehicle
from highway_env.vehicle.kinematics import Vehicle

from lookahead.sim.collision import Collision  # noqa: F401 (re-exported)
from lookahead.sim.scenario import EgoSpec

CRUISE_GAIN = 0.6  # 1/s, speed error -> acceleration
ACCEL_LIMITS = (-8.0, 3.0)  # m/s^2, controller output range (without AEB)


class EgoVehicle(IDMVehicle):
    """The ego. ``self.t`` is kept by the world for the profile controller."""

    def __init__(self, road, position, heading, spec: EgoSpec, lane_index) -> None:
        super().__init__(
            road,
            position,
            heading=heading,
            speed=spec.speed,
            target_lane_index=lane_index,
            target_speed=spec.target_speed if spec.target_speed is not None else spec.speed,
            enable_lane_change=False,
        )
        self.LENGTH, self.WIDTH = spec.length, spec.width
        self.diagonal = float(np.hypot(spec.length, spec.width))
        self.spec = spec
        self.t = 0.0
        self.accel_command: float | None = None  # m/s^2; replaces the controller while set
        self.brake_command: float | None = None  # m/s^2 (>= 0); overrides every other command
        self.hits: list = []  # partners of collisions since the last world step
        prof = np.asarray(spec.profile, dtype=np.float64).reshape(-1, 2)
        self._profile = prof[np.argsort(prof[:, 0])] if len(prof) else prof

    def profile_speed(self, t: float) -> float:
        p = self._profile
        return float(np.interp(t, p[:, 0], p[:, 1]))

    def longitudinal_accel(self) -> float:
        """The controller's acceleration command (m/s^2) before any AEB override."""
        c = self.spec.controller
        if c == "idm":
            front, rear = self.road.neighbour_vehicles(self, self.lane_index)
            a = self.acceleration(ego_vehicle=self, front_vehicle=front, rear_vehicle=rear)
        elif c == "profile":
            a = CRUISE_GAIN * 2.0 * (self.profile_speed(self.t) - self.speed)
            a += (self.profile_speed(self.t + 0.5) - self.profile_speed(self.t)) / 0.5
        else:
            a = CRUISE_GAIN * (self.target_speed - self.speed)
        return float(np.clip(a, *ACCEL_LIMITS))

    def act(self, action: dict | str | None = None) -> None:
        if self.crashed:
            return
        steering = float(np.clip(self.steering_control(self.target_lane_index),
                                 -self.MAX_STEERING_ANGLE, self.MAX_STEERING_ANGLE))
        if self.accel_command is None:
            accel = self.longitudinal_accel()
        else:  # an external command, limited as the controllers are
            accel = float(np.clip(self.accel_command, *ACCEL_LIMITS))
        if self.brake_command is not None:
            accel = -abs(self.brake_command)
        if self.speed <= 0.0 and accel < 0.0:
            accel = 0.0
        Vehicle.act(self, {"steering": steering, "acceleration": accel})

    def step(self, dt: float) -> None:
        super().step(dt)
        if self.speed < 0.0:  # braking never reverses
            self.speed = 0.0

    def handle_collisions(self, other, dt: float = 0) -> None:
        """highway-env's collision response, plus a record of every partner the
        ego touches or will touch within ``dt`` (speeds taken before the crash
        response slows anyone down)."""
        if other is not self and self.collidable and getattr(other, "collidable", True):
            intersecting, will_intersect, _ = self._is_colliding(other, dt)
            if (intersecting or will_intersect) and other not in self.hits:
                self.hits.append(other)
        super().handle_collisions(other, dt)
