"""Intent labels, behaviours, in-path and risk: ONE implementation for ground truth and predictions.

Everything is computed per object in the ego frame (ISO 8855: x forward, y
left; m, s, m/s, rad) from a ``Kinematics`` struct of arrays. The simulator
fills it from true kinematics, the estimator from its tracks; both call
``assess``. Definitions (docs/architecture.md, "Labels"):

* TTC = range / closing speed when closing (range rate < 0), else inf; 0 when
  the object already reaches the ego's front (range <= 0). Enhanced TTC (ETTC)
  and the required deceleration: the same under constant accelerations, a
  braking body stopping (``intent.collision``); with no acceleration known, ETTC
  = TTC. Risk and in-path decide on ETTC.
* Motion significance: with estimated velocities (``ground_vx_sigma`` /
  ``ground_vy_sigma`` given), a ground velocity component smaller than
  ``motion_significance`` stds is taken as 0 for behaviours and the in-path
  prediction (``critical_motion_significance`` for CRITICAL) -- a parked car's noisy velocity does not drift it into the lane
  nor make it ``wrong_way``. Ground truth (no stds) is used as it is.
* Ego corridor: |y - c(r)| < ego_half_width + corridor_margin + object half
  width, where c(r) = r^2 * yaw_rate / (2 * speed) bends it along the ego's
  predicted arc. *In path*: the object overlaps the corridor now or at any time
  in [0, min(horizon, TTC + arrival_slack)] under constant lateral velocity.
* Risk: per class group, from ETTC (CRITICAL < critical_ttc, HIGH < high_ttc,
  MEDIUM < 2 x high_ttc, LOW < 4 x high_ttc), range (same ladder with the
  distance thresholds; above MEDIUM only while closing) and the required
  deceleration (HIGH >= high_decel, CRITICAL >= critical_decel). HIGH and
  CRITICAL need the object in path, otherwise risk is capped at MEDIUM;
  CRITICAL (the AEB's level) needs it in path even ``critical_path_sigmas``
  lateral stds further out, with lateral motion significant at
  ``critical_motion_significance`` stds (estimates only), otherwise it is
  capped at HIGH -- braking needs more evidence than a warning: a parked car
  whose estimate grazes the corridor's edge warns, never brakes. Likewise its
  TTC (or required deceleration) must pass the CRITICAL threshold even closing
  ``critical_rate_sigmas`` range-rate stds slower than estimated (the range
  ladder's CRITICAL needs no rate).
* Labels: ``initializing`` (prediction younger than init_frames, or whose
  velocity estimate has not settled yet: ``Kinematics.settled``) > ``danger``
  (risk >= HIGH, i.e. in path and TTC or closing range under the HIGH
  thresholds) > ``approaching`` (range rate < -deadband) > ``receding``
  (> +deadband) > ``stable``.

Without ego speed (``ego_speed`` NaN: ``EgoOdometry.speed_known`` False, real video
without a speed source) only what relative motion decides is assessed; nothing is
computed from a guessed ego speed:

* available: TTC (range / closing speed), the labels (range rate, risk), in-path
  and risk, from the estimator's relative estimates;
* ETTC falls back to TTC (the enhanced model needs both bodies' ground speeds to
  tell when a braking one stops -- as with no acceleration known); the required
  deceleration is NaN and does not enter risk;
* the ego corridor is straight ahead (its curvature, yaw rate / speed, is
  unavailable); the lateral prediction uses the relative lateral rate, which is
  the same over the ground (the ego moves along its x axis);
* risk: the TTC and range ladders (range above MEDIUM only while closing), in
  path for HIGH and CRITICAL, CRITICAL's sure-path and sure-closing checks on the
  relative TTC (``critical_rate_sigmas`` range-rate stds slower); alerts follow
  that risk (an FCW from range and closing speed, like a camera-only FCW's);
* behaviours describe motion over the ground (standing, stopped, wrong-way ...):
  ``Behaviour.UNKNOWN`` (behaviour confidence 0).

Behaviour confidence (``behaviour_confidence``): Phi of the behaviour decision's margin in stds
(1 for ground truth, whose kinematics are exact).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from scipy.special import ndtr

from lookahead.intent.collision import enhanced_ttc, required_decel
from lookahead.intent.config import IntentConfig
from lookahead.perception.detections import CLASS_ID
from lookahead.perception.estimator import time_to_collision


class Label(IntEnum):
    INITIALIZING = 0
    STABLE = 1
    APPROACHING = 2
    RECEDING = 3
    DANGER = 4


#: A TTC (s) of "never" as run files write it: JSON has no inf, so +inf is written as ``NEVER``
#: (-inf as ``-NEVER``, ``sim.records.jsonable``) and readers decode ``abs(v) >= NEVER`` back to
#: +-inf (``tools.sinks.rundir``); displays show a TTC at or above it as none.
NEVER = 1e9

LABEL_NAMES = {
    Label.INITIALIZING: "initializing",
    Label.STABLE: "stable",
    Label.APPROACHING: "approaching",
    Label.RECEDING: "receding",
    Label.DANGER: "danger",
}
#: The CARLA study's wording.
LABEL_NAMES_ZH = {
    Label.INITIALIZING: "目标初始化中",
    Label.STABLE: "目标稳定",
    Label.APPROACHING: "目标靠近中",
    Label.RECEDING: "目标远离中",
    Label.DANGER: "危险靠近",
}


class Risk(IntEnum):
    SAFE = 0
    LOW = 1
    MEDIUM = 2
    HIGH = 3
    CRITICAL = 4


#: One colour per risk level (RGB), indexed by ``Risk`` value, SAFE green -> CRITICAL red: the
#: palette of every picture (annotated video, rerun, the gym env's render).
RISK_COLOURS: tuple[tuple[int, int, int], ...] = (
    (40, 200, 60),  # SAFE
    (170, 220, 40),  # LOW
    (255, 210, 0),  # MEDIUM
    (255, 120, 0),  # HIGH
    (235, 20, 20),  # CRITICAL
)


def risk_colour(risk: int) -> tuple[int, int, int]:
    """RGB colour of a risk level (clipped to SAFE..CRITICAL)."""
    return RISK_COLOURS[min(max(int(risk), 0), len(RISK_COLOURS) - 1)]


class Behaviour(IntEnum):
    UNKNOWN = 0
    STANDING = 1
    WALKING = 2
    RUNNING = 3
    CROSSING = 4
    STOPPED = 5
    MOVING = 6
    SPEEDING = 7
    SUDDEN_BRAKE = 8
    SUDDEN_TURN = 9
    WRONG_WAY = 10
    STATIONARY = 11
    ENTERING_ROAD = 12
    LOITERING = 13  # a pedestrian pacing to and fro at the kerb
    WAVING = 14  # a pedestrian waving an arm overhead
    FALLING = 15  # a pedestrian falling, or lying on the road


BEHAVIOUR_NAMES = {b: b.name.lower() for b in Behaviour}

#: Class group of each detection class (thresholds are per group).
GROUP_OF_CLASS = {
    "pedestrian": "pedestrian",
    "animal": "animal",
    "cyclist": "non_motor",
    "motorcyclist": "non_motor",
    "tricycle": "non_motor",
    "car": "vehicle",
    "truck": "vehicle",
    "bus": "vehicle",
    "obstacle": "obstacle",
}
GROUPS = ("pedestrian", "animal", "non_motor", "vehicle", "large_animal", "obstacle")
_GROUP_INDEX = np.full(len(CLASS_ID) + 1, GROUPS.index("vehicle"), dtype=np.int64)
for _name, _cid in CLASS_ID.items():
    _GROUP_INDEX[_cid] = GROUPS.index(GROUP_OF_CLASS[_name])


def class_groups(k: Kinematics, config: IntentConfig) -> np.ndarray:
    """Threshold group index (into ``GROUPS``) of each object: its class's group, and
    ``large_animal`` for an animal at least ``config.large_animal_height`` tall (deer, cattle,
    boar; dogs stay ``animal``) -- by size, as the detector has one animal class."""
    g = _GROUP_INDEX[np.clip(np.asarray(k.class_id, dtype=np.int64), 0, len(_GROUP_INDEX) - 1)]
    if k.height is None:
        return g
    large = (g == GROUPS.index("animal")) & (np.asarray(k.height, dtype=np.float64) >= config.large_animal_height)
    return np.where(large, GROUPS.index("large_animal"), g)


@dataclass
class Kinematics:
    """N objects in the ego frame.

    range: nearest point's x (m); lateral: centre y (m, left +); half_width:
    lateral half extent (m); range_rate / lateral_rate: relative velocity (m/s);
    ground_vx / ground_vy: the object's own velocity over the ground, in ego
    axes (m/s); accel: its acceleration along its motion (m/s^2, NaN unknown);
    yaw_rate: its yaw rate (rad/s, NaN unknown); class_id: detection class;
    age: frames since the track was born (None for ground truth);
    range_rate_sigma: std of the estimated range rate (m/s; None for ground
    truth, which is exact); settled: 1 once the estimator's range rate has
    converged, 0 before, NaN without an estimate -- predictions not settled
    are ``initializing`` (None for ground truth); accel_x: the object's ground
    acceleration along the ego x axis (m/s^2; None or NaN = 0, for the enhanced
    TTC); ground_vx_sigma / ground_vy_sigma: stds of the estimated ground
    velocity (m/s; None for ground truth); lateral_sigma: std of the estimated
    lateral offset (m; None for ground truth); height: the object's height (m; None =
    unknown), which makes an animal of ``large_animal_height`` or more a large animal.
    """

    class_id: np.ndarray
    range: np.ndarray
    lateral: np.ndarray
    half_width: np.ndarray
    range_rate: np.ndarray
    lateral_rate: np.ndarray
    ground_vx: np.ndarray
    ground_vy: np.ndarray
    accel: np.ndarray
    yaw_rate: np.ndarray
    age: np.ndarray | None = None
    range_rate_sigma: np.ndarray | None = None
    settled: np.ndarray | None = None
    accel_x: np.ndarray | None = None
    ground_vx_sigma: np.ndarray | None = None
    ground_vy_sigma: np.ndarray | None = None
    lateral_sigma: np.ndarray | None = None
    height: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.range)

    def significant_ground_velocity(self, z: float) -> tuple[np.ndarray, np.ndarray]:
        """(v_x, v_y) over the ground with each component below ``z`` of its std set to 0
        (as given where no std is known, or z <= 0)."""
        out = []
        for v, sig in ((self.ground_vx, self.ground_vx_sigma), (self.ground_vy, self.ground_vy_sigma)):
            v = np.asarray(v, dtype=np.float64)
            if sig is not None and z > 0:
                v = np.where(np.abs(v) >= z * np.nan_to_num(np.asarray(sig, dtype=np.float64), nan=np.inf), v, 0.0)
            out.append(v)
        return out[0], out[1]


@dataclass
class Assessment:
    """Per-object outputs of ``assess`` (all (N,) arrays): constant-velocity ``ttc`` (s),
    ``ettc`` (enhanced, s), ``decel_req`` (the ego's required deceleration, m/s^2),
    ``in_path``, ``risk``, ``label``, ``behaviour``, ``behaviour_confidence`` (in [0, 1],
    ``behaviour_confidence``)."""

    ttc: np.ndarray
    in_path: np.ndarray
    risk: np.ndarray
    label: np.ndarray
    behaviour: np.ndarray
    ettc: np.ndarray | None = None
    decel_req: np.ndarray | None = None
    behaviour_confidence: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.ttc)

    def to_dict(self) -> dict:
        return {
            "ttc": np.round(self.ttc, 3).tolist(),
            "in_path": self.in_path.tolist(),
            "risk": self.risk.tolist(),
            "label": self.label.tolist(),
            "behaviour": self.behaviour.tolist(),
            **{name: np.round(np.minimum(getattr(self, name), NEVER), 3).tolist()
               for name in ("ettc", "decel_req") if getattr(self, name) is not None},
            **({"behaviour_confidence": np.round(self.behaviour_confidence, 3).tolist()}
               if self.behaviour_confidence is not None else {}),
        }


def _threshold_table(config: IntentConfig) -> dict[str, np.ndarray]:
    rt = [config.risk[g] for g in GROUPS]
    bt = [config.behaviour[g] for g in GROUPS]
    return {
        "d_high": np.array([r.high_distance for r in rt]),
        "a_high": np.array([r.high_decel for r in rt]),
        "a_crit": np.array([r.critical_decel for r in rt]),
        "d_crit": np.array([r.critical_distance for r in rt]),
        "t_high": np.array([r.high_ttc for r in rt]),
        "t_crit": np.array([r.critical_ttc for r in rt]),
        "still": np.array([b.still_speed for b in bt]),
        "fast": np.array([b.fast_speed for b in bt]),
        "cross": np.array([b.cross_speed for b in bt]),
        "brake": np.array([b.brake_decel for b in bt]),
        "turn": np.array([b.turn_rate for b in bt]),
        "wrong": np.array([b.wrong_way_speed for b in bt]),
    }


def _ladder(value: np.ndarray, crit: np.ndarray, high: np.ndarray) -> np.ndarray:
    lvl = np.full(value.shape, int(Risk.SAFE))
    lvl = np.where(value < 4 * high, int(Risk.LOW), lvl)
    lvl = np.where(value < 2 * high, int(Risk.MEDIUM), lvl)
    lvl = np.where(value < high, int(Risk.HIGH), lvl)
    return np.where(value < crit, int(Risk.CRITICAL), lvl)


def in_path(
    k: Kinematics, ttc: np.ndarray, config: IntentConfig, ego_speed: float, ego_yaw_rate: float,
    sigmas: float = 0.0, look_ahead: bool = True, significance: float | None = None,
) -> np.ndarray:
    """Whether each object overlaps the ego corridor now or within the prediction window
    (now only, without ``look_ahead``); with ``sigmas`` > 0, even when placed that many
    lateral stds (``Kinematics.lateral_sigma``) further out (ground truth: no std, the same test);
    ``significance``: z of the lateral motion taken as real (default ``motion_significance``)."""
    r = np.asarray(k.range, dtype=np.float64)
    # the ego path's curvature; without ego speed (NaN) unavailable: a straight corridor
    curvature = ego_yaw_rate / max(ego_speed, 1.0) if np.isfinite(ego_speed) else 0.0
    centre = 0.5 * curvature * np.maximum(r, 0.0) ** 2
    half = config.ego_half_width + config.corridor_margin + np.asarray(k.half_width)
    d0 = np.asarray(k.lateral) - centre
    window = np.minimum(config.horizon, ttc + config.arrival_slack) if look_ahead else 0.0
    z = config.motion_significance if significance is None else significance
    _, vy = k.significant_ground_velocity(z)
    lateral_rate = np.asarray(k.lateral_rate) - np.asarray(k.ground_vy) + vy  # ego rotation kept
    d1 = d0 + lateral_rate * window
    crosses = np.sign(d0) != np.sign(d1)
    closest = np.where(crosses, 0.0, np.minimum(np.abs(d0), np.abs(d1)))
    if sigmas > 0.0 and k.lateral_sigma is not None:
        closest = closest + sigmas * np.nan_to_num(np.asarray(k.lateral_sigma, dtype=np.float64), nan=np.inf)
    return (closest < half) & (r > -1.0)


def behaviours(k: Kinematics, config: IntentConfig, thresholds: dict | None = None) -> np.ndarray:
    """Behaviour code (N,) per object from its ground motion (see ``Behaviour``)."""
    th = thresholds or _threshold_table(config)
    g = class_groups(k, config)
    vx, vy = k.significant_ground_velocity(config.motion_significance)
    speed = np.hypot(vx, vy)
    still, fast, cross_v = th["still"][g], th["fast"][g], th["cross"][g]
    half = config.ego_half_width + config.corridor_margin + np.asarray(k.half_width)
    y = np.asarray(k.lateral)
    lateral_motion = (np.abs(vy) > cross_v) & (np.abs(vy) >= 0.5 * np.abs(vx))
    toward_or_inside = (y * vy < 0) | (np.abs(y) < half)
    crossing = lateral_motion & toward_or_inside
    accel = np.nan_to_num(np.asarray(k.accel, dtype=np.float64), nan=0.0)
    yaw = np.nan_to_num(np.asarray(k.yaw_rate, dtype=np.float64), nan=0.0)
    moving = speed >= still

    ped = g == GROUPS.index("pedestrian")
    ani = (g == GROUPS.index("animal")) | (g == GROUPS.index("large_animal"))
    wheeled = ~(ped | ani | (g == GROUPS.index("obstacle")))
    out = np.full(len(g), int(Behaviour.UNKNOWN))
    # pedestrians
    out = np.where(ped, np.where(~moving, Behaviour.STANDING, np.where(speed >= fast, Behaviour.RUNNING, Behaviour.WALKING)), out)
    out = np.where(ped & moving & crossing, Behaviour.CROSSING, out)
    # animals
    out = np.where(ani, np.where(~moving, Behaviour.STATIONARY, np.where(speed >= fast, Behaviour.RUNNING, Behaviour.MOVING)), out)
    out = np.where(ani & moving & crossing, Behaviour.ENTERING_ROAD, out)
    # static obstacles do not move: any motion estimated is error
    obs = g == GROUPS.index("obstacle")
    out = np.where(obs, Behaviour.STATIONARY, out)
    # non-motorised and vehicles, lowest priority first
    wb = np.where(~moving, Behaviour.STOPPED, np.where(speed > fast, Behaviour.SPEEDING, Behaviour.MOVING))
    wb = np.where(moving & crossing, Behaviour.CROSSING, wb)
    wb = np.where((vx < -th["wrong"][g]) & (-vx > np.abs(vy)), Behaviour.WRONG_WAY, wb)
    wb = np.where((np.abs(yaw) > th["turn"][g]) & (speed > 2.0), Behaviour.SUDDEN_TURN, wb)
    wb = np.where((accel < -th["brake"][g]) & (speed > 1.0), Behaviour.SUDDEN_BRAKE, wb)
    return np.where(wheeled, wb, out).astype(np.int64)


class _Test:
    """A boolean test per object and its margin ``z``: how many stds its deciding quantity is from
    the threshold (inf: exact, or no std known; 0: on it, or its std unknown)."""

    def __init__(self, val: np.ndarray, z: np.ndarray) -> None:
        self.val, self.z = np.asarray(val, dtype=bool), np.asarray(z, dtype=np.float64)

    @classmethod
    def compare(cls, val: np.ndarray, q: np.ndarray, threshold, sigma) -> _Test:
        """``val`` (the test as ``behaviours`` takes it), decided by quantity ``q`` against
        ``threshold`` with std ``sigma`` (None: exact; NaN: unknown, margin 0)."""
        d = np.abs(np.asarray(q, dtype=np.float64) - threshold)
        if sigma is None:
            return cls(val, np.full(d.shape, np.inf))
        sig = np.nan_to_num(np.broadcast_to(np.asarray(sigma, dtype=np.float64), d.shape), nan=np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(sig > 0, d / np.where(sig > 0, sig, 1.0), np.inf)
        return cls(val, np.where(np.isfinite(sig), z, 0.0))

    def __and__(self, o: _Test) -> _Test:  # true: either flips it; false: every false part must flip
        both = self.val & o.val
        z_false = np.maximum(np.where(self.val, 0.0, self.z), np.where(o.val, 0.0, o.z))
        return _Test(both, np.where(both, np.minimum(self.z, o.z), z_false))

    def __or__(self, o: _Test) -> _Test:
        return ~(~self & ~o)

    def __invert__(self) -> _Test:
        return _Test(~self.val, self.z)


def _speed_sigma(vx: np.ndarray, vy: np.ndarray, k: Kinematics) -> np.ndarray | None:
    """Std of the ground speed hypot(vx, vy) from the component stds (first order; at rest the
    larger component std); None for ground truth."""
    if k.ground_vx_sigma is None or k.ground_vy_sigma is None:
        return None
    sx, sy = (np.asarray(s, dtype=np.float64) for s in (k.ground_vx_sigma, k.ground_vy_sigma))
    speed = np.hypot(vx, vy)
    with np.errstate(divide="ignore", invalid="ignore"):
        lin = np.sqrt((vx * sx) ** 2 + (vy * sy) ** 2) / speed
    return np.where(speed > 0, lin, np.maximum(sx, sy))


def behaviour_confidence(k: Kinematics, config: IntentConfig, thresholds: dict | None = None) -> np.ndarray:
    """How sure each object's behaviour (``behaviours``) is, in [0, 1]: Phi(z), the standard
    normal CDF of the margin z of its decision -- the probability, under Gaussian estimation
    errors, that the nearest decision boundary lies on the estimated side.

    The behaviour is the first true test of its class group's priority chain (wheeled: sudden
    brake > sudden turn > wrong way > crossing > stopped > speeding > moving; pedestrians:
    crossing > standing > running > walking; animals: entering road > stationary > running >
    moving); its margin is the smallest margin of the tests that decided it (every test before
    it in the chain, found false, and its own). A test's margin is |quantity - threshold| / std:
    speed over ground (std from the ground-velocity stds) against the still / fast / 1 and 2 m/s
    thresholds, the lateral ground speed against the crossing speed, |v_y| - |v_x| / 2, the
    longitudinal speed against the wrong-way speed, -v_x - |v_y|, the lateral offset against the
    corridor's half-width (``lateral_sigma``), and the signs of y and v_y (toward the corridor).
    An AND that holds has its parts' smallest margin, one that fails the largest of its failing
    parts' (all must flip); OR likewise. Acceleration and yaw rate carry no std: their tests
    count as exact. Ground truth (no stds): 1 everywhere; an unknown std (NaN): margin 0, 0.5.
    Velocities are the significant ones (``motion_significance``), as ``behaviours`` uses them."""
    th = thresholds or _threshold_table(config)
    n = len(k)
    g = class_groups(k, config)
    vx, vy = k.significant_ground_velocity(config.motion_significance)
    sx = None if k.ground_vx_sigma is None else np.asarray(k.ground_vx_sigma, dtype=np.float64)
    sy = None if k.ground_vy_sigma is None else np.asarray(k.ground_vy_sigma, dtype=np.float64)
    sl = None if k.lateral_sigma is None else np.asarray(k.lateral_sigma, dtype=np.float64)
    speed, s_speed = np.hypot(vx, vy), _speed_sigma(vx, vy, k)
    still, fast, cross_v = th["still"][g], th["fast"][g], th["cross"][g]
    half = config.ego_half_width + config.corridor_margin + np.asarray(k.half_width, dtype=np.float64)
    y = np.asarray(k.lateral, dtype=np.float64)
    avx, avy = np.abs(vx), np.abs(vy)
    s_ratio = None if sx is None or sy is None else np.hypot(sy, 0.5 * sx)
    s_diag = None if sx is None or sy is None else np.hypot(sx, sy)
    lateral_motion = (_Test.compare(avy > cross_v, avy, cross_v, sy)
                      & _Test.compare(avy >= 0.5 * avx, avy - 0.5 * avx, 0.0, s_ratio))
    toward = _Test.compare(y * vy < 0, 0.0, 0.0, None)
    toward.z = np.minimum(_Test.compare(toward.val, y, 0.0, sl).z, _Test.compare(toward.val, vy, 0.0, sy).z)
    inside = _Test.compare(np.abs(y) < half, np.abs(y), half, sl)
    moving = _Test.compare(speed >= still, speed, still, s_speed)
    crossing = moving & lateral_motion & (toward | inside)
    accel = np.nan_to_num(np.asarray(k.accel, dtype=np.float64), nan=0.0)
    yaw = np.nan_to_num(np.asarray(k.yaw_rate, dtype=np.float64), nan=0.0)
    brake = _Test.compare(accel < -th["brake"][g], accel, -th["brake"][g], None) & _Test.compare(speed > 1.0, speed, 1.0, s_speed)
    turn = _Test.compare(np.abs(yaw) > th["turn"][g], yaw, th["turn"][g], None) & _Test.compare(speed > 2.0, speed, 2.0, s_speed)
    wrong = (_Test.compare(vx < -th["wrong"][g], vx, -th["wrong"][g], sx)
             & _Test.compare(-vx > avy, -vx - avy, 0.0, s_diag))
    ped_fast = _Test.compare(speed >= fast, speed, fast, s_speed)
    speeding = _Test.compare(speed > fast, speed, fast, s_speed)
    always = _Test(np.ones(n, dtype=bool), np.full(n, np.inf))

    ped = g == GROUPS.index("pedestrian")
    ani = (g == GROUPS.index("animal")) | (g == GROUPS.index("large_animal"))
    obs = g == GROUPS.index("obstacle")
    chains = (
        (ped, (crossing, ~moving, ped_fast, always)),
        (ani, (crossing, ~moving, ped_fast, always)),
        (~(ped | ani | obs), (brake, turn, wrong, crossing, ~moving, speeding, always)),
        (obs, (always,)),
    )
    z = np.full(n, np.inf)
    for rows, chain in chains:
        decided, margin = np.zeros(n, dtype=bool), np.full(n, np.inf)
        for test in chain:
            open_ = ~decided
            margin = np.where(open_, np.minimum(margin, test.z), margin)
            decided |= test.val
        z = np.where(rows, margin, z)
    return ndtr(z)


def _slower(v_o: np.ndarray, k: Kinematics, z: float) -> np.ndarray:
    """The object's ground speed along x raised by ``z`` range-rate stds: the ego closing that
    much more slowly than estimated (an unknown std: as if never closing)."""
    if k.range_rate_sigma is None:
        return v_o
    return v_o + z * np.nan_to_num(np.asarray(k.range_rate_sigma, dtype=np.float64), nan=1e6)


def _slower_ttc(
    k: Kinematics, r: np.ndarray, rr: np.ndarray, v_o: np.ndarray, a_o: np.ndarray, z: float,
    ego_speed: float, ego_accel: float,
) -> np.ndarray:
    """ETTC closing ``z`` range-rate stds more slowly than estimated; without ego speed (NaN) the
    constant-closing-speed TTC on the relative range rate."""
    if np.isfinite(ego_speed):
        return enhanced_ttc(r, _slower(v_o, k, z), a_o, ego_speed, ego_accel)
    return time_to_collision(r, _slower(rr, k, z))


def _confirmed_fast(
    k: Kinematics, r: np.ndarray, rr: np.ndarray, v_o: np.ndarray, a_o: np.ndarray, t_crit: np.ndarray,
    config: IntentConfig, ego_speed: float, ego_yaw_rate: float, ego_accel: float,
) -> np.ndarray:
    """Young or unsettled tracks that may raise CRITICAL at once: at least ``fast_confirm_frames``
    old, in the corridor now (no prediction, ``critical_path_sigmas`` lateral stds further out),
    and under the CRITICAL TTC even if closing ``critical_motion_significance`` range-rate stds
    slower than estimated -- a child out of an occlusion in front of the ego, not a new car ahead
    whose speed is still unknown."""
    old_enough = np.asarray(k.age) >= config.fast_confirm_frames
    z = config.critical_motion_significance
    late = _slower_ttc(k, r, rr, v_o, a_o, z, ego_speed, ego_accel) < t_crit
    inside = in_path(k, np.zeros(len(r)), config, ego_speed, ego_yaw_rate, config.critical_path_sigmas,
                     look_ahead=False, significance=z)
    return old_enough & inside & late


def assess(
    k: Kinematics, config: IntentConfig, ego_speed: float = 0.0, ego_yaw_rate: float = 0.0,
    ego_accel: float = 0.0,
) -> Assessment:
    """TTC, enhanced TTC, required deceleration, in-path flag, risk, intent label and
    behaviour for every object (ego speed m/s, yaw rate rad/s, acceleration m/s^2).

    ``ego_speed`` NaN: the ego's speed is unknown -- relative assessment only (module
    docstring, "Without ego speed": ETTC = TTC, required deceleration NaN, straight corridor,
    behaviours ``UNKNOWN``)."""
    th = _threshold_table(config)
    n = len(k)
    if n == 0:
        z = np.zeros(0, dtype=np.int64)
        return Assessment(np.zeros(0), np.zeros(0, dtype=bool), z, z.copy(), z.copy(), np.zeros(0), np.zeros(0),
                          np.zeros(0))
    g = class_groups(k, config)
    r = np.asarray(k.range, dtype=np.float64)
    rr = np.asarray(k.range_rate, dtype=np.float64)
    ttc = time_to_collision(r, rr)
    speed_known = bool(np.isfinite(ego_speed))
    v_o = rr + ego_speed  # the object's ground speed along x, consistent with the range rate (NaN: unknown)
    a_o = np.zeros(n) if k.accel_x is None else np.asarray(k.accel_x, dtype=np.float64)
    if speed_known:
        ettc = enhanced_ttc(r, v_o, a_o, ego_speed, ego_accel)
        decel = required_decel(r, v_o, a_o, ego_speed)
    else:  # relative only: constant closing speed; the required deceleration is unavailable
        ettc, decel = ttc.copy(), np.full(n, np.nan)
    path = in_path(k, ettc, config, ego_speed, ego_yaw_rate)
    closing = rr < -config.range_rate_deadband
    by_ttc = _ladder(ettc, th["t_crit"][g], th["t_high"][g])
    by_dist = _ladder(np.where(r > 0, r, 0.0), th["d_crit"][g], th["d_high"][g])
    by_dist = np.where(closing, by_dist, np.minimum(by_dist, int(Risk.MEDIUM)))
    by_decel = np.where(decel >= th["a_high"][g], int(Risk.HIGH), int(Risk.SAFE))
    by_decel = np.where(decel >= th["a_crit"][g], int(Risk.CRITICAL), by_decel)
    risk = np.maximum(np.maximum(by_ttc, by_dist), by_decel)
    risk = np.where(path, risk, np.minimum(risk, int(Risk.MEDIUM)))
    if config.critical_path_sigmas > 0.0 and k.lateral_sigma is not None:  # brakes need a sure path
        sure = in_path(k, ettc, config, ego_speed, ego_yaw_rate, config.critical_path_sigmas,
                       significance=config.critical_motion_significance)
        risk = np.where(sure, risk, np.minimum(risk, int(Risk.HIGH)))
    if config.critical_rate_sigmas > 0.0 and k.range_rate_sigma is not None:  # ... and a sure closing speed
        slower = _slower(v_o, k, config.critical_rate_sigmas)
        sure_ttc = _slower_ttc(k, r, rr, v_o, a_o, config.critical_rate_sigmas, ego_speed, ego_accel) < th["t_crit"][g]
        sure_decel = required_decel(r, slower, a_o, ego_speed) >= th["a_crit"][g]  # NaN: False
        sure_dist = by_dist == int(Risk.CRITICAL)
        risk = np.where(sure_ttc | sure_decel | sure_dist, risk, np.minimum(risk, int(Risk.HIGH)))
    risk = np.where(r < -1.0, int(Risk.SAFE), risk)

    label = np.where(rr < -config.range_rate_deadband, Label.APPROACHING, Label.STABLE)
    label = np.where(rr > config.range_rate_deadband, Label.RECEDING, label)
    label = np.where(risk >= Risk.HIGH, Label.DANGER, label)
    init = np.zeros(n, dtype=bool)
    if k.age is not None:
        init |= np.asarray(k.age) < config.init_frames
    if k.settled is not None:  # a prediction without a converged velocity (or any estimate) yet
        init |= np.asarray(k.settled, dtype=np.float64) != 1.0
    if k.age is not None and np.any(init):
        init &= ~_confirmed_fast(k, r, rr, v_o, a_o, th["t_crit"][g], config, ego_speed, ego_yaw_rate, ego_accel)
    label = np.where(init, Label.INITIALIZING, label)
    return Assessment(
        ttc=ttc,
        in_path=path,
        risk=risk.astype(np.int64),
        label=label.astype(np.int64),
        behaviour=behaviours(k, config, th) if speed_known else np.full(n, int(Behaviour.UNKNOWN), dtype=np.int64),
        ettc=ettc,
        decel_req=decel,
        behaviour_confidence=behaviour_confidence(k, config, th) if speed_known else np.zeros(n),
    )
