"""Random scenes for detector data: a generator file -> ``Scenario`` per seed (domain randomisation).

A generator file (YAML, see ``scenarios/generators/detector.yaml``) names seed
ranges per split and the ranges every random draw comes from; scene ``seed`` is
expanded by ``generate_scenario(spec, seed)`` into a full, validated
expanded by ``generate_scenario(spec, seed)`` into a full, validated
``Scenario`` -- road, traffic, ego, camera mount, weather and 3-10 actors of the
disjoint seed ranges, so train, validation and test never share a scene, and a
scene is the same whatever split list or worker count produced it.

Placements are ego-relative at t = 0 (x forward from the front bumper, y left,
m). The road's lanes run in the ego's direction, lane 0 leftmost; with the ego
in lane ``e`` of width ``w``, lane ``i``'s centre is at y = (e - i) * w and the
sidewalks lie beyond y = (e + 0.5) * w (left) and y = (e - lanes + 0.5) * w
(right). Actors are kept apart by rejection sampling on their footprints.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import AfterValidator, Field, ValidationError, field_validator, model_validator

from lookahead.sim.scenario import SUBTYPES, Scenario, ScenarioError, Strict
from lookahead.tools.runs.inputs import read_yaml


def _ordered(v: tuple) -> tuple:
    """A [min, max] range: min <= max (a reversed one is a mistake, not an empty range)."""
    if v[0] > v[1]:
        raise ValueError(f"expected [min, max] with min <= max, got {list(v)}")
    return v


def _span(lo: float | None = None, hi: float | None = None, positive: bool = False, kind: type = float):
    """A [min, max] range of ``kind`` whose ends lie in [lo, hi] (> 0 with ``positive``), ordered."""
    end = Annotated[kind, Field(ge=None if positive else lo, gt=lo if positive else None, le=hi)]
    return Annotated[tuple[end, end], AfterValidator(_ordered)]


Range = _span()  # finite (Strict: no NaN or inf), min <= max


class SplitSpec(Strict):
    seeds: tuple[int, int] = Field(description="scene seeds [first, last) of this split")

    @field_validator("seeds")
    @classmethod
    def _ordered(cls, v: tuple[int, int]) -> tuple[int, int]:
        if not 0 <= v[0] < v[1]:
            raise ValueError(f"expected [first, last) with 0 <= first < last, got {list(v)}")
        return v


class CameraRandom(Strict):
    width: int = Field(640, ge=64, le=4096)
    height: int = Field(360, ge=48, le=4096)
    fov_h: _span(10.0, 169.0, positive=True) = (85.0, 95.0)
    z: _span(0.2, 5.0, positive=True) = Field((1.2, 1.8), description="mount height (m)")
    x: _span(-10.0, 2.0) = Field((-2.0, -1.0), description="mount x, ego frame (m)")
    pitch: _span(-45.0, 45.0) = Field((-6.0, 2.0), description="deg, > 0 looks up")
    rate: float = Field(2.0, gt=0.0, le=20.0, description="frames per second exported")


class WeatherRandom(Strict):
    """Weights of the weather kinds and the ranges of their parameters."""

    clear: float = Field(0.4, ge=0.0)
    night: float = Field(0.2, ge=0.0)
    fog: float = Field(0.2, ge=0.0)
    rain: float = Field(0.2, ge=0.0)
    fog_visibility: _span(0.0, 1e5, positive=True) = Field((50.0, 300.0), description="m, log-uniform")
    intensity: _span(0.0, 1.0) = Field((0.3, 1.0), description="rain / night strength")

    @model_validator(mode="after")
    def _some(self) -> WeatherRandom:
        if self.clear + self.night + self.fog + self.rain <= 0:
            raise ValueError("at least one weather weight must be positive")
        return self


#: Most actors (and parked cars) a scene may ask for: each is placed by rejection sampling.
MAX_ACTORS = 100


class ActorRandom(Strict):
    count: _span(0, MAX_ACTORS, kind=int) = Field((3, 10), description="actors per scene [min, max]")
    x: _span(0.0, 2000.0) = Field((3.0, 90.0), description="ego-relative start x (m)")
    #: relative weights of the actor classes drawn
    mix: dict[str, float] = Field(
        default_factory=lambda: {
            "pedestrian": 3.0, "cyclist": 1.5, "motorcyclist": 1.5, "tricycle": 1.0,
            "car": 2.0, "truck": 0.8, "bus": 0.8, "animal": 2.0, "obstacle": 0.5,
        }
    )
    parked_cars: _span(0, MAX_ACTORS, kind=int) = Field((0, 3), description="stationary cars at the kerb")

    @field_validator("mix")
    @classmethod
    def _known_weights(cls, v: dict[str, float]) -> dict[str, float]:
        unknown = sorted(set(v) - set(_MOTION))
        if unknown:
            raise ValueError(f"unknown class(es) {', '.join(unknown)}; expected some of {', '.join(_MOTION)}")
        if any(w < 0 for w in v.values()) or not sum(v.values()) > 0:
            raise ValueError("expected weights >= 0, at least one positive")
        return v


class GeneratorSpec(Strict):
    """What ``generate_scenario`` draws from; see the module docstring."""

    name: str = Field("det", min_length=1, description="scene name prefix")
    duration: float = Field(4.0, gt=0.0, le=60.0, description="s per scene")
    rate: float = Field(10.0, gt=0.0, le=100.0, description="simulation ticks per second")
    splits: dict[str, SplitSpec]
    lanes: _span(1, 6, kind=int) = (1, 4)
    lane_width: _span(2.5, 5.0) = (3.0, 3.8)
    intersection: float = Field(0.2, ge=0.0, le=1.0, description="share of crossroads scenes")
    traffic: _span(0, 60, kind=int) = Field((0, 6), description="IDM vehicles [min, max]")
    ego_speed: _span(0.0, 60.0) = Field((0.0, 15.0), description="m/s")
    camera: CameraRandom = Field(default_factory=CameraRandom)
    weather: WeatherRandom = Field(default_factory=WeatherRandom)
    actors: ActorRandom = Field(default_factory=ActorRandom)

    @field_validator("splits")
    @classmethod
    def _disjoint(cls, v: dict[str, SplitSpec]) -> dict[str, SplitSpec]:
        for name, split in v.items():
            other = overlapping_split(v, name)
            if other is not None:
                raise ValueError(f"split {name!r} {list(split.seeds)} overlaps split {other!r} {list(v[other].seeds)}")
        return v


def overlapping_split(splits: dict[str, SplitSpec], name: str) -> str | None:
    """The first split other than ``name`` whose seed range overlaps ``name``'s, or None."""
    lo, hi = splits[name].seeds
    return next((o for o, s in splits.items() if o != name and lo < s.seeds[1] and s.seeds[0] < hi), None)


