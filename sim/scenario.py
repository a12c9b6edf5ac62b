"""The scenario file: a pydantic model, its loader and its JSON Schema.

Units in YAML: metres, seconds, m/s, and **degrees** for angles (converted to
radians by the world). Positions given as ``{x, y}`` are ego-relative at t = 0
(x forward, y left); ``{lane, s}`` is a lane index (0 = leftmost) and a
longitudinal distance ahead of the ego at t = 0. See docs/scenarios.md.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)
from pydantic_core import PydanticCustomError

from lookahead.intent.alerts import AlertConfig
from lookahead.intent.config import IntentConfig
from lookahead.intent.labels import Risk
from lookahead.perception import yaml_model
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import (  # noqa: F401  (DetectorSpec, PerceptionSpec, *Overrides: re-exported)
    DetectorSpec,
    EstimatorOverrides,
    Overrides,
    PerceptionSpec,
    SettingsError,
    StackSpec,
    TrackerOverrides,
)
from lookahead.perception.detections import CLASSES
from lookahead.perception.safe_yaml import YamlError, read_yaml_text
from lookahead.perception.yaml_model import field_path, format_validation  # noqa: F401  (re-exported)
from lookahead.sim.aeb import AebConfig
from lookahead.sim.driver import DriverConfig
from lookahead.sim.link import LinkConfig
from lookahead.sim.shapes import SUBTYPES

ACTOR_TYPES: tuple[str, ...] = CLASSES

# Physical bounds of a scenario's numbers (no NaN or infinity anywhere: ``Strict`` refuses them).
MAX_ROAD_M = 20_000.0  # the longest road (m); longitudinal positions stay within it
MAX_LATERAL_M = 100.0  # lateral positions (m) from the ego's lane: the widest road with sidewalks and more
MAX_SPEED = 60.0  # m/s (216 km/h)
MAX_TIME_S = 3600.0  # s
MAX_HEADING_DEG = 720.0
MAX_SEED = 2**32 - 1  # numpy's legacy seeds and highway-env's take 32 bits
MAX_IMAGE_PX = 4096  # the largest camera image side (px)
#: Comfortable |acceleration| (m/s^2) per class when a script gives none (``sim.actors``).
DEFAULT_ACCEL = {
    "pedestrian": 2.0,
    "animal": 4.0,
    "cyclist": 2.0,
    "motorcyclist": 3.0,
    "tricycle": 1.5,
    "car": 3.0,
    "truck": 2.0,
    "bus": 2.0,
    "obstacle": 1.0,
}

Seconds = Annotated[float, Field(ge=0.0, le=MAX_TIME_S)]
Speed = Annotated[float, Field(ge=0.0, le=MAX_SPEED)]
Longitudinal = Annotated[float, Field(ge=-MAX_ROAD_M, le=MAX_ROAD_M)]
Lateral = Annotated[float, Field(ge=-MAX_LATERAL_M, le=MAX_LATERAL_M)]
Heading = Annotated[float, Field(ge=-MAX_HEADING_DEG, le=MAX_HEADING_DEG)]
Lane = Annotated[int, Field(ge=0, le=5)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


# --- overrides of the intent config ------------------------------------------------------------
# ``intent`` stays a plain mapping (what the runner, sweeps and run.json see) checked on load by
# building the real config, as ``perception.tracker`` / ``perception.estimator`` are
# (``perception.config``): a typo is a located one-line error instead of a crash at run time.


def _error_at(loc: tuple, msg: str, value: Any) -> ValidationError:
    """A one-error ``ValidationError`` at ``loc`` (for checks that span fields)."""
    return ValidationError.from_exception_data(
        "Scenario", [{"type": PydanticCustomError("value_error", msg), "loc": loc, "input": value}]
    )


def _check_intent(v: dict) -> dict:
    IntentConfig().with_overrides(v)
    return v


IntentOverrides = Annotated[dict[str, Any], Overrides(_check_intent, IntentConfig, partial=True)]


class RoadSpec(Strict):
    kind: Literal["straight", "intersection"] = "straight"
    lanes: int = Field(3, ge=1, le=6, description="lanes in the ego's direction")
    lane_width: float = Field(3.5, ge=2.5, le=5.0, description="m")
    sidewalks: bool = True
    sidewalk_width: float = Field(3.0, ge=0.5, le=10.0, description="m")
    length: float = Field(2000.0, ge=100.0, le=20000.0, description="m")
    speed_limit: float = Field(30.0, gt=0, le=60.0, description="m/s")


class TrafficSpec(Strict):
    count: int = Field(0, ge=0, le=60, description="IDM/MOBIL vehicles placed ahead of the ego")
    density: float = Field(
        1.0, ge=0.0, le=5.0, description="highway-env vehicles_density; 0 = no traffic"
    )
    speed: tuple[Speed, Speed] | None = Field(
        None, description="initial speed range [low, high] (m/s); default 70-80 % of the speed limit"
    )
    lane_change: bool = True

    @field_validator("speed")
    @classmethod
    def _ordered(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and v[0] > v[1]:
            raise ValueError(f"expected [low, high] with low <= high, got {list(v)}")
        return v


class EgoSpec(Strict):
    lane: Lane = 1
    s: float = Field(50.0, ge=0.0, le=MAX_ROAD_M, description="start position along the road (m)")
    speed: float = Field(11.1, ge=0.0, le=60.0, description="initial speed (m/s)")
    target_speed: float | None = Field(None, ge=0.0, le=60.0, description="cruise set speed (m/s)")
    controller: Literal["cruise", "idm", "profile"] = "cruise"
    profile: list[tuple[Seconds, Speed]] = Field(
        default_factory=list, description="[[t s, speed m/s], ...] for controller: profile"
    )
    aeb: bool | AebConfig = Field(
        False,
        description="autonomous emergency braking (sim.aeb): false = off, true = on with the defaults, or a"
        " mapping of its settings (on), e.g. {latency: 0.3, decel: 8}",
    )
    driver: DriverConfig | None = Field(
        None,
        description="a driver who brakes for the first in-path forward-collision warning (sim.driver): absent"
        " = none (no driver reaction), or {reaction_s: s, decel: m/s^2}, e.g. {reaction_s: 1.2, decel: 4.0}",
    )
    length: float = Field(4.6, gt=1.0, le=20.0)
    width: float = Field(1.85, gt=0.5, le=3.0)

    @field_validator("aeb", mode="wrap")
    @classmethod
    def _aeb(cls, v: Any, handler: Any) -> Any:
        if isinstance(v, bool | AebConfig):
            return v
        if isinstance(v, dict):
            return AebConfig.model_validate(v)  # its errors keep their key (ego.aeb.latency)
        raise ValueError(f"expected true, false or a mapping of AEB settings ({', '.join(AebConfig.model_fields)})")

    @model_validator(mode="after")
    def _profile_needed(self) -> EgoSpec:
        if self.controller == "profile" and len(self.profile) < 1:
            raise ValueError("controller 'profile' needs a non-empty 'profile' of [t, speed] pairs")
        return self

    @property
    def aeb_config(self) -> AebConfig | None:
        """The AEB's settings, or None when it is off."""
        if isinstance(self.aeb, AebConfig):
            return self.aeb
        return AebConfig() if self.aeb else None


