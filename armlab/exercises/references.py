"""The kit's reference paths for the notebooks' own exercises, for `with_reference` while an exercise is blank.

Each one computes what the exercise asks by another method than the one the notebook teaches (a library call, a
numerical solve, a different model), so that later cells of the notebook keep working; none is the solution, and
a check cell never uses them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import ndimage, stats

from armlab import kinematics
from armlab.robot import RobotModel, rx200
from armlab.transforms import wrap_quarter

__all__ = ["fk_by_kit_dh", "planar_ik_numerical", "centroid_by_scipy", "wrap_yaw_by_kit", "line_by_scipy",
           "scaled_durations_by_search", "segment_by_colour_model"]


def fk_by_kit_dh(q, table) -> np.ndarray:
    """fk.fk_from_table's reference: the kit's DH chain (kinematics.fk_dh) on the RX200 with the DH table `table`
    (5, 4) in its place; tool pose (4, 4), mm. Joint limits are not checked."""
    robot = replace(rx200(), dh=np.asarray(table, dtype=float))
    return kinematics.fk_dh(np.asarray(q, dtype=float), robot, check_limits=False)


def _planar_pose(q234: np.ndarray, robot: RobotModel) -> np.ndarray:
    """(N, 3): (r, z, psi) of the tool in the arm's plane for joints 2-4 (N, 3) rad (waist at 0: the plane's
    forward direction is +y)."""
    q = np.zeros((len(q234), 5))
    q[:, 1:4] = q234
    T = kinematics.fk(q, robot, check_limits=False)
    return np.column_stack([T[:, 1, 3], T[:, 2, 3], np.arctan2(-T[:, 2, 0], T[:, 1, 0])])


def _wrapped(a):
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


_PLANAR_SEEDS = [(s, e) for s in (0.0, 1.5, -1.5, 2.8) for e in (0.3, 1.2, 2.1, 2.9)]   # (shoulder, bend) rad
_PLANAR_WEIGHTS = np.array([1.0, 1.0, 100.0])     # the approach angle's error counts as 100 mm per rad
_PLANAR_ITERATIONS = 30


def _gauss_newton(q: np.ndarray, goal: np.ndarray, robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    """Damped Gauss-Newton on the weighted planar pose error of every row at once; returns q and the residual."""
    h = 1e-7
    for _ in range(_PLANAR_ITERATIONS):
        e = _planar_pose(q, robot) - goal
        e[:, 2] = _wrapped(e[:, 2])
        J = np.stack([(_planar_pose(q + h * np.eye(3)[k], robot) - goal - e) / h for k in range(3)], axis=2)
        J[:, 2, :] = _wrapped(J[:, 2, :] * h) / h
        Jw, ew = J * _PLANAR_WEIGHTS[None, :, None], e * _PLANAR_WEIGHTS
        A = np.swapaxes(Jw, 1, 2) @ Jw + 1e-9 * np.eye(3)
        q = q - np.linalg.solve(A, (np.swapaxes(Jw, 1, 2) @ ew[..., None]))[..., 0]
    e = _planar_pose(q, robot) - goal
    e[:, 2] = _wrapped(e[:, 2])
    return q, e


def planar_ik_numerical(r, z, psi, elbow_up: bool = True, robot: RobotModel | None = None):
    """ik.planar_ik's reference: (q2, q3, q4) rad putting the tool at reach r, height z (mm) with approach psi (rad)
    in the arm's plane (scalars or arrays), found by Gauss-Newton on the kit's FK from seeds on the requested elbow
    side; NaN where no solution reaches the point. Elbow up: the forearm bends down from the upper arm's line
    (q3 + the DH table's elbow offset > 0)."""
    robot = robot or rx200()
    r, z, psi = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (r, z, psi)))
    goal = np.column_stack([r.ravel(), z.ravel(), psi.ravel()])
    out = np.full(goal.shape, np.nan)
    todo = np.all(np.isfinite(goal), axis=1)
    for shoulder, bend in _PLANAR_SEEDS:
        if not todo.any():
            break
        idx = np.flatnonzero(todo)
        seed = np.tile([shoulder, -bend if elbow_up else bend, 0.0], (len(idx), 1))
        q, e = _gauss_newton(seed, goal[idx], robot)
        side = _wrapped(q[:, 1] + robot.dh[2, 0]) > 0
        ok = (np.abs(e).max(axis=1) < 1e-7) & (side == elbow_up)
        out[idx[ok]] = _wrapped(q[ok])
        todo[idx[ok]] = False
    out = out.reshape(r.shape + (3,))
    return out[..., 0], out[..., 1], out[..., 2]


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