WEATHER_KINDS = ("clear", "night", "fog", "rain")
#: class -> (speed range m/s, footprint length m, width m) used for placement and motion.
_MOTION = {
    "pedestrian": ((0.0, 2.5), 0.6, 0.6),
    "cyclist": ((0.0, 6.0), 1.9, 0.7),
    "motorcyclist": ((0.0, 9.0), 2.0, 0.8),
    "tricycle": ((0.0, 4.0), 2.2, 1.2),
    "car": ((0.0, 10.0), 4.8, 2.0),
    "truck": ((0.0, 8.0), 8.0, 2.6),
    "bus": ((0.0, 8.0), 12.0, 2.6),
    "animal": ((0.0, 4.0), 1.8, 0.7),
    "obstacle": ((0.0, 0.0), 1.2, 0.6),
}


def load_generator(path: str | Path) -> GeneratorSpec:
    """Read and validate a generator file; one-line ``ScenarioError`` naming file and field."""
    data = read_yaml(path, "generator")
    if not isinstance(data, dict) or not isinstance(data.get("generator"), dict):
        raise ScenarioError(f"{path}: expected a mapping with a 'generator' section")
    try:
        return GeneratorSpec.model_validate(data["generator"])
    except ValidationError as e:
        first = e.errors()[0]
        field = ".".join(str(x) for x in first["loc"])
        raise ScenarioError(f"{path}: generator.{field}: {first['msg'].removeprefix('Value error, ')}") from None


