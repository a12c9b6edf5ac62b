"""Per-track range, lateral offset, ego-frame velocity and TTC: one motion filter per track.

``Estimator.update`` measures every track's box with ``perception.ranging.BoxRanger``
(the single-frame measurement model: range of the nearest face, lateral offset,
half-width and their covariance from a box and the camera) and runs one motion
filter per track id on those measurements; ``Estimates`` holds the results.
Settings: ``perception.estimator_config`` (``EstimatorConfig``, ``ClassPrior``;
re-exported here, as is ``Measurement``).

Frames and units
----------------
Ego frame (ISO 8855): origin at the centre of the front bumper on the ground,
x forward, y left, z up. m, s, m/s, rad. ``range`` is the ego-frame x of the
object's *nearest* point (its visible face), ``lateral`` the y of its centre,
``half_width`` half its y extent -- the definitions the ground truth uses
(``sim.groundtruth``).

Tracking: one motion filter per track_id
----------------------------------------
State X = [x, y, v_x, v_y, a_x, a_y]: the nearest face's point in the
*current* ego frame (m) and the object's velocity (m/s) and acceleration
(m/s^2) **over the ground**, in the current ego axes. Keeping ground motion (not motion relative
to the ego) in the state makes a stationary object a constant state while the
ego brakes or turns. Ego motion between frames (dt, mean odometry speed v and
yaw rate w over the interval, the origin moving at (v, 0) as the ground truth
assumes) is a turn theta = w dt and a chord c = v dt sinc(theta / 2) along
heading theta / 2; the state is first re-expressed in the new ego frame:

    p <- R(-theta) (p - c (cos theta/2, sin theta/2)),  v <- R(-theta) v,  a <- R(-theta) a,
    P <- J P J^T,  J = diag(R(-theta), R(-theta)[, R(-theta)]),

then predicted with (I = 2x2 identity; sigma_a, q_j per class)

    ca: F = [[I, dt I, dt^2/2 I], [0, I, dt I], [0, 0, I]],
        Q = continuous white-noise jerk, spectral density q_j = jerk_sigma^2
            (filterpy ``Q_continuous_white_noise``);
    cv: F = [[I, dt I, 0], [0, I, 0], [0, 0, 0]] (no acceleration),
        Q = sigma_a^2 [[dt^4/4 I, dt^3/2 I], [dt^3/2 I, dt^2 I]] (piecewise white acceleration),

and updated with z = (x, y) of ``perception.ranging`` (steps 3-6), H = [I 0 0]
and R = its 2x2 covariance. ``motion_model``:

    "cv" / "ca": one Kalman filter with that model;
    "imm" (default): an interacting multiple model filter (Blom & Bar-Shalom)
        of a *quiet* cv model (sigma_a times ``imm_quiet_accel_scale``) and
        the ca model (manoeuvres: braking, accelerating from rest, cutting
        in). Markov switching with mean sojourn ``imm_quiet_s`` /
        ``imm_manoeuvre_s``; the quiet model keeps the acceleration's
        variance open (sigma_a^2) so mixing does not pin the ca model's
        acceleration to 0. Output: the moment-matched mixture. The measured
        box noise (5 % of the box per edge, white) makes one frame's range
        good to ~5 %, so a deceleration takes a few frames to stand out; the
        IMM follows a braking lead (TTC) much better than cv, and settles on
        steady targets much better than ca.

The filters are plain numpy (``_MotionFilter``; Joseph-form updates). With
``detections``, a track matched this frame is measured on its raw detection box, not on the tracker's smoothed one (no stacked lag).
A box cut at the bottom updates a running filter with its bearing only (the
range std set to 100 m along the ray; the height prior's error is the same
every frame and would drag the filter), and pulls a prediction beyond the
bound back to x_max. A measurement with NIS > ``reinit_nis`` restarts the
filter. New filters start at the measurement with the class's prior on the
ground velocity, N(0, ``speed_sigma``^2) per axis (pedestrians 1.5 m/s, cars
12 m/s), zero acceleration with std ``init_accel_sigma`` -- a broad prior the
first measurements quickly override, where the tracker's box rates after two
or three noisy boxes are not a usable velocity (the scale change of a 10 px
box with 5 % edge noise says nothing about its range rate at 50 m);
``init_from_box_rates`` fuses them in anyway, with std
``init_velocity_sigma``.

Convergence. A new filter's velocity is the prior's until a second or so of
boxes has pinned it (a car 20 m ahead: about 1 m range noise per frame), and
in between it can be wrong by several m/s -- a lead car followed at constant
distance looked 'receding', a stationary one 'about to hit' (false FCW). The
filter reports ``range_rate_sigma`` (its std of range_rate) and ``settled``,
latched once range_rate_sigma <= max(``settle_range_rate_sigma`` 1 m/s -- the
intent labels' deadband --, ``settle_range_rate_rel`` x |range_rate| -- a TTC
good to 25 %) on a frame whose box gives a range (not cut at the bottom, not
``side_bound``: a bound carries no range-rate information, and the pull-backs
and widened updates of such frames shrink the std without it), or
``settle_max_s`` after the filter's birth, whichever comes first. Intent labels
unsettled tracks 'initializing' (so they do not alert).
Latched, because the std grows again in a manoeuvre (the IMM's ca model takes
over), when the estimate must not drop back to 'initializing'. A filter
restarted by the NIS gate starts over. The heading used for the contact
offset and the end-on tests is the motion's only once settled (road-aligned
before). Outputs (the ground truth's formulas):

    range_rate = v_x - v_ego + w y,   lateral_rate = v_y - w x,
    ground_vx, ground_vy = v_x, v_y,
    ttc = range / -range_rate while closing, inf otherwise, 0 at range <= 0,
    range_rate_sigma = sqrt(var v_x + w^2 var y + 2 w cov(v_x, y)) (odometry exact),
    settled = 1 / 0 (NaN without an estimate).

accel: the filter's acceleration (ca) or the slope of a least-squares line
through the filtered ground velocity over the last ``history_s`` (cv, imm),
projected on the direction of motion; yaw_rate: slope of a line through the
unwrapped heading of the ground velocity (world-fixed axes, integrating the
ego's yaw) over ``history_s``. Both are NaN until the filter has had
``settle_updates`` updates and ``min_history`` samples, and while the object
is slower than ``min_speed_accel`` / ``min_speed_yaw``. A slope is also NaN
(unknown) within ``derivative_min_sigmas`` stds of the drift a *converging*
estimate makes over the window: by Kalman orthogonality an estimate of a
constant moves by (its variance at the window's start - at its end) in
variance as it converges, so sqrt(var_0 - var_1) / window is the std of a
slope that is no motion at all (0 once the filter is steady, so steady tracks
keep their slopes). A new track's velocity converging from the prior read
as up to 35 m/s^2 ('sudden brake' of oncoming and parked cars) and its
heading as a turn. The yaw rate also needs a heading at the window's ends:
speed at least ``heading_min_sigmas`` of the velocity's std across the
motion (a crossing cyclist whose velocity is known to +-2 m/s across its
4 m/s read as turning at 1.7 rad/s).

Learned height
--------------
Every box with a ground contact and a top gives the track's height as the ground cue
sees it, h = (x_ground at the face - m_x) (s(y1) - s(y2)) (``Measurement.height_ground``,
relative std from the box's noise). A contact z above the road (a kerb, a pavement:
0.15 m, 11 % of a 1.4 m camera height) is read as the road, so h = H m_z / (m_z - z):
log h = log H + b with b ~ z / m_z the same every frame. The track keeps the
inverse-variance mean o of log h (variance 1 / info) and its height is the posterior
of log H given o under the class's height prior -- a mixture where the class has
``height_modes`` (pedestrians: adults 1.70 +- 0.10, children 1.20 +- 0.15, one in
five), else N(height, height_sigma^2), in log space -- and b ~ N(0, (contact_height_sigma /
m_z)^2): per mode, gain Va / (Va + Vb + 1 / info), variance Va (Vb + 1 / info) / (Va + Vb +
1 / info); modes weighted by how well each explains o, moment-matched. ``Estimates.height``
is that posterior's mean (the prior before any evidence). Measured on the shipped
scenarios (gt detector, settled tracks), median estimated / true height: adults 1.81 /
1.81 m (the previous running mean of ground-cue heights with the prior: 1.99, the
pavement's 11 % in it), cones 0.64 / 0.63, cows 1.28 / 1.29; a child on a pavement
1.48 / 1.24 (its evidence, 1.40, sits between the modes).

``range_learned_height`` (off by default) ranges each box with that height and its
std instead of the class prior (``BoxRanger.measure(height=...)``). Measured on the
shipped scenarios (gt detector) it made the monocular scale ambiguity worse, not
better: the learned height comes from the ground cue, so the height cue then
repeats the ground cue's scale -- a pedestrian on a pavement is ranged the full
11 % too far, where the class prior's height (1.60 m, adults in the simulator
1.75-1.9 m) had put the height cue about as far too near; running pedestrians
read as walking (pedestrian behaviour F1 0.77 to 0.59 with ``height_modes``, 0.65
without; the pedestrians' range p90 did drop, 4.2 to 2.8 m), a waving pedestrian's
raised arm moved its range, and car ranges
lost the independent height cue (per-run median relative range error of the
car-following runs 0.9-2.2 % to 1.9-2.8 %).
Cyclists and vehicles gained behaviour F1 (0.82 to 0.91, 0.68 to 0.72; small
classes). The pavement's height itself is not observable from one camera and
the ego's motion alone (a scaled world with a scaled object speed explains the
same boxes); a road-edge model would be needed.

Call ``update`` every frame, also with no tracks, so ego motion accumulates.
Filters of tracks unseen for more than ``max_coast_s`` are dropped.

Without ego speed
-----------------
``EgoOdometry.speed_known`` False (real video without a speed source): the
filters' velocity is the object's velocity *relative to the ego's translation*
(ego speed 0 in the compensation above; the ego's yaw rate is still applied),
with a broader x prior (``UNKNOWN_EGO_SPEED_SIGMA`` added in quadrature: a
parked car closes at the ego's speed) and the ego's unknown acceleration as
extra process noise on x (``UNKNOWN_EGO_ACCEL_SIGMA``). Relative quantities are
estimated as usual: range, lateral, half_width, range_rate, lateral_rate,
range_rate_sigma, settled, ttc (range / closing speed), height, and ground_vy /
ground_vy_sigma (the ego moves along its own x axis, so lateral velocity is the
same relative and over the ground). Whatever needs the ego's speed is NaN --
unavailable, not guessed (``Estimator.NEEDS_EGO_SPEED``): ground_vx and its std,
accel_x and its std, accel and yaw_rate of the motion over the ground; the
heading used for the contact offset is road-aligned and no ground-velocity
history is kept. When the speed's availability changes, every filter's x
velocity is shifted by the ego speed at the change (the last known one held
over the interval when it goes; the new one when it comes back) and the
histories restart, so tracks carry on. The tracker works in pixels and uses no
odometry.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field, fields

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import Detections
from lookahead.perception.estimator_config import ClassPrior, EstimatorConfig, PriorTable
from lookahead.perception.frame import EgoOdometry
from lookahead.perception.geometry import rotation_2d
from lookahead.perception.ground_map import GroundMap
from lookahead.perception.ranging import MIN_DEPTH, BoxRanger, Measurement
from lookahead.perception.tracker import Tracks, TrackState

__all__ = ["ClassPrior", "Estimates", "Estimator", "EstimatorConfig", "Measurement", "time_to_collision"]

log = logging.getLogger(__name__)

_BEARING_ONLY_SIGMA = 100.0  # m, range std of a bearing-only measurement
#: Without ego speed (``EgoOdometry.speed_known`` False): the std (m/s) of the unknown ego speed,
#: added in quadrature to a new filter's x-velocity prior (the velocity is relative then, and a
#: parked car ahead of an ego at 50 km/h closes at 14 m/s) ...
UNKNOWN_EGO_SPEED_SIGMA = 15.0
#: ... and the std (m/s^2) of the ego's unknown acceleration, white acceleration noise added to
#: the x axis of every model (the ego's braking moves every relative velocity).
UNKNOWN_EGO_ACCEL_SIGMA = 2.0


@dataclass
class Estimates:
    """Per-track estimates, rows aligned with the ``Tracks`` given to ``update`` (all (N,) float).

    range: nearest point's ego x (m); range_sigma: its std (m); lateral: centre
    y (m, left +); half_width: half the y extent (m); range_rate /
    lateral_rate: velocity relative to the (rotating) ego frame (m/s);
    ground_vx / ground_vy: velocity over the ground in ego axes (m/s; ground_vx NaN
    without ego speed, like ground_vx_sigma, accel_x(_sigma), accel and yaw_rate:
    ``Estimator.NEEDS_EGO_SPEED``); accel:
    along the motion (m/s^2, NaN unknown); yaw_rate: of the object's motion
    (rad/s, NaN unknown); ttc: time to collision (s, inf when not closing);
    range_rate_sigma: the filter's std of range_rate (m/s), which tells how far
    the velocity can be trusted yet (a new track starts from a broad prior);
    ground_vx_sigma / ground_vy_sigma: stds of ground_vx / ground_vy (m/s);
    lateral_sigma: std of lateral (m);
    accel_x: the ground acceleration along the ego x axis (m/s^2; the IMM's
    mixture, so a steady object reads ~0) and accel_x_sigma its std; height: the
    track's height (m), its class prior refined by every box's ground contact.
    """

    range: np.ndarray
    range_sigma: np.ndarray
    lateral: np.ndarray
    half_width: np.ndarray
    range_rate: np.ndarray
    lateral_rate: np.ndarray
    ground_vx: np.ndarray
    ground_vy: np.ndarray
    accel: np.ndarray
    yaw_rate: np.ndarray
    ttc: np.ndarray
    range_rate_sigma: np.ndarray
    settled: np.ndarray
    ground_vx_sigma: np.ndarray
    ground_vy_sigma: np.ndarray
    lateral_sigma: np.ndarray
    accel_x: np.ndarray
    accel_x_sigma: np.ndarray
    height: np.ndarray

    #: Fields of ``intent.labels.Kinematics`` this struct provides.
    KINEMATICS_FIELDS = (
        "range",
        "lateral",
        "half_width",
        "range_rate",
        "lateral_rate",
        "ground_vx",
        "ground_vy",
        "accel",
        "yaw_rate",
        "range_rate_sigma",
        "settled",
        "accel_x",
        "ground_vx_sigma",
        "ground_vy_sigma",
        "lateral_sigma",
        "height",
    )
    _DECIMALS = {"yaw_rate": 4, "ttc": 3}

    @classmethod
    def empty(cls, n: int = 0) -> Estimates:
        """N rows of NaN (ttc NaN too)."""
        return cls(**{f.name: np.full(n, np.nan) for f in fields(cls)})

    def __len__(self) -> int:
        return len(self.range)

    def __getitem__(self, index: np.ndarray | slice | int) -> Estimates:
        if isinstance(index, int | np.integer):
            index = np.array([index])
        return Estimates(**{f.name: getattr(self, f.name)[index] for f in fields(self)})

    def kinematics_fields(self) -> dict[str, np.ndarray]:
        """Keyword arguments for ``intent.labels.Kinematics`` (add ``class_id`` and ``age``).

        perception never imports intent; intent builds the struct:
        ``Kinematics(class_id=tracks.class_id, age=tracks.age, **est.kinematics_fields())``.
        """
        return {name: getattr(self, name) for name in self.KINEMATICS_FIELDS}

    def to_dict(self) -> dict:
        """Lists rounded to mm / mm/s (yaw rate 1e-4 rad/s); NaN and inf kept as floats."""
        return {
            f.name: np.round(getattr(self, f.name), self._DECIMALS.get(f.name, 3)).tolist()
            for f in fields(self)
        }


def time_to_collision(rng: np.ndarray, range_rate: np.ndarray) -> np.ndarray:
    """TTC (s): range / closing speed while closing, inf when opening, 0 at range <= 0, NaN for NaN."""
    r = np.asarray(rng, dtype=np.float64)
    closing = -np.asarray(range_rate, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ttc = np.where(closing > 1e-6, np.maximum(r, 0.0) / closing, np.inf)
    ttc = np.where(r <= 0.0, 0.0, ttc)
    return np.where(np.isnan(r) | np.isnan(closing), np.nan, ttc)


def _drift_sigma(t: np.ndarray, var: np.ndarray) -> float:
    """Std of the slope over the window ``t`` (n,) s that is drift, not change, of an estimate
    whose variance went from ``var[0]`` to ``var[-1]`` (units^2; the slope's: units / s): one
    converging on a constant moves by var[0] - var[-1] in variance over the window (Kalman
    orthogonality: its error at the start is its error at the end plus an independent part);
    a steady or widening one, 0."""
    return float(np.sqrt(max(float(var[0] - var[-1]), 0.0))) / float(t[-1] - t[0])


def _along_var(cov: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Variance (n,) along the unit vectors ``u`` ((2,) or (n, 2)) of 2x2 covariances ``cov``
    (n, 3) stored as (pxx, pxy, pyy)."""
    u = np.broadcast_to(u, (len(cov), 2))
    return np.maximum(u[:, 0] ** 2 * cov[:, 0] + 2 * u[:, 0] * u[:, 1] * cov[:, 1] + u[:, 1] ** 2 * cov[:, 2], 0.0)


def _slope_fit(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares slopes of y (n, k) against t (n,)."""
    tc = t - t.mean()
    return tc @ (y - y.mean(axis=0)) / (tc @ tc)


class _MotionFilter:
    """Interacting multiple model (IMM) Kalman filter on X = [x, y, v_x, v_y, a_x, a_y].

    One model is a plain Kalman filter (mode probability 1). ``xs`` (M, 6) and
    ``Ps`` (M, 6, 6) are the models' states, ``mu`` (M,) their probabilities;
    ``x`` / ``P`` the moment-matched mixture. H = [I 0 0].
    """

    def __init__(self, x: np.ndarray, p: np.ndarray, mu: np.ndarray) -> None:
        m = len(mu)
        self.xs = np.repeat(x[None], m, axis=0)
        self.Ps = np.repeat(p[None], m, axis=0)
        self.mu = np.asarray(mu, dtype=np.float64).copy()
        self._combine()

    def _combine(self) -> None:
        self.x = self.mu @ self.xs
        dx = self.xs - self.x
        self.P = np.einsum("m,mij->ij", self.mu, self.Ps + dx[:, :, None] * dx[:, None, :])

    def transform(self, jac: np.ndarray, shift: np.ndarray) -> None:
        """x <- J (x - [shift, 0 ...]), P <- J P J^T (every model)."""
        self.xs[:, :2] -= shift
        self.xs = self.xs @ jac.T
        self.Ps = jac @ self.Ps @ jac.T
        self._combine()

    def predict(self, models: list[tuple[np.ndarray, np.ndarray]], trans: np.ndarray) -> None:
        """IMM mixing with the Markov matrix ``trans`` (M, M), then each model's (F, Q)."""
        if len(models) > 1:
            c = trans.T @ self.mu  # predicted mode probabilities
            w = trans * self.mu[:, None] / np.maximum(c, 1e-300)[None, :]  # w[i, j] = P(i | j)
            x0 = w.T @ self.xs
            dx = self.xs[:, None, :] - x0[None, :, :]  # (i, j, d)
            self.Ps = np.einsum("ij,iab->jab", w, self.Ps) + np.einsum("ij,ija,ijb->jab", w, dx, dx)
            self.xs = x0
            self.mu = c / c.sum()
        for j, (f, q) in enumerate(models):
            self.xs[j] = f @ self.xs[j]
            self.Ps[j] = f @ self.Ps[j] @ f.T + q
        self._combine()

    def nis(self, z: np.ndarray, r: np.ndarray) -> float:
        """Normalised innovation squared of ``z`` against the mixture's prediction."""
        innov = z - self.x[:2]
        try:
            return float(innov @ np.linalg.solve(self.P[:2, :2] + r, innov))
        except np.linalg.LinAlgError:
            return np.inf

    def update(self, z: np.ndarray, r: np.ndarray) -> None:
        """Kalman update of every model; mode probabilities from the innovation likelihoods."""
        m = len(self.mu)
        loglik = np.zeros(m)
        for j in range(m):
            p = self.Ps[j]
            innov = z - self.xs[j, :2]
            s = p[:2, :2] + r
            k = np.linalg.solve(s, p[:2, :]).T  # P H^T S^-1 (S symmetric)
            self.xs[j] = self.xs[j] + k @ innov
            ikh = np.eye(len(p))
            ikh[:, :2] -= k
            self.Ps[j] = ikh @ p @ ikh.T + k @ r @ k.T  # Joseph form
            loglik[j] = -0.5 * (innov @ np.linalg.solve(s, innov) + np.log(np.linalg.det(s)))
        if m > 1:
            lw = np.log(np.maximum(self.mu, 1e-300)) + loglik
            w = np.exp(lw - lw.max())
            self.mu = np.maximum(w / w.sum(), 1e-6)
            self.mu /= self.mu.sum()
        self._combine()

    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.xs)) and np.all(np.isfinite(self.Ps)) and np.all(np.isfinite(self.mu)))


