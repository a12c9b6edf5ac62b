"""Image preprocessing before detection: a registry of named operators run as a chain behind a low-contrast gate.

Operators (images are RGB uint8 H x W x 3 in and out; OpenCV colour codes are
used only inside the operators):

* ``clahe`` -- dehaze by CLAHE (contrast-limited adaptive histogram
  equalisation) on the luminance channel only: Y of YCrCb by default
  (``space: ycrcb``) or L of CIE Lab (``space: lab``). The chroma channels are
  left untouched, so hue is kept. YCrCb is the default because its round trip
  is cheap (about 1.3 ms per 640x360 frame in all against 3.3 ms for Lab, most
  of it Lab -> RGB); Lab's L is more perceptually uniform, for those who want it.
  ``clip_limit`` is OpenCV's (contrast limit per tile histogram, relative to a
  flat histogram), ``tile`` the grid side (tile x tile tiles).
* ``median`` -- derain / denoise by a ``ksize`` x ``ksize`` median filter per
  channel (odd 3-9). It removes salt-and-pepper noise and streaks thinner than
  half the window while keeping step edges, unlike a mean or Gaussian blur.
  Cost grows fast: 3 -> 0.2 ms, 5 -> 1.7 ms, 7 -> 16 ms per 640x360 frame.
* ``gamma`` -- ``out = round(255 * (in / 255) ** gamma)`` per channel through a
  256-entry look-up table built once; ``gamma < 1`` brightens (dark or night
  frames), ``gamma > 1`` darkens -- after CLAHE on a washed-out hazy frame
  1.3-1.5 restores more global contrast than 0.8 does (p99-p1 span 50 -> 79
  with clahe 3 + gamma 1.5, 50 -> 47 with clahe 2 + gamma 0.8 on a
  synthetic-haze render). CLAHE with high clip limits draws faint tile fans
  on flat sky and walls; the median thins 1-px poles at distance.

The **low-contrast gate** (the seed's ``auto_gate``) skips the whole chain
when the frame already has enough contrast. Its span measure is robust:
``p_hi - p_lo`` of the grey levels (BT.601 luma, OpenCV's RGB -> GRAY) with
percentiles ``[1, 99]`` by default, taken from a histogram of every
``stride``-th pixel in each direction (inverted-CDF percentiles: the smallest
grey level whose cumulative count reaches the share). The seed's max - min
is ``percentiles: [0, 100]``; it is fragile -- one specular highlight, hot
pixel or bright rain streak makes any foggy frame look contrasty. The chain
is skipped when ``span > span_above``. Default threshold 100 grey levels:
clear rendered frames measure about 156, synthetic haze 90-100 (light) to
about 50 (thick).

Build a chain from a config (a mapping as in the scenario YAML, or
``PreprocessConfig``)::

    chain = PreprocessChain({
        "chain": [{"op": "clahe", "clip_limit": 2.0, "tile": 8},
                  {"op": "median", "ksize": 3},
                  {"op": "gamma", "gamma": 0.8}],
        "gate": {"span_above": 100, "percentiles": [1, 99]},
    })
    out = chain(rgb)          # RGB uint8 in, RGB uint8 out (None passes through)
    chain.last_skipped        # True when the gate found enough contrast
    chain.last_span           # the gate's span measure for the last frame

An unknown op or a bad parameter raises ``ValueError`` with one line naming
the op and the field. New operators register a params model and a factory::

    class BlurParams(OpParams):
        ksize: int = 3

    @register("blur", BlurParams)
    class Blur(Op):
        def __init__(self, params: BlurParams) -> None:
            self.k = params.ksize
        def apply(self, src, dst):
            cv2.blur(src, (self.k, self.k), dst=dst)

**Devices.** ``device: auto`` (default) uses OpenCV's CUDA operators when
``cv2.cuda.getCudaEnabledDeviceCount() > 0`` (guarded: pip's opencv builds
have no CUDA device, some lack the attribute) and the CPU ones otherwise;
``cpu`` forces the CPU; ``cuda`` demands a device. The CUDA branch is kept
deliberately small and is *not exercised here* (no CUDA build on the test
machines): each CUDA op uploads, runs its ``cv2.cuda`` routine and downloads
again; an op whose CUDA version cannot be built falls back to the CPU.
CUDA and CPU CLAHE differ slightly in rounding, so bit-identical runs need
the same device.

**Hot path.** Look-up tables, CLAHE objects and intermediate buffers are made
once (buffers again only when the frame size changes); the chain's result
is a fresh array unless ``out=`` is given, so callers may keep it. Measured
at 640x360 on the dev machine (CPU, OpenCV 5.0 with 2 threads), ms per frame:
gate 0.25, clahe 1.3, median(3) 0.2, gamma 0.3; clahe -> median -> gamma
behind the gate 2.2 when it runs, 0.3 when the gate skips. Not thread-safe:
one chain per thread.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from pydantic_core import core_schema

log = logging.getLogger(__name__)

Device = Literal["auto", "cpu", "cuda"]


# --------------------------------------------------------------------------- registry


class OpParams(BaseModel):
    """Base of every operator's typed parameters (unknown fields are errors)."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Op:
    """One preprocessing operator: ``apply(src, dst)`` writes the result of ``src`` into ``dst``.

    ``src`` and ``dst`` are distinct RGB uint8 H x W x 3 arrays of the same
    shape. ``__call__(rgb)`` is the allocating convenience form.
    """

    device: str = "cpu"

    def apply(self, src: np.ndarray, dst: np.ndarray) -> None:
        raise NotImplementedError

    def __call__(self, rgb: np.ndarray) -> np.ndarray:
        _check_rgb(rgb)
        dst = np.empty_like(rgb)
        self.apply(rgb, dst)
        return dst


