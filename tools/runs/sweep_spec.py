"""Sweep files: a base scenario, parameter grids, random draws and sets -> the list of variants.

The file format is described in ``tools.runs.sweep``; this module reads and checks a sweep file
and expands it into ``Variant``s. Light on purpose: it imports neither the simulator nor the
scorers, so the CLI refuses a hostile sweep (billion laughs, 10^10 variants) at the cost of
Python's start-up alone (issue 31).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
import math
import re
import types
import typing
import zlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, Discriminator, Field, Tag, ValidationError, model_validator

from lookahead.sim.scenario import (
    DEFAULT_ACCEL,
    Scenario,
    ScenarioError,
    Strict,
    format_validation,
    load_scenario,
    parse_yaml_model,
    read_text_file,
    with_aeb,
)

log = logging.getLogger(__name__)

IMPACT_OFFSET = "impact_offset"
SLUG_MAX = 60


class SweepError(ScenarioError):
    """A sweep that cannot be used (file, parameter or Ray cluster); ``str()`` is one line."""


# --------------------------------------------------------------------------- the sweep file


class Uniform(Strict):
    uniform: tuple[float, float]

    @model_validator(mode="after")
    def _order(self) -> Uniform:
        low, high = self.uniform
        if not (math.isfinite(low) and math.isfinite(high) and math.isfinite(high - low)):
            raise ValueError(f"uniform: expected finite [low, high], got {list(self.uniform)}")
        if not low <= high:
            raise ValueError("uniform: expected [low, high] with low <= high")
        return self


_INT64 = Annotated[int, Field(ge=-(2**63), le=2**63 - 1)]


class RandInt(Strict):
    randint: tuple[_INT64, _INT64] = Field(description="[low, high], both inclusive")

    @model_validator(mode="after")
    def _order(self) -> RandInt:
        if not self.randint[0] <= self.randint[1]:
            raise ValueError("randint: expected [low, high] with low <= high")
        return self


class Choice(Strict):
    choice: list[Any] = Field(min_length=1)

    @model_validator(mode="after")
    def _values(self) -> Choice:
        for i, v in enumerate(self.choice):
            _check_value(f"item {i}", v)
        return self


def _check_value(where: str, value: Any) -> None:
    """A parameter value a variant can take (``_norm``: JSON-able, finite); else ValueError naming ``where``."""
    try:
        _norm(value)
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None


def _dist_kind(v: Any) -> str | None:
    if isinstance(v, BaseModel):
        return next(iter(type(v).model_fields))
    if isinstance(v, dict) and len(v) == 1 and next(iter(v)) in ("uniform", "randint", "choice"):
        return next(iter(v))
    return None


Distribution = Annotated[
    Annotated[Uniform, Tag("uniform")] | Annotated[RandInt, Tag("randint")] | Annotated[Choice, Tag("choice")],
    Discriminator(_dist_kind, custom_error_type="distribution",
                  custom_error_message="expected {uniform: [low, high]}, {randint: [low, high]} or {choice: [...]}"),
]


class SampleSpec(Strict):
    n: int = Field(ge=1, le=100_000, description="number of random draws")
    seed: int = Field(0, ge=0)
    params: dict[str, Distribution] = Field(min_length=1)


class ReportSpec(Strict):
    x: list[str] | None = Field(None, description="parameters on the x axes (default: numeric ones)")
    split: str | None = Field(None, description="parameter whose values are separate series")
    metrics: list[str] | None = Field(None, description="dotted metrics.json paths to plot")


class SweepSpec(Strict):
    name: str | None = Field(None, min_length=1)
    description: str = ""
    scenario: str = Field(min_length=1, description="base scenario, relative to the sweep file")
    set: dict[str, Any] = Field(default_factory=dict, description="fixed overrides for every variant")
    grid: dict[str, list[Any]] = Field(default_factory=dict)
    samples: SampleSpec | None = None
    report: ReportSpec = Field(default_factory=ReportSpec)

    @model_validator(mode="after")
    def _consistent(self) -> SweepSpec:
        for path, values in self.grid.items():
            if not values:
                raise ValueError(f"grid: {path}: expected a non-empty list of values")
            for i, v in enumerate(values):
                _check_value(f"grid: {path}[{i}]", v)
        for path, v in self.set.items():
            _check_value(f"set: {path}", v)
        sampled = set(self.samples.params) if self.samples else set()
        for a, b, what in ((self.grid, sampled, "grid and samples"), (self.set, set(self.grid) | sampled,
                                                                        "set and grid/samples")):
            both = sorted(set(a) & set(b))
            if both:
                raise ValueError(f"{both[0]} is given in both {what}")
        count = math.prod(len(v) for v in self.grid.values()) * (self.samples.n if self.samples else 1)
        if count > MAX_VARIANTS:  # counted before anything is expanded
            raise ValueError(f"the sweep expands to {count:,} variants; at most {MAX_VARIANTS:,} are allowed")
        params = self.parameters()
        for name in [*(self.report.x or []), *([self.report.split] if self.report.split else [])]:
            if name not in params:
                raise ValueError(f"report: {name!r} is not a grid or samples parameter ({', '.join(params) or 'none'})")
        return self

    def parameters(self) -> list[str]:
        return [*self.grid, *(self.samples.params if self.samples else {})]


#: The most variants one sweep file may expand to (grid points x samples), checked before expanding.
MAX_VARIANTS = 10_000


@dataclass
class Variant:
    id: str
    params: dict[str, Any]
    scenario: Scenario


# --------------------------------------------------------------------------- parameter paths

_TOKEN = re.compile(r"(?P<dot>\.)?(?:(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<num>\d+))|\[(?P<sel>[^\]]+)\]")
_FREE = "free"  # a free-form mapping: any key
_SCALAR = "scalar"


def parse_path(path: str) -> list[tuple[str, str | int]]:
    """Tokens of a parameter path: ``("name", field)``, ``("index", i)`` or ``("id", item id)``."""
    tokens: list[tuple[str, str | int]] = []
    pos = 0
    while pos < len(path):
        m = _TOKEN.match(path, pos)
        first = pos == 0
        if m is None or (first and (m["dot"] or m["num"])) or (not first and (m["name"] or m["num"]) and not m["dot"]):
            raise ValueError(f"malformed parameter path (at {path[pos:]!r}); expected e.g. ego.speed, "
                             "actors[ped1].speed or actors.0.speed")
        if m["name"]:
            tokens.append(("name", m["name"]))
        elif m["num"]:
            tokens.append(("index", int(m["num"])))
        else:
            sel = m["sel"].strip()
            tokens.append(("index", int(sel)) if sel.isdigit() else ("id", sel))
        pos = m.end()
    if not tokens:
        raise ValueError("empty parameter path")
    return tokens


def _kind(annotation: Any) -> tuple[str, Any]:
    """What a field holds: ("model", cls), ("list", item kind), (_FREE, None) or (_SCALAR, None)."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _kind(typing.get_args(annotation)[0])
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "model", annotation
    if origin is list:
        (item,) = typing.get_args(annotation) or (Any,)
        return "list", _kind(item)
    if origin is dict or annotation is dict:
        return _FREE, None
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if origin in (typing.Union, types.UnionType) and len(args) == 1:
        return _kind(args[0])
    return _SCALAR, None


