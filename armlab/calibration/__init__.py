"""Camera calibration: checkerboard intrinsics, AprilTag extrinsics, board homography, depth-plane correction and
extrinsic refinement from depth, grid validation, calibration files and checkerboard photo sets. Units: px for
images, mm for the world (board frame)."""

from armlab.calibration.depth import DepthCorrection, board_depth, board_samples, fit_depth_correction
from armlab.calibration.extrinsics import (
    ExtrinsicsResult,
    calibrate_extrinsics,
    compare_extrinsics,
    extrinsics_from_detections,
    hand_measured_extrinsic,
)
from armlab.calibration.homography import BoardView, tag_homography
from armlab.calibration.intrinsics import (
    IntrinsicsResult,
    calibrate_intrinsics,
    checkerboard_points,
    compare_intrinsics,
    find_checkerboard,
)
from armlab.calibration.refine import PlaneRefinement, fit_plane, refine_extrinsic_from_depth
from armlab.calibration.storage import Calibration, CalibrationFileError, load_calibration, save_calibration
from armlab.calibration.tags import TagDetection, detect_tags
from armlab.calibration.validation import GridError, grid_world_error, visible_grid_points
from armlab.calibration.views import load_checkerboard_set, save_checkerboard_set

__all__ = [
    "BoardView", "Calibration", "CalibrationFileError", "DepthCorrection", "ExtrinsicsResult", "GridError",
    "IntrinsicsResult", "PlaneRefinement", "TagDetection", "board_depth", "board_samples", "calibrate_extrinsics",
    "calibrate_intrinsics", "checkerboard_points", "compare_extrinsics", "compare_intrinsics", "detect_tags",
    "extrinsics_from_detections", "find_checkerboard", "fit_depth_correction", "fit_plane", "grid_world_error",
    "hand_measured_extrinsic", "load_calibration", "load_checkerboard_set", "refine_extrinsic_from_depth",
    "save_calibration", "save_checkerboard_set", "tag_homography", "visible_grid_points",
]