OpFactory = Callable[[Any], Op]


@dataclass
class OpInfo:
    """A registered operator: its params model and one factory per device."""

    name: str
    params: type[OpParams]
    factories: dict[str, OpFactory] = field(default_factory=dict)


_REGISTRY: dict[str, OpInfo] = {}


def register(name: str, params: type[OpParams], *, device: Literal["cpu", "cuda"] = "cpu") -> Callable:
    """Decorator: register ``factory(params) -> Op`` (usually an ``Op`` class) as ``name`` on ``device``.

    Every op needs a CPU factory; a CUDA one is optional. Registering the same
    name and device twice, or one name with two params models, is an error.
    """
    if not isinstance(params, type) or not issubclass(params, OpParams):
        raise TypeError(f"register({name!r}): params must be an OpParams subclass, got {params!r}")

    def deco(factory: OpFactory) -> OpFactory:
        info = _REGISTRY.setdefault(name, OpInfo(name, params))
        if info.params is not params:
            raise ValueError(f"op {name!r} is registered with params {info.params.__name__}, not {params.__name__}")
        if device in info.factories:
            raise ValueError(f"op {name!r} already has a {device} implementation")
        info.factories[device] = factory
        return factory

    return deco


def registered_ops() -> tuple[str, ...]:
    """Names of the registered operators, sorted."""
    return tuple(sorted(_REGISTRY))


def op_info(name: str) -> OpInfo:
    """The registry entry of ``name``; ``ValueError`` naming the known ops otherwise."""
    info = _REGISTRY.get(name) if isinstance(name, str) else None
    if info is None or "cpu" not in info.factories:
        raise ValueError(f"unknown preprocess op {name!r} (known: {', '.join(registered_ops())})")
    return info


def _first_error(err: ValidationError) -> tuple[str, str]:
    """(field path, message) of a pydantic error, one line."""
    e = err.errors()[0]
    path = ".".join(str(x) if not isinstance(x, int) else f"[{x}]" for x in e["loc"]).replace(".[", "[")
    if e["type"] == "extra_forbidden":
        msg = "unknown field"
    else:
        msg = e["msg"].removeprefix("Value error, ")
        if "input" in e and e["type"] != "missing" and not isinstance(e["input"], dict | list):
            msg += f", got {e['input']!r}"
    more = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    return path, msg + more


def parse_params(name: str, values: Mapping[str, Any]) -> OpParams:
    """Validate ``values`` as the params of op ``name``; one-line ``ValueError`` naming op and field."""
    info = op_info(name)
    try:
        return info.params.model_validate(dict(values))
    except ValidationError as e:
        path, msg = _first_error(e)
        if e.errors()[0]["type"] == "extra_forbidden":
            msg = f"unknown parameter (known: {', '.join(info.params.model_fields)})"
        raise ValueError(f"{name}: {path}: {msg}") from None


