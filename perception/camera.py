"""The one camera model: pinhole intrinsics, optional distortion, mount extrinsics.

Frames (see docs/architecture.md):

* ego frame (ISO 8855): origin at the centre of the front bumper on the ground,
  x forward, y left, z up; metres.
* camera frame (OpenCV): x right, y down, z forward (optical axis); metres.
* image: pixels, continuous coordinates; pixel (i, j) covers u in [i, i+1),
  v in [j, j+1). Boxes are float ``xyxy``.

The simulator projects ground-truth boxes with this model and perception
back-projects detections to the road with it: one implementation, both ways.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# The 12 edges of a box whose 8 corners are ordered as in ``geometry.box_corners``.
BOX_EDGES = np.array(
    [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]]
)

# Camera axes expressed in the mount frame (x forward, y left, z up):
# camera x = -mount y, camera y = -mount z, camera z = mount x.
_CAM_FROM_MOUNT = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


def _rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True, eq=False)
class CameraModel:
    """A calibrated forward camera rigidly mounted on the ego vehicle.

    Attributes:
        width, height: image size in pixels.
        K: 3x3 intrinsic matrix (pixels).
        dist: OpenCV distortion coefficients (k1, k2, p1, p2, k3); zeros for a pinhole.
        mount: camera centre in the ego frame (m).
        yaw, pitch, roll: mount angles (rad). ``yaw`` > 0 turns the optical axis
            left, ``pitch`` > 0 tilts it up, ``roll`` > 0 rotates the image
            clockwise as seen by the camera (right-handed about the optical axis).
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    mount: np.ndarray = field(default_factory=lambda: np.array([-1.5, 0.0, 1.4]))
    yaw: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", np.asarray(self.K, dtype=np.float64).reshape(3, 3))
        object.__setattr__(self, "dist", np.asarray(self.dist, dtype=np.float64).ravel())
        object.__setattr__(self, "mount", np.asarray(self.mount, dtype=np.float64).reshape(3))
        # R maps mount-frame vectors to ego-frame vectors; pitch up = negative rotation about y.
        r_ego_from_mount = _rot_z(self.yaw) @ _rot_y(-self.pitch) @ _rot_x(self.roll)
        object.__setattr__(self, "R_cam_from_ego", _CAM_FROM_MOUNT @ r_ego_from_mount.T)

    R_cam_from_ego: np.ndarray = field(init=False, repr=False, compare=False)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_fov(
        cls,
        width: int,
        height: int,
        fov_h_deg: float,
        mount: tuple[float, float, float] = (-1.5, 0.0, 1.4),
        yaw_deg: float = 0.0,
        pitch_deg: float = 0.0,
        roll_deg: float = 0.0,
    ) -> CameraModel:
        """Square-pixel pinhole with the principal point at the image centre."""
        fx = width / (2.0 * np.tan(np.radians(fov_h_deg) / 2.0))
        K = np.array([[fx, 0.0, width / 2.0], [0.0, fx, height / 2.0], [0.0, 0.0, 1.0]])
        return cls(
            width=width,
            height=height,
            K=K,
            mount=np.asarray(mount, dtype=np.float64),
            yaw=np.radians(yaw_deg),
            pitch=np.radians(pitch_deg),
            roll=np.radians(roll_deg),
        )

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def fov_v(self) -> float:
        """Vertical field of view (rad)."""
        return float(2.0 * np.arctan(self.height / (2.0 * self.fy)))

    @property
    def has_distortion(self) -> bool:
        return bool(np.any(self.dist != 0.0))

    def to_dict(self) -> dict:
        return {
            "width": self.width,
            "height": self.height,
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "mount": self.mount.tolist(),
            "yaw": self.yaw,
            "pitch": self.pitch,
            "roll": self.roll,
        }

    @classmethod
    def from_dict(cls, d: dict) -> CameraModel:
        return cls(**{k: d[k] for k in ("width", "height", "K", "dist", "mount", "yaw", "pitch", "roll")})

    # ------------------------------------------------------------------ transforms
    def ego_to_camera(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 3) in the ego frame -> camera frame (m)."""
        return (np.asarray(points, dtype=np.float64) - self.mount) @ self.R_cam_from_ego.T

    def camera_to_ego(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 3) in the camera frame -> ego frame (m)."""
        return np.asarray(points, dtype=np.float64) @ self.R_cam_from_ego + self.mount

    def _distort(self, xn: np.ndarray, yn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k1, k2, p1, p2, k3 = (list(self.dist) + [0.0] * 5)[:5]
        r2 = xn * xn + yn * yn
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xd = xn * radial + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn)
        yd = yn * radial + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn
        return xd, yd

    def project_camera(self, points_cam: np.ndarray) -> np.ndarray:
        """Camera-frame points (..., 3) -> pixels (..., 2); NaN where z <= 0."""
        p = np.asarray(points_cam, dtype=np.float64)
        z = p[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            zs = np.where(z > 0.0, z, np.nan)
            xn, yn = p[..., 0] / zs, p[..., 1] / zs
        if self.has_distortion:
            xn, yn = self._distort(xn, yn)
        u = self.K[0, 0] * xn + self.K[0, 1] * yn + self.K[0, 2]
        v = self.K[1, 1] * yn + self.K[1, 2]
        return np.stack([u, v], axis=-1)

    def project(self, points_ego: np.ndarray) -> np.ndarray:
        """Ego-frame points (..., 3) -> pixels (..., 2); NaN behind the camera."""
        return self.project_camera(self.ego_to_camera(points_ego))

    def project_boxes(self, corners_ego: np.ndarray, near: float = 0.05) -> np.ndarray:
        """Amodal 2D boxes of 3D boxes, clipped at the near plane.

        Args:
            corners_ego: (N, 8, 3) box corners in the ego frame, ordered as
                ``geometry.box_corners`` makes them.
            near: near-plane depth (m). Edges that cross it are cut there, so a
                box partly behind the camera gets the box of its visible part.

        Returns:
            (N, 4) float xyxy in pixels, not clipped to the image; rows of NaN
            for boxes wholly behind the near plane.
        """
        c = self.ego_to_camera(np.asarray(corners_ego, dtype=np.float64).reshape(-1, 8, 3))
        n = c.shape[0]
        if n == 0:
            return np.zeros((0, 4))
        p0, p1 = c[:, BOX_EDGES[:, 0]], c[:, BOX_EDGES[:, 1]]  # (N, 12, 3)
        z0, z1 = p0[..., 2], p1[..., 2]
        crosses = (z0 - near) * (z1 - near) < 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(crosses, (near - z0) / (z1 - z0), 0.0)
        cut = p0 + t[..., None] * (p1 - p0)
        cut[..., 2] = near
        cut[~crosses] = np.nan
        front = np.where((c[..., 2] >= near)[..., None], c, np.nan)
        pts = np.concatenate([front, cut], axis=1)  # (N, 20, 3)
        uv = self.project_camera(pts)
        out = np.full((n, 4), np.nan)
        valid = ~np.all(np.isnan(uv[..., 0]), axis=1)
        if valid.any():
            u, v = uv[valid, :, 0], uv[valid, :, 1]
            out[valid] = np.stack(
                [np.nanmin(u, 1), np.nanmin(v, 1), np.nanmax(u, 1), np.nanmax(v, 1)], axis=1
            )
        return out

    # ------------------------------------------------------------------ back-projection
    def pixel_rays(self, uv: np.ndarray) -> np.ndarray:
        """Pixels (..., 2) -> unit ray directions (..., 3) in the ego frame."""
        uv = np.asarray(uv, dtype=np.float64)
        shape = uv.shape[:-1]
        flat = uv.reshape(-1, 2)
        if self.has_distortion:
            import cv2

            xn = cv2.undistortPoints(flat.reshape(-1, 1, 2), self.K, self.dist).reshape(-1, 2)
        else:
            yn = (flat[:, 1] - self.K[1, 2]) / self.K[1, 1]
            xn0 = (flat[:, 0] - self.K[0, 2] - self.K[0, 1] * yn) / self.K[0, 0]
            xn = np.stack([xn0, yn], axis=1)
        d_cam = np.concatenate([xn, np.ones((xn.shape[0], 1))], axis=1)
        d_ego = d_cam @ self.R_cam_from_ego
        d_ego /= np.linalg.norm(d_ego, axis=1, keepdims=True)
        return d_ego.reshape(*shape, 3)

    def ground_points(self, uv: np.ndarray, ground_z: float | np.ndarray = 0.0) -> np.ndarray:
        """Pixels (..., 2) -> ego-frame points (..., 3) on the plane z = ground_z (a scalar, or an
        array broadcasting against the pixels' leading shape: a plane per pixel).

        NaN where the ray does not meet the plane in front of the camera (at or
        above the horizon).
        """
        d = self.pixel_rays(uv)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (ground_z - self.mount[2]) / d[..., 2]
        s = np.where(s > 0.0, s, np.nan)
        return self.mount + s[..., None] * d

    def ground_depth(self, ground_z: float = 0.0) -> np.ndarray:
        """(H, W) float64 depth (m along the optical axis) of the plane z = ``ground_z`` seen at
        each pixel centre; inf where the ray does not meet it in front of the camera."""
        u, v = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        z = self.ego_to_camera(self.ground_points(np.stack([u, v], axis=-1), ground_z))[..., 2]
        return np.where(np.isfinite(z), z, np.inf)

    def horizon_v(self) -> float:
        """Image row (px) of the horizon at the image centre column (pinhole)."""
        return float(self.K[1, 2] + self.K[1, 1] * np.tan(self.pitch))


def truncation(boxes: np.ndarray, width: int, height: int) -> np.ndarray:
    """Fraction (N,) of each xyxy box's area that lies outside the image; 1 for NaN boxes."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    area = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    cw = np.clip(np.minimum(b[:, 2], width) - np.maximum(b[:, 0], 0.0), 0.0, None)
    ch = np.clip(np.minimum(b[:, 3], height) - np.maximum(b[:, 1], 0.0), 0.0, None)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = 1.0 - cw * ch / area
    return np.where(np.isfinite(frac) & (area > 0), np.clip(frac, 0.0, 1.0), 1.0)
