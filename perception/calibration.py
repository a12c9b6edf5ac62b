"""Camera calibration files for real video, and undistortion of their frames.

A calibration is a small YAML file (schema: ``scenarios/calibration.schema.json``)::

    # lookahead camera calibration
    version: 1
    image: {width: 1280, height: 720}          # px
    intrinsics: {fx: 1000.0, fy: 1000.0, cx: 640.0, cy: 360.0}   # px
    distortion: {k1: -0.28, k2: 0.07, p1: 0.0, p2: 0.0, k3: 0.0}  # OpenCV; optional, zeros
    mount:
      x: -1.8          # m forward of the front bumper (negative: behind it)
      y: 0.0           # m left of the vehicle centreline
      height: 1.35     # m above the ground
      yaw_deg: 0.0     # > 0 turns the optical axis left
      pitch_deg: -2.0  # > 0 tilts it up
      roll_deg: 0.0    # > 0 rotates the image clockwise as seen by the camera

Intrinsics come in one of two forms: ``fx`` and ``fy`` (what a calibration tool gives), or
``fov_h_deg`` alone (square pixels, for a camera known only by its data sheet). ``cx``/``cy``
default to the image centre and ``skew`` to 0. Pixel coordinates are continuous, as in
``perception.camera``: pixel (i, j) covers u in [i, i+1), v in [j, j+1). Angles are degrees in
the file and radians in ``CameraModel``; the mount is in the ego frame (origin at the centre of
the front bumper on the ground, x forward, y left, z up), so ``height`` is the mount's z.

``load_calibration`` refuses anything wrong with one line ``file:line: field: problem``
(``CalibrationError``); the YAML is read through ``perception.safe_yaml`` (size, depth and
alias limits, duplicate keys). ``Undistorter`` maps distorted frames to the pinhole camera with
the same K.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from lookahead.perception.camera import CameraModel
from lookahead.perception.safe_yaml import YamlError, read_yaml_text
from lookahead.perception.yaml_model import LocatedError, format_validation, parse_yaml_model

log = logging.getLogger(__name__)

MAX_CALIBRATION_BYTES = 64 * 2**10  # a calibration is a few hundred bytes
MAX_IMAGE_SIDE = 16384


class CalibrationError(ValueError):
    """A calibration that cannot be used; ``str()`` is one line ``file[:line]: field: problem``."""


# ---------------------------------------------------------------------------- the file's model
class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True, frozen=True)


class ImageSize(_Strict):
    width: int = Field(ge=16, le=MAX_IMAGE_SIDE, description="image width (px)")
    height: int = Field(ge=16, le=MAX_IMAGE_SIDE, description="image height (px)")


class Intrinsics(_Strict):
    """Either ``fx`` and ``fy``, or ``fov_h_deg`` (square pixels); ``cx``/``cy`` default to the centre."""

    fx: float | None = Field(None, gt=0.0, le=1e6, description="focal length along u (px)")
    fy: float | None = Field(None, gt=0.0, le=1e6, description="focal length along v (px)")
    fov_h_deg: float | None = Field(
        None, gt=1.0, lt=170.0, description="horizontal field of view (deg), instead of fx/fy"
    )
    cx: float | None = Field(None, ge=0.0, le=MAX_IMAGE_SIDE, description="principal point u (px); default width/2")
    cy: float | None = Field(None, ge=0.0, le=MAX_IMAGE_SIDE, description="principal point v (px); default height/2")
    skew: float = Field(0.0, ge=-1e4, le=1e4, description="K[0,1] (px); 0 for every ordinary camera")

    @model_validator(mode="after")
    def _one_form(self) -> Intrinsics:
        focal = (self.fx is not None, self.fy is not None)
        if self.fov_h_deg is not None:
            if any(focal):
                raise ValueError("give either fx and fy, or fov_h_deg, not both")
        elif not all(focal):
            missing = "fy" if focal[0] else "fx" if focal[1] else "fx and fy (or fov_h_deg)"
            raise ValueError(f"missing {missing}")
        return self


class Distortion(_Strict):
    """OpenCV (Brown-Conrady) coefficients; all zero for a pinhole camera."""

    k1: float = Field(0.0, ge=-100.0, le=100.0, description="radial r^2")
    k2: float = Field(0.0, ge=-1000.0, le=1000.0, description="radial r^4")
    p1: float = Field(0.0, ge=-1.0, le=1.0, description="tangential")
    p2: float = Field(0.0, ge=-1.0, le=1.0, description="tangential")
    k3: float = Field(0.0, ge=-10000.0, le=10000.0, description="radial r^6")


class Mount(_Strict):
    """Camera position in the ego frame (origin: front bumper centre on the ground) and its angles."""

    x: float = Field(ge=-30.0, le=5.0, description="m forward of the front bumper (negative: behind it)")
    y: float = Field(0.0, ge=-5.0, le=5.0, description="m left of the vehicle centreline")
    height: float = Field(gt=0.0, le=10.0, description="m above the ground")
    yaw_deg: float = Field(0.0, ge=-180.0, le=180.0, description="> 0 turns the optical axis left (deg)")
    pitch_deg: float = Field(0.0, ge=-60.0, le=60.0, description="> 0 tilts the optical axis up (deg)")
    roll_deg: float = Field(
        0.0, ge=-180.0, le=180.0, description="> 0 rotates the image clockwise as seen by the camera (deg)"
    )


class CameraCalibration(_Strict):
    """A camera calibration file: image size, intrinsics, distortion and mount."""

    version: Literal[1] = Field(1, description="file format version")
    image: ImageSize
    intrinsics: Intrinsics
    distortion: Distortion = Field(default_factory=Distortion)
    mount: Mount

    @model_validator(mode="after")
    def _principal_point_in_image(self) -> CameraCalibration:
        for name, value, side in (("cx", self.intrinsics.cx, self.image.width), ("cy", self.intrinsics.cy, self.image.height)):
            if value is not None and not 0.0 <= value <= side:
                raise LocatedError(("intrinsics", name), f"{value} is outside the image (0..{side} px)")
        return self

    @property
    def K(self) -> np.ndarray:
        """The 3x3 intrinsic matrix (px)."""
        w, h, i = self.image.width, self.image.height, self.intrinsics
        if i.fov_h_deg is not None:
            fx = fy = w / (2.0 * np.tan(np.radians(i.fov_h_deg) / 2.0))
        else:
            fx, fy = float(i.fx), float(i.fy)  # type: ignore[arg-type]
        cx = w / 2.0 if i.cx is None else i.cx
        cy = h / 2.0 if i.cy is None else i.cy
        return np.array([[fx, i.skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])

    def to_camera(self) -> CameraModel:
        """The ``CameraModel`` this file describes (angles in radians)."""
        d, m = self.distortion, self.mount
        return CameraModel(
            width=self.image.width,
            height=self.image.height,
            K=self.K,
            dist=np.array([d.k1, d.k2, d.p1, d.p2, d.k3]),
            mount=np.array([m.x, m.y, m.height]),
            yaw=float(np.radians(m.yaw_deg)),
            pitch=float(np.radians(m.pitch_deg)),
            roll=float(np.radians(m.roll_deg)),
        )

    @classmethod
    def from_camera(cls, cam: CameraModel) -> CameraCalibration:
        """The calibration of ``cam`` (fx/fy form); ``CalibrationError`` when a value is out of bounds
        or ``cam`` has more than the five distortion coefficients a file holds."""
        K, dist = cam.K, np.asarray(cam.dist, dtype=np.float64).ravel()
        if dist.size > 5 and np.any(dist[5:] != 0.0):
            raise CalibrationError(f"camera: {dist.size} distortion coefficients, a calibration holds 5")
        k1, k2, p1, p2, k3 = (list(map(float, dist[:5])) + [0.0] * 5)[:5]
        data = {
            "image": {"width": int(cam.width), "height": int(cam.height)},
            "intrinsics": {
                "fx": float(K[0, 0]), "fy": float(K[1, 1]), "cx": float(K[0, 2]), "cy": float(K[1, 2]),
                "skew": float(K[0, 1]),
            },
            "distortion": {"k1": k1, "k2": k2, "p1": p1, "p2": p2, "k3": k3},
            "mount": {
                "x": float(cam.mount[0]), "y": float(cam.mount[1]), "height": float(cam.mount[2]),
                "yaw_deg": float(np.degrees(cam.yaw)), "pitch_deg": float(np.degrees(cam.pitch)),
                "roll_deg": float(np.degrees(cam.roll)),
            },
        }
        try:
            return cls.model_validate(data)
        except ValidationError as e:
            raise CalibrationError(format_validation("camera", e, None)) from None

    def to_yaml_data(self) -> dict:
        """The file's mapping: every field explicit, ``None`` intrinsics left out."""
        return self.model_dump(exclude_none=True)