@dataclass(eq=False)
class _TrackFilter:
    """Motion filter and history of one track."""

    kf: _MotionFilter
    class_id: int
    last_update: float
    half_width: float
    updates: int = 1
    born: float = 0.0  # time of the first update (s)
    settled: bool = False  # the range rate has converged (latched)
    outliers: int = 0  # consecutive measurements that failed the NIS gate
    height_info: float = 0.0  # sum of inverse variances of the log-height evidence (no prior)
    height_sum: float = 0.0  # inverse-variance weighted sum of the log heights
    #: (t, vx, vy, pxx, pxy, pyy): ground velocity (m/s) and its covariance (m^2/s^2), world-fixed axes
    history: deque = field(default_factory=deque)


class Estimator:
    """Per-track range, lateral offset, velocity and TTC (see the module docstring).

    Args:
        camera: the calibrated camera the boxes come from.
        config: parameters; ``EstimatorConfig()`` when None.
    """

    def __init__(self, camera: CameraModel, config: EstimatorConfig | None = None) -> None:
        self.camera = camera
        self.config = config or EstimatorConfig()
        self.priors = PriorTable(self.config)
        self.ranger = BoxRanger(camera, self.config, self.priors)
        self._dim = 6
        self.reset()

    def reset(self) -> None:
        """Forget every filter, the clock and the integrated ego yaw."""
        self._filters: dict[int, _TrackFilter] = {}
        self._t: float | None = None
        self._speed = 0.0
        self._yaw_rate = 0.0
        self._ego_yaw = 0.0  # integrated ego heading since the first frame (rad)
        self._relative = False  # filter velocities relative to the ego (no ego speed), not over the ground

    @property
    def num_filters(self) -> int:
        """Number of filters in the bank (tracks seen within ``max_coast_s``)."""
        return len(self._filters)

    # ------------------------------------------------------------ priors
    def prior_of(self, class_id: np.ndarray, key: str) -> np.ndarray:
        """The class prior ``key`` (a ``ClassPrior`` field) of each class id; ids outside ``CLASSES``
        get ``default_prior``'s."""
        return self.priors.of(class_id, key)

    # ------------------------------------------------------------ one frame
    def measure(
        self, xyxy: np.ndarray, class_id: np.ndarray, cos_heading: np.ndarray | None = None,
        height: np.ndarray | None = None, height_sigma: np.ndarray | None = None,
        ground: GroundMap | None = None,
    ) -> Measurement:
        """Single-frame position measurements of boxes (N, 4) with classes (N,):
        ``BoxRanger.measure`` (``perception.ranging``) with this estimator's camera and config.

        ``cos_heading``: |cos| of each object's heading relative to the ego x axis
        (1 = seen end-on, the default; 0 = side-on), for the contact offset; ``height`` /
        ``height_sigma``: each object's own height and std (m) in place of the class prior;
        ``ground``: the frame's ground map, whose surface under each box's bottom-centre ray is
        the contact's plane (with ``config.ground_map``; None: the road plane).
        """
        return self.ranger.measure(xyxy, class_id, cos_heading, height, height_sigma, ground)

    def update(
        self,
        tracks: Tracks,
        odometry: EgoOdometry | None,
        t: float,
        detections: Detections | None = None,
        ground: GroundMap | None = None,
    ) -> Estimates:
        """Advance to time ``t`` (s) with this frame's tracks and ego odometry; return estimates.

        Rows are aligned with ``tracks``. Rows with an invalid box (NaN,
        degenerate, above the horizon) get NaN; lost tracks (``state`` LOST)
        get their filter's prediction without an update. With ``detections``
        (the ones given to the tracker this frame), a track matched this frame
        is measured on its raw detection box (``det_index``) rather than on
        the tracker's smoothed box, so the two filters do not stack their lag. ``ground``: the
        frame's ground map (``Frame.ground``), for contacts on a pavement (``measure``).

        ``odometry.speed_known`` False (see "Without ego speed" in the module docstring): the
        filters run on velocities relative to the ego and the fields that need the ego's speed
        are NaN; a change of the speed's availability converts the filters at the change.
        """
        cfg = self.config
        speed, yaw_rate = self._odometry(odometry)
        known = odometry is None or bool(getattr(odometry, "speed_known", True))
        if not known:
            speed = 0.0  # the filters' velocities are relative: the ego's translation is theirs
        t = float(t)
        if not np.isfinite(t):
            log.warning("non-finite time %r: estimates are NaN", t)
            return Estimates.empty(len(tracks))
        if self._t is not None:
            dt = t - self._t
            was_known = not self._relative
            w_mean = 0.5 * (yaw_rate + self._yaw_rate)
            if dt < 0.0:
                log.warning("time went back from %.3f to %.3f s: resetting the estimator", self._t, t)
                self.reset()
            elif known == was_known:
                if dt > 0.0:
                    self._advance(dt, 0.5 * (speed + self._speed), w_mean, relative=not known)
            elif known:  # the speed is back: relative over the interval, then over the ground
                if dt > 0.0:
                    self._advance(dt, 0.0, w_mean, relative=True)
                self._shift_velocity(speed)
            else:  # the speed is gone: the last one held over the interval, then relative
                if dt > 0.0:
                    self._advance(dt, self._speed, w_mean, relative=False)
                self._shift_velocity(-self._speed)
        self._t, self._speed, self._yaw_rate = t, speed, yaw_rate
        self._relative = not known

        n = len(tracks)
        mapped = ground is not None and cfg.ground_map  # contact heights known: the map's std, not the class's
        h_known, sh_known = self._learned_heights(tracks, mapped) if cfg.range_learned_height else (None, None)
        meas = self.measure(self._boxes(tracks, detections), tracks.class_id, self._cos_heading(tracks),
                            h_known, sh_known, ground)
        valid = meas.valid
        state = np.full((n, self._dim), np.nan)
        p_diag = np.full((n, self._dim), np.nan)
        p_rr = np.full(n, np.nan)
        settled = np.full(n, np.nan)
        hw = np.full(n, np.nan)
        height = np.full(n, np.nan)
        hist: list[deque | None] = [None] * n
        to_world = rotation_2d(self._ego_yaw)
        for i in range(n):
            tid, cls = int(tracks.track_id[i]), int(tracks.class_id[i])
            trk = self._filters.get(tid)
            outlier = False
            if valid[i] and int(tracks.state[i]) != TrackState.LOST:
                z0, r0 = np.array([meas.x[i], meas.lateral[i]]), meas.cov[i]
                z, r = z0, r0
                if trk is not None and meas.cut_bottom[i]:
                    z, r = self._cut_bottom_update(trk, meas, i)
                outcome = "restart" if trk is None else self._update(trk, z, r)
                outlier = outcome == "outlier"
                if outcome == "restart":  # a new filter starts from the box itself
                    trk = self._new_filter(z0, r0, cls, tracks.xyxy[i], tracks.velocity_px[i], t, speed, yaw_rate)
                    self._filters[tid] = trk
            if not outlier and valid[i] and int(tracks.state[i]) != TrackState.LOST:
                trk.class_id, trk.last_update = cls, t
                a, hw_i = cfg.half_width_alpha, float(meas.half_width[i])
                trk.half_width = hw_i if np.isnan(trk.half_width) else a * hw_i + (1 - a) * trk.half_width
                self._add_height(trk, meas, i)
                if trk.updates >= cfg.settle_updates and not self._relative:  # ground velocities only
                    v_w = to_world @ trk.kf.x[2:4]
                    p_w = to_world @ trk.kf.P[2:4, 2:4] @ to_world.T
                    trk.history.append((t, v_w[0], v_w[1], p_w[0, 0], p_w[0, 1], p_w[1, 1]))
                while trk.history and trk.history[0][0] < t - cfg.history_s - 1e-9:
                    trk.history.popleft()
            if trk is None or not (valid[i] or int(tracks.state[i]) == TrackState.LOST):
                continue
            state[i] = trk.kf.x
            p_diag[i] = np.diag(trk.kf.P)
            # var(v_x + w y): range_rate = v_x - v_ego + w y, the ego's odometry taken as exact
            pm = trk.kf.P
            p_rr[i] = pm[2, 2] + yaw_rate**2 * pm[1, 1] + 2.0 * yaw_rate * pm[1, 2]
            if not trk.settled and trk.last_update == t:
                rr_i = abs(float(trk.kf.x[2]) - speed + yaw_rate * float(trk.kf.x[1]))
                limit = max(cfg.settle_range_rate_sigma, cfg.settle_range_rate_rel * rr_i)
                bound_only = meas.cut_bottom[i] or meas.side_bound[i]  # a range bound says nothing of its rate
                converged = np.sqrt(max(p_rr[i], 0.0)) <= limit and not bound_only
                trk.settled = bool(converged) or t - trk.born >= cfg.settle_max_s - 1e-9
            settled[i] = float(trk.settled)
            hw[i] = trk.half_width
            height[i] = self._height_posterior(trk.height_sum, trk.height_info, cls, mapped)[0]
            hist[i] = trk.history if trk.updates >= cfg.settle_updates and not self._relative else None

        for tid in [k for k, f in self._filters.items() if t - f.last_update > cfg.max_coast_s]:
            del self._filters[tid]
        est = self._outputs(state, p_diag, p_rr, settled, hw, height, hist, speed, yaw_rate)
        if self._relative:  # over-ground quantities need the ego's speed: unavailable, not guessed
            for name in self.NEEDS_EGO_SPEED:
                getattr(est, name)[:] = np.nan
        return est

    #: ``Estimates`` fields that need the ego's speed, NaN without it: the object's velocity and
    #: acceleration over the ground along the ego's x axis (ground_vy stays: the ego moves along
    #: its own x axis, so the lateral velocity is the same relative and over the ground) and the
    #: accel / yaw rate of its motion over the ground.
    NEEDS_EGO_SPEED = ("ground_vx", "ground_vx_sigma", "accel", "yaw_rate", "accel_x", "accel_x_sigma")

    def _shift_velocity(self, dv: float) -> None:
        """Add ``dv`` (m/s) to every filter's x velocity (ground <-> relative at a change of the ego
        speed's availability; the covariance is unchanged) and forget the ground-velocity histories."""
        for trk in self._filters.values():
            trk.kf.xs[:, 2] += dv
            trk.kf._combine()
            trk.history.clear()

    def _add_height(self, trk: _TrackFilter, meas: Measurement, i: int) -> None:
        """Add this frame's height evidence to the track's: every box with a ground contact and a
        top gives h = ``height_ground`` (the ground cue's face x - m_x) * height_slope, relative std
        ``height_rel_sigma`` (the box's noise) -- the ground cue only, so the height the range
        leans on does not come back as evidence; at the face, not at the contact the box bottom
        shows (a bus's rear wheels are 2.8 m behind its face: heights 15-30 % too tall at 10-20
        m). Kept as the inverse-variance weighted mean of log h (``_height_posterior``)."""
        h, rel = float(meas.height_ground[i]), float(meas.height_rel_sigma[i])
        if np.isfinite(h) and np.isfinite(rel) and h > 0.0 and rel > 0.0:
            trk.height_info += 1.0 / rel**2
            trk.height_sum += np.log(h) / rel**2

    def _height_posterior(self, log_sum: float, info: float, cls: int, mapped: bool = False) -> tuple[float, float]:
        """A track's height and its std (m) from its evidence (``_add_height``: sum of log h / var and
        of 1 / var) and its class's priors (module docstring, "Learned height"). ``mapped``: the
        contacts' heights come from a ground map (``EstimatorConfig.ground_map_sigma`` for b).

        The ground cue reads a contact z above the road (a kerb, a pavement) as the road, so its
        heights are H m_z / (m_z - z): log h = log H + b, b ~ z / m_z, the same every frame. With
        log H ~ N(log height, (height_sigma / height)^2) and b ~ N(0, (contact_height_sigma /
        m_z)^2), the evidence's mean o (variance 1 / info) measures log H + b: log H's posterior
        has gain Va / (Va + Vb + 1 / info) and variance Va (Vb + 1 / info) / (Va + Vb + 1 / info).
        No evidence: the prior."""
        cid = np.array([cls])
        if not info > 0.0:
            return float(self.prior_of(cid, "height")[0]), float(self.prior_of(cid, "height_sigma")[0])
        contact_sigma = self.config.ground_map_sigma if mapped else float(self.prior_of(cid, "contact_height_sigma")[0])
        vb = (contact_sigma / self.camera.mount[2]) ** 2
        vo, o = vb + 1.0 / info, log_sum / info
        w, m, v = [], [], []
        for weight, h0, s0 in self.priors.modes_of(cls):
            va, mu = (s0 / h0) ** 2, np.log(h0)
            w.append(weight * np.exp(-0.5 * (o - mu) ** 2 / (va + vo)) / np.sqrt(va + vo))
            m.append(mu + va / (va + vo) * (o - mu))
            v.append(va * vo / (va + vo))
        w_arr, m_arr, v_arr = np.asarray(w), np.asarray(m), np.asarray(v)
        if not w_arr.sum() > 0.0:  # the evidence far from every mode: the nearest one's posterior
            w_arr = np.eye(len(w))[int(np.argmin(np.abs(o - m_arr)))]
        w_arr = w_arr / w_arr.sum()
        a = float(w_arr @ m_arr)
        var = float(w_arr @ (v_arr + (m_arr - a) ** 2))
        h = float(np.exp(a))
        return h, h * float(np.sqrt(var))

    def _learned_heights(self, tracks: Tracks, mapped: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Each track's learned height and std (``_height_posterior``) for the ranging; NaN (the class
        prior) for tracks without a filter or evidence yet."""
        n = len(tracks)
        h, sh = np.full(n, np.nan), np.full(n, np.nan)
        for i, tid in enumerate(tracks.track_id):
            trk = self._filters.get(int(tid))
            if trk is not None and trk.height_info > 0.0:
                h[i], sh[i] = self._height_posterior(trk.height_sum, trk.height_info, int(tracks.class_id[i]), mapped)
        return h, sh

    def _cut_bottom_update(self, trk: _TrackFilter, meas: Measurement, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Measurement for a running filter from a box cut at the bottom.

        The top ray's error is mostly the object's height minus the prior: the
        same every frame, so repeating it would not average out but drag the
        filter. The box adds its bearing only (a huge range std along the ray)
        and the filter's prediction carries the range; a prediction beyond the
        bound x_max is pulled back to it, and so is one nearer than x_min: the
        point whose bearing the box shows is in view, so in front of the camera
        (x_min = m_x + MIN_DEPTH - ``Measurement.bearing_depth``: a car alongside
        whose box shows its front inner corner reaches at most its length
        behind that). A filter started on a car alongside from the velocity
        prior carried it 5-8 m behind the ego (``cut_in``) and its bearing taken
        at a clamped depth there put its lateral 1-2 m off the line the bearing
        defines. A pull-back far beyond the filter's own spread fails the NIS gate:
        the filter coasts a frame and restarts on the box's own measurement (the
        truncated top-ray range, ``perception.ranging`` step 4) -- in ``cut_in``
        two frames earlier than the range-rate disagreement did before.
        """
        mx, my = self.camera.mount[0], self.camera.mount[1]
        x_pred, x_max = float(trk.kf.x[0]), float(meas.x_max[i])
        deep = float(meas.bearing_depth[i])
        x_min = mx + MIN_DEPTH - deep
        if x_pred > x_max:
            x, sig = x_max, float(meas.sigma[i])
        elif x_pred < x_min:
            x, sig = x_min, float(meas.sigma[i])
        else:
            x, sig = x_pred, _BEARING_ONLY_SIGMA
        xc = max(x - mx, MIN_DEPTH - deep)
        z = np.array([x, my + xc * meas.tan_y[i] + meas.lateral_offset[i]])
        r = self.ranger.position_cov(
            np.array([xc]), np.array([sig]), meas.tan_y[i : i + 1], meas.sigma_bearing[i], meas.var_y_extra[i]
        )[0]
        return z, r

    def _cos_heading(self, tracks: Tracks) -> np.ndarray:
        """|cos| of each track's heading vs the ego x axis: its motion direction when its
        filter has settled and its ground speed is above ``heading_min_speed``, else 1
        (aligned with the road); a velocity component under ``heading_min_sigmas`` of its
        std counts as 0 (a bus's lateral noise must not turn it across the road)."""
        out = np.ones(len(tracks))
        if self._relative:  # without ego speed the heading over the ground is unknown: road-aligned
            return out
        for i, tid in enumerate(tracks.track_id):
            trk = self._filters.get(int(tid))
            if trk is None or not trk.settled:  # a velocity not yet converged says nothing of the heading
                continue
            v = trk.kf.x[2:4]
            sig = np.sqrt(np.maximum(np.diag(trk.kf.P)[2:4], 0.0))
            v = np.where(np.abs(v) >= self.config.heading_min_sigmas * sig, v, 0.0)  # noise is no heading
            speed = float(np.hypot(*v))
            if np.isfinite(speed) and speed >= self.config.heading_min_speed:
                out[i] = abs(float(v[0])) / speed
        return out

    @staticmethod
    def _boxes(tracks: Tracks, detections: Detections | None) -> np.ndarray:
        """Boxes to measure: raw detection boxes where a track has one this frame."""
        boxes = tracks.xyxy
        if detections is None or len(tracks) == 0:
            return boxes
        di = tracks.det_index
        raw = (di >= 0) & (di < len(detections))
        if np.any(raw):
            boxes = boxes.copy()
            boxes[raw] = detections.xyxy[di[raw]]
        return boxes

    @staticmethod
    def _odometry(odometry: EgoOdometry | None) -> tuple[float, float]:
        if odometry is None:
            return 0.0, 0.0
        v, w = float(odometry.speed), float(odometry.yaw_rate)
        if not (np.isfinite(v) and np.isfinite(w)):
            log.warning("non-finite odometry (speed %r, yaw rate %r) taken as 0", v, w)
            v, w = (v if np.isfinite(v) else 0.0), (w if np.isfinite(w) else 0.0)
        return v, w

    def _process(self, dt: float, class_id: int, relative: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
        """(F, Q) over ``dt`` (s) of each model: [cv], [ca] or [quiet cv, ca] (``imm``); ``relative``
        (no ego speed): plus white acceleration noise ``UNKNOWN_EGO_ACCEL_SIGMA`` on the x axis."""
        # lazy: filterpy.common pulls in filterpy.kalman and scipy.stats (~0.6 s), which every
        # command that only reads a scenario would pay at start-up
        from filterpy.common import Q_continuous_white_noise, Q_discrete_white_noise

        cfg = self.config
        cid = np.array([class_id])
        models = []
        names = {"cv": ("cv",), "ca": ("ca",), "imm": ("cv", "ca")}[cfg.motion_model]
        for name in names:
            f = np.eye(6)
            f[0, 2] = f[1, 3] = dt  # p += v dt
            q = np.zeros((6, 6))
            if name == "cv":
                f[4, 4] = f[5, 5] = 0.0  # no acceleration
                sa = float(self.prior_of(cid, "accel_sigma")[0])
                if cfg.motion_model == "imm":
                    sa *= cfg.imm_quiet_accel_scale
                q[:4, :4] = Q_discrete_white_noise(2, dt=dt, var=sa**2, block_size=2, order_by_dim=False)
                if cfg.motion_model == "imm":  # acceleration unknown to this model, not zero: mixing
                    q[4:, 4:] = np.eye(2) * float(self.prior_of(cid, "accel_sigma")[0]) ** 2  # keeps ca's open
            else:
                f[2, 4] = f[3, 5] = dt  # v += a dt
                f[0, 4] = f[1, 5] = 0.5 * dt * dt  # p += a dt^2 / 2
                dens = float(self.prior_of(cid, "jerk_sigma")[0]) ** 2
                q = Q_continuous_white_noise(3, dt=dt, spectral_density=dens, block_size=2, order_by_dim=False)
            if relative:
                q = q.copy()
                q[np.ix_([0, 2], [0, 2])] += Q_discrete_white_noise(2, dt=dt, var=UNKNOWN_EGO_ACCEL_SIGMA**2)
            models.append((f, q))
        return models

    def _transition(self, dt: float) -> np.ndarray:
        """IMM Markov matrix over ``dt``: mean sojourn ``imm_quiet_s`` / ``imm_manoeuvre_s``."""
        cfg = self.config
        p01 = 1.0 - np.exp(-dt / cfg.imm_quiet_s)
        p10 = 1.0 - np.exp(-dt / cfg.imm_manoeuvre_s)
        return np.array([[1.0 - p01, p01], [p10, 1.0 - p10]])

    def _advance(self, dt: float, speed: float, yaw_rate: float, relative: bool = False) -> None:
        """Re-express every filter in the new ego frame, then predict it by ``dt`` (``relative``:
        velocities relative to the ego, ``speed`` 0 -- the ego's translation is in them)."""
        theta = yaw_rate * dt
        chord = speed * dt * np.sinc(theta / (2.0 * np.pi))
        shift = chord * np.array([np.cos(theta / 2.0), np.sin(theta / 2.0)])
        rot = rotation_2d(-theta)
        jac = np.kron(np.eye(self._dim // 2), rot)
        self._ego_yaw += theta
        models: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
        trans = self._transition(dt)
        for trk in self._filters.values():
            trk.kf.transform(jac, shift)
            if trk.class_id not in models:
                models[trk.class_id] = self._process(dt, trk.class_id, relative)
            trk.kf.predict(models[trk.class_id], trans)

    def _update(self, trk: _TrackFilter, z: np.ndarray, r: np.ndarray) -> str:
        """Kalman update: ``ok``; ``outlier`` (skipped, the filter coasts) when the innovation
        fails the NIS gate for fewer than ``reinit_outliers`` frames in a row -- one box of a
        neighbour the tracker took for a frame must not restart the filter --; ``restart`` when
        it keeps failing (the track follows another object now) or the update breaks."""
        nis = trk.kf.nis(z, r)
        if not nis <= self.config.reinit_nis:
            trk.outliers += 1
            if trk.outliers < self.config.reinit_outliers:
                log.debug("measurement skipped as an outlier: NIS %.1f", nis)
                return "outlier"
            log.debug("track filter restarted: NIS %.1f", nis)
            return "restart"
        try:
            trk.kf.update(z, r)
        except np.linalg.LinAlgError:
            return "restart"
        trk.updates += 1
        trk.outliers = 0
        return "ok" if trk.kf.finite() else "restart"

    def _new_filter(
        self,
        z: np.ndarray,
        r: np.ndarray,
        cls: int,
        xyxy: np.ndarray,
        velocity_px: np.ndarray,
        t: float,
        speed: float,
        yaw_rate: float,
    ) -> _TrackFilter:
        """Filter at the measurement; ground velocity from the class prior N(0, speed_sigma^2)
        per axis, optionally fused with the tracker's box rates (scale change). Without ego speed
        (relative velocities) the x axis's prior std has ``UNKNOWN_EGO_SPEED_SIGMA`` added in quadrature."""
        cfg, cam = self.config, self.camera
        var0 = np.full(2, float(self.prior_of(np.array([cls]), "speed_sigma")[0]) ** 2)
        if self._relative:
            var0[0] += UNKNOWN_EGO_SPEED_SIGMA**2
        ground, var = np.zeros(2), var0
        if cfg.init_from_box_rates:
            xc = z[0] - cam.mount[0]
            with np.errstate(all="ignore"):
                h = xyxy[3] - xyxy[1]
                vcx, vh = velocity_px[0], velocity_px[3]
                rr = -xc * vh / h  # relative range rate from the scale change
                tan_y = (z[1] - cam.mount[1]) / xc
                lr = rr * tan_y - xc * vcx / cam.fx  # d/dt of (x - m_x) * tan_y
            if np.isfinite(rr) and np.isfinite(lr):
                rel = np.clip(np.array([rr, lr]), -cfg.max_init_speed, cfg.max_init_speed)
                meas = rel + np.array([speed - yaw_rate * z[1], yaw_rate * z[0]])
                var1 = cfg.init_velocity_sigma**2
                ground, var = meas * var0 / (var0 + var1), var0 * var1 / (var0 + var1)
        x = np.zeros(6)
        x[:4] = np.concatenate([z, ground])
        p = np.zeros((6, 6))
        p[:2, :2] = r
        p[2:4, 2:4] = np.diag(var)
        mu = {"cv": [1.0], "ca": [1.0], "imm": [cfg.imm_init_quiet, 1.0 - cfg.imm_init_quiet]}[cfg.motion_model]
        if cfg.motion_model != "cv":
            p[4:, 4:] = np.eye(2) * cfg.init_accel_sigma**2
        kf = _MotionFilter(x, p, np.array(mu))
        if cfg.motion_model == "imm":  # the quiet model carries no acceleration
            kf.Ps[0, 4:, :] = kf.Ps[0, :, 4:] = 0.0
            kf._combine()
        return _TrackFilter(kf=kf, class_id=cls, last_update=t, half_width=np.nan, born=t)

    def _outputs(
        self,
        state: np.ndarray,
        p_diag: np.ndarray,
        p_rr: np.ndarray,
        settled: np.ndarray,
        hw: np.ndarray,
        height: np.ndarray,
        hist: list[deque | None],
        speed: float,
        yaw_rate: float,
    ) -> Estimates:
        cfg = self.config
        n = len(state)
        x, y, vx, vy = state[:, :4].T
        rr = vx - speed + yaw_rate * y
        lr = vy - yaw_rate * x
        accel, yaw = np.full(n, np.nan), np.full(n, np.nan)
        to_world = rotation_2d(self._ego_yaw)
        for i, h in enumerate(hist):
            if h is None or len(h) < cfg.min_history:
                continue
            arr = np.asarray(h)
            tt, v_w, p_w = arr[:, 0], arr[:, 1:3], arr[:, 3:6]
            if tt[-1] - tt[0] <= 0:
                continue
            v_now = to_world @ state[i, 2:4]  # world-fixed axes
            s_now = float(np.hypot(*v_now))
            z = cfg.derivative_min_sigmas
            if s_now >= cfg.min_speed_accel:
                u = v_now / s_now
                if cfg.motion_model == "ca":  # the filter's own acceleration: its prior covers convergence
                    accel[i] = float(to_world @ state[i, 4:6] @ u)
                else:  # a slope of the filtered velocity: significant, or a converging velocity's drift
                    a = float(_slope_fit(tt, v_w) @ u)
                    accel[i] = a if abs(a) >= z * _drift_sigma(tt, _along_var(p_w, u)) else np.nan
            speeds = np.hypot(v_w[:, 0], v_w[:, 1])
            if s_now >= cfg.min_speed_yaw and speeds.min() >= cfg.min_speed_yaw:
                heading = np.unwrap(np.arctan2(v_w[:, 1], v_w[:, 0]))
                w = float(_slope_fit(tt, heading[:, None])[0])
                across = np.stack([-v_w[:, 1], v_w[:, 0]], axis=1) / speeds[:, None]
                var_across = _along_var(p_w, across)  # the velocity's variance across the motion (m^2/s^2)
                # a heading at both ends of the window: the speed stands out of its noise across the
                # motion (``heading_min_sigmas``); a turn: beyond the heading's convergence (rad^2)
                ends = [0, -1]
                known = z <= 0 or bool(np.all(speeds[ends] >= cfg.heading_min_sigmas * np.sqrt(var_across[ends])))
                turn = abs(w) >= z * _drift_sigma(tt, var_across / speeds**2)
                yaw[i] = w if known and turn else np.nan
        return Estimates(
            range=x,
            range_sigma=np.sqrt(p_diag[:, 0]),
            lateral=y,
            half_width=hw,
            range_rate=rr,
            lateral_rate=lr,
            ground_vx=vx,
            ground_vy=vy,
            accel=accel,
            yaw_rate=yaw,
            ttc=time_to_collision(x, rr),
            range_rate_sigma=np.sqrt(np.maximum(p_rr, 0.0)),
            settled=settled,
            ground_vx_sigma=np.sqrt(np.maximum(p_diag[:, 2], 0.0)),
            ground_vy_sigma=np.sqrt(np.maximum(p_diag[:, 3], 0.0)),
            lateral_sigma=np.sqrt(np.maximum(p_diag[:, 1], 0.0)),
            accel_x=state[:, 4],
            accel_x_sigma=np.sqrt(np.maximum(p_diag[:, 4], 0.0)),
            height=height,
        )