class MountSpec(Strict):
    x: float = Field(-1.5, ge=-10.0, le=2.0, description="m, ego frame (front bumper = 0)")
    y: float = Field(0.0, ge=-2.0, le=2.0)
    z: float = Field(1.4, gt=0.2, le=5.0)
    pitch: float = Field(-2.0, ge=-45.0, le=45.0, description="deg, > 0 looks up")
    yaw: float = Field(0.0, ge=-45.0, le=45.0, description="deg, > 0 looks left")
    roll: float = Field(0.0, ge=-30.0, le=30.0, description="deg")


def mounted_camera(width: int, height: int, fov_h: float, mount: MountSpec) -> CameraModel:
    """A pinhole camera of ``fov_h`` deg horizontal field of view at ``width`` x ``height`` px on
    ``mount`` (a scenario's camera, or ``lookahead watch``'s default one)."""
    return CameraModel.from_fov(width, height, fov_h, mount=(mount.x, mount.y, mount.z), yaw_deg=mount.yaw,
                                pitch_deg=mount.pitch, roll_deg=mount.roll)


class CameraSpec(Strict):
    width: int = Field(640, ge=64, le=MAX_IMAGE_PX)
    height: int = Field(360, ge=48, le=MAX_IMAGE_PX)
    fov_h: float = Field(90.0, gt=10.0, lt=170.0, description="horizontal field of view (deg)")
    rate: float = Field(10.0, ge=1.0, le=120.0, description="frames per second")
    mount: MountSpec = Field(default_factory=MountSpec)
    renderer: Literal["auto", "egl", "tiny"] = "auto"


