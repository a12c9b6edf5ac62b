"""Range, lateral offset, ego-frame velocity and TTC of tracked objects from one camera.

Frames and units
----------------
Ego frame (ISO 8855): origin at the centre of the front bumper on the ground,
x forward, y left, z up. m, s, m/s, rad. Pixels through ``CameraModel``
(``mount`` m = (m_x, m_y, m_z) in the ego frame). Boxes are float xyxy px.
``range`` is the ego-frame x of the object's *nearest* point (its visible
face), ``lateral`` the y of its centre, ``half_width`` half its y extent --
the definitions the ground truth uses (``sim.groundtruth``).

One frame: range from a box (``Estimator.measure``, vectorised)
----------------------------------------------------------------
Let u_c = (x1 + x2) / 2, d(u, v) the ego-frame ray of a pixel
(``camera.pixel_rays``) and s(v) = d_z / d_x its slope in column u_c.

1. Ground contact. The lowest image point of an object standing on a flat
   road is where it touches the road (a vehicle's wheels, see step 6), so
   the bottom-centre pixel (u_c, y2) back-projected onto z = 0
   (``camera.ground_points``) gives x_g. Its std is sigma_g = |dx_g/dv| *
   sigma_v with sigma_v^2 = sigma_px^2 + (k h_px)^2 + (f_y sigma_pitch)^2
   (fixed pixel noise, edge jitter proportional to the box height h_px --
   ``edge_sigma_rel`` 0.05, the ``gt`` detector's default ``box_sigma`` --
   road slope / pitching); dx_g/dv ~ (x_g - m_x)^2 / (f_y m_z), so sigma_g
   grows as r^2 / (f h). A contact above the road plane by z (a kerb, a
   pavement: 0.15 m in the simulator) puts x_g too far by z (x_g - m_x) / m_z;
   the class's ``contact_height_sigma`` (pedestrians 0.1 m) adds that spread
   to sigma_g, so at range the height cue weighs more for classes found on
   pavements. Without a road model the bias itself stays.
2. Height prior H +- sigma_H of the class. A vertical face at x whose foot
   and top project to rows y2 and y1 obeys H = (x - m_x) (s(y1) - s(y2)), so
   x_h = m_x + H / ds -- the exact, pitch-aware form of r_cam ~ f_y H / h_px.
   sigma_h^2 = (x_c sigma_H / H)^2 + (x_c sigma_ds / ds)^2, x_c = x_h - m_x.
   Width prior W +- sigma_W (classes with ``width_cue``: cars, trucks, buses).
   A vehicle seen end-on (|cos psi| >= ``width_cue_min_cos``, psi as in step
   6) whose end face spans the camera's column (t_r < 0 < t_l, t = d_y/d_x of
   the rays through the bottom corners) shows no side face, so the box width
   is W at the face: x_w = m_x + W / (t_l - t_r), sigma_w^2 = (x_c sigma_W /
   W)^2 + (x_c sigma_dt / dt)^2. Its noise comes from the two vertical edges,
   independent of the horizontal ones the other cues share: for a car 20 m
   ahead it cuts the single-frame range error by about a sixth.
3. Fusion. Ground and height cues both move with y2: their errors covary by
   c = (dx_g/dy2)(dx_h/dy2)(k h_px)^2. Their best linear unbiased combination
   has weights (sigma_h^2 - c, sigma_g^2 - c) / (sigma_g^2 + sigma_h^2 - 2c)
   and variance (sigma_g^2 sigma_h^2 - c^2) / (sigma_g^2 + sigma_h^2 - 2c)
   (c capped at the better cue's variance, so no weight is negative; ignoring
   c made the fused range worse than the ground cue alone at 10 m once that is
   precise). The width cue is independent: inverse-variance weighting.
4. Truncation. An edge within ``edge_margin_px`` of the image border is cut;
   a side or bottom edge also within ``edge_cut_sigmas`` edge-noise stds
   (``edge_sigma_rel`` x the box size) of it, as a truncated box's noisy edge
   lands that far inside (not the top edge: a box cut at both ends would keep
   no range cue but the bound). A box cut at the top has no height: ground
   contact only. A box cut at the image bottom has no
   contact point: its top ray meets the plane z = H at x_t = m_x +
   (H - m_z) / s(y1) (std from sigma_H and the top edge), and its foot is
   below the image, so x <= U = the ground x of the bottom image row (and
   x <= m_x + (H + 2 sigma_H) / ds_visible). The estimate is the mean and
   std of N(x_t, sigma_t^2) truncated to [min(0, U), U] (uniform on it when
   x_t is undefined, e.g. H <= m_z). Cut at both ends: the uniform only.
5. Lateral: the bottom-centre ray at the fused contact x, y = m_y + (x - m_x) d_y/d_x;
   the rays through the two bottom corners give the y extent and half_width.
   A box cut at the left / right image edge: the visible edge plus the class
   half-width prior. Vehicles seen end-on (as for the width cue) have a
   W x L footprint (class priors ``width``, ``length``) behind the face at x:
   for one wholly to one side of the camera's column the box's *outer* edge
   is the end face's outer corner, exact, while its inner edge is the far
   end's inner corner, L deeper -- taken at the face's depth it made a car
   3 m aside 1.3 m half-wide instead of 0.9 at 10 m (1.5 m at 5 m), its
   inner edge 0.5-0.7 m nearer the ego's path: cars parked at the kerb
   looked in path. So y = (outer edge at x) -/+ W/2, half_width = W/2; an end face
   spanning the column gives both edges at x; a box cut on the side the
   vehicle lies on shows only the inner edge, at depth x + L (std from
   sigma_L). Measurement covariance: sigma_y^2 = (t sigma_x)^2 + ((x - m_x)
   sigma_u / f_x)^2 + floor^2 (+ prior terms), cov_xy = t sigma_x^2, t the
   slope d y / d x of the ray or edge used.
6. Nearest face (done per cue before the fusion of step 3). ``range`` is the
   nearest point's x, but the box bottom shows the ground contact: a car seen
   from behind touches the road with its rear wheels, ``contact_offset``
   (its rear overhang, 0.95 m) behind its bumper; a cyclist's wheel touches
   about a wheel radius behind its front; a pedestrian's feet are its nearest
   point (0). Seen side-on the offset is ``contact_offset_side``; in between
   off = contact_offset |cos psi| + contact_offset_side |sin psi|, psi the
   heading from the filter's ground velocity above ``heading_min_speed``
   once the filter has settled (else the road's direction, psi = 0). Very close, the face's lower edge
   (bumper, ``clearance`` c above the road) is lower in the image than the
   wheels, so the ground cue maps to the face as
   x = max(x_g - off, m_x + (x_g - m_x) (m_z - c) / m_z). The height cue
   assumed foot and top at one x; with the foot off behind a face of height
   H it reads about off m_z / H too far: x = max(x_h - off m_z / H,
   m_x + (x_h - m_x) (H - c) / H). The offset's own uncertainty
   (``contact_offset_rel_sigma`` of the correction) is added to each cue's
   std. Real monocular estimators carry the same per-class priors; the
   values follow typical vehicles (and the simulator's shapes: sedan / SUV
   rear overhang 0.21 L, truck 1.6 m, bus 3.0 m). Boxes cut at the bottom
   keep the top ray's estimate (step 4), which already refers to the face.
7. Cut at a side, nearest face out of view (``side_bound``). A box cut at the
   left or right image edge (not at the bottom) of a class whose footprint is
   long along x (x extent L |cos psi| + W |sin psi| >= ``side_cut_min_extent``,
   1 m: vehicles, cyclists end-on) whose nearest face is wholly beyond the
   border -- the face's span lat -/+ W/2 at the measured x lies beyond y_b,
   where the ray through the box's bottom corner at the border meets that
   depth -- shows only a farther part of the object: a car overtaking
   alongside. A segmentation mask's (or a detector's) box bottom is then the
   lowest pixel at the border, the ground under the visible part, not the
   nearest contact: the measured face x is an upper bound, the object reaching
   up to the extent nearer. The measurement keeps x with sigma widened by the
   extent's uniform std (extent / sqrt(12)); the filter does not settle on it
   (below). A box clipped at the border whose face is partly in view is
   measured as in steps 1-6.

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

and updated with z = (x, y) of steps 3-6, H = [I 0 0] and R = its 2x2
covariance. ``motion_model``:

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

The filters are plain numpy (``_MotionFilter``; Joseph-form updates). With ``detections``, a track matched this frame is measured on
its raw detection box, not on the tracker's smoothed one (no stacked lag).
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
is slower than ``min_speed_accel`` / ``min_speed_yaw``.

Call ``update`` every frame, also with no tracks, so ego motion accumulates.
Filters of tracks unseen for more than ``max_coast_s`` are dropped.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field, fields
from typing import Literal

import numpy as np
from filterpy.common import Q_continuous_white_noise, Q_discrete_white_noise
from pydantic import BaseModel, ConfigDict, Field
from scipy.stats import truncnorm

from lookahead.perception.camera import CameraModel
from lookahead.perception.detections import CLASSES, Detections
from lookahead.perception.frame import EgoOdometry
from lookahead.perception.tracker import Tracks, TrackState

log = logging.getLogger(__name__)

_DV = 0.5  # px, finite-difference step for d(ray)/dv
_MIN_DEPTH = 0.1  # m, nearest camera-forward distance accepted for a measurement
_BEARING_ONLY_SIGMA = 100.0  # m, range std of a bearing-only measurement


class ClassPrior(BaseModel):
    """Size and motion prior of one class (m, m/s^2). Width = y extent seen from behind/front."""

    model_config = ConfigDict(extra="forbid")
    height: float = Field(gt=0, description="mean object height (m)")
    height_sigma: float = Field(gt=0, description="std of the height (m)")
    width: float = Field(gt=0, description="mean width (m)")
    width_sigma: float = Field(gt=0, description="std of the width (m)")
    accel_sigma: float = Field(2.0, gt=0, description="'cv' model: white-noise acceleration std (m/s^2)")
    jerk_sigma: float = Field(
        3.0, gt=0, description="'ca' model: sqrt of the white-noise jerk spectral density (m/s^2.5)"
    )
    contact_offset: float = Field(
        0.0, ge=0, description="x from the nearest face to the ground contact the box bottom shows, seen end-on (m)"
    )
    contact_offset_side: float = Field(0.0, ge=0, description="the same, seen side-on (m)")
    clearance: float = Field(
        0.0, ge=0, description="height of the nearest face's lower edge (bumper, wheel axle) above the road (m)"
    )
    contact_height_sigma: float = Field(
        0.0, ge=0, description="std of the contact's height above the road plane: kerbs, pavements (m)"
    )
    speed_sigma: float = Field(10.0, gt=0, description="std of a new track's ground velocity, per axis, mean 0 (m/s)")
    length: float = Field(1.0, gt=0, description="mean length along its heading (m)")
    length_sigma: float = Field(0.5, gt=0, description="std of the length (m)")
    width_cue: bool = Field(
        False, description="rigid body whose box width is its width when seen end-on: a range cue (vehicles)"
    )


def _default_priors() -> dict[str, ClassPrior]:
    p = ClassPrior
    return {
        # 1.60 +- 0.25: adults (1.70 +- 0.10) and children together.
        "pedestrian": p(height=1.60, height_sigma=0.25, width=0.55, width_sigma=0.15, accel_sigma=1.5, jerk_sigma=4.0,
                        contact_height_sigma=0.1, speed_sigma=1.5, length=0.3, length_sigma=0.1),
        "cyclist": p(height=1.75, height_sigma=0.15, width=0.65, width_sigma=0.2, accel_sigma=2.0, jerk_sigma=5.0,
                     contact_offset=0.3, contact_offset_side=0.25, clearance=0.3, contact_height_sigma=0.05,
                     speed_sigma=5.0, length=1.7, length_sigma=0.2),
        "motorcyclist": p(height=1.60, height_sigma=0.20, width=0.80, width_sigma=0.2, accel_sigma=3.0, jerk_sigma=6.0,
                          contact_offset=0.3, contact_offset_side=0.25, clearance=0.3, speed_sigma=10.0,
                          length=2.0, length_sigma=0.3),
        "tricycle": p(height=1.60, height_sigma=0.25, width=1.10, width_sigma=0.3, accel_sigma=2.0, jerk_sigma=5.0,
                      contact_offset=0.4, contact_offset_side=0.25, clearance=0.3, contact_height_sigma=0.05,
                      speed_sigma=4.0, length=2.0, length_sigma=0.4),
        # vehicles: lengths of typical cars (3.8-4.9 m), rigid trucks (6.5-10 m), buses (10.5-12.5 m)
        "car": p(height=1.50, height_sigma=0.15, width=1.80, width_sigma=0.15, accel_sigma=3.0, jerk_sigma=6.0,
                 contact_offset=0.95, contact_offset_side=0.05, clearance=0.2, speed_sigma=12.0,
                 length=4.5, length_sigma=0.4, width_cue=True),
        "truck": p(height=3.20, height_sigma=0.50, width=2.50, width_sigma=0.15, accel_sigma=2.0, jerk_sigma=4.0,
                   contact_offset=1.5, contact_offset_side=0.05, clearance=0.55, speed_sigma=12.0,
                   length=8.0, length_sigma=2.0, width_cue=True),
        "bus": p(height=3.10, height_sigma=0.30, width=2.55, width_sigma=0.10, accel_sigma=2.0, jerk_sigma=4.0,
                 contact_offset=2.8, contact_offset_side=0.05, clearance=0.32, speed_sigma=10.0,
                 length=11.5, length_sigma=1.5, width_cue=True),
        "animal": p(height=0.90, height_sigma=0.45, width=0.50, width_sigma=0.30, accel_sigma=3.0, jerk_sigma=6.0,
                    contact_offset=0.1, contact_offset_side=0.05, clearance=0.3, contact_height_sigma=0.05,
                    speed_sigma=3.0, length=0.8, length_sigma=0.5),
    }


class EstimatorConfig(BaseModel):
    """Estimator parameters (SI units; pixel noise in px).

    Defaults suit a 640x360, 90 deg camera at 10 Hz fed by the tracker's boxes.
    Box noise: edges jitter by ``edge_sigma_rel`` (5 %, the ``gt`` detector's
    default) of the box size plus ``contact_sigma_px`` 0.3 px (was 1.0:
    detector boxes are sub-pixel regressions, and 1 px made the modelled range
    std about twice the actual error at 30-50 m, a filter slow to follow a
    braking lead); ``pitch_sigma`` 0.0005 rad (was 0.003: the simulator's
    camera does not pitch and its roads are flat -- for a real car, whose body
    pitches under braking and whose roads slope, set about 0.003). With these
    the modelled single-frame std matches the ``gt`` detector's range errors
    (5-60 m; ``tests/perception/test_estimator.py``).
    """

    model_config = ConfigDict(extra="forbid")
    priors: dict[str, ClassPrior] = Field(
        default_factory=_default_priors, description="per class name (perception.detections.CLASSES)"
    )
    default_prior: ClassPrior = Field(
        default_factory=lambda: ClassPrior(
            height=1.5, height_sigma=0.6, width=1.5, width_sigma=0.8, accel_sigma=3.0, jerk_sigma=3.0
        ),
        description="for classes without a prior (e.g. class id -1)",
    )
    motion_model: Literal["cv", "ca", "imm"] = Field(
        "imm", description="constant velocity, constant acceleration, or an IMM of a quiet cv and a ca model"
    )
    imm_quiet_accel_scale: float = Field(
        0.5, gt=0, description="'imm': the quiet cv model's accel std, times the class's accel_sigma"
    )
    imm_quiet_s: float = Field(2.0, gt=0, description="'imm': mean time in the quiet model (s)")
    imm_manoeuvre_s: float = Field(1.0, gt=0, description="'imm': mean time in the manoeuvre (ca) model (s)")
    imm_init_quiet: float = Field(0.8, ge=0, le=1, description="'imm': a new filter's quiet-model probability")
    contact_sigma_px: float = Field(0.3, ge=0, description="fixed pixel noise of a box edge (px)")
    edge_sigma_rel: float = Field(0.05, ge=0, description="edge noise as a fraction of the box size")
    pitch_sigma: float = Field(
        0.0005, ge=0, description="road slope / pitching std; ground contact only (rad)"
    )
    edge_margin_px: float = Field(1.0, ge=0, description="a box this close to an image edge is cut there (px) ...")
    edge_cut_sigmas: float = Field(
        2.0, ge=0, description="... a side or bottom edge also within this many of its noise stds (edge_sigma_rel x size)"
    )
    position_sigma_floor: float = Field(0.1, ge=0, description="model error added to x and y (m)")
    side_cut_min_extent: float = Field(
        1.0, ge=0, description="a box cut at a side bounds the range only, if the footprint's x extent is this long (m)"
    )
    init_from_box_rates: bool = Field(False, description="fuse the tracker's box rates into a new filter's velocity")
    init_velocity_sigma: float = Field(8.0, gt=0, description="std of the box-rate velocity (m/s)")
    heading_min_speed: float = Field(
        2.0, ge=0, description="ground speed above which the motion direction gives the heading (m/s)"
    )
    contact_offset_rel_sigma: float = Field(0.2, ge=0, description="std of the contact offset, relative")
    width_cue_min_cos: float = Field(
        0.985, ge=0, le=1, description="|cos| of the heading above which a vehicle counts as seen end-on (width cue)"
    )

    init_accel_sigma: float = Field(3.0, gt=0, description="std of a new 'ca' filter's accel (m/s^2)")
    max_init_speed: float = Field(40.0, gt=0, description="clip of the initial relative speed (m/s)")
    reinit_nis: float = Field(50.0, gt=0, description="restart a filter above this NIS (2 dof)")
    max_coast_s: float = Field(2.0, ge=0, description="drop a filter unseen for longer (s)")
    half_width_alpha: float = Field(0.5, gt=0, le=1, description="EMA weight of a new half-width")
    history_s: float = Field(1.0, gt=0, description="window of the accel / yaw-rate fits (s)")
    min_history: int = Field(4, ge=2, description="samples needed for accel / yaw rate")
    settle_updates: int = Field(5, ge=1, description="updates before velocity enters the history")
    min_speed_accel: float = Field(0.5, ge=0, description="accel is NaN below this ground speed (m/s)")
    min_speed_yaw: float = Field(1.0, ge=0, description="yaw rate is NaN below this ground speed (m/s)")
    settle_range_rate_sigma: float = Field(
        1.0, ge=0, description="a track's range rate has converged once its std is below this (m/s) ..."
    )
    settle_max_s: float = Field(
        1.5, ge=0, description="... or once it has run this long: 'initializing' is a start-up state (s)"
    )
    settle_range_rate_rel: float = Field(
        0.25, ge=0, description="... or below this fraction of |range rate| (latched per filter)"
    )


@dataclass
class Measurement:
    """Single-frame position measurements of N boxes (ego frame, m). NaN where undefined.

    ``x`` / ``sigma``: fused range of the nearest face and its std; ``x_ground`` /
    ``sigma_ground``: the ground contact (before the contact offset); ``x_height`` /
    ``sigma_height``: height prior (box height, or the top ray for boxes cut at
    the bottom); ``x_width`` / ``sigma_width``: width prior (vehicles seen
    end-on, at the face; NaN otherwise); ``cov``: (N, 2, 2) covariance
    of (x, lateral). ``x_max``: upper bound of the range of boxes cut at the
    bottom (NaN otherwise). ``side_bound``: cut at a side with a footprint extending
    ``side_cut_min_extent`` or more along x: ``x`` is the visible part's face, an upper
    bound, with ``sigma`` widened by the extent's uniform std (docstring, step 7). The lateral as a function of the range: lateral = m_y + (x - m_x)
    ``tan_y`` + ``lateral_offset`` (``tan_y`` the bearing of the edge or ray it comes from,
    ``lateral_offset`` 0 or a half-width prior); ``sigma_bearing`` the bearing's std (rad);
    ``var_y_extra``: lateral variance not due to x or bearing (m^2).
    """

    x: np.ndarray
    sigma: np.ndarray
    x_ground: np.ndarray
    sigma_ground: np.ndarray
    x_height: np.ndarray
    sigma_height: np.ndarray
    x_width: np.ndarray
    sigma_width: np.ndarray
    lateral: np.ndarray
    half_width: np.ndarray
    cov: np.ndarray
    cut_bottom: np.ndarray
    cut_top: np.ndarray
    x_max: np.ndarray
    side_bound: np.ndarray
    tan_y: np.ndarray
    sigma_bearing: np.ndarray
    var_y_extra: np.ndarray
    lateral_offset: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.x) & np.isfinite(self.lateral) & np.all(np.isfinite(self.cov), axis=(1, 2))


@dataclass
class Estimates:
    """Per-track estimates, rows aligned with the ``Tracks`` given to ``update`` (all (N,) float).

    range: nearest point's ego x (m); range_sigma: its std (m); lateral: centre
    y (m, left +); half_width: half the y extent (m); range_rate /
    lateral_rate: velocity relative to the (rotating) ego frame (m/s);
    ground_vx / ground_vy: velocity over the ground in ego axes (m/s); accel:
    along the motion (m/s^2, NaN unknown); yaw_rate: of the object's motion
    (rad/s, NaN unknown); ttc: time to collision (s, inf when not closing);
    range_rate_sigma: the filter's std of range_rate (m/s), which tells how far
    the velocity can be trusted yet (a new track starts from a broad prior).
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


