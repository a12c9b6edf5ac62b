"""Autonomous emergency braking in the loop.

Decides at camera frames from the perception stack's alerts; acts on the ego
at simulation ticks. A CRITICAL alert on an in-path object requests braking;
the brake comes on ``latency`` seconds later at ``decel``; it is released when
no CRITICAL in-path object has been seen for ``release_s`` — except at a
standstill, where it holds while any in-path object is closer than
``hold_range`` (the ego does not creep into what it stopped for).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class AebConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")
    latency: float = Field(0.2, ge=0.0, description="s from decision to braking")
    decel: float = Field(6.0, gt=0.0, le=12.0, description="braking deceleration (m/s^2)")
    release_s: float = Field(0.5, ge=0.0, description="s without a critical in-path object before release")
    hold_range: float = Field(15.0, ge=0.0, description="at standstill, hold while an in-path object is nearer (m)")
    standstill_speed: float = Field(0.1, ge=0.0, description="m/s")


class Aeb:
    """AEB state machine: ``decide`` at camera frames, ``command`` at every sim tick."""

    def __init__(self, config: AebConfig | None = None) -> None:
        self.config = config or AebConfig()
        self.engage_at: float | None = None  # s, when the brake comes on
        self.last_critical: float | None = None
        self.activations: list[float] = []  # decision times

    @property
    def requested(self) -> bool:
        return self.engage_at is not None

    def decide(self, t: float, critical_in_path: bool, nearest_in_path: float, ego_speed: float) -> None:
        """Update from one perception frame: is any CRITICAL alert on an in-path object,
        and how far is the nearest in-path object (m, inf if none)."""
        cfg = self.config
        if critical_in_path:
            self.last_critical = t
            if self.engage_at is None:
                self.engage_at = t + cfg.latency
                self.activations.append(t)
            return
        if self.engage_at is None:
            return
        holding = ego_speed <= cfg.standstill_speed and nearest_in_path < cfg.hold_range
        if not holding and (self.last_critical is None or t - self.last_critical >= cfg.release_s):
            self.engage_at = None

    def command(self, t: float) -> float | None:
        """Brake deceleration (m/s^2) to apply at time ``t``, or None."""
        if self.engage_at is not None and t + 1e-9 >= self.engage_at:
            return self.config.decel
        return None