FOG_PRESETS: dict[str, float] = {
    "mist": 2000.0, "light": 1000.0, "moderate": 500.0, "thick": 200.0, "dense": 50.0,
}  # meteorological optical range (m) of the named visibility presets


class WeatherSpec(Strict):
    """Weather and light of the camera image (``sim.weather``); only the RGB changes, never
    ground truth. ``None`` = the kind's default. Fields that do not apply to ``kind`` are
    ignored (``clear`` ignores all), so a sweep may vary ``kind`` alone."""

    kind: Literal["clear", "night", "fog", "rain"] = "clear"
    visibility: (
        Annotated[float, Field(ge=10.0, le=100_000.0)]
        | Literal["mist", "light", "moderate", "thick", "dense"]
        | None
    ) = Field(
        None,
        description="meteorological optical range (m, contrast falls to 5 %) or a preset: mist 2000,"
        " light 1000, moderate 500, thick 200, dense 50. fog: default thick; rain: default from"
        " intensity; night: clear air unless given",
    )
    intensity: float | None = Field(
        None, ge=0.0, le=1.0,
        description="rain: 0 drizzle .. 1 downpour (default 0.5); night: darkness, 0 dusk .. 1"
        " moonless (default 0.7)",
    )
    variation: float = Field(
        0.3, ge=0.0, le=1.0, description="fog/haze density variation (std of log density); 0 = uniform"
    )
    variation_scale: float = Field(
        40.0, ge=5.0, le=500.0, description="correlation length of the density variation (m, world-fixed)"
    )
    headlights: Literal["off", "low", "high"] = Field("low", description="night: the ego's headlamps")
    street_lights: bool = Field(True, description="night: light the roadside lamp posts")
    sensor_noise: float = Field(
        1.0, ge=0.0, le=4.0, description="night: scale of the shot + read noise; 0 = none"
    )
    wind: float = Field(10.0, ge=-60.0, le=60.0, description="rain: streak slant (deg); > 0: drops drift right as they fall")

    @field_validator("visibility", mode="wrap")
    @classmethod
    def _visibility(cls, v: Any, handler: Any) -> Any:
        try:
            return handler(v)
        except ValidationError:
            raise ValueError(
                f"expected metres in [10, 100000] or a preset {list(FOG_PRESETS)}"
            ) from None

    @property
    def visibility_m(self) -> float | None:
        """Meteorological optical range (m) with presets and kind defaults resolved; None = clear air."""
        v = self.visibility
        if self.kind == "clear":
            return None
        if isinstance(v, str):
            return FOG_PRESETS[v]
        if v is not None:
            return float(v)
        if self.kind == "fog":
            return FOG_PRESETS["thick"]
        if self.kind == "rain":  # 0 -> 3 km, 0.5 -> 460 m, 1 -> 250 m (downpour)
            return 3000.0 / (1.0 + 11.0 * self.rain_intensity)
        return None

    @property
    def rain_intensity(self) -> float:
        return 0.5 if self.intensity is None else float(self.intensity)

    @property
    def night_darkness(self) -> float:
        return 0.7 if self.intensity is None else float(self.intensity)


class StartSpec(Strict):
    x: Longitudinal | None = Field(None, description="ego-relative longitudinal (m) at t=0")
    y: Lateral | None = Field(None, description="ego-relative lateral (m, left +) at t=0")
    lane: Lane | None = None
    s: Longitudinal | None = Field(None, description="ahead of the ego along the road (m) at t=0")
    offset: float = Field(0.0, ge=-10.0, le=10.0, description="lateral offset within the lane (m, left +)")
    ref: Literal["centre", "rear", "front", "nearest"] = Field(
        "centre",
        description="which point of the actor's footprint the position is: centre (default), rear / front"
        " (bumper centre, along its heading), nearest (x = its ground-truth range at t=0, y = its centre's)",
    )
    impact: float | None = Field(
        None,
        ge=0.0,
        le=100.0,
        description="instead of y: impact point on the ego's front in % of the ego's width (0 = its left"
        " side, 50 = its centreline, 100 = its right side); the actor's centre starts at"
        " y = (0.5 - impact/100) * ego width (actors moving along the road only)",
    )

    @model_validator(mode="after")
    def _one_form(self) -> StartSpec:
        if self.impact is not None:
            if self.y is not None or self.lane is not None or self.s is not None or "offset" in self.model_fields_set:
                raise ValueError(
                    "impact sets the lateral position: give it as {x, impact}, without y, lane, s or offset"
                )
            if self.x is None:
                raise ValueError("impact needs x: give {x, impact}")
            return self
        xy = self.x is not None and self.y is not None
        ls = self.lane is not None and self.s is not None
        if xy == ls:
            raise ValueError("give either {x, y} (ego-relative) or {lane, s}")
        return self


