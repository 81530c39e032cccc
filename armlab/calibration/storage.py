"""Saving and loading a calibration as JSON (written atomically, validated on load)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armlab.arguments import finite_array
from armlab.calibration.depth import DepthCorrection
from armlab.camera import MAX_DISTANCE_MM, MAX_IMAGE_SIDE_PX, Camera, check_intrinsics
from armlab.files import read_json, write_json_atomic
from armlab.images import check_depth, sample_depth
from armlab.schemas import camera_matrix, comment, field_error, integer, matrix, number, strict_object, validate, vector

__all__ = ["Calibration", "save_calibration", "load_calibration", "CalibrationFileError", "SCHEMA"]

_FORMAT = "armlab-calibration/1"


class CalibrationFileError(ValueError):
    """A calibration file is missing or corrupt; the message names the file and the problem."""


@dataclass(frozen=True)
class Calibration:
    """Everything pixel + depth -> world needs: the camera (K, dist, T_cam_world, size) and the depth correction."""

    camera: Camera
    depth_correction: DepthCorrection = field(default_factory=DepthCorrection)
    notes: str = ""

    def __post_init__(self):
        if not isinstance(self.camera, Camera):
            raise TypeError(f"Calibration.camera must be an armlab.camera.Camera, got {type(self.camera).__name__}")
        if not isinstance(self.depth_correction, DepthCorrection):
            raise TypeError("Calibration.depth_correction must be an armlab.calibration.DepthCorrection")

    def pixel_to_world(self, uv, depth_mm, radius: int = 2) -> np.ndarray:
        """World points (N, 3) mm seen at pixels uv (N, 2) of a depth image depth_mm (H, W) mm: the depth is
        bias-corrected, read as the median of the valid pixels within `radius` px, and back-projected through the
        camera. NaN rows where the depth has no return."""
        depth = self.depth_correction.apply(check_depth(depth_mm, self.camera.image_shape))
        uv = finite_array(uv, "uv", [(2,), (None, 2)], "pixels (u, v)", allow_nan=True).reshape(-1, 2)
        return self.camera.pixel_to_world(uv, sample_depth(depth, uv, radius))

    def to_dict(self) -> dict:
        c = self.camera
        d = self.depth_correction
        return {"format": _FORMAT, "width": c.width, "height": c.height, "K": c.K.tolist(), "dist": c.dist.tolist(),
                "T_cam_world": c.T_cam_world.tolist(),
                "depth_correction": {"a": d.a, "b": d.b, "c": d.c, "residual_mm": d.residual_mm, "inliers": d.inliers},
                "notes": self.notes}

    @staticmethod
    def from_dict(raw: dict, source: str = "calibration") -> Calibration:
        """A Calibration from its dict (to_dict's format), validated against SCHEMA and the camera model's rules;
        CalibrationFileError names `source` and the field at fault."""
        if not isinstance(raw, dict) or raw.get("format") != _FORMAT:
            raise CalibrationFileError(f"{source}: not an armlab calibration (format must be {_FORMAT!r})")
        validate(raw, SCHEMA, source, CalibrationFileError)
        try:
            K, dist = check_intrinsics(raw["K"], raw["dist"])
        except ValueError as e:
            raise field_error(source, "K" if str(e).startswith("camera matrix") else "dist", str(e),
                              CalibrationFileError) from None
        try:
            camera = Camera(K, dist, raw["T_cam_world"], int(raw["width"]), int(raw["height"]))
        except ValueError as e:
            raise field_error(source, "T_cam_world", str(e), CalibrationFileError) from None
        dc = raw.get("depth_correction", {})
        correction = DepthCorrection(float(dc.get("a", 0)), float(dc.get("b", 0)), float(dc.get("c", 0)),
                                     float(dc.get("residual_mm", 0)), int(dc.get("inliers", 0)))
        return Calibration(camera, correction, str(raw.get("notes", "")))


_COEFFICIENT = number(minimum=-1e6, maximum=1e6)
SCHEMA = strict_object({
    "format": {"const": _FORMAT},
    "width": integer(1, MAX_IMAGE_SIDE_PX), "height": integer(1, MAX_IMAGE_SIDE_PX),
    "K": camera_matrix(),
    "dist": vector(number(minimum=-1e4, maximum=1e4), (4, 5, 8)),
    "T_cam_world": matrix(4, 4, number(minimum=-MAX_DISTANCE_MM, maximum=MAX_DISTANCE_MM)),
    "depth_correction": strict_object({"a": _COEFFICIENT, "b": _COEFFICIENT, "c": _COEFFICIENT,
                                       "residual_mm": number(minimum=0.0, maximum=1e6),
                                       "inliers": integer(0, 10**9)}),
    "notes": comment()}, required=("format", "width", "height", "K", "dist", "T_cam_world"))
"""The declared schema of a calibration file (armlab.schemas): fields, types, finite numbers and ranges."""


def save_calibration(calibration: Calibration, path) -> Path:
    """Write the calibration as JSON atomically (temporary file in the same folder, then rename): a failed write
    leaves any previous file untouched. Raises ValueError for non-finite values (JSON has no NaN)."""
    if not isinstance(calibration, Calibration):
        raise TypeError(f"save_calibration takes a Calibration, got {type(calibration).__name__}")
    return write_json_atomic(path, calibration.to_dict(), indent=2, make_parents=True)


def load_calibration(path) -> Calibration:
    """Read and validate a calibration file; raises CalibrationFileError naming the file and the problem."""
    path = Path(path)
    return Calibration.from_dict(read_json(path, "calibration", CalibrationFileError), str(path))
