"""Hidden checks of exercise calib.zhang: fresh cameras (focal lengths 600-1200 px, principal point near the image
centre, zero skew) each looking at 3-8 tilted board poses; the exact board-to-image homographies, each scaled by a
random factor of either sign, go to the student's function and its K is compared with the reference's
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec

SIZES = ((1280, 720), (640, 480), (1920, 1080))


def _rotation(axis, angle) -> np.ndarray:
    """Rodrigues' formula: the rotation by `angle` rad about the unit vector `axis`."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    S = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * S + (1 - np.cos(angle)) * S @ S


def _views(rng):
    cases = []
    for n_views in (3, 3, 4, 5, 6, 8, 8):
        width, height = SIZES[int(rng.integers(len(SIZES)))]
        f = rng.uniform(600, 1200)
        K = np.array([[f, 0.0, width / 2 + rng.uniform(-0.04, 0.04) * width],
                      [0.0, f * rng.uniform(0.97, 1.03), height / 2 + rng.uniform(-0.04, 0.04) * height],
                      [0.0, 0.0, 1.0]])
        homographies = []
        for _ in range(n_views):
            # the board faces the camera (its z axis away from it), tilted 15-50 degrees about an axis in its plane
            # and turned in-plane at random; its centre 400-900 mm in front of the camera
            tilt_axis = rng.uniform(0, 2 * np.pi)
            R = (np.diag([1.0, -1.0, -1.0]) @ _rotation([np.cos(tilt_axis), np.sin(tilt_axis), 0.0],
                                                        np.radians(rng.uniform(15, 50)))
                 @ _rotation([0.0, 0.0, 1.0], rng.uniform(-np.pi, np.pi)))
            centre = np.array([rng.uniform(-80, 80), rng.uniform(-60, 60), rng.uniform(400, 900)])
            t = centre - R @ np.array([100.0, 62.5, 0.0])          # the board's origin at a corner of it
            scale = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-3, 3)
            homographies.append((scale * K @ np.column_stack([R[:, 0], R[:, 1], t])).tolist())
        cases.append([[homographies, [width, height]]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("intrinsics_from_homographies", _views, atol=1e-6,
                                            adapter="_call_intrinsics", prelude="definitions",
                                            what="the intrinsics K (its pixel rows in units of 1000 px)"),)
FORBIDDEN: tuple[str, ...] = (
    "cv2.calibrateCamera", "cv2.calibrateCameraExtended", "cv2.calibrateCameraRO", "cv2.initCameraMatrix2D",
    "calibration.calibrate_intrinsics", "cv2.fisheye.calibrate",
)