def is_generator(data: object) -> bool:
    return isinstance(data, dict) and "generator" in data


def _uniform(rng: np.random.Generator, r: Range) -> float:
    return float(rng.uniform(r[0], r[1])) if r[1] > r[0] else float(r[0])


def _weather(rng: np.random.Generator, w: WeatherRandom) -> dict:
    p = np.array([w.clear, w.night, w.fog, w.rain], dtype=np.float64)
    kind = WEATHER_KINDS[int(rng.choice(4, p=p / p.sum()))]
    out: dict = {"kind": kind}
    if kind == "fog":
        lo, hi = np.log(w.fog_visibility[0]), np.log(w.fog_visibility[1])
        out["visibility"] = round(float(np.exp(rng.uniform(lo, hi))), 1)
    elif kind in ("rain", "night"):
        out["intensity"] = round(_uniform(rng, w.intensity), 3)
    return out


def _place(
    rng: np.random.Generator, cls: str, lanes: int, lane_w: float, ego_lane: int, sidewalk: float,
    x_range: Range,
) -> tuple[float, float, float, float]:
    """(x, y, heading deg, speed m/s) of one actor of ``cls``, ego-relative at t = 0."""
    left_edge, right_edge = (ego_lane + 0.5) * lane_w, (ego_lane - lanes + 0.5) * lane_w
    x = _uniform(rng, x_range)
    speeds = _MOTION[cls][0]
    speed = _uniform(rng, speeds) if rng.random() < 0.75 else 0.0
    on_road = {"car": 1.0, "truck": 1.0, "bus": 1.0, "cyclist": 0.8, "motorcyclist": 0.85,
               "tricycle": 0.8, "pedestrian": 0.35, "animal": 0.5, "obstacle": 0.7}[cls]
    if rng.random() < on_road:
        lane = int(rng.integers(lanes))
        y = (ego_lane - lane) * lane_w + float(rng.uniform(-0.3, 0.3)) * lane_w
    else:
        side = 1.0 if rng.random() < 0.5 else -1.0
        edge = left_edge if side > 0 else right_edge
        y = edge + side * float(rng.uniform(0.3, max(0.4, sidewalk - 0.3)))
    if cls in ("car", "truck", "bus"):
        heading = float(rng.choice([0.0, 0.0, 0.0, 180.0])) + float(rng.normal(0.0, 3.0))
    elif cls == "obstacle":
        heading = float(rng.uniform(-180.0, 180.0))
    else:
        r = rng.random()
        heading = 0.0 if r < 0.35 else 180.0 if r < 0.55 else float(rng.choice([90.0, -90.0])) if r < 0.85 \
            else float(rng.uniform(-180.0, 180.0))
        heading += float(rng.normal(0.0, 8.0))
    return x, y, heading, speed


def _overlaps(boxes: list[tuple[float, float, float, float]], x: float, y: float, length: float,
              width: float) -> bool:
    """Whether an axis-aligned footprint (conservative: the larger side both ways) hits a placed one."""
    r = 0.5 * max(length, width) + 0.3
    return any(abs(x - bx) < r + br and abs(y - by) < r + bw for bx, by, br, bw in boxes)