@dataclass(frozen=True)
class OpStep:
    """One validated chain entry: the op name and its typed params.

    In YAML / JSON it is one flat mapping: ``{op: clahe, clip_limit: 2.0, tile: 8}``.
    """

    op: str
    params: OpParams

    @classmethod
    def parse(cls, value: Any) -> OpStep:
        if isinstance(value, OpStep):
            return value
        if not isinstance(value, Mapping):
            raise ValueError(f"a chain step is a mapping like {{op: median, ksize: 3}}, got {value!r}")
        if "op" not in value:
            raise ValueError(f"a chain step needs 'op' (one of: {', '.join(registered_ops())})")
        name = value["op"]
        return cls(name, parse_params(name, {k: v for k, v in value.items() if k != "op"}))

    def to_dict(self) -> dict[str, Any]:
        return {"op": self.op, **self.params.model_dump(mode="json")}

    def __str__(self) -> str:
        args = ", ".join(f"{k}={v}" for k, v in self.params.model_dump(mode="json").items())
        return f"{self.op}({args})"

    @classmethod
    def __get_pydantic_core_schema__(cls, source: Any, handler: Any) -> core_schema.CoreSchema:
        return core_schema.no_info_plain_validator_function(
            cls.parse, serialization=core_schema.plain_serializer_function_ser_schema(lambda s: s.to_dict())
        )

    @classmethod
    def __get_pydantic_json_schema__(cls, schema: Any, handler: Any) -> dict[str, Any]:
        variants = []
        for name in registered_ops():
            ps = _REGISTRY[name].params.model_json_schema()
            variants.append({
                "type": "object",
                "title": name,
                "description": (ps.get("description") or "").strip(),
                "properties": {"op": {"const": name}, **ps.get("properties", {})},
                "required": ["op", *ps.get("required", [])],
                "additionalProperties": False,
            })
        return {"oneOf": variants, "description": "one operator: {op: NAME, ...its parameters}"}


# --------------------------------------------------------------------------- config


class GateConfig(BaseModel):
    """Low-contrast gate: run the chain only when ``p_hi - p_lo`` of the grey levels is at most ``span_above``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    span_above: float = Field(
        100.0, ge=0.0, le=255.0, description="skip the chain when the grey-level span exceeds this (0-255)"
    )
    percentiles: tuple[float, float] = Field(
        (1.0, 99.0), description="[low, high] percentiles of the span; [0, 100] = max - min (fragile)"
    )
    stride: int = Field(2, ge=1, le=16, description="histogram every stride-th pixel in each direction")

    @field_validator("percentiles")
    @classmethod
    def _ordered(cls, v: tuple[float, float]) -> tuple[float, float]:
        lo, hi = v
        if not (0.0 <= lo < hi <= 100.0):
            raise ValueError(f"need 0 <= low < high <= 100, got [{lo}, {hi}]")
        return v


class PreprocessConfig(BaseModel):
    """The preprocessing chain of a camera; the default (empty chain) does nothing."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    chain: list[OpStep] = Field(default_factory=list, description="operators applied in order")
    gate: GateConfig | None = Field(None, description="low-contrast gate; absent = always run the chain")
    device: Device = Field("auto", description="auto: OpenCV CUDA when a device is present, else CPU")


def parse_config(config: PreprocessConfig | Mapping[str, Any] | Sequence[Any] | None) -> PreprocessConfig:
    """A ``PreprocessConfig`` from a config, a mapping or a bare chain list; one-line ``ValueError`` if bad."""
    if isinstance(config, PreprocessConfig):
        return config
    if isinstance(config, list | tuple):
        config = {"chain": list(config)}
    try:
        return PreprocessConfig.model_validate(config if config is not None else {})
    except ValidationError as e:
        path, msg = _first_error(e)
        raise ValueError(f"preprocess.{path}: {msg}" if path else f"preprocess: {msg}") from None


# --------------------------------------------------------------------------- devices


def cuda_available() -> bool:
    """Whether OpenCV has a usable CUDA device (False on builds without ``cv2.cuda``)."""
    try:
        return cv2.cuda.getCudaEnabledDeviceCount() > 0
    except (AttributeError, cv2.error):
        return False


