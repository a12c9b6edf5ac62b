"""Perception-stack plug-ins: your own detector + tracker + range/velocity estimator, with
lookahead's intent (labels, risk, alerts) on top.

A stack plug-in is a factory (``module:factory``, ``file.py:factory`` or an entry point of group
``lookahead.stacks``; resolved as detector plug-ins are, ``perception.plugins``) called with
keyword options plus ``camera`` (``perception.camera.CameraModel``) and ``frame_rate`` (frames/s)
when its signature takes them. It returns an object with::

    process(frame, truth=None) -> StackResult        # or (detections, tracks, estimates)

``frame`` is a ``perception.frame.Frame`` (image RGB uint8 or None, ``t``, ``odometry`` with the
ego's speed / yaw rate / accel, ``camera``); ``truth`` a ``DetectorTruth`` in the simulator, None
on real video (a plug-in whose ``process`` takes only ``frame`` is called so). ``StackResult``
holds N tracks (``perception.tracker.Tracks``: id, box, class, score, age ...) and per track the
ego-frame range (m, nearest point's x), lateral offset (m, left +), range rate and lateral rate
(m/s, relative to the ego); what it leaves out (half width, ground velocity, TTC) is derived.
Expert plug-ins may return the first three values of ``intent.stack.PerceptionStack.process``
instead: ``(Detections, Tracks, Estimates)``.

``PluginStack`` puts the plug-in behind ``PerceptionStack``'s interface (``process(frame, truth,
timings)`` -> detections, tracks, estimates, assessment, alerts; ``critical_in_path``; ``alerts``),
so the closed-loop runner, replay and ``watch`` can drive it unchanged; each result is checked
(types, lengths, NaN) and any failure is a one-line ``PluginError``.
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from lookahead.intent.alerts import AlertConfig, AlertManager
from lookahead.intent.config import IntentConfig
from lookahead.intent.gestures import GestureRecognizer
from lookahead.intent.labels import Kinematics
from lookahead.intent.stack import PerceptionStack
from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import CLASSES, Detections
from lookahead.perception.detectors.base import DetectorTruth
from lookahead.perception.estimator import Estimates, Estimator
from lookahead.perception.frame import Frame
from lookahead.perception.plugins import (
    STACK_GROUP,
    PluginError,
    call_plugin,
    check_detections,
    load_plugin,
    resolve,
)
from lookahead.perception.tracker import Tracks


@dataclass
class StackResult:
    """One frame of a stack plug-in: N tracks and their motion in the ego frame (ISO 8855: x
    forward, y left; relative to the ego, as ``perception.estimator.Estimates``).

    Attributes:
        tracks: the tracks (``Tracks``; ``age`` counts frames since birth: young tracks are
            ``initializing``).
        range: (N,) m, the nearest point's x.  lateral: (N,) m, the centre's y.
        range_rate, lateral_rate: (N,) m/s, d/dt of range and lateral.
        half_width: (N,) m, half the y extent; None = the class's prior width / 2.
        range_rate_sigma, lateral_sigma: (N,) stds (m/s, m); None = exact (as ground truth):
            CRITICAL alerts need sure estimates, so give them if yours are not.
        detections: this frame's detections (recorded and scored); None = the tracks' boxes.
    """

    tracks: Tracks
    range: np.ndarray
    lateral: np.ndarray
    range_rate: np.ndarray
    lateral_rate: np.ndarray
    half_width: np.ndarray | None = None
    range_rate_sigma: np.ndarray | None = None
    lateral_sigma: np.ndarray | None = None
    detections: Detections | None = None


def _takes(fn: Any, name: str) -> bool:
    """Whether ``fn`` names a keyword parameter ``name`` (a bare ``**options`` does not count)."""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == name and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) for p in params)


def _positional(fn: Any) -> int:
    try:
        params = list(inspect.signature(fn).parameters.values())
    except (TypeError, ValueError):
        return 2
    if any(p.kind == p.VAR_POSITIONAL for p in params):
        return 2
    return sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)


def _column(where: str, name: str, v: Any, n: int, finite: bool = True) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise PluginError(f"{where} returned {name} that is not numeric ({type(v).__name__})") from None
    if a.shape != (n,):
        raise PluginError(f"{where} returned {name} of shape {a.shape}, expected ({n},) (one per track)")
    if finite and n and not np.isfinite(a).all():
        raise PluginError(f"{where} returned NaN or infinite {name}")
    return a


class PluginStack(PerceptionStack):
    """A stack plug-in with lookahead's intent and alerts on top, driven like ``PerceptionStack``.

    Build it with ``load_stack``. ``detector`` is the plug-in object (``reconfigure`` sets its
    ``conf_threshold`` / ``iou_threshold`` when it has them); ``estimator`` only serves class priors.
    """

    def __init__(
        self, plugin: Any, ref: str, camera: CameraModel, frame_rate: float, intent_config: IntentConfig,
        alert_config: AlertConfig | None = None,
    ) -> None:
        process = getattr(plugin, "process", None)
        if not callable(process):
            raise PluginError(
                f"plug-in {ref!r}: its factory returned an object of type {type(plugin).__name__}, expected one "
                "with process(frame, truth=None) -> StackResult"
            )
        self.plugin = plugin
        self.ref = ref
        self.detector = plugin
        self.camera = camera
        self.frame_rate = frame_rate
        self.estimator = Estimator(camera)  # class priors (half widths, lengths) only
        self.intent_config = intent_config
        self.alerts = AlertManager(alert_config)
        self.fusion = None
        self.gestures = GestureRecognizer()
        self._process = process
        self._truth = _positional(process) >= 2
        self._where = f"stack plug-in {ref!r}: process"

    def process(
        self, frame: Frame, truth: DetectorTruth | None, timings: dict[str, float]
    ) -> tuple[Detections, Tracks, Estimates, Any, list]:
        """The plug-in on one frame, then intent and alerts; stage times (ms) into ``timings``
        (the plug-in's time is ``detect``; ``track`` and ``estimate`` are 0)."""
        t0 = time.perf_counter()
        out = call_plugin(self._where, self._process, frame, *((truth,) if self._truth else ()))
        t1 = time.perf_counter()
        dets, tracks, est, kin = self._checked(out, frame)
        assessment, alerts = self._intent(frame, tracks, est, kin)
        t2 = time.perf_counter()
        timings.update(preprocess=0.0, detect=(t1 - t0) * 1e3, track=0.0, estimate=0.0, intent=(t2 - t1) * 1e3)
        return dets, tracks, est, assessment, alerts

    def _checked(self, out: Any, frame: Frame) -> tuple[Detections, Tracks, Estimates, Kinematics]:
        where = self._where
        if isinstance(out, tuple) and len(out) == 3:
            dets, tracks, est = out
            if not isinstance(tracks, Tracks) or not isinstance(est, Estimates):
                raise PluginError(f"{where} returned a tuple of {', '.join(type(v).__name__ for v in out)}, "
                                  "expected (Detections, Tracks, Estimates)")
            check_detections(dets, where)
            n = len(tracks)
            for name in Estimates.KINEMATICS_FIELDS:
                _column(where, f"estimates.{name}", getattr(est, name), n, finite=False)
            _column(where, "estimates.range", est.range, n)
            kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
            self._check_classes(tracks)
            return dets, tracks, est, kin
        if not isinstance(out, StackResult):
            raise PluginError(f"{where} returned {type(out).__name__}, expected intent.plugins.StackResult "
                              "or (Detections, Tracks, Estimates)")
        tracks = out.tracks
        if not isinstance(tracks, Tracks):
            raise PluginError(f"{where} returned StackResult.tracks of type {type(tracks).__name__}, expected Tracks")
        n = len(tracks)
        if n and not np.isfinite(tracks.xyxy).all():
            raise PluginError(f"{where} returned NaN or infinite track boxes")
        self._check_classes(tracks)
        rng = _column(where, "range", out.range, n)
        lat = _column(where, "lateral", out.lateral, n)
        rr = _column(where, "range_rate", out.range_rate, n)
        lr = _column(where, "lateral_rate", out.lateral_rate, n)
        if out.half_width is None:
            hw = self.estimator.prior_of(tracks.class_id, "width") / 2.0
        else:
            hw = _column(where, "half_width", out.half_width, n)
        rr_sig = None if out.range_rate_sigma is None else _column(where, "range_rate_sigma", out.range_rate_sigma, n)
        lat_sig = None if out.lateral_sigma is None else _column(where, "lateral_sigma", out.lateral_sigma, n)
        odo = frame.odometry
        # over the ground, in ego axes: relative velocity + the ego's own (speed, and the yaw rate's sweep)
        gvx = rr + odo.speed - odo.yaw_rate * lat
        gvy = lr + odo.yaw_rate * rng
        with np.errstate(divide="ignore", invalid="ignore"):
            ttc = np.where(rr < 0, rng / -rr, np.inf)
        def nan() -> np.ndarray:  # unknown, as the estimator records it
            return np.full(n, np.nan)

        est = Estimates(
            range=rng, range_sigma=nan(), lateral=lat, half_width=hw, range_rate=rr, lateral_rate=lr,
            ground_vx=gvx, ground_vy=gvy, accel=nan(), yaw_rate=nan(), ttc=ttc,
            range_rate_sigma=nan() if rr_sig is None else rr_sig, settled=np.ones(n), ground_vx_sigma=nan(),
            ground_vy_sigma=nan(), lateral_sigma=nan() if lat_sig is None else lat_sig, accel_x=nan(),
            accel_x_sigma=nan(), height=self.estimator.prior_of(tracks.class_id, "height"),
        )
        kin = Kinematics(  # sigmas not given: exact, as ground truth (None)
            class_id=tracks.class_id, range=rng, lateral=lat, half_width=hw, range_rate=rr, lateral_rate=lr,
            ground_vx=gvx, ground_vy=gvy, accel=nan(), yaw_rate=nan(), age=tracks.age, range_rate_sigma=rr_sig,
            lateral_sigma=lat_sig, height=est.height,
        )
        if out.detections is None:
            dets = Detections(xyxy=tracks.xyxy, score=tracks.score, class_id=tracks.class_id)
        else:
            dets = check_detections(out.detections, where)
        return dets, tracks, est, kin

    def _check_classes(self, tracks: Tracks) -> None:
        if len(tracks) and (tracks.class_id.min() < 0 or tracks.class_id.max() >= len(CLASSES)):
            raise PluginError(f"{self._where} returned track class ids outside 0..{len(CLASSES) - 1} "
                              "(perception.detections.CLASSES)")


def load_stack(
    ref: str, options: Mapping[str, Any] | None, camera: CameraModel, frame_rate: float, *,
    intent: IntentConfig | Mapping[str, Any] | None = None, alerts: AlertConfig | None = None,
) -> PluginStack:
    """The stack plug-in ``ref`` (``module:factory`` or an entry point of ``lookahead.stacks``) made
    with ``options`` (plus ``camera`` and ``frame_rate`` when its factory takes them), with
    lookahead's intent (``intent``: config or overrides) and alerts on top; ``PluginError`` otherwise."""
    factory = resolve(ref, STACK_GROUP)
    opts = dict(options or {})
    for name, value in (("camera", camera), ("frame_rate", frame_rate)):
        if name not in opts and _takes(factory, name):
            opts[name] = value
    plugin = load_plugin(ref, STACK_GROUP, opts)
    if not isinstance(intent, IntentConfig):
        intent = IntentConfig().with_overrides(dict(intent or {}))
    return PluginStack(plugin, ref, camera, frame_rate, intent, alerts)