# ---------------------------------------------------------------------------- files
def parse_calibration(text: str, source: str = "<string>") -> CameraCalibration:
    """Validate calibration YAML text; ``CalibrationError`` with one line ``source:line: field: problem``."""
    return parse_yaml_model(text, source, CameraCalibration, "calibration", CalibrationError)


def load_calibration(path: str | Path) -> CameraCalibration:
    """Read and validate a calibration YAML file (size checked before reading)."""
    try:
        text = read_yaml_text(path, "calibration", MAX_CALIBRATION_BYTES)
    except YamlError as e:
        raise CalibrationError(str(e)) from None
    cal = parse_calibration(text, str(path))
    log.debug("calibration %s: %dx%d px, fx %.1f", path, cal.image.width, cal.image.height, cal.K[0, 0])
    return cal


HEADER = """\
# lookahead camera calibration (schema: scenarios/calibration.schema.json)
# image, intrinsics: px; distortion: OpenCV k1 k2 p1 p2 k3; mount: m in the ego frame
# (x forward of the front bumper, y left, height above the ground), angles in degrees.
"""


def write_calibration(cal: CameraCalibration, path: str | Path) -> Path:
    """Write ``cal`` as YAML with a header comment; returns the path."""
    p = Path(path)
    body = yaml.safe_dump(cal.to_yaml_data(), sort_keys=False, default_flow_style=False)
    p.write_text(HEADER + body, encoding="utf-8")
    return p


