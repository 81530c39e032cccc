"""Hidden checks of exercise calib.pinhole: both directions of the pinhole model at fresh cameras (intrinsics and a
tilted extrinsic), projections of world points and back-projections of pixels with a depth; compared with the
reference's results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec
from ._common import _pinhole


def _projections(rng):
    cases = []
    for _ in range(3):
        K, T = _pinhole(rng)
        cases.append([[K, T, np.column_stack([rng.uniform(-300, 300, 10), rng.uniform(-100, 400, 10),
                                              rng.uniform(0, 100, 10)]).tolist()]])
    return cases


def _back_projections(rng):
    cases = []
    for _ in range(3):
        K, T = _pinhole(rng)
        cases.append([[K, T, [float(rng.uniform(0, 1280)), float(rng.uniform(0, 720))],
                       float(rng.uniform(700, 1200))] for _ in range(4)])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("project_pinhole", _projections, atol=1e-6,
                                            what="the projected pixels (u, v)", unit="px"),
                                 HiddenSpec("pixel_to_world_pinhole", _back_projections, atol=1e-6,
                                            what="the back-projected world points (x, y, z)", unit="mm"))
FORBIDDEN: tuple[str, ...] = (
    "cv2.projectPoints", "Camera.project", "Camera.project_camera", "Camera.pixel_to_world", "Camera.pixel_to_camera",
    "Camera.camera_to_world",
)
