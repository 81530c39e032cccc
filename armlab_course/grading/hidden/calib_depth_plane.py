"""Hidden checks of exercise calib.depth_plane: fresh inputs from the grader's seed, compared with the reference's
results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec
from ._common import _camera_over_board


def _depth_scenes(rng):
    # a small depth camera over the board: a tilted bias plane, noise, dropouts and objects 12-25 mm tall (within
    # the first guess's 30 mm, so only the refit-and-reject loop drops them)
    cases = []
    for _ in range(3):
        K, T = _camera_over_board(rng, 160, 90)
        bias = [float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-15, 15))]
        cases.append([[K, T, bias, int(rng.integers(0, 2**31))]])
    return cases


def _judge_depth_plane(call, K, T, bias, seed):
    """The depth image (90 x 160 mm) of the board seen by K, T with the bias plane, noise, objects and dropouts of
    `seed`, made here; the child's fit [a, b, c, residual mm, inliers]."""
    from armlab.calibration.depth import board_depth
    from armlab.camera import Camera

    camera = Camera(np.asarray(K, float), np.zeros(5), np.asarray(T, float), 160, 90)
    rng = np.random.default_rng(int(seed))
    depth, _ = board_depth(camera, 1)
    v, u = np.mgrid[0:90, 0:160]
    depth = depth + bias[0] * u + bias[1] * v + bias[2] + rng.normal(0, 1.0, depth.shape)
    for _ in range(4):
        r, c = rng.integers(0, 80), rng.integers(0, 150)
        depth[r:r + 10, c:c + 10] -= rng.uniform(12, 25)
    depth[rng.random(depth.shape) < 0.05] = np.nan
    return call(depth.astype(np.float32), K, T)


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("armlab.calibration.depth.fit_depth_correction", _depth_scenes, atol=1e-6,
                                    adapter="_call_depth_plane", judge=_judge_depth_plane, what="the depth-plane fit",
                                    parts=(("a", "mm per px"), ("b", "mm per px"), ("c", "mm"), ("residual_mm", "mm"),
                                           ("inliers", "pixels"))),)
FORBIDDEN: tuple[str, ...] = (
    "scipy.optimize.least_squares", "depth._robust_plane", "cv2.fitLine"
)
