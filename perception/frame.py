"""``Frame``: one camera image with its calibration and the ego's odometry."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.perception.ground_map import GroundMap


@dataclass
class EgoOdometry:
    """Ego motion at the frame time: speed (m/s), longitudinal accel (m/s^2), yaw rate (rad/s, left +).

    ``speed_known`` False: no source gives the ego's speed (real video without a speed log);
    ``speed`` is then 0 and the estimates that need it are marked unavailable, not guessed.
    """

    speed: float = 0.0
    accel: float = 0.0
    yaw_rate: float = 0.0
    speed_known: bool = True

    def to_dict(self) -> dict:
        return {"speed": round(self.speed, 4), "accel": round(self.accel, 4), "yaw_rate": round(self.yaw_rate, 5)}


@dataclass
class Frame:
    """A camera frame.

    ``image`` is RGB uint8 (H, W, 3) or None when rendering is off; ``depth``
    (H, W) float32 metres along the optical axis and ``segmentation`` (H, W)
    int32 object ids (-1 background) are present only for simulated frames.
    """

    tick: int
    t: float
    camera: CameraModel
    odometry: EgoOdometry
    image: np.ndarray | None = None
    depth: np.ndarray | None = None
    segmentation: np.ndarray | None = None
    index: int = 0
    ground: GroundMap | None = None  # raised ground (pavements) and the ego's pose on it; None: the road plane only
