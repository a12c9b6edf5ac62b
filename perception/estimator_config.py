"""Settings of the range / velocity estimator: class priors and ``EstimatorConfig``.

One flat pydantic model serves both halves of the estimator: the single-frame
measurement model (``perception.ranging``: box noise, truncation, the size and
contact priors) and the per-track motion filter (``perception.estimator``: motion
model, IMM, initialisation, settling). Scenarios override its fields by name
(``perception.estimator``) and the scenario JSON Schema ships it, so the field
names and their order stay as they are. SI units (m, s, m/s, m/s^2); pixel noise
in px.

``PriorTable`` turns the per-class priors into arrays indexed by class id (the
``perception.detections.CLASSES`` order; any other id gets ``default_prior``).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from lookahead.perception.detections import CLASSES


class ClassPrior(BaseModel):
    """Size and motion prior of one class (m, m/s^2). Width = y extent seen from behind/front."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
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
    height_modes: list[tuple[float, float, float]] = Field(
        default_factory=list,
        description="the height as a mixture, [weight, mean, std] per mode (m; pedestrians: adults and children), "
        "for a track's learned height; empty: height +- height_sigma",
    )


def _default_priors() -> dict[str, ClassPrior]:
    p = ClassPrior
    return {
        # 1.60 +- 0.25: adults (1.70 +- 0.10) and children (1.20 +- 0.15, one in five) together; a
        # track's learned height tells the two apart (``height_modes``)
        "pedestrian": p(height=1.60, height_sigma=0.25, width=0.55, width_sigma=0.15, accel_sigma=1.5, jerk_sigma=4.0,
                        contact_height_sigma=0.1, speed_sigma=1.5, length=0.3, length_sigma=0.1,
                        height_modes=[(0.8, 1.70, 0.10), (0.2, 1.20, 0.15)]),
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
        # cones 0.7 m, barriers 0.9-1 m, boxes and debris 0.2-0.6 m, a standing bicycle 1.05 m; they do not move
        "obstacle": p(height=0.75, height_sigma=0.3, width=1.0, width_sigma=0.6, accel_sigma=0.3, jerk_sigma=0.5,
                      speed_sigma=0.3, length=0.8, length_sigma=0.5),
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

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
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
    heading_min_sigmas: float = Field(
        2.0, ge=0, description="a ground velocity component below this many stds counts as 0 for the heading"
    )
    contact_offset_rel_sigma: float = Field(0.2, ge=0, description="std of the contact offset, relative")
    width_cue_min_cos: float = Field(
        0.985, ge=0, le=1, description="|cos| of the heading above which a vehicle counts as seen end-on (width cue)"
    )

    init_accel_sigma: float = Field(3.0, gt=0, description="std of a new 'ca' filter's accel (m/s^2)")
    max_init_speed: float = Field(40.0, gt=0, description="clip of the initial relative speed (m/s)")
    reinit_nis: float = Field(
        9.21, gt=0, description="a measurement above this NIS (2 dof; 9.21: p = 0.01) is an outlier ...")
    reinit_outliers: int = Field(
        2, ge=1, description="... skipped while the filter coasts; this many in a row restart the filter")
    max_coast_s: float = Field(2.0, ge=0, description="drop a filter unseen for longer (s)")
    half_width_alpha: float = Field(0.5, gt=0, le=1, description="EMA weight of a new half-width")
    history_s: float = Field(1.0, gt=0, description="window of the accel / yaw-rate fits (s)")
    min_history: int = Field(4, ge=2, description="samples needed for accel / yaw rate")
    settle_updates: int = Field(5, ge=1, description="updates before velocity enters the history")
    min_speed_accel: float = Field(0.5, ge=0, description="accel is NaN below this ground speed (m/s)")
    min_speed_yaw: float = Field(1.0, ge=0, description="yaw rate is NaN below this ground speed (m/s)")
    derivative_min_sigmas: float = Field(
        2.0, ge=0, description="accel / yaw rate are NaN (unknown) unless at least this many of their stds "
        "from 0: a converging or noisy velocity's slope is no acceleration, nor its heading's a turn (0: off)")
    settle_range_rate_sigma: float = Field(
        1.0, ge=0, description="a track's range rate has converged once its std is below this (m/s) ..."
    )
    settle_max_s: float = Field(
        1.5, ge=0, description="... or once it has run this long: 'initializing' is a start-up state (s)"
    )
    settle_range_rate_rel: float = Field(
        0.25, ge=0, description="... or below this fraction of |range rate| (latched per filter)"
    )
    range_learned_height: bool = Field(
        False, description="range a track's boxes with its learned height (and std) instead of the class prior "
        "once it has height evidence (off: measured worse on the shipped scenarios, see perception.estimator)")
    ground_map: bool = Field(
        False, description="range a box's ground contact on the surface a frame's ground map says its ray meets "
        "first (a pavement's top, perception.ground_map) instead of the road plane; off: the road plane always "
        "(off by default: measured better range and behaviour on the shipped scenarios, but parked SUVs then "
        "range short by the car's size priors and one read in path; see perception.ground_map)")
    ground_map_sigma: float = Field(
        0.02, ge=0, description="std of the ground's height under a contact where a ground map gives it (m): "
        "replaces the classes' contact_height_sigma")



class PriorTable:
    """``ClassPrior`` fields as arrays over class ids, for vectorised look-ups.

    Args:
        config: the priors come from ``config.priors`` (by class name) and
            ``config.default_prior`` (classes without one, ids outside ``CLASSES``).
    """

    def __init__(self, config: EstimatorConfig) -> None:
        table = [config.priors.get(name, config.default_prior) for name in CLASSES] + [config.default_prior]
        self._arrays = {
            key: np.array([getattr(p, key) for p in table]) for key in ClassPrior.model_fields if key != "height_modes"
        }
        #: per class id (the last: ``default_prior``): [(weight, mean, std)] of the height's modes
        self.height_modes = [list(p.height_modes) or [(1.0, p.height, p.height_sigma)] for p in table]

    def modes_of(self, class_id: int) -> list[tuple[float, float, float]]:
        """The height's modes (weight, mean, std) of one class id (``ClassPrior.height_modes``; a
        single mode height +- height_sigma when it has none)."""
        cid = int(class_id)
        return self.height_modes[cid if 0 <= cid < len(CLASSES) else len(CLASSES)]

    def of(self, class_id: np.ndarray, key: str) -> np.ndarray:
        """The prior ``key`` (a ``ClassPrior`` field) of each class id (same shape as ``class_id``)."""
        cid = np.asarray(class_id, dtype=np.int64)
        idx = np.where((cid >= 0) & (cid < len(CLASSES)), cid, len(CLASSES))
        return self._arrays[key][idx]