def _rot(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


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
    history: deque = field(default_factory=deque)  # (t, vx, vy): ground velocity, world-fixed axes


class Estimator:
    """Per-track range, lateral offset, velocity and TTC (see the module docstring).

    Args:
        camera: the calibrated camera the boxes come from.
        config: parameters; ``EstimatorConfig()`` when None.
    """

    def __init__(self, camera: CameraModel, config: EstimatorConfig | None = None) -> None:
        self.camera = camera
        self.config = config or EstimatorConfig()
        cfg = self.config
        table = [cfg.priors.get(name, cfg.default_prior) for name in CLASSES] + [cfg.default_prior]
        self._prior = {
            key: np.array([getattr(p, key) for p in table])
            for key in ClassPrior.model_fields
        }
        self._dim = 6
        self.reset()

    def reset(self) -> None:
        """Forget every filter, the clock and the integrated ego yaw."""
        self._filters: dict[int, _TrackFilter] = {}
        self._t: float | None = None
        self._speed = 0.0
        self._yaw_rate = 0.0
        self._ego_yaw = 0.0  # integrated ego heading since the first frame (rad)

    @property
    def num_filters(self) -> int:
        """Number of filters in the bank (tracks seen within ``max_coast_s``)."""
        return len(self._filters)

    # ------------------------------------------------------------ priors
    def prior_of(self, class_id: np.ndarray, key: str) -> np.ndarray:
        """The class prior ``key`` (a ``ClassPrior`` field) of each class id; ids outside ``CLASSES``
        get ``default_prior``'s."""
        cid = np.asarray(class_id, dtype=np.int64)
        idx = np.where((cid >= 0) & (cid < len(CLASSES)), cid, len(CLASSES))
        return self._prior[key][idx]

    # ------------------------------------------------------------ one frame
    def measure(
        self, xyxy: np.ndarray, class_id: np.ndarray, cos_heading: np.ndarray | None = None
    ) -> Measurement:
        """Position measurements (module docstring, steps 1-6) of boxes (N, 4) with classes (N,).

        ``cos_heading``: |cos| of each object's heading relative to the ego x axis
        (1 = seen end-on, the default; 0 = side-on), for the contact offset.
        """
        b = np.asarray(xyxy, dtype=np.float64).reshape(-1, 4)
        n = len(b)
        cid = np.broadcast_to(np.asarray(class_id, dtype=np.int64).reshape(-1), (n,))
        c = np.ones(n) if cos_heading is None else np.broadcast_to(np.asarray(cos_heading, float).reshape(-1), (n,))
        with np.errstate(all="ignore"):
            return self._measure(b, cid, np.clip(np.nan_to_num(c, nan=1.0), 0.0, 1.0))

    def _measure(self, b: np.ndarray, cid: np.ndarray, cos_h: np.ndarray) -> Measurement:
        cfg, cam = self.config, self.camera
        n = len(b)
        mx, my, mz = cam.mount
        x1, y1, x2, y2 = b.T
        w_px, h_px = x2 - x1, y2 - y1
        ok = np.all(np.isfinite(b), axis=1) & (w_px > 0) & (h_px > 0) & np.all(np.abs(b) < 1e6, axis=1)
        H, sH = self.prior_of(cid, "height"), self.prior_of(cid, "height_sigma")
        W, sW = self.prior_of(cid, "width"), self.prior_of(cid, "width_sigma")
        # a side or bottom edge within its noise of the image border may be the border: cut there
        # (not the top edge: a box cut at both ends keeps no range cue but the bound)
        margin = cfg.edge_margin_px
        margin_u = margin + cfg.edge_cut_sigmas * cfg.edge_sigma_rel * w_px
        margin_v = margin + cfg.edge_cut_sigmas * cfg.edge_sigma_rel * h_px
        cut_bottom = ok & (y2 >= cam.height - margin_v)
        cut_top = ok & (y1 <= margin)
        cut_left = ok & (x1 <= margin_u)
        cut_right = ok & (x2 >= cam.width - margin_u)

        sv = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * h_px)  # one horizontal edge, px
        su = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * w_px) / np.sqrt(2.0)  # box centre, px
        uc = 0.5 * (x1 + x2)
        vb = np.minimum(y2, float(cam.height))  # bottom row, at most the image's
        pix = np.stack(
            [
                np.stack([uc, vb], -1),
                np.stack([uc, vb + _DV], -1),
                np.stack([uc, vb - _DV], -1),
                np.stack([uc, y1], -1),
                np.stack([uc, y1 + _DV], -1),
                np.stack([uc, y1 - _DV], -1),
                np.stack([x1, vb], -1),
                np.stack([x2, vb], -1),
            ],
            axis=1,
        )  # (N, 8, 2)
        pix = np.where(ok[:, None, None], pix, 0.0)
        rays = cam.pixel_rays(pix) if n else np.zeros((0, 8, 3))
        fwd = rays[..., 0] > 1e-9
        slope = np.where(fwd, rays[..., 2] / rays[..., 0], np.nan)  # d_z / d_x
        tan_y = np.where(fwd, rays[..., 1] / rays[..., 0], np.nan)  # d_y / d_x

        # 1. ground contact (also the bound U of boxes cut at the bottom)
        gp = cam.ground_points(pix[:, :3]) if n else np.zeros((0, 3, 3))
        xg_all = gp[:, 0, 0]
        dxdv = np.abs(gp[:, 1, 0] - gp[:, 2, 0]) / (2.0 * _DV)
        sig_g = dxdv * np.hypot(sv, cam.fy * cfg.pitch_sigma)
        sig_g = np.hypot(sig_g, (xg_all - mx) * self.prior_of(cid, "contact_height_sigma") / mz)
        g_ok = ok & ~cut_bottom & np.isfinite(xg_all) & np.isfinite(sig_g) & (xg_all - mx > _MIN_DEPTH)
        x_g = np.where(g_ok, xg_all, np.nan)
        sig_g = np.where(g_ok, sig_g, np.nan)

        # 2. height prior from the box height
        s_b, s_t = slope[:, 0], slope[:, 3]
        dsdv_b = np.abs(slope[:, 1] - slope[:, 2]) / (2.0 * _DV)
        dsdv_t = np.abs(slope[:, 4] - slope[:, 5]) / (2.0 * _DV)
        ds = s_t - s_b
        xc_h = H / ds
        sig_ds = np.hypot(dsdv_t * sv, dsdv_b * sv)
        sig_h = xc_h * np.hypot(sH / H, sig_ds / ds)
        h_ok = ok & ~cut_top & ~cut_bottom & (ds > 0) & (xc_h > _MIN_DEPTH) & np.isfinite(sig_h)
        x_h = np.where(h_ok, mx + xc_h, np.nan)
        sig_h = np.where(h_ok, sig_h, np.nan)

        # 2b. width prior of a vehicle seen end-on whose end face spans the camera's column
        # (then no side face is in the box): x_c = W / (t_l - t_r), at the face
        t_l, t_r = tan_y[:, 6], tan_y[:, 7]
        dt = t_l - t_r
        xc_w = W / dt
        sig_dt = np.sqrt(2.0) * np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * w_px) / cam.fx
        sig_w = xc_w * np.hypot(sW / W, sig_dt / dt)
        w_cue = self.prior_of(cid, "width_cue").astype(bool)
        w_ok = (
            ok & w_cue & ~cut_left & ~cut_right & ~cut_bottom & (t_r < 0.0) & (t_l > 0.0)
            & (cos_h >= cfg.width_cue_min_cos) & (xc_w > _MIN_DEPTH) & np.isfinite(sig_w)
        )
        x_w = np.where(w_ok, mx + xc_w, np.nan)
        sig_w = np.where(w_ok, sig_w, np.nan)

        # 3. the nearest face from each cue (step 6 of the docstring), then the fusion: x (the
        # contact, for the lateral) and x_face (the range). Ground and height cues share the
        # bottom edge's noise: best linear unbiased weights of the correlated pair (never
        # negative), then the independent width cue by inverse variance.
        xg_f, xh_f, off = self._faces(x_g, x_h, cid, cos_h, H)
        var_g = sig_g**2 + (cfg.contact_offset_rel_sigma * (x_g - xg_f)) ** 2
        var_h = sig_h**2 + (cfg.contact_offset_rel_sigma * (x_h - xh_f)) ** 2
        dxg_dv = (gp[:, 1, 0] - gp[:, 2, 0]) / (2.0 * _DV)  # signed, per px of y2
        dxh_dv = xc_h / ds * (slope[:, 1] - slope[:, 2]) / (2.0 * _DV)  # x_h - m_x = H / (s_t - s_b)
        both = g_ok & h_ok
        c_gh = np.where(both, dxg_dv * dxh_dv * (cfg.edge_sigma_rel * h_px) ** 2, 0.0)
        c_gh = np.minimum(c_gh, np.fmin(var_g, var_h))  # at most the better cue alone
        den = np.where(both, var_g + var_h - 2.0 * c_gh, 1.0)
        a_g = np.where(both, (var_h - c_gh) / den, np.where(g_ok, 1.0, 0.0))  # weight of the ground cue
        a_h = np.where(both, (var_g - c_gh) / den, np.where(h_ok, 1.0, 0.0))
        var_gh = np.where(both, (var_g * var_h - c_gh**2) / den, np.where(g_ok, var_g, var_h))
        gh_ok = g_ok | h_ok
        x_gh = np.nan_to_num(x_g) * a_g + np.nan_to_num(x_h) * a_h
        xf_gh = np.nan_to_num(xg_f) * a_g + np.nan_to_num(xh_f) * a_h
        w_gh = np.where(gh_ok, 1.0 / var_gh, 0.0)
        w_w = np.where(w_ok, 1.0 / sig_w**2, 0.0)
        w_sum = w_gh + w_w
        xw_c = x_w + off  # the width cue's face, moved back to the contact
        with np.errstate(invalid="ignore", divide="ignore"):
            x = np.where(w_sum > 0, (np.where(gh_ok, x_gh, 0.0) * w_gh + np.nan_to_num(xw_c) * w_w) / w_sum, np.nan)
            x_face = np.where(
                w_sum > 0, (np.where(gh_ok, xf_gh, 0.0) * w_gh + np.nan_to_num(x_w) * w_w) / w_sum, np.nan
            )
            sig = np.where(w_sum > 0, 1.0 / np.sqrt(w_sum), np.nan)

        # 4. boxes cut at the bottom: top ray on z = H, bounded by the bottom image row
        x_max = np.full(n, np.nan)
        if np.any(cut_bottom):
            x, sig, x_h, sig_h, x_max = self._cut_bottom(
                cut_bottom, cut_top, x, sig, x_h, sig_h, xg_all, s_t, dsdv_t, ds, sv, H, sH
            )

        # 5. lateral offset and half-width at the fused range (the bottom-centre ray at the contact)
        xc = x - mx
        front = xc > _MIN_DEPTH
        x = np.where(front, x, np.nan)
        sig = np.where(front, sig, np.nan)
        t_c = tan_y[:, 0]
        y_c, y_l, y_r = my + xc * t_c, my + xc * t_l, my + xc * t_r
        hw = 0.5 * (y_l - y_r)
        side = cut_left ^ cut_right
        hw = np.where(cut_left | cut_right, np.maximum(hw, 0.5 * W), hw)
        lat = np.where(cut_left & ~cut_right, y_r + hw, y_c)
        lat = np.where(cut_right & ~cut_left, y_l - hw, lat)
        lat = np.where(np.isfinite(x), lat, np.nan)
        tan_eff = np.where(side, (lat - my) / xc, t_c)
        s_bear = su / cam.fx
        extra = np.where(side, (0.5 * sW) ** 2, 0.0)
        offset = np.zeros(n)

        # 6. the range is the nearest face's (boxes cut at the bottom: the top ray's estimate)
        x = np.where(cut_bottom | ~front, x, x_face)
        xc = x - mx  # the face's depth; the lateral stays the contact's (the box centre's ray) ...

        # 5b. ... except for a vehicle seen end-on, whose footprint is W x L behind its face
        end_on = w_cue & (cos_h >= cfg.width_cue_min_cos) & (xc > _MIN_DEPTH) & ~(cut_left & cut_right)
        if np.any(end_on):
            e = self._end_on_lateral(xc, t_l, t_r, cut_left, cut_right, W, sW, cid, w_px, s_bear)
            lat, hw, tan_eff, offset, s_bear, extra = (
                np.where(end_on, a, b) for a, b in zip(e, (lat, hw, tan_eff, offset, s_bear, extra), strict=True)
            )
            lat = np.where(np.isfinite(x), lat, np.nan)

        # 7. cut at a side, with a footprint long along x, and none of its nearest face in view
        # (the face spans lat -/+ W/2 at x; the border ray through the box's bottom corner at the
        # border reaches y_b there): the nearest part is out of view, up to the footprint's x
        # extent nearer than the visible part. The measured face is an upper bound; its std is
        # widened by the extent's uniform std, and the filter does not settle on it.
        extent = self.prior_of(cid, "length") * cos_h + W * np.sqrt(1.0 - cos_h**2)
        y_b = my + xc * np.where(cut_left, t_l, t_r)
        half = np.minimum(hw, 0.5 * W)
        beyond = np.where(cut_left, lat - half >= y_b, lat + half <= y_b)
        side_bound = (cut_left ^ cut_right) & ~cut_bottom & (extent >= cfg.side_cut_min_extent) & beyond
        side_bound &= np.isfinite(x)
        if np.any(side_bound):
            sig = np.where(side_bound, np.hypot(sig, extent / np.sqrt(12.0)), sig)
        return Measurement(
            x=x,
            sigma=sig,
            x_ground=x_g,
            sigma_ground=sig_g,
            x_height=x_h,
            sigma_height=sig_h,
            x_width=x_w,
            sigma_width=sig_w,
            lateral=lat,
            half_width=np.where(np.isfinite(lat), hw, np.nan),
            cov=self._position_cov(xc, sig, tan_eff, s_bear, extra),
            cut_bottom=cut_bottom,
            cut_top=cut_top,
            x_max=x_max,
            side_bound=side_bound,
            tan_y=tan_eff,
            sigma_bearing=s_bear,
            var_y_extra=extra,
            lateral_offset=np.where(np.isfinite(lat), offset, np.nan),
        )

    def _end_on_lateral(
        self,
        xf: np.ndarray,
        t_l: np.ndarray,
        t_r: np.ndarray,
        cut_left: np.ndarray,
        cut_right: np.ndarray,
        W: np.ndarray,
        sW: np.ndarray,
        cid: np.ndarray,
        w_px: np.ndarray,
        s_bear_c: np.ndarray,
    ) -> tuple[np.ndarray, ...]:
        """Lateral of vehicles seen end-on: footprint W x L behind the face at depth ``xf`` (step 5b).

        Returns (lateral, half_width, tan_y, lateral_offset, sigma_bearing, var_y_extra);
        lateral = m_y + xf tan_y + lateral_offset.
        """
        cfg, my = self.config, self.camera.mount[1]
        L, sL = self.prior_of(cid, "length"), self.prior_of(cid, "length_sigma")
        s_edge = np.hypot(cfg.contact_sigma_px, cfg.edge_sigma_rel * w_px) / self.camera.fx  # one edge (rad)
        left_of, right_of = t_r > 0.0, t_l < 0.0  # the box wholly left / right of the camera's column
        whole = ~cut_left & ~cut_right
        span = whole & ~left_of & ~right_of
        # the end face spans the camera's column: both edges are its corners
        tan = np.where(span, 0.5 * (t_l + t_r), np.nan)
        off = np.zeros(len(xf))
        hw = np.where(span, 0.5 * xf * (t_l - t_r), 0.5 * W)
        s_bear = np.where(span, s_bear_c, s_edge)
        extra = np.where(span, 0.0, (0.5 * sW) ** 2)
        # the outer edge is the end face's outer corner: -/+ W/2 from it (also a box cut on
        # the far side whose visible edge is then the outer one)
        for m, t_e, sgn in ((whole & left_of, t_l, -1.0), (whole & right_of, t_r, 1.0),
                            (cut_left & ~cut_right & ~left_of, t_r, 1.0),
                            (cut_right & ~cut_left & ~right_of, t_l, -1.0)):  # fmt: skip
            tan, off = np.where(m, t_e, tan), np.where(m, sgn * 0.5 * W, off)
        # cut on the side it lies on: only the inner edge is seen, the far end's corner, L deeper
        for m, t_e, sgn in ((cut_left & ~cut_right & left_of, t_r, 1.0),
                            (cut_right & ~cut_left & right_of, t_l, -1.0)):  # fmt: skip
            tan, off = np.where(m, t_e, tan), np.where(m, sgn * 0.5 * W + L * t_e, off)
            extra = np.where(m, (0.5 * sW) ** 2 + (sL * t_e) ** 2, extra)
        return my + xf * tan + off, hw, tan, off, s_bear, extra

    def _faces(
        self, x_g: np.ndarray, x_h: np.ndarray, cid: np.ndarray, cos_h: np.ndarray, H: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest-face range from the ground cue and from the height cue (docstring, step 6),
        and the contact offset ``off`` used.

        The box bottom is the lower of the ground contact, ``off`` behind the face, and
        the face's lower edge at height c: x = max(x_g - off, m_x + (x_g - m_x)(m_z - c)/m_z).
        The height cue assumed its foot and top at one x; with the foot ``off`` behind
        a face of height H it reads about off m_z / H too far (c: (x_h - m_x) H / (H - c)).
        """
        mx, mz = self.camera.mount[0], self.camera.mount[2]
        sin_h = np.sqrt(1.0 - cos_h**2)
        off = self.prior_of(cid, "contact_offset") * cos_h + self.prior_of(cid, "contact_offset_side") * sin_h
        clr = np.minimum(self.prior_of(cid, "clearance"), 0.9 * mz)
        xg_f = np.maximum(x_g - off, mx + (x_g - mx) * (mz - clr) / mz)
        hh = np.maximum(H, clr + 0.1)
        xh_f = np.maximum(x_h - off * mz / hh, mx + (x_h - mx) * (hh - clr) / hh)
        return xg_f, xh_f, off

    def _position_cov(
        self, xc: np.ndarray, sig_x: np.ndarray, tan_y: np.ndarray, s_bear: np.ndarray, extra: np.ndarray
    ) -> np.ndarray:
        """(N, 2, 2) covariance of (x, y) = (x, m_y + (x - m_x) tan_y) (module docstring, step 5)."""
        xc, sig_x, tan_y = np.atleast_1d(xc), np.atleast_1d(sig_x), np.atleast_1d(tan_y)
        floor2 = self.config.position_sigma_floor**2
        cov = np.empty((len(xc), 2, 2))
        cov[:, 0, 0] = sig_x**2 + floor2
        cov[:, 1, 1] = (tan_y * sig_x) ** 2 + (xc * s_bear) ** 2 + floor2 + extra
        cov[:, 0, 1] = cov[:, 1, 0] = tan_y * sig_x**2
        return cov

    def _cut_bottom(
        self,
        cut_bottom: np.ndarray,
        cut_top: np.ndarray,
        x: np.ndarray,
        sig: np.ndarray,
        x_h: np.ndarray,
        sig_h: np.ndarray,
        x_row: np.ndarray,
        s_t: np.ndarray,
        dsdv_t: np.ndarray,
        ds_vis: np.ndarray,
        sv: np.ndarray,
        H: np.ndarray,
        sH: np.ndarray,
    ) -> tuple[np.ndarray, ...]:
        """Range of boxes whose foot is below the image (module docstring, step 4)."""
        mx, mz = self.camera.mount[0], self.camera.mount[2]
        x, sig, x_h, sig_h = x.copy(), sig.copy(), x_h.copy(), sig_h.copy()
        i = np.flatnonzero(cut_bottom)
        # top ray meets z = H
        xc_t = (H[i] - mz) / s_t[i]
        sig_t = np.hypot(sH[i] / s_t[i], xc_t / s_t[i] * dsdv_t[i] * sv[i])
        t_ok = ~cut_top[i] & (xc_t > _MIN_DEPTH) & np.isfinite(sig_t)
        # the foot is below the bottom row: x <= U
        upper = np.where(np.isfinite(x_row[i]), x_row[i], np.inf)
        h_bound = mx + (H[i] + 2.0 * sH[i]) / ds_vis[i]
        upper = np.where(~cut_top[i] & (ds_vis[i] > 0) & (h_bound < upper), h_bound, upper)
        lower = np.minimum(0.0, upper)
        bounded = np.isfinite(upper)
        width = np.maximum(upper - lower, 0.1)
        xi = np.where(bounded, 0.5 * (lower + upper), np.nan)  # uniform on [lower, upper]
        si = width / np.sqrt(12.0)
        use_t = t_ok & bounded  # the top ray's Gaussian truncated to the bounds
        if np.any(use_t):
            mu, sd = mx + xc_t[use_t], sig_t[use_t]
            a, bb = (lower[use_t] - mu) / sd, (upper[use_t] - mu) / sd
            m_tr, v_tr = truncnorm.stats(a, bb, loc=mu, scale=sd, moments="mv")
            m_tr, s_tr = np.asarray(m_tr, float), np.sqrt(np.asarray(v_tr, float))
            good = np.isfinite(m_tr) & np.isfinite(s_tr)  # far outside: the nearer bound
            xi[use_t] = np.where(good, m_tr, np.clip(mu, lower[use_t], upper[use_t]))
            si[use_t] = np.where(good, np.maximum(s_tr, 1e-3), si[use_t])
        only_t = t_ok & ~bounded
        xi[only_t], si[only_t] = mx + xc_t[only_t], sig_t[only_t]
        x[i], sig[i] = xi, si
        x_h[i] = np.where(t_ok, mx + xc_t, np.nan)
        sig_h[i] = np.where(t_ok, sig_t, np.nan)
        x_max = np.full(len(x), np.nan)
        x_max[i] = np.where(bounded, upper, np.nan)
        return x, sig, x_h, sig_h, x_max

    # ------------------------------------------------------------ tracking
    def update(
        self,
        tracks: Tracks,
        odometry: EgoOdometry | None,
        t: float,
        detections: Detections | None = None,
    ) -> Estimates:
        """Advance to time ``t`` (s) with this frame's tracks and ego odometry; return estimates.

        Rows are aligned with ``tracks``. Rows with an invalid box (NaN,
        degenerate, above the horizon) get NaN; lost tracks (``state`` LOST)
        get their filter's prediction without an update. With ``detections``
        (the ones given to the tracker this frame), a track matched this frame
        is measured on its raw detection box (``det_index``) rather than on
        the tracker's smoothed box, so the two filters do not stack their lag.
        """
        cfg = self.config
        speed, yaw_rate = self._odometry(odometry)
        t = float(t)
        if not np.isfinite(t):
            log.warning("non-finite time %r: estimates are NaN", t)
            return Estimates.empty(len(tracks))
        if self._t is not None:
            dt = t - self._t
            if dt < 0.0:
                log.warning("time went back from %.3f to %.3f s: resetting the estimator", self._t, t)
                self.reset()
            elif dt > 0.0:
                self._advance(dt, 0.5 * (speed + self._speed), 0.5 * (yaw_rate + self._yaw_rate))
        self._t, self._speed, self._yaw_rate = t, speed, yaw_rate

        n = len(tracks)
        meas = self.measure(self._boxes(tracks, detections), tracks.class_id, self._cos_heading(tracks))
        valid = meas.valid
        state = np.full((n, self._dim), np.nan)
        p_xx = np.full(n, np.nan)
        p_rr = np.full(n, np.nan)
        settled = np.full(n, np.nan)
        hw = np.full(n, np.nan)
        hist: list[deque | None] = [None] * n
        to_world = _rot(self._ego_yaw)
        for i in range(n):
            tid, cls = int(tracks.track_id[i]), int(tracks.class_id[i])
            trk = self._filters.get(tid)
            if valid[i] and int(tracks.state[i]) != TrackState.LOST:
                z0, r0 = np.array([meas.x[i], meas.lateral[i]]), meas.cov[i]
                z, r = z0, r0
                if trk is not None and meas.cut_bottom[i]:
                    z, r = self._cut_bottom_update(trk, meas, i)
                if trk is None or not self._update(trk, z, r):  # a new filter starts from the box itself
                    trk = self._new_filter(z0, r0, cls, tracks.xyxy[i], tracks.velocity_px[i], t, speed, yaw_rate)
                    self._filters[tid] = trk
                trk.class_id, trk.last_update = cls, t
                a, hw_i = cfg.half_width_alpha, float(meas.half_width[i])
                trk.half_width = hw_i if np.isnan(trk.half_width) else a * hw_i + (1 - a) * trk.half_width
                if trk.updates >= cfg.settle_updates:
                    v_w = to_world @ trk.kf.x[2:4]
                    trk.history.append((t, v_w[0], v_w[1]))
                while trk.history and trk.history[0][0] < t - cfg.history_s - 1e-9:
                    trk.history.popleft()
            if trk is None or not (valid[i] or int(tracks.state[i]) == TrackState.LOST):
                continue
            state[i] = trk.kf.x
            p_xx[i] = trk.kf.P[0, 0]
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
            hist[i] = trk.history if trk.updates >= cfg.settle_updates else None

        for tid in [k for k, f in self._filters.items() if t - f.last_update > cfg.max_coast_s]:
            del self._filters[tid]
        return self._outputs(state, p_xx, p_rr, settled, hw, hist, speed, yaw_rate)

    def _cut_bottom_update(self, trk: _TrackFilter, meas: Measurement, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Measurement for a running filter from a box cut at the bottom.

        The top ray's error is mostly the object's height minus the prior: the
        same every frame, so repeating it would not average out but drag the
        filter. The box adds its bearing only (a huge range std along the ray)
        and the filter's prediction carries the range; a prediction beyond the
        bound x_max is pulled back to it.
        """
        mx, my = self.camera.mount[0], self.camera.mount[1]
        x_pred, x_max = float(trk.kf.x[0]), float(meas.x_max[i])
        x, sig = (x_max, float(meas.sigma[i])) if x_pred > x_max else (x_pred, _BEARING_ONLY_SIGMA)
        xc = max(x - mx, _MIN_DEPTH)
        z = np.array([x, my + xc * meas.tan_y[i] + meas.lateral_offset[i]])
        r = self._position_cov(
            np.array([xc]), np.array([sig]), meas.tan_y[i : i + 1], meas.sigma_bearing[i], meas.var_y_extra[i]
        )[0]
        return z, r

    def _cos_heading(self, tracks: Tracks) -> np.ndarray:
        """|cos| of each track's heading vs the ego x axis: its motion direction when its
        filter has settled and its ground speed is above ``heading_min_speed``, else 1
        (aligned with the road)."""
        out = np.ones(len(tracks))
        for i, tid in enumerate(tracks.track_id):
            trk = self._filters.get(int(tid))
            if trk is None or not trk.settled:  # a velocity not yet converged says nothing of the heading
                continue
            v = trk.kf.x[2:4]
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

    def _process(self, dt: float, class_id: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """(F, Q) over ``dt`` (s) of each model: [cv], [ca] or [quiet cv, ca] (``imm``)."""
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
            models.append((f, q))
        return models

    def _transition(self, dt: float) -> np.ndarray:
        """IMM Markov matrix over ``dt``: mean sojourn ``imm_quiet_s`` / ``imm_manoeuvre_s``."""
        cfg = self.config
        p01 = 1.0 - np.exp(-dt / cfg.imm_quiet_s)
        p10 = 1.0 - np.exp(-dt / cfg.imm_manoeuvre_s)
        return np.array([[1.0 - p01, p01], [p10, 1.0 - p10]])

    def _advance(self, dt: float, speed: float, yaw_rate: float) -> None:
        """Re-express every filter in the new ego frame, then predict it by ``dt``."""
        theta = yaw_rate * dt
        chord = speed * dt * np.sinc(theta / (2.0 * np.pi))
        shift = chord * np.array([np.cos(theta / 2.0), np.sin(theta / 2.0)])
        rot = _rot(-theta)
        jac = np.kron(np.eye(self._dim // 2), rot)
        self._ego_yaw += theta
        models: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
        trans = self._transition(dt)
        for trk in self._filters.values():
            trk.kf.transform(jac, shift)
            if trk.class_id not in models:
                models[trk.class_id] = self._process(dt, trk.class_id)
            trk.kf.predict(models[trk.class_id], trans)

    def _update(self, trk: _TrackFilter, z: np.ndarray, r: np.ndarray) -> bool:
        """Kalman update; False (filter to restart) when the innovation fails the NIS gate."""
        nis = trk.kf.nis(z, r)
        if not nis <= self.config.reinit_nis:
            log.debug("track filter restarted: NIS %.1f", nis)
            return False
        try:
            trk.kf.update(z, r)
        except np.linalg.LinAlgError:
            return False
        trk.updates += 1
        return trk.kf.finite()

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
        per axis, optionally fused with the tracker's box rates (scale change)."""
        cfg, cam = self.config, self.camera
        var0 = float(self.prior_of(np.array([cls]), "speed_sigma")[0]) ** 2
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
        p[2:4, 2:4] = np.eye(2) * var
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
        p_xx: np.ndarray,
        p_rr: np.ndarray,
        settled: np.ndarray,
        hw: np.ndarray,
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
        to_world = _rot(self._ego_yaw)
        for i, h in enumerate(hist):
            if h is None or len(h) < cfg.min_history:
                continue
            arr = np.asarray(h)
            tt, v_w = arr[:, 0], arr[:, 1:]
            if tt[-1] - tt[0] <= 0:
                continue
            v_now = to_world @ state[i, 2:4]  # world-fixed axes
            s_now = float(np.hypot(*v_now))
            if s_now >= cfg.min_speed_accel:
                a_vec = to_world @ state[i, 4:6] if cfg.motion_model == "ca" else _slope_fit(tt, v_w)
                accel[i] = float(a_vec @ v_now) / s_now
            if s_now >= cfg.min_speed_yaw and np.hypot(v_w[:, 0], v_w[:, 1]).min() >= cfg.min_speed_yaw:
                heading = np.unwrap(np.arctan2(v_w[:, 1], v_w[:, 0]))
                yaw[i] = float(_slope_fit(tt, heading[:, None])[0])
        return Estimates(
            range=x,
            range_sigma=np.sqrt(p_xx),
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
        )
