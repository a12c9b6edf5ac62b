"""Autonomous emergency braking in the loop: brake to a standstill and hold.

Decides at camera frames from the perception stack's alerts; acts on the ego
at simulation ticks. A small state machine (``Aeb.state``):

* ``idle`` → ``braking``: a CRITICAL alert on an in-path object. The brake
  comes on ``latency`` s after that decision, at ``decel`` m/s², and overrides
  every other longitudinal command (``EgoVehicle.brake_command``).
* ``braking`` → ``holding``: the ego stands still (speed ≤ ``standstill_speed``)
  while the path is still blocked (below). The brake command stays on; the ego
  cannot roll, so the cruise controller cannot creep into what it stopped for.
* ``braking`` / ``holding`` → ``idle``: the path has been clear for ``release_s``
  without a break. Only then does the brake come off.

The path is *blocked* at a frame when a CRITICAL alert is on an in-path object,
or the nearest in-path object is closer than the clear range
``max(hold_range, clear_time * ego_speed)``. Falling TTC alone (the ego slowing
down) therefore never releases the brake: the ego brakes to a standstill unless
the object leaves the path or gets far ahead, and at a standstill the range to
a stationary object never grows, so the hold lasts until it drives away (or off
the path). Defaults: ``clear_time`` 4 s is the largest default ``high_ttc`` (an
FCW for a vehicle or a cyclist), so the brake comes off only where even a
stationary object would not raise a warning at the current speed; ``hold_range``
15 m is the largest default ``high_distance`` (non-motorised) and takes the
cruise controller, at its 3 m/s² limit from rest, over 3 s to cover.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

AebState = Literal["idle", "braking", "holding"]


class AebConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    latency: float = Field(0.2, ge=0.0, le=2.0, description="s from decision to braking")
    decel: float = Field(6.0, gt=0.0, le=12.0, description="braking deceleration (m/s^2)")
    release_s: float = Field(
        0.5, ge=0.0, le=10.0, description="s the path must stay clear (no critical in-path object, "
        "nothing in path within the clear range) before the brake is released")
    hold_range: float = Field(
        15.0, ge=0.0, le=200.0, description="m; the clear range at a standstill (and its minimum "
        "when moving): an in-path object nearer keeps the brake on / the ego held")
    clear_time: float = Field(
        4.0, ge=0.0, le=20.0, description="s; when moving, the clear range is at least "
        "clear_time * ego speed")
    standstill_speed: float = Field(0.1, ge=0.0, le=2.0, description="m/s counted as standing still")


class Aeb:
    """AEB state machine: ``decide`` at camera frames, ``command`` at every sim tick."""

    def __init__(self, config: AebConfig | None = None) -> None:
        self.config = config or AebConfig()
        self.state: AebState = "idle"
        self.engage_at: float | None = None  # s, when the brake comes on (None while idle)
        self.last_blocked: float | None = None  # s, the last frame the path was blocked
        self.activations: list[float] = []  # decision times (idle -> braking)
        self.transitions: list[tuple[float, AebState]] = []  # (frame time s, new state)

    @property
    def requested(self) -> bool:
        return self.state != "idle"

    def clear_range(self, ego_speed: float) -> float:
        """Range (m) beyond which an in-path object no longer keeps the brake on."""
        return max(self.config.hold_range, self.config.clear_time * max(ego_speed, 0.0))

    def _to(self, t: float, state: AebState) -> None:
        self.state = state
        self.transitions.append((t, state))

    def decide(self, t: float, critical_in_path: bool, nearest_in_path: float, ego_speed: float) -> None:
        """Update from one perception frame at time ``t`` (s): is any CRITICAL alert on an
        in-path object, how far is the nearest in-path object (m, inf if none), and the
        ego's speed (m/s)."""
        cfg = self.config
        if self.state == "idle":
            if critical_in_path:
                self.engage_at = t + cfg.latency
                self.last_blocked = t
                self.activations.append(t)
                self._to(t, "braking")
            return
        if critical_in_path or nearest_in_path < self.clear_range(ego_speed):
            self.last_blocked = t
            if self.state == "braking" and ego_speed <= cfg.standstill_speed:
                self._to(t, "holding")
        elif self.last_blocked is None or t - self.last_blocked + 1e-9 >= cfg.release_s:
            self.engage_at = self.last_blocked = None
            self._to(t, "idle")

    def command(self, t: float) -> float | None:
        """Brake deceleration (m/s^2) to apply at time ``t``, or None."""
        if self.engage_at is not None and t + 1e-9 >= self.engage_at:
            return self.config.decel
        return None