class ActorCondition(Strict):
    id: str
    speed_gt: Speed | None = None
    speed_lt: Speed | None = None
    range_lt: float | None = Field(None, gt=0.0, le=MAX_ROAD_M, description="that actor's range from the ego < m")
    moving: bool | None = None


class TriggerSpec(Strict):
    """All given conditions must hold (AND)."""

    t: Seconds | None = Field(None, description="scenario time >= s")
    ego_range_lt: float | None = Field(None, gt=0.0, le=MAX_ROAD_M, description="range from the ego's front < m")
    ttc_lt: float | None = Field(None, gt=0.0, le=100.0, description="time to collision with the ego < s")
    actor: ActorCondition | None = None


class ActionSpec(Strict):
    speed: float | None = Field(None, ge=0.0, le=60.0, description="target speed (m/s)")
    accel: float | None = Field(None, gt=0.0, le=15.0, description="|accel| to reach it (m/s^2)")
    heading: Heading | None = Field(None, description="target heading (deg, world; 0 = along the road)")
    turn_rate: float | None = Field(None, gt=0.0, le=720.0, description="deg/s")
    waypoints: list[tuple[Longitudinal, Lateral]] | None = Field(
        None, description="[[x, y], ...] ego-relative at t=0 (m), followed in order"
    )
    lane: Lane | None = Field(None, description="change to this lane")
    lateral: Lateral | None = Field(None, description="move to this ego-relative-at-t0 y (m)")
    stop: bool | None = None
    gesture: Literal["wave", "fall", "loiter", "none"] | None = Field(
        None, description="pedestrians: wave an arm overhead, fall onto the road (stopping), loiter (pace to and "
        "fro along the heading within loiter_m of here at speed, default 0.8 m/s), or none (stop gesturing)")
    loiter_m: float = Field(1.5, gt=0.0, le=20.0, description="m each way of a loiter's pacing")


class StepSpec(Strict):
    when: TriggerSpec = Field(default_factory=TriggerSpec)
    delay: Seconds = Field(0.0, description="s after the trigger")
    do: ActionSpec