def resolve_device(device: str) -> str:
    """``auto`` -> ``cuda`` or ``cpu``; ``cuda`` without a device is a ``ValueError``."""
    if device == "cpu":
        return "cpu"
    has = cuda_available()
    if device == "cuda" and not has:
        raise ValueError("preprocess.device: cuda requested but OpenCV reports no CUDA device")
    if device not in ("auto", "cuda"):
        raise ValueError(f"preprocess.device: expected auto, cpu or cuda, got {device!r}")
    return "cuda" if has else "cpu"


def build_op(step: OpStep, device: str = "cpu") -> Op:
    """Instantiate ``step`` on ``device`` (``cpu``/``cuda``/``auto``); CPU when the CUDA version is missing or fails."""
    info = op_info(step.op)
    dev = resolve_device(device)
    if dev == "cuda" and "cuda" in info.factories:
        try:
            return info.factories["cuda"](step.params)
        except (AttributeError, cv2.error) as e:  # a CUDA build without the needed module
            log.warning("preprocess op %s: CUDA version unavailable (%s); using the CPU", step.op, e)
    return info.factories["cpu"](step.params)


def make_op(name: str, device: str = "cpu", **params: Any) -> Op:
    """One operator by name, e.g. ``make_op("median", ksize=3)``."""
    return build_op(OpStep(name, parse_params(name, params)), device)


# --------------------------------------------------------------------------- operators


def _check_rgb(rgb: Any) -> None:
    if not isinstance(rgb, np.ndarray) or rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        desc = f"shape {getattr(rgb, 'shape', None)} dtype {getattr(rgb, 'dtype', type(rgb).__name__)}"
        raise ValueError(f"preprocess: expected an RGB uint8 H x W x 3 image, got {desc}")


class ClaheParams(OpParams):
    """CLAHE on the luminance channel (dehaze / local contrast)."""

    clip_limit: float = Field(2.0, gt=0.0, le=40.0, description="OpenCV clip limit (contrast cap per tile)")
    tile: int = Field(8, ge=1, le=64, description="grid side: tile x tile tiles")
    space: Literal["ycrcb", "lab"] = Field("ycrcb", description="luminance of YCrCb (Y, faster) or Lab (L)")


_SPACES = {"ycrcb": (cv2.COLOR_RGB2YCrCb, cv2.COLOR_YCrCb2RGB), "lab": (cv2.COLOR_RGB2Lab, cv2.COLOR_Lab2RGB)}


@register("clahe", ClaheParams)
class Clahe(Op):
    def __init__(self, params: ClaheParams) -> None:
        self.params = params
        self._clahe = cv2.createCLAHE(clipLimit=params.clip_limit, tileGridSize=(params.tile, params.tile))
        self._fwd, self._inv = _SPACES[params.space]
        self._conv = np.empty((0, 0, 3), np.uint8)
        self._lum = self._lum2 = np.empty((0, 0), np.uint8)

    def apply(self, src: np.ndarray, dst: np.ndarray) -> None:
        if self._conv.shape != src.shape:
            self._conv = np.empty_like(src)
            self._lum = np.empty(src.shape[:2], np.uint8)
            self._lum2 = np.empty(src.shape[:2], np.uint8)
        cv2.cvtColor(src, self._fwd, dst=self._conv)
        cv2.extractChannel(self._conv, 0, dst=self._lum)
        self._clahe.apply(self._lum, dst=self._lum2)
        cv2.insertChannel(self._lum2, self._conv, 0)
        cv2.cvtColor(self._conv, self._inv, dst=dst)


class MedianParams(OpParams):
    """Median filter per channel (derain / salt-and-pepper)."""

    ksize: int = Field(3, ge=3, le=9, description="odd window side, 3-9 (7 and up are slow on uint8 RGB)")

    @field_validator("ksize")
    @classmethod
    def _odd(cls, v: int) -> int:
        if v % 2 == 0:
            raise ValueError("must be odd")
        return v


@register("median", MedianParams)
class Median(Op):
    def __init__(self, params: MedianParams) -> None:
        self.params = params

    def apply(self, src: np.ndarray, dst: np.ndarray) -> None:
        cv2.medianBlur(src, self.params.ksize, dst=dst)


