"""Perception settings as a scenario (or any other caller) gives them: detector, tracker,
estimator and preprocessing, validated, plus where the shipped detector lives.

``DetectorSpec`` and ``PerceptionSpec`` are embedded in ``sim.scenario.Scenario`` (which
re-exports them) and read by ``intent.stack.build_stack``. ``tracker`` and ``estimator`` stay
plain mappings of overrides (what the runner, sweeps and run.json see), checked on load by
building the real config, so a typo is a located one-line error instead of a crash at run time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from pydantic_core import core_schema

from lookahead.perception.detectors.gt_detector import GtNoiseConfig
from lookahead.perception.detectors.windows import DEFAULT_WINDOWS, check_windows
from lookahead.perception.estimator import EstimatorConfig
from lookahead.perception.preprocess import PreprocessConfig
from lookahead.perception.tracker import TrackerConfig

#: The shipped detector (see ``models/MODEL_CARD.md``), found in the ``lookahead.models`` data package.
DEFAULT_MODEL = Path(str(files("lookahead.models"))) / "lookahead-det.onnx"


class SettingsError(ValueError):
    """Settings that cannot be used together; ``str()`` is one line naming the field and the problem."""


def relocated(err: ValidationError, prefix: tuple) -> ValidationError:
    """``err`` with ``prefix`` put in front of every error location."""
    return ValidationError.from_exception_data(err.title, [
        {"type": e["type"], "loc": (*prefix, *e["loc"]), "input": e["input"], **({"ctx": e["ctx"]} if "ctx" in e else {})}
        for e in err.errors(include_url=False)
    ])


@dataclass(frozen=True)
class Overrides:
    """Annotation of a ``dict`` field holding overrides of a config: ``check`` validates them
    (raising the config's own ``ValidationError``, so errors carry the key's location) and
    returns the dict to keep; the JSON Schema is that of ``model``. ``partial``: nested
    mappings may be given in part (they are merged into the defaults, as ``intent`` is)."""

    check: Callable[[dict], dict]
    model: type[BaseModel]
    partial: bool = False

    def __get_pydantic_core_schema__(self, source: Any, handler: Any) -> Any:
        return core_schema.no_info_after_validator_function(self.check, handler(source))

    def __get_pydantic_json_schema__(self, schema: Any, handler: Any) -> Any:
        js = handler(self.model.__pydantic_core_schema__)
        if self.partial:
            seen: set[str] = set()

            def optional(node: Any) -> None:
                if isinstance(node, dict):
                    if "$ref" in node and node["$ref"] not in seen:
                        seen.add(node["$ref"])
                        optional(handler.resolve_ref_schema(node))
                    node.pop("required", None)
                    for v in node.values():
                        optional(v)
                elif isinstance(node, list):
                    for v in node:
                        optional(v)

            optional(js)
        return js


def _check_tracker(v: dict) -> dict:
    return TrackerConfig.model_validate(v).model_dump(exclude_unset=True)  # the given keys, coerced


def _check_estimator(v: dict) -> dict:
    EstimatorConfig.model_validate(v)
    return v


TrackerOverrides = Annotated[dict[str, Any], Overrides(_check_tracker, TrackerConfig)]
EstimatorOverrides = Annotated[dict[str, Any], Overrides(_check_estimator, EstimatorConfig)]


class DetectorSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    kind: Literal["auto", "gt", "onnx", "hog", "plugin"] = Field(
        "auto", description="auto: onnx (the shipped model) when rendering, else gt; hog: OpenCV's HOG people "
        "detector (perception.detectors.hog_detector, pedestrians only, options: HogConfig); plugin: your own "
        "(plugin, options; docs/plugins.md)",
    )
    model: str | None = Field(None, description="onnx model file; default models/lookahead-det.onnx")
    conf: float = Field(0.25, gt=0.0, lt=1.0, description="onnx: minimum detection score (calibrated, see calibration)")
    iou: float = Field(0.45, gt=0.0, le=1.0, description="onnx: per-class NMS IoU threshold")
    calibration: str | None = Field(
        None,
        description="onnx: score calibration file (lookahead calibrate-scores); default: <model>.scores.json beside "
        "the model when there is one (the shipped model needs none: it sets the scale); 'none': raw scores",
    )
    layout: Literal["auto", "yolov5", "yolov8", "yolox", "end2end"] = Field(
        "auto",
        description="onnx: output layout. yolov5 [1, N, 5+C] (also YOLOv7, decoded YOLOX); yolov8 [1, 4+C, N]; "
        "yolox: raw YOLOX [1, N, 5+C], one row per grid cell of strides 8, 16, 32, decoded here; end2end "
        "[1, N, 6] rows x1, y1, x2, y2, score, class id, NMS-free (YOLOv10, Ultralytics end2end/nms exports). "
        "auto: the model's metadata (layout / model_type, Ultralytics end2end), else the shape and class count "
        "(perception.detectors.onnx_detector)",
    )
    windows: list[Annotated[tuple[float, ...], Field(min_length=4, max_length=5)]] = Field(
        default_factory=lambda: list(DEFAULT_WINDOWS),
        description="onnx: zoom windows x0, y0, x1, y1 (fractions of the image) and an optional zoom (model-input "
        "px per image px; default: fit the model's input) the model also runs on, magnified; small objects whole "
        "inside a window are the most magnified one's to detect (perception.detectors.windows). "
        "Default: the middle half around the horizon (2x at 640 x 360); [] for the whole frame only",
    )
    threads: int = Field(
        0, ge=0, le=256,
        description="onnx: inference threads; 0: auto (1 in the simulator's rendered loop, whose other core "
        "renders the next frame; else onnxruntime's default, one per core)",
    )
    noise: dict[str, float] = Field(default_factory=dict, description="gt detector noise model")
    plugin: str | None = Field(
        None, description="plugin: 'module:factory' (or 'file.py:factory') or the name of an entry point in group "
        "lookahead.detectors; the factory is called with options and returns an object with "
        "detect(image, truth=None) -> Detections (docs/plugins.md)",
    )
    options: dict[str, Any] = Field(
        default_factory=dict, description="keyword options: plugin: for its factory; hog: HogConfig fields"
    )

    @model_validator(mode="after")
    def _plugin(self) -> DetectorSpec:
        if self.kind == "plugin" and not (self.plugin or "").strip():
            raise ValueError("kind plugin needs plugin: 'module:factory' or an installed plug-in's name")
        if self.plugin is not None and self.kind != "plugin":
            raise ValueError(f"plugin is for kind plugin, not {self.kind}")
        if self.kind == "hog":
            from lookahead.perception.detectors.hog_detector import HogConfig

            try:
                HogConfig.model_validate(self.options)
            except ValidationError as e:
                raise relocated(e, ("options",)) from None
        elif self.options and self.kind != "plugin":
            raise ValueError(f"options are for kinds hog and plugin, not {self.kind}")
        return self

    @field_validator("windows", mode="after")
    @classmethod
    def _windows(cls, v: list[tuple[float, ...]]) -> list[tuple[float, ...]]:
        return list(check_windows(v))  # ValueError: which window, what was expected


class StackSpec(BaseModel):
    """A whole perception stack from a plug-in (frame -> tracks with range and velocity), under
    lookahead's intent and alerts (``intent.plugins.load_stack``; docs/plugins.md)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    plugin: str = Field(
        ..., min_length=1, description="'module:factory' (or 'file.py:factory') or the name of an entry point in "
        "group lookahead.stacks; the factory returns an object with process(frame, truth=None)",
    )
    options: dict[str, Any] = Field(default_factory=dict, description="keyword options for the factory")


