"""Hidden checks of exercise calib.tag_extrinsics: fresh inputs from the grader's seed, compared with the reference's
results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec
from ._common import _camera_over_board


def _tag_views(rng):
    # exact board corners (z = 0) seen by random cameras, no distortion: any correct planar pose is exact here,
    # before the refinement (which the adapter leaves out) could repair a wrong one
    cases = []
    for n in (4, 8, 12, 20):
        K, T = _camera_over_board(rng)
        world = np.column_stack([rng.uniform(-400, 400, n), rng.uniform(-150, 450, n), np.zeros(n)])
        cam = world @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3]
        uv = cam @ np.asarray(K).T
        cases.append([[world.tolist(), (uv[:, :2] / uv[:, 2:]).tolist(), K, [0.0] * 5]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("armlab.calibration.extrinsics.pose_from_corners", _tag_views, atol=1e-6,
                                       adapter="_call_initial_pose",
                                       what="the camera pose (its rotation's entries, unitless, and translation, mm)"),)
FORBIDDEN: tuple[str, ...] = (
    "cv2.solvePnP", "cv2.solvePnPRansac", "cv2.solvePnPGeneric", "cv2.solvePnPRefineLM",
    "cv2.decomposeHomographyMat", "extrinsics._opencv_pose", "cv2.findHomography"
)