class GammaParams(OpParams):
    """Gamma curve out = 255 * (in / 255) ** gamma via a look-up table."""

    gamma: float = Field(1.0, gt=0.0, le=10.0, description="exponent; < 1 brightens, > 1 darkens")


def gamma_lut(gamma: float) -> np.ndarray:
    """The 256-entry uint8 table ``round(255 * (i / 255) ** gamma)``."""
    x = np.arange(256, dtype=np.float64) / 255.0
    return np.clip(np.rint(255.0 * x**gamma), 0, 255).astype(np.uint8)


@register("gamma", GammaParams)
class Gamma(Op):
    def __init__(self, params: GammaParams) -> None:
        self.params = params
        self.lut = gamma_lut(params.gamma)

    def apply(self, src: np.ndarray, dst: np.ndarray) -> None:
        cv2.LUT(src, self.lut, dst=dst)


class _CudaOp(Op):
    """Minimal CUDA form: upload, ``_run(GpuMat) -> GpuMat``, download (one round trip per op)."""

    device = "cuda"

    def __init__(self) -> None:
        self._gpu = cv2.cuda_GpuMat()

    def _run(self, g: Any) -> Any:
        raise NotImplementedError

    def apply(self, src: np.ndarray, dst: np.ndarray) -> None:
        self._gpu.upload(np.ascontiguousarray(src))
        dst[...] = self._run(self._gpu).download()


@register("clahe", ClaheParams, device="cuda")
class ClaheCuda(_CudaOp):
    def __init__(self, params: ClaheParams) -> None:
        super().__init__()
        self._clahe = cv2.cuda.createCLAHE(params.clip_limit, (params.tile, params.tile))
        self._fwd, self._inv = _SPACES[params.space]

    def _run(self, g: Any) -> Any:
        ch = list(cv2.cuda.split(cv2.cuda.cvtColor(g, self._fwd)))
        ch[0] = self._clahe.apply(ch[0], cv2.cuda.Stream_Null())
        return cv2.cuda.cvtColor(cv2.cuda.merge(ch), self._inv)


@register("median", MedianParams, device="cuda")
class MedianCuda(_CudaOp):
    def __init__(self, params: MedianParams) -> None:
        super().__init__()
        self._filter = cv2.cuda.createMedianFilter(cv2.CV_8UC1, params.ksize)  # single-channel only

    def _run(self, g: Any) -> Any:
        return cv2.cuda.merge([self._filter.apply(c) for c in cv2.cuda.split(g)])


@register("gamma", GammaParams, device="cuda")
class GammaCuda(_CudaOp):
    def __init__(self, params: GammaParams) -> None:
        super().__init__()
        self._lut = cv2.cuda.createLookUpTable(gamma_lut(params.gamma).reshape(1, 256))

    def _run(self, g: Any) -> Any:
        return self._lut.transform(g)


# --------------------------------------------------------------------------- gate and chain


class LowContrastGate:
    """Grey-level span ``p_hi - p_lo`` of a frame and the skip decision (``span > span_above``)."""

    def __init__(self, config: GateConfig) -> None:
        self.config = config
        self._q = (config.percentiles[0] / 100.0, config.percentiles[1] / 100.0)
        self._grey = np.empty((0, 0), np.uint8)
        self._hist = np.zeros((256, 1), np.float32)
        self._cdf = np.zeros(256, np.float64)

    def span(self, rgb: np.ndarray) -> float:
        """``p_hi - p_lo`` of the BT.601 grey levels (0-255) over every ``stride``-th pixel."""
        if self._grey.shape != rgb.shape[:2]:
            self._grey = np.empty(rgb.shape[:2], np.uint8)
        cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY, dst=self._grey)
        s = self.config.stride
        hist = cv2.calcHist([self._grey[::s, ::s]], [0], None, [256], [0, 256], hist=self._hist)
        np.cumsum(hist[:, 0], out=self._cdf)
        n = self._cdf[-1]
        lo = np.searchsorted(self._cdf, max(math.ceil(self._q[0] * n), 1.0))
        hi = np.searchsorted(self._cdf, max(math.ceil(self._q[1] * n), 1.0))
        return float(hi - lo)

    def skip(self, rgb: np.ndarray) -> tuple[bool, float]:
        """(skip the chain?, span)."""
        s = self.span(rgb)
        return s > self.config.span_above, s


