"""A driver who brakes for a forward-collision warning, so a warning is judged by its outcome.

Decides at camera frames, acts on the ego at simulation ticks (as ``sim.aeb``).
At the first camera frame with a forward-collision warning on an in-path object
(an active alert of level HIGH or above, i.e. ``fcw`` or ``critical``, on a track
the intent stack counts as in the ego's path: ``intent.stack.alert_in_path`` at HIGH,
the AEB's rule at CRITICAL), the driver starts braking ``reaction_s`` later (sim-tick
resolution) at ``decel`` m/s², and keeps braking to a standstill and holds it
for the rest of the run: a driver who braked for a warning does not drive on
into the obstacle in these tests. Later warnings change nothing. Euro NCAP's FCW
assessment uses a 1.2 s reaction time and 4 m/s².

The driver's brake and the AEB's act together through ``EgoVehicle.brake_command``:
the stronger deceleration wins (``combine_brakes``).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class DriverConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    reaction_s: float = Field(
        1.2, ge=0.0, le=10.0, description="s from the first in-path forward-collision warning to braking")
    decel: float = Field(4.0, gt=0.0, le=12.0, description="the driver's braking deceleration (m/s^2)")


def combine_brakes(*commands: float | None) -> float | None:
    """The strongest of the brake commands (m/s^2) that are on, or None if none is."""
    on = [c for c in commands if c is not None]
    return max(on) if on else None


class Driver:
    """The driver: ``decide`` at camera frames, ``command`` at every sim tick."""

    def __init__(self, config: DriverConfig | None = None) -> None:
        self.config = config or DriverConfig()
        self.warned_at: float | None = None  # s, the frame of the first in-path FCW
        self.brake_at: float | None = None  # s, when the driver's brake comes on

    @property
    def braking(self) -> bool:
        return self.brake_at is not None

    def decide(self, t: float, fcw: bool) -> None:
        """Update from one perception frame at time ``t`` (s): is an in-path FCW on."""
        if fcw and self.warned_at is None:
            self.warned_at = t
            self.brake_at = t + self.config.reaction_s

    def command(self, t: float) -> float | None:
        """The driver's brake deceleration (m/s^2) at time ``t``, or None."""
        if self.brake_at is not None and t + 1e-9 >= self.brake_at:
            return self.config.decel
        return None
