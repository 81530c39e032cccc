"""Hidden checks of exercise calib.tag_homography: fresh inputs from the grader's seed, compared with the reference's
results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _homographies(rng):
    # exact pairs through a random homography (a camera looking at a plane), 4 points and more
    cases = []
    for n in (4, 4, 6, 15):
        H = np.array([[rng.uniform(0.5, 2), rng.uniform(-0.3, 0.3), rng.uniform(-300, 300)],
                      [rng.uniform(-0.3, 0.3), rng.uniform(0.5, 2), rng.uniform(-300, 300)],
                      [rng.uniform(-4e-4, 4e-4), rng.uniform(-4e-4, 4e-4), 1.0]])
        src = np.column_stack([rng.uniform(-400, 400, n), rng.uniform(-300, 300, n)])
        dst = np.column_stack([src, np.ones(n)]) @ H.T
        cases.append([[src.tolist(), (dst[:, :2] / dst[:, 2:]).tolist()]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("armlab.calibration.homography.dlt_homography", _homographies, atol=1e-7,
                                            what="the homography's entries (unitless)"),)
FORBIDDEN: tuple[str, ...] = (
    "cv2.findHomography", "cv2.getPerspectiveTransform", "homography.opencv_homography"
)