def grey_span(rgb: np.ndarray, percentiles: tuple[float, float] = (1.0, 99.0), stride: int = 1) -> float:
    """The gate's span measure for one image (convenience; the gate reuses its buffers)."""
    _check_rgb(rgb)
    return LowContrastGate(GateConfig(percentiles=percentiles, stride=stride)).span(rgb)


class PreprocessChain:
    """The configured operators behind the low-contrast gate: ``chain(rgb) -> rgb``.

    ``None`` passes through (frames without an image). An empty chain returns
    its input unchanged at no cost; so does a gate skip (the *same* array --
    don't modify it). Otherwise the result is a new array (or ``out``).
    After each call: ``last_ran`` (the operators ran), ``last_skipped`` (the
    gate skipped them), ``last_span`` (gate measure or None), ``last_ms``
    (``{"gate": ms, "<i>.<op>": ms}``); ``stats()`` counts frames.
    """

    def __init__(
        self, config: PreprocessConfig | Mapping[str, Any] | Sequence[Any] | None = None,
        device: Device | None = None,
    ) -> None:
        self.config = parse_config(config)
        self.device = resolve_device(device or self.config.device) if self.config.chain else "cpu"
        self.steps = list(self.config.chain)
        self.ops = [build_op(s, self.device) for s in self.steps]
        self._keys = [f"{i}.{s.op}" for i, s in enumerate(self.steps)]
        self.gate = LowContrastGate(self.config.gate) if self.config.gate is not None else None
        self._bufs: list[np.ndarray] = []
        self.last_ran = False
        self.last_skipped = False
        self.last_span: float | None = None
        self.last_ms: dict[str, float] = {}
        self.frames = self.ran = self.skipped = 0

    @property
    def enabled(self) -> bool:
        return bool(self.ops)

    def __repr__(self) -> str:
        ops = " -> ".join(str(s) for s in self.steps) or "(empty)"
        g = self.config.gate
        gate = f"; gate span > {g.span_above:g} over p{g.percentiles[0]:g}-p{g.percentiles[1]:g}" if g else ""
        return f"PreprocessChain({ops}{gate}; {self.device})"

    def stats(self) -> dict[str, int]:
        return {"frames": self.frames, "ran": self.ran, "skipped": self.skipped}

    def __call__(self, rgb: np.ndarray | None, out: np.ndarray | None = None) -> np.ndarray | None:
        self.last_ran = self.last_skipped = False
        self.last_span = None
        if rgb is None or not self.ops:
            if rgb is not None and out is not None:
                np.copyto(out, rgb)
                return out
            return rgb
        _check_rgb(rgb)
        self.frames += 1
        ms = self.last_ms = {}
        if self.gate is not None:
            t0 = time.perf_counter()
            skip, self.last_span = self.gate.skip(rgb)
            ms["gate"] = (time.perf_counter() - t0) * 1e3
            if skip:
                self.last_skipped = True
                self.skipped += 1
                if out is not None:
                    np.copyto(out, rgb)
                    return out
                return rgb
        if out is None or np.shares_memory(out, rgb):
            final = np.empty_like(rgb)
        else:
            if out.shape != rgb.shape or out.dtype != np.uint8:
                raise ValueError(f"preprocess: out must be uint8 {rgb.shape}, got {out.dtype} {out.shape}")
            final = out
        n = len(self.ops)
        if n > 1 and (not self._bufs or self._bufs[0].shape != rgb.shape):
            self._bufs = [np.empty_like(rgb) for _ in range(min(2, n - 1))]
        src = rgb
        for i, op in enumerate(self.ops):
            dst = final if i == n - 1 else self._bufs[i % 2]
            t0 = time.perf_counter()
            op.apply(src, dst)
            ms[self._keys[i]] = (time.perf_counter() - t0) * 1e3
            src = dst
        self.last_ran = True
        self.ran += 1
        if out is not None and final is not out:
            np.copyto(out, final)
            return out
        return final


__all__ = [
    "ClaheParams", "GammaParams", "GateConfig", "LowContrastGate", "MedianParams", "Op", "OpInfo", "OpParams",
    "OpStep", "PreprocessChain", "PreprocessConfig", "build_op", "cuda_available", "gamma_lut", "grey_span",
    "make_op", "op_info", "parse_config", "parse_params", "register", "registered_ops", "resolve_device",
]
