"""The perception + intent stack of one camera, and the one factory that builds it from settings.

Per camera frame: preprocess -> detector -> tracker -> estimator -> ``intent.labels.assess``
-> ``intent.alerts.AlertManager``, each stage timed (ms). The closed-loop runner, the gym
env and replay all build it with ``build_stack`` from a scenario's ``perception``,
``intent`` and ``alerts`` settings. It knows nothing of the simulator: importing this
module loads neither highway-env, gymnasium nor PyBullet, so the stack runs on video too.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lookahead.intent.alerts import Alert, AlertConfig, AlertManager
from lookahead.intent.cipv import select_cipv
from lookahead.intent.config import IntentConfig
from lookahead.intent.cooperative import FusionStage
from lookahead.intent.gestures import GestureRecognizer
from lookahead.intent.labels import Assessment, Kinematics, Risk, assess
from lookahead.perception.camera import CameraModel
from lookahead.perception.config import DEFAULT_MODEL, DetectorSpec, PerceptionSpec, SettingsError
from lookahead.perception.detections import Detections
from lookahead.perception.detectors.base import Detector, DetectorTruth
from lookahead.perception.detectors.gt_detector import GtNoiseConfig, GtNoiseDetector
from lookahead.perception.detectors.onnx_detector import OnnxDetector
from lookahead.perception.embedder import AppearanceEmbedder
from lookahead.perception.estimator import Estimates, Estimator, EstimatorConfig
from lookahead.perception.frame import Frame
from lookahead.perception.preprocess import PreprocessChain
from lookahead.perception.tracker import Tracker, TrackerConfig, Tracks


def resolve_detector(spec: DetectorSpec, render: bool) -> DetectorSpec:
    """``kind: auto`` made concrete: the shipped ONNX model when frames carry images (``render``), else ``gt``."""
    kind = spec.kind if spec.kind != "auto" else ("onnx" if render else "gt")
    model = spec.model or (str(DEFAULT_MODEL) if kind == "onnx" else None)
    return spec.model_copy(update={"kind": kind, "model": model})


def build_detector(spec: DetectorSpec, seed: int, render: bool = True) -> Detector:
    """The detector of ``spec`` (``gt`` noise model seeded with ``seed``, an ``onnx`` model, see
    ``resolve_detector``, the ``hog`` people detector with ``spec.options``, or a ``plugin`` made
    with ``spec.options``, ``perception.plugins``); ``SettingsError`` for ``onnx`` or ``hog``
    without images (``render`` False); ``PluginError`` for a plug-in that cannot be made."""
    spec = resolve_detector(spec, render)
    if spec.kind == "plugin":
        from lookahead.perception.plugins import load_detector

        return load_detector(spec.plugin or "", spec.options)
    if spec.kind == "hog":
        if not render:
            raise SettingsError("perception.detector.kind: hog needs rendered frames, and rendering is off")
        from lookahead.perception.detectors.hog_detector import HogConfig, HogDetector

        return HogDetector(HogConfig.model_validate(spec.options))
    if spec.kind == "onnx":
        if not render:
            raise SettingsError("perception.detector.kind: onnx needs rendered frames, and rendering is off")
        from lookahead.perception.score_calibration import calibration_for

        return OnnxDetector(spec.model, conf_threshold=spec.conf, iou_threshold=spec.iou, windows=spec.windows,
                            layout=spec.layout, calibration=calibration_for(spec.model, spec.calibration),
                            threads=spec.threads)
    return GtNoiseDetector(GtNoiseConfig(**spec.noise), seed=seed)


class PerceptionStack:
    """Preprocess -> detector -> tracker -> estimator -> intent for one camera; each stage timed (ms).

    Knows nothing of the simulator: ``truth`` is only handed to simulated detectors.
    ``preprocess`` (``perception.preprocess.PreprocessChain``) feeds the detector
    only; ``frame.image`` stays the camera's image. Build it with ``build_stack``.
    """

    def __init__(
        self, detector: Detector, camera: CameraModel, frame_rate: float, intent_config: IntentConfig,
        tracker_config: TrackerConfig | None = None, estimator_config: EstimatorConfig | None = None,
        alert_config: AlertConfig | None = None, preprocess: PreprocessChain | None = None,
        embedder: AppearanceEmbedder | None = None,
    ) -> None:
        self.preprocess = preprocess or PreprocessChain()
        self.detector = detector
        self.embedder = embedder
        self.tracker = Tracker(tracker_config, frame_rate=frame_rate)
        self.estimator = Estimator(camera, estimator_config)
        self.intent_config = intent_config
        self.alerts = AlertManager(alert_config)
        self.fusion: FusionStage | None = None  # others' objects joined before intent (``intent.cooperative``)
        self.gestures = GestureRecognizer()  # pedestrians' gestures from their tracks' history

    def reconfigure(
        self, *, intent_config: IntentConfig | None = None, alert_config: AlertConfig | None = None,
        detector_conf: float | None = None, detector_iou: float | None = None,
    ) -> None:
        """New thresholds from the next ``process`` on (``intent.live_config``); what is None stays.

        Only settings read afresh every frame: the intent thresholds, the alerts' debounce and
        hysteresis, and the detector's score (``detector_conf``) and NMS IoU (``detector_iou``)
        thresholds. Tracks, their estimates and the alerts' per-track state are kept: a debounce
        under way counts on against the new ``on_frames``, an alert on stays on until the new
        thresholds and ``off_frames`` clear it. ``SettingsError``, and nothing changed, when the
        detector has no such threshold (e.g. the ``gt`` detector).
        """
        for arg, attr, value in (("detector_conf", "conf_threshold", detector_conf),
                                 ("detector_iou", "iou_threshold", detector_iou)):
            if value is not None and not hasattr(self.detector, attr):
                name = getattr(self.detector, "name", type(self.detector).__name__)
                raise SettingsError(f"{arg}: the detector {name} has no {attr.replace('_', ' ')} to set")
        if intent_config is not None:
            self.intent_config = intent_config
        if alert_config is not None:
            self.alerts.config = alert_config
        if detector_conf is not None:
            self.detector.conf_threshold = float(detector_conf)  # type: ignore[attr-defined]
        if detector_iou is not None:
            self.detector.iou_threshold = float(detector_iou)  # type: ignore[attr-defined]

    def process(
        self, frame: Frame, truth: DetectorTruth | None, timings: dict[str, float]
    ) -> tuple[Detections, Tracks, Estimates, Assessment, list[Alert]]:
        """One frame through every stage; stage times (ms) go into ``timings``.

        A frame without ego speed (``frame.odometry.speed_known`` False) is assessed on relative
        motion only: the estimator marks what needs the ego's speed NaN and ``assess`` is given a
        NaN ego speed (``intent.labels``, "Without ego speed")."""
        dets, tracks, est = self.perceive(frame, truth, timings)
        t3 = time.perf_counter()
        kin = Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())
        assessment, alerts = self._intent(frame, tracks, est, kin)
        timings["intent"] = (time.perf_counter() - t3) * 1e3
        return dets, tracks, est, assessment, alerts

    def perceive(
        self, frame: Frame, truth: DetectorTruth | None, timings: dict[str, float]
    ) -> tuple[Detections, Tracks, Estimates]:
        """``process`` up to the estimator (what a cooperative sender shares, ``sim.cooperation``);
        stage times (ms) into ``timings``."""
        tp = time.perf_counter()
        image = self.preprocess(frame.image)
        t0 = time.perf_counter()
        dets = self.detector.detect(image, truth)
        t1 = time.perf_counter()
        features = self._features(image, dets)
        te = time.perf_counter()
        tracks = self.tracker.update(dets, features)
        t2 = time.perf_counter()
        est = self.estimator.update(tracks, frame.odometry, frame.t, detections=dets, ground=frame.ground)
        t3 = time.perf_counter()
        timings.update(preprocess=(t0 - tp) * 1e3, detect=(t1 - t0) * 1e3, track=(t2 - te) * 1e3,
                       estimate=(t3 - t2) * 1e3)
        if self.embedder is not None:
            timings["embed"] = (te - t1) * 1e3
        return dets, tracks, est

    def _intent(self, frame: Frame, tracks: Tracks, est: Estimates, kin: Kinematics) -> tuple[Assessment, list[Alert]]:
        """Intent and alerts of one frame's tracks; a frame without ego speed is assessed with a NaN
        ego speed (unknown, not 0: ``intent.labels``, "Without ego speed"). With a ``fusion``
        stage (``intent.cooperative``), of the union of the tracks and the objects only others
        see; the tracks' rows are returned, the others' stay in ``fusion.remote``."""
        odo = frame.odometry
        ego_speed = odo.speed if getattr(odo, "speed_known", True) else float("nan")
        ids, classes = tracks.track_id, tracks.class_id
        if self.fusion is not None:  # the ego alone too, for comparison (``FusionStage.alone``)
            alone = assess(kin, self.intent_config, ego_speed, odo.yaw_rate, odo.accel)
            self.fusion.alone_alerts = self.fusion.alone.update(frame.t, ids, classes, kin.range, alone)
            kin, ids, classes = self.fusion(frame, tracks, est, kin)
            for old, new in self.fusion.handovers if self.fusion.enabled else ():
                self.alerts.hand_over(old, new)
        assessment = assess(kin, self.intent_config, ego_speed, odo.yaw_rate, odo.accel)
        self.gestures.update(frame.t, tracks, est, assessment)  # falling, waving, loitering: over time
        alerts = self.alerts.update(frame.t, ids, classes, kin.range, assessment)
        if self.fusion is not None:
            assessment = self.fusion.split(assessment)
        return assessment, alerts

    def _features(self, image: np.ndarray | None, dets: Detections) -> np.ndarray | None:
        """Appearance features (N, D) of the detections the tracker asks for (NaN rows for the
        others), or None: no embedder, no image, or nothing asked (most frames)."""
        if self.embedder is None or image is None:
            return None
        need = self.tracker.features_needed(dets)
        if not need.any():
            return None
        features = np.full((len(dets), self.embedder.dim), np.nan, dtype=np.float32)
        features[need] = self.embedder.embed(image, dets.xyxy[need])
        return features

    def critical_in_path(self, tracks: Tracks, est: Estimates, a: Assessment) -> tuple[bool, float]:
        """Whether a CRITICAL alert is on for an in-path track, and the nearest in-path range (m)."""
        crit = alert_in_path(self.alerts.active(), tracks.track_id.tolist(), a.in_path.tolist(), Risk.CRITICAL)
        cipv = select_cipv(tracks.track_id, est.range, a.in_path)  # the primary target's range
        return crit, cipv.range if cipv.range is not None else float("inf")


def alert_in_path(active: Mapping[int, int], track_ids: Sequence[int], in_path: Sequence[bool],
                  level: Risk) -> bool:
    """Whether an alert of ``level`` or above is on for an in-path track (the AEB's rule at
    CRITICAL; a forward-collision warning at HIGH).

    Args:
        active: track id -> current alert level (``AlertManager.active()``).
        track_ids: this frame's track ids; ``in_path``: per track, whether it is in the ego's path.
    """
    return any(active.get(int(t), 0) >= level and bool(p) for t, p in zip(track_ids, in_path, strict=True))


def build_stack(
    perception: PerceptionSpec,
    camera: CameraModel,
    frame_rate: float,
    *,
    intent: IntentConfig | Mapping[str, Any] | None = None,
    alerts: AlertConfig | None = None,
    detector: Detector | None = None,
    seed: int = 0,
    render: bool = True,
) -> PerceptionStack:
    """The stack a scenario's settings describe.

    Args:
        perception: detector, tracker / estimator overrides and preprocessing (a scenario's
            ``perception``).
        camera: the camera the frames come from.
        frame_rate: camera frames per second (the tracker's time base).
        intent: the intent thresholds, or overrides of their defaults (a scenario's ``intent``).
        alerts: debounce and hysteresis (a scenario's ``alerts``); None = the defaults.
        detector: used instead of the one ``perception.detector`` describes (e.g. recorded boxes);
            without it, ``perception.stack`` (a stack plug-in) replaces detector, tracker and estimator.
        seed: seeds the ``gt`` detector's noise.
        render: whether frames carry camera images (``auto`` picks the detector by it).

    Raises:
        SettingsError: ``onnx`` detector without images; ``ModelError``: an unloadable model.
    """
    if not isinstance(intent, IntentConfig):
        intent = IntentConfig().with_overrides(dict(intent or {}))
    if perception.stack is not None and detector is None:
        from lookahead.intent.plugins import load_stack  # (imports this module)

        return load_stack(perception.stack.plugin, perception.stack.options, camera, frame_rate, intent=intent,
                          alerts=alerts)
    embedder = None
    if perception.appearance.enabled and render:  # features need pixels
        embedder = AppearanceEmbedder(perception.appearance.model)
    return PerceptionStack(
        detector or build_detector(perception.detector, seed, render), camera, frame_rate, intent,
        perception.tracker_config(), perception.estimator_config(), alert_config=alerts,
        preprocess=PreprocessChain(perception.preprocess), embedder=embedder,
    )