def _resolve(data: dict, tokens: list, path: str, create: bool = True) -> tuple[Any, str | int, tuple]:
    """(container, key, loc) of the last token of ``path`` in the scenario data ``data``."""
    node: Any = data
    kind: tuple[str, Any] = ("model", Scenario)
    loc: list[str | int] = []

    def where() -> str:
        return ".".join(str(x) for x in loc) or "the scenario"

    for i, (tk, val) in enumerate(tokens):
        last = i == len(tokens) - 1
        if kind[0] == "list":
            if tk == "name":
                raise ValueError(f"{where()} is a list: select an item with [id] or .N, not .{val}")
            if not isinstance(node, list):
                raise ValueError(f"{where()} is not set in the base scenario")
            if tk == "index":
                if not 0 <= int(val) < len(node):
                    raise ValueError(f"{where()} has {len(node)} items, no index {val}")
                idx = int(val)
            else:
                ids = [item.get("id") for item in node if isinstance(item, dict)]
                if val not in ids:
                    raise ValueError(f"{where()} has no item with id {val!r} (ids: {', '.join(map(str, ids)) or 'none'})")
                idx = ids.index(val)
            loc.append(idx)
            if last:
                return node, idx, tuple(loc)
            node, kind = node[idx], kind[1]
            continue
        if tk != "name":
            raise ValueError(f"{where()} is not a list; use .field, not [{val}]")
        if kind[0] == "model":
            cls = kind[1]
            if val not in cls.model_fields:
                raise ValueError(f"unknown field {val!r} of {where()} (fields: {', '.join(cls.model_fields)})")
            sub = _kind(cls.model_fields[val].annotation)
        elif kind[0] == _FREE:
            sub = (_FREE, None)
        else:
            raise ValueError(f"{where()} is a single value; it has no field {val!r}")
        loc.append(val)
        if last:
            return node, val, tuple(loc)
        if node.get(val) is None:
            if sub[0] in ("model", _FREE) and create:
                node[val] = {}
            else:
                raise ValueError(f"{where()} is not set in the base scenario")
        node, kind = node[val], sub
    raise AssertionError("unreachable")


