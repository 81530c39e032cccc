"""The kit's reference paths for the notebooks' own exercises, for `with_reference` while an exercise is blank.

Each one computes what the exercise asks by another method than the one the notebook teaches (a library call, a
numerical solve, a different model), so that later cells of the notebook keep working; none is the solution, and
a check cell never uses them.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from armlab.robot import RobotModel, rx200
from armlab.transforms import wrap_quarter

__all__ = ["click_target_by_kit", "intrinsics_by_opencv", "centroid_by_scipy", "wrap_yaw_by_kit", "line_by_scipy",
           "scaled_durations_by_search", "segment_by_colour_model", "stack_by_kit",
           "pose_error_by_log", "ik_by_least_squares"]


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
    # imported here: scipy.stats costs 0.7 s of CPU to import, in every notebook kernel that imports this module
    from scipy import stats

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


_LOOKUP_BITS = 6          # bits per channel of segment_by_colour_model's lookup table (64 levels: 262144 colours)
_LOOKUPS: dict[tuple, np.ndarray] = {}


def _colour_lookup(max_distance: float) -> np.ndarray:
    """The kit's colour model's label (an index in armlab.blocks.COLORS, -1 for none) of every colour quantised to
    _LOOKUP_BITS per channel (taken at its bin's centre), indexed r << 2b | g << b | b: computed once per model."""
    from armlab.blocks import COLORS
    from armlab.detection import default_color_model

    model = default_color_model()
    key = (model.names, model.means.tobytes(), model.stds.tobytes(), float(max_distance))
    if key not in _LOOKUPS:
        step = 1 << (8 - _LOOKUP_BITS)
        levels = np.arange(0, 256, step) + (step - 1) / 2
        grid = np.stack(np.meshgrid(levels, levels, levels, indexing="ij"), -1).reshape(-1, 3)
        d = model.common_distances(grid)
        labels = np.array([COLORS.index(n) for n in model.names])[d.argmin(axis=1)]
        labels[d.min(axis=1) > max_distance] = -1
        _LOOKUPS.clear()
        _LOOKUPS[key] = labels.astype(np.int64)
    return _LOOKUPS[key]


def segment_by_colour_model(rgb_balanced, max_distance: float = 8.0) -> np.ndarray:
    """detect.segment's reference: every pixel of a white-balanced RGB image (H, W, 3) uint8 labelled by the kit's
    colour model (nearest class mean in chromaticity, one spread common to every class) through a lookup table of
    colours quantised to 64 levels per channel; -1 where even the nearest class is more than `max_distance` spreads
    away (the board, shadows); else the colour's index in armlab.blocks.COLORS."""
    rgb = np.asarray(rgb_balanced).astype(np.int64) >> (8 - _LOOKUP_BITS)
    index = (rgb[..., 0] << (2 * _LOOKUP_BITS)) | (rgb[..., 1] << _LOOKUP_BITS) | rgb[..., 2]
    return _colour_lookup(max_distance)[index]


def stack_by_kit(depth_mm, mask, camera, edges_mm=(38.0, 25.0)) -> tuple[float, int, np.ndarray]:
    """detect.stacks' reference: the kit's height map (armlab.detection.height_from_depth) over the mask; the top face
    as the pixels within 5 mm of the median of the mask's highest 20 %, its height their median; their world points on
    that plane (armlab.detection.heightmap.pixels_to_plane), the top block's size from their minimum-area rectangle
    (cv2.minAreaRect) and the kit's stack rule (armlab.detection.stacks.stack_levels): (top_z mm, levels, centre (3,)
    world mm)."""
    import cv2

    from armlab.detection import height_from_depth
    from armlab.detection.heightmap import pixels_to_plane
    from armlab.detection.stacks import stack_levels

    depth = np.asarray(depth_mm, dtype=float)
    height = height_from_depth(np.where(depth > 0, depth, np.nan), camera)
    h = height[np.asarray(mask, bool) & np.isfinite(height)]
    top_z = float(np.median(h[h >= np.percentile(h, 80)]))
    top_z = float(np.median(h[np.abs(h - top_z) < 5.0]))
    v, u = np.nonzero(np.asarray(mask, bool) & (np.abs(height - top_z) < 5.0))
    xy = pixels_to_plane(camera, np.column_stack([u, v]), top_z)[:, :2]
    (cx, cy), (w, l), _ = cv2.minAreaRect(xy.astype(np.float32))
    small, large = sorted(edges_mm)
    edge = large if np.sqrt(w * l) > 0.5 * (large + small) else small
    return top_z, stack_levels(top_z, edge, {"large": large, "small": small}), np.array([cx, cy, top_z])


def pose_error_by_log(T, T_target) -> np.ndarray:
    """ik.numerical's reference for pose_error: the position difference and the rotation vector (scipy's
    Rotation.as_rotvec) of the rotation from the tool's orientation to the target's."""
    from scipy.spatial.transform import Rotation

    pose, target = np.array(T, dtype=float), np.array(T_target, dtype=float)
    turn = Rotation.from_matrix(target[:3, :3] @ pose[:3, :3].T).as_rotvec()
    return np.concatenate([target[:3, 3] - pose[:3, 3], turn])


def ik_by_least_squares(T_target, q0, weight_mm: float = 100.0, tol_mm: float = 1e-3, max_iterations: int = 200,
                        **_ignored) -> tuple[np.ndarray, np.ndarray]:
    """ik.numerical's reference for solve_ik_dls: scipy.optimize.least_squares (trust region, within the joint
    limits) on the weighted pose error; (q, history) with the position (mm) and orientation (rad) errors at each
    evaluation. The damping and step options of the exercise do not apply (accepted and ignored)."""
    from scipy.optimize import least_squares

    from armlab import kinematics

    robot = rx200()
    weight = np.array([1.0, 1.0, 1.0, weight_mm, weight_mm, weight_mm])
    history = []

    def residual(q):
        e = pose_error_by_log(kinematics.fk(q, check_limits=False), T_target)
        history.append([float(np.sqrt(e[:3] @ e[:3])), float(np.sqrt(e[3:] @ e[3:]))])
        return weight * e

    q0 = np.clip(np.asarray(q0, dtype=float), robot.lower + 1e-9, robot.upper - 1e-9)   # strictly inside
    fit = least_squares(residual, q0, jac=lambda q: -weight[:, None] * kinematics.jacobian(q),
                        bounds=(robot.lower, robot.upper), xtol=1e-12, ftol=1e-12, gtol=1e-12,
                        max_nfev=max_iterations)
    return fit.x, np.array(history)


def click_target_by_kit(click, tops, yaws, edges, margin_mm: float = 3.0) -> int:
    """grab.click_target's reference: the nearest-centre rule (the kit's click-to-grab panel's in the instructor's
    tree): the detected top-face centre nearest the click in x and y, if it is within one block edge; -1 otherwise
    (yaw, margin and depth not used)."""
    click, tops, edges = np.asarray(click, float), np.asarray(tops, float).reshape(-1, 3), np.asarray(edges, float)
    if not len(tops):
        return -1
    d = np.hypot(*(tops[:, :2] - click[:2]).T)
    best = int(np.argmin(d))
    return best if d[best] <= edges[best] else -1
