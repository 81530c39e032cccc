"""Hidden checks of exercise calib.project_pinhole: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

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


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("project_pinhole", _projections, atol=1e-6),)
FORBIDDEN: tuple[str, ...] = (
    "cv2.projectPoints", "Camera.project", "Camera.project_camera"
)