def _is_actor_path(tokens: list) -> bool:
    return len(tokens) == 3 and tokens[0] == ("name", "actors") and tokens[2] == ("name", IMPACT_OFFSET)


def _ramp_distance(u: float, v: float, a: float, t: float) -> float:
    """Distance in ``t`` s going from speed ``u`` to ``v`` at |accel| ``a``, then holding ``v``."""
    if a <= 0 or u == v:
        return v * t
    t_ramp = abs(v - u) / a
    if t <= t_ramp:
        return u * t + math.copysign(0.5 * a * t * t, v - u)
    return 0.5 * (u + v) * t_ramp + v * (t - t_ramp)


def place_impact_offset(actor: dict, ego: dict, offset: float) -> None:
    """Move ``actor`` (scenario data) so that, with the ego holding its initial speed, the
    actor's centre is ``offset`` m (left +) from the ego's centreline where the ego meets it.

    * An actor moving along the road (|sin heading| < 0.5): its lateral start is set
      (``start.y``, or ``start.lane`` = the ego's lane and ``start.offset``).
    * A crossing actor with an ego-relative start ``{x, y}``: ``start.y`` is set so its
      lateral travel until the ego's front reaches ``x`` ends at ``offset``. It either
      moves at its initial speed from t = 0 (no script), or starts from rest on its first
      script step (``do.speed``, ``do.accel`` or the class default, ``delay``) triggered by
      ``ego_range_lt`` or ``t``. Kinematic approximation: the actor's footprint is ignored
      (error ~ its half-length, about 0.3 m for a pedestrian).
    """
    aid = actor.get("id")
    heading = math.radians(float(actor.get("heading", 0.0)))
    start = actor.setdefault("start", {})
    xy = start.get("x") is not None and start.get("y") is not None
    if abs(math.sin(heading)) < 0.5:
        if xy:
            start["y"] = offset
        else:
            start["lane"], start["offset"] = int(ego.get("lane", 1)), offset
        return
    if not xy:
        raise ValueError(f"actor {aid}: impact_offset of a crossing actor needs an ego-relative start {{x, y}}")
    v_e = float(ego.get("speed", 11.1))
    if v_e <= 0:
        raise ValueError(f"actor {aid}: impact_offset needs a moving ego (ego.speed > 0)")
    x = float(start["x"])
    u = float(actor.get("speed", 0.0))
    script = actor.get("script") or []
    if not script and u > 0:
        walk = u * x / v_e
    elif script and u == 0:
        step = script[0]
        when = {k: v for k, v in (step.get("when") or {}).items() if v is not None}
        do = step.get("do") or {}
        speed, delay = do.get("speed"), float(step.get("delay", 0.0))
        if not speed:
            raise ValueError(f"actor {aid}: impact_offset needs the first script step to set a speed > 0")
        if set(when) == {"ego_range_lt"}:
            t_move = float(when["ego_range_lt"]) / v_e - delay
        elif set(when) == {"t"}:
            t_move = x / v_e - float(when["t"]) - delay
        else:
            raise ValueError(f"actor {aid}: impact_offset needs the first script step triggered by "
                             "ego_range_lt or t alone")
        if t_move < 0:
            raise ValueError(f"actor {aid}: impact_offset: it starts moving after the ego has passed")
        accel = float(do.get("accel") or DEFAULT_ACCEL.get(str(actor.get("type")), 2.0))
        walk = _ramp_distance(0.0, float(speed), accel, t_move)
    else:
        raise ValueError(f"actor {aid}: impact_offset needs a crossing actor that walks at its initial speed "
                         "(no script) or starts from rest on its first script step")
    start["y"] = round(offset - math.sin(heading) * walk, 6)


