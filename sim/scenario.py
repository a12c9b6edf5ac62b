"""The scenario file: a pydantic model, its loader and its JSON Schema.

Units in YAML: metres, seconds, m/s, and **degrees** for angles (converted to
radians by the world). Positions given as ``{x, y}`` are ego-relative at t = 0
(x forward, y left); ``{lane, s}`` is a lane index (0 = leftmost) and a
longitudinal distance ahead of the ego at t = 0. See docs/scenarios.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from perception.detections import CLASSES

ACTOR_TYPES: tuple[str, ...] = (*CLASSES, "obstacle")
SUBTYPES: dict[str, tuple[str, ...]] = {
    "pedestrian": ("adult", "child"),
    "cyclist": ("bicycle",),
    "motorcyclist": ("e-bike", "motorcycle"),
    "tricycle": ("tricycle",),
    "car": ("sedan", "suv", "hatchback"),
    "truck": ("truck",),
    "bus": ("bus",),
    "animal": ("dog", "deer", "cow"),
    "obstacle": ("barrier", "cone", "box"),
}

Pos = Annotated[float, Field(ge=0)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


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
    speed: tuple[float, float] | None = Field(
        None, description="initial speed range (m/s); default 70-80 % of the speed limit"
    )
    lane_change: bool = True


class EgoSpec(Strict):
    lane: int = Field(1, ge=0)
    s: float = Field(50.0, ge=0.0, description="start position along the road (m)")
    speed: float = Field(11.1, ge=0.0, le=60.0, description="initial speed (m/s)")
    target_speed: float | None = Field(None, ge=0.0, le=60.0, description="cruise set speed (m/s)")
    controller: Literal["cruise", "idm", "profile"] = "cruise"
    profile: list[tuple[Pos, Pos]] = Field(
        default_factory=list, description="[[t s, speed m/s], ...] for controller: profile"
    )
    aeb: bool = False
    length: float = Field(4.6, gt=1.0, le=20.0)
    width: float = Field(1.85, gt=0.5, le=3.0)

    @model_validator(mode="after")
    def _profile_needed(self) -> EgoSpec:
        if self.controller == "profile" and len(self.profile) < 1:
            raise ValueError("controller 'profile' needs a non-empty 'profile' of [t, speed] pairs")
        return self


class MountSpec(Strict):
    x: float = Field(-1.5, ge=-10.0, le=2.0, description="m, ego frame (front bumper = 0)")
    y: float = Field(0.0, ge=-2.0, le=2.0)
    z: float = Field(1.4, gt=0.2, le=5.0)
    pitch: float = Field(-2.0, ge=-45.0, le=45.0, description="deg, > 0 looks up")
    yaw: float = Field(0.0, ge=-45.0, le=45.0, description="deg, > 0 looks left")
    roll: float = Field(0.0, ge=-30.0, le=30.0, description="deg")


class CameraSpec(Strict):
    width: int = Field(640, ge=64, le=4096)
    height: int = Field(360, ge=48, le=4096)
    fov_h: float = Field(90.0, gt=10.0, lt=170.0, description="horizontal field of view (deg)")
    rate: float = Field(10.0, gt=0.0, le=120.0, description="frames per second")
    mount: MountSpec = Field(default_factory=MountSpec)
    renderer: Literal["auto", "egl", "tiny"] = "auto"


class WeatherSpec(Strict):
    kind: Literal["clear", "night", "fog", "rain"] = "clear"
    visibility: float | None = Field(None, gt=0.0, description="fog: meteorological visibility (m)")
    intensity: float | None = Field(None, ge=0.0, le=1.0, description="rain/night strength")


class DetectorSpec(Strict):
    kind: Literal["gt", "onnx"] = "gt"
    model: str | None = None
    noise: dict[str, float] = Field(default_factory=dict, description="gt detector noise model")


class PerceptionSpec(Strict):
    detector: DetectorSpec = Field(default_factory=DetectorSpec)
    tracker: dict[str, Any] = Field(default_factory=dict, description="perception.tracker.TrackerConfig overrides")
    estimator: dict[str, Any] = Field(
        default_factory=dict, description="perception.estimator.EstimatorConfig overrides"
    )


class StartSpec(Strict):
    x: float | None = Field(None, description="ego-relative longitudinal (m) at t=0")
    y: float | None = Field(None, description="ego-relative lateral (m, left +) at t=0")
    lane: int | None = Field(None, ge=0)
    s: float | None = Field(None, description="ahead of the ego along the road (m) at t=0")
    offset: float = Field(0.0, description="lateral offset within the lane (m, left +)")

    @model_validator(mode="after")
    def _one_form(self) -> StartSpec:
        xy = self.x is not None and self.y is not None
        ls = self.lane is not None and self.s is not None
        if xy == ls:
            raise ValueError("give either {x, y} (ego-relative) or {lane, s}")
        return self


class ActorCondition(Strict):
    id: str
    speed_gt: float | None = None
    speed_lt: float | None = None
    range_lt: float | None = Field(None, description="that actor's range from the ego < m")
    moving: bool | None = None


class TriggerSpec(Strict):
    """All given conditions must hold (AND)."""

    t: float | None = Field(None, ge=0.0, description="scenario time >= s")
    ego_range_lt: float | None = Field(None, gt=0.0, description="range from the ego's front < m")
    ttc_lt: float | None = Field(None, gt=0.0, description="time to collision with the ego < s")
    actor: ActorCondition | None = None


class ActionSpec(Strict):
    speed: float | None = Field(None, ge=0.0, le=60.0, description="target speed (m/s)")
    accel: float | None = Field(None, gt=0.0, le=15.0, description="|accel| to reach it (m/s^2)")
    heading: float | None = Field(None, description="target heading (deg, world; 0 = along the road)")
    turn_rate: float | None = Field(None, gt=0.0, le=720.0, description="deg/s")
    waypoints: list[tuple[float, float]] | None = Field(
        None, description="[[x, y], ...] ego-relative at t=0 (m), followed in order"
    )
    lane: int | None = Field(None, ge=0, description="change to this lane")
    lateral: float | None = Field(None, description="move to this ego-relative-at-t0 y (m)")
    stop: bool | None = None


class StepSpec(Strict):
    when: TriggerSpec = Field(default_factory=TriggerSpec)
    delay: float = Field(0.0, ge=0.0, description="s after the trigger")
    do: ActionSpec


class ActorSpec(Strict):
    id: str = Field(min_length=1)
    type: Literal[ACTOR_TYPES]  # type: ignore[valid-type]
    subtype: str | None = None
    start: StartSpec
    heading: float = Field(0.0, description="deg, world; 0 = along the road, 90 = to the left")
    speed: float = Field(0.0, ge=0.0, le=60.0, description="initial speed (m/s)")
    script: list[StepSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _subtype(self) -> ActorSpec:
        allowed = SUBTYPES[self.type]
        if self.subtype is None:
            self.subtype = allowed[0]
        elif self.subtype not in allowed:
            raise ValueError(f"subtype {self.subtype!r} is not one of {list(allowed)} for {self.type}")
        return self


class Scenario(Strict):
    """A closed-loop scenario. ``seed`` drives every random draw."""

    name: str = Field(min_length=1)
    description: str = ""
    seed: int = Field(0, ge=0)
    duration: float = Field(10.0, gt=0.0, le=600.0, description="s")
    rate: float = Field(20.0, gt=0.0, le=200.0, description="simulation ticks per second")
    end_on_collision: bool = True
    road: RoadSpec = Field(default_factory=RoadSpec)
    traffic: TrafficSpec = Field(default_factory=TrafficSpec)
    ego: EgoSpec = Field(default_factory=EgoSpec)
    camera: CameraSpec = Field(default_factory=CameraSpec)
    weather: WeatherSpec = Field(default_factory=WeatherSpec)
    perception: PerceptionSpec = Field(default_factory=PerceptionSpec)
    intent: dict[str, Any] = Field(default_factory=dict, description="overrides of intent thresholds")
    actors: list[ActorSpec] = Field(default_factory=list)
    expect: list[dict[str, Any]] = Field(default_factory=list)

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        ids = [a.id for a in self.actors]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"actor ids must be unique, repeated: {dup}")
        if self.ego.lane >= self.road.lanes:
            raise ValueError(f"ego.lane {self.ego.lane} is outside the road's {self.road.lanes} lanes")
        if self.camera.rate > self.rate:
            raise ValueError(f"camera.rate {self.camera.rate} exceeds the simulation rate {self.rate}")
        for a in self.actors:
            lanes = [a.start.lane] + [s.do.lane for s in a.script]
            bad = [ln for ln in lanes if ln is not None and ln >= self.road.lanes]
            if bad:
                raise ValueError(f"actor {a.id}: lane {bad[0]} is outside the road's {self.road.lanes} lanes")
            for s in a.script:
                if s.when.actor is not None and s.when.actor.id not in ids:
                    raise ValueError(f"actor {a.id}: trigger names unknown actor {s.when.actor.id!r}")
        return self


class ScenarioError(ValueError):
    """A scenario that cannot be used; ``str()`` is one line naming file, field and problem."""


def _node_line(node: yaml.Node | None, loc: tuple) -> int | None:
    """1-based line of the YAML node at ``loc`` (or of its deepest existing parent)."""
    line = None
    for key in loc:
        if node is None:
            break
        line = node.start_mark.line + 1
        if isinstance(node, yaml.MappingNode):
            node = next((v for k, v in node.value if k.value == key), None)
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and key < len(node.value):
            node = node.value[key]
        else:
            node = None
    if node is not None:
        line = node.start_mark.line + 1
    return line


def _format_validation(path: str, err: ValidationError, root: yaml.Node | None) -> str:
    first = err.errors()[0]
    loc = tuple(x for x in first["loc"] if not (isinstance(x, str) and x.startswith("function-")))
    field_path = ".".join(str(x) if not isinstance(x, int) else f"[{x}]" for x in loc).replace(".[", "[")
    line = _node_line(root, loc) if loc else None
    msg = first["msg"].removeprefix("Value error, ")
    where = f"{path}:{line}" if line else path
    more = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    if first["type"] == "extra_forbidden":
        msg = "unknown field"
    if "input" in first and first["type"] not in ("missing", "extra_forbidden") and not isinstance(
        first["input"], dict | list
    ):
        msg += f", got {first['input']!r}"
    return f"{where}: {field_path or '(top level)'}: {msg}{more}"


def parse_scenario(text: str, path: str = "<string>") -> Scenario:
    """Validate scenario YAML text; raises ``ScenarioError`` with one clear line."""
    try:
        root = yaml.compose(text)
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark else path
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ScenarioError(f"{where}: malformed YAML: {problem}") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: expected a mapping of scenario fields, got {type(data).__name__}")
    try:
        return Scenario.model_validate(data)
    except ValidationError as e:
        raise ScenarioError(_format_validation(path, e, root)) from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: no such scenario file")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ScenarioError(f"{p}: cannot read: {e}") from None
    return parse_scenario(text, str(p))


def scenario_json_schema() -> dict:
    """JSON Schema (draft 2020-12) of the scenario file, generated from the model."""
    schema = Scenario.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "lookahead scenario"
    return schema