class ActorSpec(Strict):
    id: str = Field(min_length=1)
    type: Literal[ACTOR_TYPES]  # type: ignore[valid-type]
    subtype: str | None = None
    start: StartSpec
    heading: Heading = Field(0.0, description="deg, world; 0 = along the road, 90 = to the left")
    speed: float = Field(0.0, ge=0.0, le=60.0, description="initial speed (m/s)")
    script: list[StepSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _impact_along_the_road(self) -> ActorSpec:
        if self.start.impact is not None and abs(math.sin(math.radians(self.heading))) > 1e-9:
            raise ValueError(
                f"start.impact needs a heading along the road (0 or 180), not {self.heading:g}: a crossing"
                " actor's impact point depends on its timing; place it with {x, y} and time it with a trigger"
            )
        return self

    @model_validator(mode="after")
    def _subtype(self) -> ActorSpec:
        allowed = SUBTYPES[self.type]
        if self.subtype is None:
            self.subtype = allowed[0]
        elif self.subtype not in allowed:
            raise ValueError(f"subtype {self.subtype!r} is not one of {list(allowed)} for {self.type}")
        return self


def repeated(values: list[str]) -> list[str]:
    """The values that occur more than once, sorted."""
    return sorted({v for v in values if values.count(v) > 1})


class SenderCameraSpec(Strict):
    """A sender's camera: like the ego's (``CameraSpec``) without a rate (it captures with the ego's frames)."""

    width: int = Field(640, ge=64, le=MAX_IMAGE_PX)
    height: int = Field(360, ge=48, le=MAX_IMAGE_PX)
    fov_h: float = Field(90.0, gt=10.0, lt=170.0, description="horizontal field of view (deg)")
    mount: MountSpec = Field(default_factory=MountSpec, description="on the carrier's frame (front bumper, or"
                             " the roadside unit's foot)")


class RoadsidePose(Strict):
    x: Longitudinal = Field(description="ego-relative longitudinal (m) at t=0")
    y: Lateral = Field(description="ego-relative lateral (m, left +) at t=0")
    heading: Heading = Field(0.0, description="deg, world; where the camera looks")


class SenderSpec(Strict):
    """A camera elsewhere in the world that shares what it sees (``sim.cooperation``): on a
    scenario actor (``actor``) or a roadside unit standing at ``at``."""

    name: str = Field(min_length=1)
    actor: str | None = Field(None, description="the id of the actor carrying the camera")
    at: RoadsidePose | None = Field(None, description="a roadside unit's place and heading")
    camera: SenderCameraSpec = Field(default_factory=SenderCameraSpec)
    perception: PerceptionSpec = Field(
        default_factory=lambda: PerceptionSpec(detector=DetectorSpec(kind="gt")),
        description="its own stack's settings (default: the gt detector; onnx needs the run rendered)",
    )

    @model_validator(mode="after")
    def _one_carrier(self) -> SenderSpec:
        if (self.actor is None) == (self.at is None):
            raise ValueError("give either actor (a camera on a scenario actor) or at (a roadside unit)")
        return self


class PoseNoiseSpec(Strict):
    xy: float = Field(0.2, ge=0.0, le=20.0, description="std of a sender's position (m), per axis")
    heading: float = Field(0.3, ge=0.0, le=20.0, description="std of a sender's heading (deg)")


class CooperativeSpec(Strict):
    """Other cameras' objects shared over a link and fused into the ego's (``sim.cooperation``,
    ``perception.cooperative``)."""

    senders: list[SenderSpec] = Field(min_length=1)
    link: LinkConfig = Field(default_factory=LinkConfig)
    pose_noise: PoseNoiseSpec = Field(default_factory=PoseNoiseSpec, description="of every message's sender pose")
    fusion: bool = Field(True, description="false: the messages are fused and recorded, but intent and alerts"
                         " see the ego's own objects only (the comparison run)")

    @model_validator(mode="after")
    def _unique(self) -> CooperativeSpec:
        if dup := repeated([s.name for s in self.senders]):
            raise ValueError(f"sender names must be unique, repeated: {dup}")
        return self


RISK_LEVELS: tuple[str, ...] = tuple(r.name for r in Risk)  # SAFE LOW MEDIUM HIGH CRITICAL
RiskLevel = Literal[RISK_LEVELS]  # type: ignore[valid-type]


class _Given(Strict):
    """Dumps only the fields the file gave: the scorer (``tools.scoring.intent``) reads
    expectations back from run.json as plain single-key mappings."""

    @model_serializer(mode="wrap")
    def _given(self, handler: Any) -> dict[str, Any]:
        return {k: v for k, v in handler(self).items() if k in self.model_fields_set}


def _one_of(schema: dict) -> None:
    """JSON Schema of an ``X | None = None`` expectation key: just X (null is refused on load)."""
    schema.pop("default", None)
    branches = [b for b in schema.pop("anyOf", []) if b != {"type": "null"}]
    if len(branches) == 1:
        schema.update(branches[0])


class NoAlertExpect(_Given):
    actor: str = Field(min_length=1, description="actor id")
    level_at_least: RiskLevel = Field("HIGH", description="alerts at this level or above count")


class AlertExpect(NoAlertExpect):
    before_ttc: float | None = Field(
        None, gt=0.0, le=100.0, description="the first such alert comes while the true TTC is still >= s"
    )


class MetricExpect(_Given):
    section: Literal["intent", "danger", "closed_loop"] = Field(
        description="metrics.json section (expectations are scored with these three)"
    )
    name: str = Field(min_length=1, description="key in that section, e.g. macro_f1, missed, min_ttc")
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _bound(self) -> MetricExpect:
        if self.min is None and self.max is None:
            raise ValueError("give min and/or max")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min {self.min:g} is above max {self.max:g}")
        return self


class Expectation(_Given):
    """One scored check of the run: a mapping with exactly one of these keys."""

    model_config = ConfigDict(json_schema_extra={"minProperties": 1, "maxProperties": 1})
    alert: AlertExpect | None = Field(None, description="an alert >= level_at_least on the actor", json_schema_extra=_one_of)
    no_alert: NoAlertExpect | None = Field(
        None, description="no alert >= level_at_least on the actor", json_schema_extra=_one_of
    )
    collision: bool | None = Field(None, description="whether the ego collides", json_schema_extra=_one_of)
    max_impact_speed: float | None = Field(
        None, ge=0.0, le=100.0, description="impact speed <= m/s (0 without a collision)", json_schema_extra=_one_of
    )
    danger_warned: Literal[True] | None = Field(
        None, description="every danger event is warned (danger.missed == 0)", json_schema_extra=_one_of
    )
    metric: MetricExpect | None = Field(None, description="a metric within [min, max]", json_schema_extra=_one_of)

    @model_validator(mode="before")
    @classmethod
    def _one_kind(cls, data: Any) -> Any:
        if isinstance(data, dict):
            kinds = ", ".join(cls.model_fields)
            unknown = [k for k in data if k not in cls.model_fields]
            if unknown:
                raise ValueError(f"unknown expectation {unknown[0]!r}, expected one of {kinds}")
            if len(data) != 1:
                raise ValueError(f"expected exactly one of {kinds}, got {len(data)} keys")
            (k, v), = data.items()
            if v is None:
                raise ValueError(f"{k}: needs a value")
        return data


class Scenario(Strict):
    """A closed-loop scenario. ``seed`` drives every random draw."""

    name: str = Field(min_length=1)
    description: str = ""
    seed: int = Field(0, ge=0, le=MAX_SEED)
    duration: float = Field(10.0, ge=0.1, le=600.0, description="s")
    rate: float = Field(20.0, ge=1.0, le=200.0, description="simulation ticks per second")
    end_on_collision: bool = True
    road: RoadSpec = Field(default_factory=RoadSpec)
    traffic: TrafficSpec = Field(default_factory=TrafficSpec)
    ego: EgoSpec = Field(default_factory=EgoSpec)
    camera: CameraSpec = Field(default_factory=CameraSpec)
    weather: WeatherSpec = Field(default_factory=WeatherSpec)
    perception: PerceptionSpec = Field(default_factory=PerceptionSpec)
    intent: IntentOverrides = Field(
        default_factory=dict, description="overrides of intent.config.IntentConfig thresholds, nested like it"
    )
    alerts: AlertConfig = Field(
        default_factory=AlertConfig, description="alert debounce and hysteresis (intent.alerts), in camera frames"
    )
    actors: list[ActorSpec] = Field(default_factory=list)
    cooperative: CooperativeSpec | None = Field(None, description="cameras of other road users and roadside"
                                                " units whose objects the ego fuses (absent: none)")
    expect: list[Expectation] = Field(default_factory=list, description="checks scored after the run")

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        ids = [a.id for a in self.actors]
        if dup := repeated(ids):
            raise ValueError(f"actor ids must be unique, repeated: {dup}")
        if self.ego.lane >= self.road.lanes:
            raise ValueError(f"ego.lane {self.ego.lane} is outside the road's {self.road.lanes} lanes")
        if self.camera.rate > self.rate:
            raise ValueError(f"camera.rate {self.camera.rate} exceeds the simulation rate {self.rate}")
        if self.duration * self.camera.rate < 1.0:
            raise _error_at(("duration",), f"shorter than one camera frame (1/{self.camera.rate:g} s)", self.duration)
        if self.ego.s > self.road.length:
            raise _error_at(("ego", "s"), f"beyond the road's end at {self.road.length:g} m", self.ego.s)
        for i, a in enumerate(self.actors):
            along = a.start.s if a.start.s is not None else a.start.x
            if along is not None and not 0.0 <= self.ego.s + along <= self.road.length:
                raise _error_at(
                    ("actors", i, "start", "s" if a.start.s is not None else "x"),
                    f"places the actor {self.ego.s + along:g} m along a road of {self.road.length:g} m", along,
                )
            lanes = [a.start.lane] + [s.do.lane for s in a.script]
            bad = [ln for ln in lanes if ln is not None and ln >= self.road.lanes]
            if bad:
                raise ValueError(f"actor {a.id}: lane {bad[0]} is outside the road's {self.road.lanes} lanes")
            for s in a.script:
                if s.when.actor is not None and s.when.actor.id not in ids:
                    raise ValueError(f"actor {a.id}: trigger names unknown actor {s.when.actor.id!r}")
        for i, sender in enumerate(self.cooperative.senders if self.cooperative else []):
            if sender.actor is not None and sender.actor not in ids:
                raise _error_at(("cooperative", "senders", i, "actor"), f"unknown actor, expected one of {ids}",
                                sender.actor)
        for i, e in enumerate(self.expect):
            kind = "alert" if e.alert is not None else "no_alert" if e.no_alert is not None else None
            if kind and (actor := getattr(e, kind).actor) not in ids:
                raise _error_at(("expect", i, kind, "actor"), f"unknown actor, expected one of {ids}", actor)
        return self


def with_detector(scenario: Scenario, kind: str | None, model: str | Path | None = None) -> Scenario:
    """``scenario`` with its detector replaced (the CLI's ``--detector`` / ``--model``).

    ``kind``: gt | onnx | hog | auto, or a detector plug-in (``kind: plugin``): ``module:factory``,
    ``file.py:factory`` or the name of an installed one (entry-point group ``lookahead.detectors``;
    the built-in kinds win over a plug-in of the same name). The scenario's options stay when the
    kind (and plug-in) stays, otherwise they are dropped. ``model``: an ONNX file (implies
    ``onnx``; refused with ``hog`` or a plug-in). ``None`` for both returns ``scenario`` unchanged.
    See ``perception.plugins.override_detector``.
    """
    if kind is None and model is None:
        return scenario
    from lookahead.perception.plugins import override_detector

    try:
        spec = override_detector(scenario.perception.detector, kind, model)
    except SettingsError as e:
        raise ScenarioError(str(e)) from None
    perception = scenario.perception.model_copy(update={"detector": spec})
    return scenario.model_copy(update={"perception": perception})


def with_stack(scenario: Scenario, ref: str | None) -> Scenario:
    """``scenario`` with a stack plug-in (the CLI's ``--stack``: ``module:factory``,
    ``file.py:factory`` or an entry point of ``lookahead.stacks``) in place of its detector,
    tracker and estimator; ``None`` returns ``scenario`` unchanged."""
    if ref is None:
        return scenario
    if not ref.strip():
        raise ScenarioError("--stack: expected module:factory or an installed stack plug-in's name")
    perception = scenario.perception.model_copy(update={"stack": StackSpec(plugin=ref.strip())})
    return scenario.model_copy(update={"perception": perception})


AEB_SWITCH: tuple[str, ...] = ("on", "off")


def with_aeb(scenario: Scenario, aeb: str | None) -> Scenario:
    """``scenario`` with its ego's AEB switched (the CLI's ``--aeb on|off``).

    ``on``: the scenario's AEB settings if it has them (``ego.aeb`` true or a mapping), else the
    defaults (``ego.aeb: true``); ``off``: no AEB (``ego.aeb: false``); ``None`` returns ``scenario``
    unchanged.
    """
    if aeb is None:
        return scenario
    if aeb not in AEB_SWITCH:
        raise ScenarioError(f"--aeb: expected on or off, got {aeb!r}")
    value: bool | AebConfig = (scenario.ego.aeb or True) if aeb == "on" else False
    if value is scenario.ego.aeb:
        return scenario
    return scenario.model_copy(update={"ego": scenario.ego.model_copy(update={"aeb": value})})


class ScenarioError(SettingsError):
    """A scenario that cannot be used; ``str()`` is one line naming file, field and problem."""


def parse_yaml_model(
    text: str, path: str, model: type[BaseModel], what: str, error: type[ScenarioError] | None = None,
) -> Any:
    """Validate YAML ``text`` as pydantic ``model`` (``perception.yaml_model``); a one-line
    ``error`` (``ScenarioError``) naming ``path:line`` and the field when the YAML or a value is wrong."""
    return yaml_model.parse_yaml_model(text, path, model, what, error or ScenarioError)


def parse_scenario(text: str, path: str = "<string>") -> Scenario:
    """Validate scenario YAML text; raises ``ScenarioError`` with one clear line."""
    return parse_yaml_model(text, path, Scenario, "scenario")


def read_text_file(path: str | Path, what: str = "scenario", error: type[ScenarioError] | None = None) -> str:
    """The UTF-8 text of ``path``; a one-line ``error`` (``ScenarioError``) when missing or unreadable."""
    try:
        return read_yaml_text(path, what)
    except YamlError as e:
        raise (error or ScenarioError)(str(e)) from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    return parse_scenario(read_text_file(path), str(path))


def scenario_json_schema() -> dict:
    """JSON Schema (draft 2020-12) of the scenario file, generated from the model."""
    schema = Scenario.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "lookahead scenario"
    return schema