def generate_scenario(spec: GeneratorSpec, seed: int, weather: str | None = None) -> Scenario:
    """The scene of ``seed`` (module docstring); ``weather`` forces a kind (test sets per condition).

    With ``weather`` given every other draw is unchanged, so the same scenes are
    seen under each condition.
    """
    rng = np.random.default_rng([seed, 0x5CE7E])
    lanes = int(rng.integers(spec.lanes[0], spec.lanes[1] + 1))
    lane_w = round(_uniform(rng, spec.lane_width), 2)
    ego_lane = int(rng.integers(lanes))
    sidewalk = round(float(rng.uniform(2.0, 4.0)), 2)
    kind = "intersection" if rng.random() < spec.intersection else "straight"
    cam = spec.camera
    camera = {
        "width": cam.width, "height": cam.height, "fov_h": round(_uniform(rng, cam.fov_h), 2),
        "rate": cam.rate,
        "mount": {"x": round(_uniform(rng, cam.x), 3), "z": round(_uniform(rng, cam.z), 3),
                  "pitch": round(_uniform(rng, cam.pitch), 3)},
    }
    drawn = _weather(rng, spec.weather)
    if weather is not None:
        if weather not in WEATHER_KINDS:
            raise ValueError(f"--weather: expected one of {', '.join(WEATHER_KINDS)}, got {weather!r}")
        forced = WeatherRandom(**{k: float(k == weather) for k in WEATHER_KINDS},
                               fog_visibility=(80.0, 80.0), intensity=spec.weather.intensity)
        drawn = _weather(np.random.default_rng([seed, 0xF06]), forced)
    ego_speed = round(_uniform(rng, spec.ego_speed), 2)
    n_traffic = int(rng.integers(spec.traffic[0], spec.traffic[1] + 1))

    a = spec.actors
    classes = list(a.mix)
    p = np.array([a.mix[c] for c in classes], dtype=np.float64)
    n = int(rng.integers(a.count[0], a.count[1] + 1))
    placed: list[tuple[float, float, float, float]] = [(0.0, 0.0, 3.0, 1.5)]  # the ego's nose
    actors: list[dict] = []

    def add(cls: str, x: float, y: float, heading: float, speed: float, subtype: str | None = None) -> None:
        _, length, width = _MOTION[cls]
        placed.append((x, y, 0.5 * max(length, width), 0.5 * max(length, width)))
        sub = subtype or str(rng.choice(SUBTYPES[cls]))
        actor = {"id": f"{cls}{len(actors)}", "type": cls, "subtype": sub,
                 "start": {"x": round(x, 2), "y": round(y, 2)}, "heading": round(heading, 1),
                 "speed": round(speed, 2)}
        if speed > 0 and rng.random() < 0.3:  # some stop or turn on the way: varied poses and gaits
            actor["script"] = [{"when": {"t": round(float(rng.uniform(0.5, spec.duration)), 2)},
                                "do": {"speed": 0.0} if rng.random() < 0.5
                                else {"heading": round(heading + float(rng.uniform(-60, 60)), 1)}}]
        actors.append(actor)

    for _ in range(int(rng.integers(a.parked_cars[0], a.parked_cars[1] + 1))):
        side = (ego_lane - lanes + 0.5) * lane_w + 1.1 if rng.random() < 0.7 else (ego_lane + 0.5) * lane_w - 1.1
        x = _uniform(rng, (5.0, a.x[1]))
        if not _overlaps(placed, x, side, 4.8, 2.0):
            add("car", x, side, float(rng.normal(0.0, 2.0)), 0.0)
    for _ in range(n):
        cls = str(rng.choice(classes, p=p / p.sum()))
        for _attempt in range(8):
            x, y, heading, speed = _place(rng, cls, lanes, lane_w, ego_lane, sidewalk, a.x)
            _, length, width = _MOTION[cls]
            if not _overlaps(placed, x, y, length, width):
                add(cls, x, y, heading, speed)
                break

    data = {
        "name": f"{spec.name}_{seed:06d}",
        "description": "generated by tools.dataset.scene_gen for detector data",
        "seed": int(seed), "duration": spec.duration, "rate": spec.rate, "end_on_collision": False,
        "road": {"kind": kind, "lanes": lanes, "lane_width": lane_w, "sidewalks": True,
                 "sidewalk_width": sidewalk, "speed_limit": 20.0},
        "traffic": {"count": n_traffic, "density": round(float(rng.uniform(0.8, 2.0)), 2)},
        "ego": {"lane": ego_lane, "speed": ego_speed, "controller": "cruise"},
        "camera": camera, "weather": drawn, "actors": actors,
        "perception": {"detector": {"kind": "gt"}},  # labels come from ground truth; no model needed
    }
    try:
        return Scenario.model_validate(data)
    except ValidationError as e:  # a generator bug, not a user mistake: say which seed
        raise ValueError(f"scene generator: seed {seed} gave an invalid scenario: {e.errors()[0]}") from None


def split_seeds(spec: GeneratorSpec, split: str) -> range:
    if split not in spec.splits:
        raise ValueError(f"--split: the generator has splits {sorted(spec.splits)}, got {split!r}")
    lo, hi = spec.splits[split].seeds
    return range(lo, hi)