def apply_params(base: dict, params: dict[str, Any]) -> tuple[dict, dict[str, tuple]]:
    """A deep copy of scenario data ``base`` with ``params`` set; returns it and each path's loc.

    Plain paths first, then the ``impact_offset`` conveniences (they depend on the ego's
    and the actor's speed). Raises ``ValueError`` naming the path.
    """
    data = json.loads(json.dumps(base))
    locs: dict[str, tuple] = {}
    later = []
    for path, value in params.items():
        try:
            tokens = parse_path(path)
            if _is_actor_path(tokens):
                container, key, loc = _resolve(data, tokens[:2], path, create=False)
                later.append((path, key, value))
                locs[path] = (*loc, "start")
                continue
            container, key, loc = _resolve(data, tokens, path)
        except ValueError as e:
            raise ParamError(path, str(e)) from None
        container[key] = value
        locs[path] = loc
    first: dict[tuple, str] = {}
    for path, loc in locs.items():
        if loc in first:
            raise ParamError(path, f"sets the same scenario field as {first[loc]}")
        first[loc] = path
    for path, idx, value in later:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ParamError(path, f"expected a number (m, left +), got {value!r}")
        try:
            place_impact_offset(data["actors"][idx], data.get("ego") or {}, float(value))
        except ValueError as e:
            raise ParamError(path, str(e)) from None
    return data, locs


# --------------------------------------------------------------------------- expansion and ids