def calibration_json_schema() -> dict:
    """JSON Schema (draft 2020-12) of the calibration file, generated from the model."""
    schema = CameraCalibration.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "lookahead camera calibration"
    return schema


# ---------------------------------------------------------------------------- undistortion
class Undistorter:
    """Maps frames of a distorted camera to the pinhole camera with the same K.

    The remap tables are computed once (``cv2.initUndistortRectifyMap``, fixed-point maps);
    each call is one ``cv2.remap`` (bilinear; outside the source image is black). Pixel
    centres are at half-integer continuous coordinates, as in ``perception.camera``.
    With no distortion the undistorter is the identity: frames are returned as they are.

    Attributes:
        source: the distorted camera.
        camera: the undistorted camera (same size, K, mount and angles; ``dist`` zeros).
    """

    def __init__(self, cam: CameraModel) -> None:
        self.source = cam
        self.identity = not cam.has_distortion
        if self.identity:
            self.camera = cam
            self._maps: tuple[np.ndarray, np.ndarray] | None = None
            return
        import cv2

        self.camera = CameraModel(
            width=cam.width, height=cam.height, K=cam.K.copy(), dist=np.zeros(5),
            mount=cam.mount.copy(), yaw=cam.yaw, pitch=cam.pitch, roll=cam.roll,
        )
        # OpenCV puts pixel centres at integer coordinates; ours are at +0.5.
        k_cv = cam.K.copy()
        k_cv[0, 2] -= 0.5
        k_cv[1, 2] -= 0.5
        self._maps = cv2.initUndistortRectifyMap(
            k_cv, cam.dist, None, k_cv, (cam.width, cam.height), cv2.CV_16SC2
        )

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """The undistorted ``image`` (H, W[, C]) of the source camera's size."""
        if image.shape[:2] != (self.source.height, self.source.width):
            raise ValueError(
                f"frame is {image.shape[1]}x{image.shape[0]} px, the calibration is "
                f"{self.source.width}x{self.source.height}"
            )
        if self._maps is None:
            return image
        import cv2

        return cv2.remap(image, self._maps[0], self._maps[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
