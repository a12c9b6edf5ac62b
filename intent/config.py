"""Every intent, behaviour and risk threshold, in one documented config.

Defaults follow the seed design (pedestrian 10 m / 5 m, 3 s / 1.5 s; animal
8 / 4, 2.5 / 1.0; non-motorised 15 / 8, 4 / 2 for HIGH / CRITICAL; MEDIUM at
2x and LOW at 4x the HIGH thresholds). Vehicles are not in the seed: 10 / 5 m,
4 / 2 s (Euro NCAP FCW warns between about 1.7 and 2.6 s TTC). Large animals
(deer, cattle, boar: ``large_animal_height`` and taller) are obstacles a car must
not hit at rural speeds, with a car's mass: the vehicle thresholds; dogs keep the
seed's animal ones. Static obstacles (cones, barriers, debris, boxes, riderless bicycles) are
not in the seed either: a car's thresholds, as for anything else in the lane that does not move.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class RiskThresholds(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    high_distance: float = Field(description="m")
    critical_distance: float = Field(description="m")
    high_ttc: float = Field(description="s")
    critical_ttc: float = Field(description="s")
    high_decel: float = Field(
        3.5, gt=0, description="HIGH when the ego needs this deceleration or more to avoid the object (m/s^2)")
    critical_decel: float = Field(
        5.0, gt=0, description="CRITICAL at this required deceleration or more (m/s^2): an AEB at 6 m/s^2 "
        "with 0.2 s latency still stops")


class BehaviourThresholds(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    still_speed: float = Field(0.3, description="below this ground speed: standing/stopped/stationary (m/s)")
    fast_speed: float = Field(2.5, description="pedestrian/animal running, non-motor/vehicle speeding above (m/s)")
    cross_speed: float = Field(0.5, description="lateral ground speed that counts as crossing/entering (m/s)")
    brake_decel: float = Field(3.0, description="sudden brake below -this (m/s^2)")
    turn_rate: float = Field(0.35, description="sudden turn above this |yaw rate| (rad/s)")
    wrong_way_speed: float = Field(1.0, description="moving against the ego's direction faster than this (m/s)")


class IntentConfig(BaseModel):
    """Thresholds shared by ground truth and predictions (units: m, s, m/s, rad)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    ego_half_width: float = Field(0.925, description="half the ego's width (m)")
    corridor_margin: float = Field(0.5, description="added to each side of the ego corridor (m)")
    horizon: float = Field(3.0, description="in-path prediction horizon (s)")
    arrival_slack: float = Field(0.5, description="in-path window ends at min(horizon, TTC + slack) (s)")
    critical_path_sigmas: float = Field(
        1.0, ge=0.0, description="CRITICAL needs the object in path even this many lateral stds further "
        "out (estimates only; 0: off)")
    critical_rate_sigmas: float = Field(
        0.5, ge=0.0, description="CRITICAL by TTC or required deceleration needs it even closing this many "
        "range-rate stds slower than estimated (estimates only; 0: off)")
    range_rate_deadband: float = Field(1.0, description="|range rate| below this is 'stable' (m/s)")
    init_frames: int = Field(5, description="tracks younger than this are 'initializing' (frames)")
    fast_confirm_frames: int = Field(
        2, ge=1, description="a younger or unsettled track this old can be CRITICAL at once when it is in "
        "the corridor now and under the CRITICAL TTC even closing more slowly than estimated (frames)")
    motion_significance: float = Field(
        1.0, ge=0.0, description="estimated ground velocity components below this many stds count as 0 "
        "for behaviours and the in-path prediction (0: off)")
    critical_motion_significance: float = Field(
        2.0, ge=0.0, description="the same for CRITICAL (braking needs more evidence than a warning); also the "
        "range-rate stds a young track's TTC must survive to be CRITICAL at once")
    risk: dict[str, RiskThresholds] = Field(
        default_factory=lambda: {
            "pedestrian": RiskThresholds(high_distance=10, critical_distance=5, high_ttc=3.0, critical_ttc=1.5),
            "animal": RiskThresholds(high_distance=8, critical_distance=4, high_ttc=2.5, critical_ttc=1.0),
            "non_motor": RiskThresholds(high_distance=15, critical_distance=8, high_ttc=4.0, critical_ttc=2.0),
            "vehicle": RiskThresholds(high_distance=10, critical_distance=5, high_ttc=4.0, critical_ttc=2.0),
            "large_animal": RiskThresholds(high_distance=10, critical_distance=5, high_ttc=4.0, critical_ttc=2.0),
            "obstacle": RiskThresholds(high_distance=10, critical_distance=5, high_ttc=4.0, critical_ttc=2.0),
        }
    )
    behaviour: dict[str, BehaviourThresholds] = Field(
        default_factory=lambda: {
            "pedestrian": BehaviourThresholds(still_speed=0.3, fast_speed=2.5, cross_speed=0.5),
            "animal": BehaviourThresholds(still_speed=0.2, fast_speed=3.0, cross_speed=0.3),
            "non_motor": BehaviourThresholds(still_speed=0.5, fast_speed=7.0, cross_speed=0.8, brake_decel=3.0),
            "vehicle": BehaviourThresholds(still_speed=0.5, fast_speed=33.3, cross_speed=1.0, brake_decel=4.0),
            "large_animal": BehaviourThresholds(still_speed=0.2, fast_speed=3.0, cross_speed=0.3),
            "obstacle": BehaviourThresholds(still_speed=0.5, fast_speed=33.3, cross_speed=1.0),
        }
    )
    large_animal_height: float = Field(
        0.9, gt=0.0, description="an animal this tall or taller is a large animal (deer, cattle, boar: m); "
        "smaller ones (dogs, 0.5-0.75 m) keep the animal thresholds")

    def with_overrides(self, overrides: dict) -> IntentConfig:
        """A copy with a (possibly nested) dict of overrides merged in and validated."""
        merged = deep_merge(self.model_dump(), overrides or {})
        return IntentConfig.model_validate(merged)


def deep_merge(base: dict, over: dict) -> dict:
    """``base`` updated by ``over``, nested mappings merged key by key (neither is changed)."""
    out = dict(base)
    for k, v in over.items():
        out[k] = deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out
