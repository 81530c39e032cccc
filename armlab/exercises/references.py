"""The kit's reference paths for the notebooks' own exercises, for `with_reference` while an exercise is blank.

Each one computes what the exercise asks by another method than the one the notebook teaches (a library call, a
numerical solve, a different model), so that later cells of the notebook keep working; none is the solution, and
a check cell never uses them.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage, stats

from armlab.robot import RobotModel, rx200
from armlab.transforms import wrap_quarter

__all__ = ["intrinsics_by_opencv", "centroid_by_scipy", "wrap_yaw_by_kit", "line_by_scipy",
           "scaled_durations_by_search", "segment_by_colour_model"]


def intrinsics_by_opencv(homographies, image_size) -> np.ndarray:
    """calib.zhang's reference: OpenCV's initial guess (cv2.initCameraMatrix2D) from a 5 x 5 grid of board points
    mapped through each homography: the principal point fixed at the image centre, only the focal lengths fitted."""
    grid = np.stack(np.meshgrid(np.linspace(0.0, 200.0, 5), np.linspace(0.0, 125.0, 5)), -1).reshape(-1, 2)
    board = np.column_stack([grid, np.zeros(len(grid))]).astype(np.float32)
    pixels = []
    for H in homographies:
        p = np.column_stack([grid, np.ones(len(grid))]) @ np.asarray(H, dtype=float).T
        pixels.append((p[:, :2] / p[:, 2:]).astype(np.float32))
    size = (int(image_size[0]), int(image_size[1]))
    return np.asarray(cv2.initCameraMatrix2D([board] * len(pixels), pixels, size, 0.0), dtype=float)


def centroid_by_scipy(mask) -> tuple[float, float]:
    """detect.centroid's reference: scipy.ndimage.center_of_mass of the mask, as (u, v) px."""
    v, u = ndimage.center_of_mass(np.asarray(mask, dtype=float))
    return float(u), float(v)


def wrap_yaw_by_kit(angle) -> float:
    """detect.wrap_yaw's reference: the kit's quarter-turn wrap (armlab.transforms.wrap_quarter)."""
    return float(wrap_quarter(angle))


def line_by_scipy(x, y) -> tuple[float, float]:
    """grab.sag_line's reference: slope and intercept of scipy.stats.linregress(x, y)."""
    fit = stats.linregress(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    return float(fit.slope), float(fit.intercept)


def scaled_durations_by_search(program, speed: float, robot: RobotModel | None = None) -> np.ndarray:
    """teach.time_scaled's reference: per segment of the program's waypoints, the lab's pace at `speed` (largest
    joint change / (speed pi/4 rad/s), at least 0.4 s), lengthened by bisection (to 1e-9 s) until the kit's
    trapezoid move (planning.joint_move) accepts it under every joint's velocity limit."""
    from armlab import planning
    from armlab.profile import LAB_MEAN_SPEED, MIN_MOVING_TIME_S

    robot = robot or rx200()
    q = np.asarray(program.q, dtype=float)
    out = []
    for q0, q1 in zip(q[:-1], q[1:], strict=True):
        lo = max(MIN_MOVING_TIME_S, float(np.abs(q1 - q0).max()) / (speed * LAB_MEAN_SPEED))

        def accepted(duration, q0=q0, q1=q1):
            try:
                planning.joint_move(q0, q1, duration=duration, robot=robot)
                return True
            except ValueError:
                return False

        if accepted(lo):
            out.append(lo)
            continue
        hi = lo * 2
        while not accepted(hi):
            hi *= 2
        while hi - lo > 1e-9:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if accepted(mid) else (mid, hi)
        out.append(hi)
    return np.array(out)


def segment_by_colour_model(rgb_balanced, max_distance: float = 8.0) -> np.ndarray:
    """detect.segment's reference: every pixel of a white-balanced RGB image (H, W, 3) uint8 labelled by the kit's
    colour model (nearest class in chromaticity, with the per-class spreads), -1 where even the nearest class is
    more than `max_distance` spreads away (the board, shadows); else the colour's index in armlab.blocks.COLORS."""
    from armlab.blocks import COLORS
    from armlab.detection import default_color_model

    rgb = np.asarray(rgb_balanced)
    model = default_color_model()
    d = model.distances(rgb.reshape(-1, 3).astype(float))
    labels = np.array([COLORS.index(n) for n in model.names])[d.argmin(axis=1)]
    labels[d.min(axis=1) > max_distance] = -1
    return labels.reshape(rgb.shape[:2])