class AppearanceSpec(BaseModel):
    """Appearance features for the tracker's re-identification (``perception.embedder``): an ONNX
    embedder run on the detections the tracker asks for (``Tracker.features_needed``: lost
    tracks that could be re-found, galleries due for a refresh), on rendered or real frames only."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    enabled: bool = Field(False, description="run the embedder and re-identify lost tracks by appearance")
    model: str | None = Field(None, description="ONNX embedder; default models/reid-mobilenetv2.onnx")


class PerceptionSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    detector: DetectorSpec = Field(default_factory=DetectorSpec)
    appearance: AppearanceSpec = Field(default_factory=AppearanceSpec)
    stack: StackSpec | None = Field(
        None, description="a stack plug-in that replaces detector, tracker and estimator (docs/plugins.md); "
        "intent and alerts stay lookahead's",
    )
    tracker: TrackerOverrides = Field(default_factory=dict, description="perception.tracker.TrackerConfig overrides")
    estimator: EstimatorOverrides = Field(
        default_factory=dict, description="perception.estimator.EstimatorConfig overrides"
    )
    preprocess: PreprocessConfig = Field(
        default_factory=PreprocessConfig,
        description="image preprocessing before the detector (perception.preprocess); default: none",
    )
    latency: int = Field(
        0, ge=0, le=10,
        description="perception latency (camera frames): a frame's outputs reach the ego's AEB and driver, and its "
        "warnings the driver, this many frames after it was captured. 0: at the frame itself (every decision acts "
        "from the frame's own tick); 1: one frame later, as a camera pipeline that perceives frame k while frame "
        "k+1 is exposed. Simulated runs render frame k+1 while perceiving frame k whenever that cannot change the "
        "run (always with latency >= 1)",
    )

    @model_validator(mode="after")
    def _noise_model(self) -> PerceptionSpec:
        try:  # the gt detector's noise model, checked whatever the detector kind
            GtNoiseConfig.model_validate(self.detector.noise)
        except ValidationError as e:
            raise relocated(e, ("detector", "noise")) from None
        return self

    def tracker_config(self) -> TrackerConfig:
        """The tracker's settings: its defaults with ``tracker`` applied."""
        return TrackerConfig.model_validate(self.tracker)

    def estimator_config(self) -> EstimatorConfig:
        """The estimator's settings: its defaults with ``estimator`` applied."""
        return EstimatorConfig.model_validate(self.estimator)