def _norm(v: Any) -> Any:
    """JSON-able canonical value (numpy scalars to Python, 8.0 -> 8, tuples to lists)."""
    if hasattr(v, "item") and not isinstance(v, list | dict | str):
        v = v.item()
    if v is None or isinstance(v, bool | str | int):
        return v
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"expected a finite number, got {v!r}")
        return int(v) if v.is_integer() else v
    if isinstance(v, list | tuple):
        return [_norm(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _norm(x) for k, x in v.items()}
    raise ValueError(f"unsupported value {v!r:.60} ({type(v).__name__}); expected a number, string, "
                     "boolean, null, list or mapping")


def _short(path: str) -> str:
    tokens = parse_path(path)
    name = next((str(v) for t, v in reversed(tokens) if t == "name"), path)
    sel = next((v for t, v in tokens if t in ("id", "index")), None)
    return name if sel is None else f"{sel if isinstance(sel, str) else f'a{sel}'}.{name}"


def _fmt_value(v: Any) -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if v is None:
        return "none"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return "x".join(_fmt_value(x) for x in v)
    if isinstance(v, dict):
        return "obj"
    return str(v)


def variant_id(params: dict[str, Any]) -> str:
    """``slug-hash8``; depends only on the (path, value) pairs."""
    canon = json.dumps({k: _norm(v) for k, v in params.items()}, sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha1(canon.encode()).hexdigest()[:8]
    parts = [f"{_short(k)}-{_fmt_value(_norm(params[k]))}" for k in sorted(params)]
    slug = re.sub(r"[^A-Za-z0-9._+-]+", "", "_".join(parts))[:SLUG_MAX].strip("_-.") or "base"
    return f"{slug}-{digest}"


def _draw(path: str, dist: Distribution, n: int, seed: int) -> list[Any]:
    rng = np.random.default_rng([seed, zlib.crc32(path.encode())])
    if isinstance(dist, Uniform):
        return [round(float(x), 6) for x in rng.uniform(*dist.uniform, size=n)]
    if isinstance(dist, RandInt):
        return [int(x) for x in rng.integers(dist.randint[0], dist.randint[1], size=n, endpoint=True)]
    return [dist.choice[int(i)] for i in rng.integers(0, len(dist.choice), size=n)]


def parameter_sets(spec: SweepSpec) -> list[dict[str, Any]]:
    """Every grid point x every sample, as ``{path: value}`` (grid paths first)."""
    keys = list(spec.grid)
    points = [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*spec.grid.values())]
    samples: list[dict[str, Any]] = [{}]
    if spec.samples is not None:
        s = spec.samples
        draws = {p: _draw(p, d, s.n, s.seed) for p, d in s.params.items()}
        samples = [{p: draws[p][i] for p in s.params} for i in range(s.n)]
    return [{k: _norm(v) for k, v in {**g, **smp}.items()} for g in points for smp in samples]


class ParamError(ValueError):
    """A parameter path or value that does not fit the scenario; ``path`` names it."""

    def __init__(self, path: str, msg: str) -> None:
        super().__init__(f"{path}: {msg}")
        self.path = path


def _culprit(err_loc: tuple, named: dict[str, tuple]) -> str | None:
    """The label of the parameter whose scenario location contains the error's (or vice versa)."""
    best = None
    for label, loc in named.items():
        if err_loc[: len(loc)] == loc or (err_loc and loc[: len(err_loc)] == err_loc):
            if best is None or len(loc) > len(named[best]):
                best = label
    return best


def expand(spec: SweepSpec, base: Scenario, sweep_file: str = "<sweep>") -> list[Variant]:
    """Validated variants of ``base`` (duplicates, i.e. equal parameters, kept once)."""
    sampled = spec.samples.params if spec.samples else {}
    for sec, keys in (("set", spec.set), ("grid", spec.grid), ("samples", sampled)):
        for k in keys:
            try:
                parse_path(k)
            except ValueError as e:
                raise SweepError(f"{sweep_file}: {sec}: {k}: {e}") from None
    base_data = base.model_dump(mode="json", exclude_unset=True)
    try:
        fixed, set_locs = apply_params(base_data, {k: _norm(v) for k, v in spec.set.items()})
    except ValueError as e:
        raise SweepError(f"{sweep_file}: set: {e}") from None
    section = {**dict.fromkeys(spec.grid, "grid"), **dict.fromkeys(sampled,
                                                                   "samples")}
    variants: dict[str, Variant] = {}
    for params in parameter_sets(spec):
        vid = variant_id(params)
        if vid in variants:
            continue
        try:
            data, locs = apply_params(fixed, params)
        except ParamError as e:
            raise SweepError(f"{sweep_file}: {section[e.path]}: {e}") from None
        for k, loc in locs.items():
            also = next((s for s, sloc in set_locs.items() if sloc == loc), None)
            if also is not None:
                raise SweepError(f"{sweep_file}: {section[k]}: {k}: sets the same scenario field as set: {also}")
        data["name"] = f"{base.name}[{vid}]"
        try:
            sc = Scenario.model_validate(data)
        except ValidationError as e:
            first = e.errors()[0]
            loc = tuple(x for x in first["loc"] if not (isinstance(x, str) and x.startswith("function-")))
            named = {f"set: {k} = {json.dumps(spec.set[k])}": v for k, v in set_locs.items()}
            named.update({f"{section[k]}: {k} = {json.dumps(params[k])}": v for k, v in locs.items()})
            who = _culprit(loc, named) or "variant " + ", ".join(f"{k} = {json.dumps(v)}" for k, v in params.items())
            msg = format_validation("", e, None).removeprefix(": ").removeprefix("(top level): ")
            raise SweepError(f"{sweep_file}: {who}: {msg}") from None
        variants[vid] = Variant(vid, params, sc)
    return list(variants.values())


def parse_sweep(text: str, path: str) -> SweepSpec:
    return parse_yaml_model(text, path, SweepSpec, "sweep", SweepError)


def aeb_variants(variants: list[Variant], aeb: str | None) -> list[Variant]:
    """``variants`` with every scenario's ``ego.aeb`` switched (``sim.scenario.with_aeb``; None: as they are).

    The switch is part of each variant's scenario (its ``scenario.yaml`` and config hash), so a sweep
    resumed with another ``--aeb`` re-runs the variants whose scenario it changes instead of mixing them."""
    if aeb is None:
        return variants
    return [replace(v, scenario=with_aeb(v.scenario, aeb)) for v in variants]


def load_sweep(path: str | Path, aeb: str | None = None) -> tuple[SweepSpec, Path, list[Variant]]:
    """(spec, base scenario path, variants) of a sweep file; one-line ``SweepError`` when wrong.
    ``aeb`` (on | off) switches every variant's AEB (``aeb_variants``)."""
    p = Path(path)
    spec = parse_sweep(read_text_file(p, "sweep", SweepError), str(p))
    base_path = (p.parent / spec.scenario).resolve()
    if not base_path.is_file():
        raise SweepError(f"{p}: scenario: no such scenario file {base_path}")
    base = load_scenario(base_path)
    return spec, base_path, aeb_variants(expand(spec, base, str(p)), aeb)
