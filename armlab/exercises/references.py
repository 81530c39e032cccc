"""The kit's reference paths for the notebooks' own exercises, for `with_reference` while an exercise is blank.

Each one computes what the exercise asks by another method than the one the notebook teaches (a library call, a
numerical solve, a different model), so that later cells of the notebook keep working; none is the solution, and
a check cell never uses them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import ndimage, optimize, stats

from armlab import kinematics
from armlab.robot import RobotModel, rx200
from armlab.transforms import wrap_quarter

__all__ = ["fk_by_kit_dh", "planar_ik_numerical", "centroid_by_scipy", "wrap_yaw_by_kit", "line_by_scipy"]


def fk_by_kit_dh(q, table) -> np.ndarray:
    """fk.fk_from_table's reference: the kit's DH chain (kinematics.fk_dh) on the RX200 with the DH table `table`
    (5, 4) in its place; tool pose (4, 4), mm. Joint limits are not checked."""
    robot = replace(rx200(), dh=np.asarray(table, dtype=float))
    return kinematics.fk_dh(np.asarray(q, dtype=float), robot, check_limits=False)


def _planar_pose(q234: np.ndarray, robot: RobotModel) -> np.ndarray:
    """(r, z, psi) of the tool in the arm's plane (waist at 0: the plane's forward direction is +y)."""
    T = kinematics.fk(np.array([0.0, *q234, 0.0]), robot, check_limits=False)
    x_axis = T[:3, 0]
    return np.array([T[1, 3], T[2, 3], np.arctan2(-x_axis[2], x_axis[1])])


def _elbow_is_up(q234: np.ndarray, robot: RobotModel) -> bool:
    """Whether the forearm turns down from the upper arm's line (delta = -(q3 + the DH table's elbow offset) < 0:
    elbow up with the target ahead)."""
    bend = q234[1] + robot.dh[2, 0]
    return bool(np.pi - np.mod(np.pi - bend, 2 * np.pi) > 0)


_PLANAR_SEEDS = [(s, e) for s in (0.0, 1.5, -1.5, 2.8) for e in (0.3, 1.2, 2.1, 2.9)]   # rad


def _planar_ik_one(r: float, z: float, psi: float, elbow_up: bool, robot: RobotModel) -> np.ndarray:
    goal = np.array([r, z, psi], dtype=float)

    def residual(q):
        e = _planar_pose(q, robot) - goal
        e[2] = (e[2] + np.pi) % (2 * np.pi) - np.pi
        return e * [1.0, 1.0, 100.0]

    if not np.all(np.isfinite(goal)):
        return np.full(3, np.nan)
    for shoulder, elbow in _PLANAR_SEEDS:
        seed = [shoulder, -elbow if elbow_up else elbow, 0.0]
        fit = optimize.least_squares(residual, seed, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if np.abs(fit.fun).max() < 1e-7 and _elbow_is_up(fit.x, robot) == elbow_up:
            return np.pi - np.mod(np.pi - fit.x, 2 * np.pi)
    return np.full(3, np.nan)


def planar_ik_numerical(r, z, psi, elbow_up: bool = True, robot: RobotModel | None = None):
    """ik.planar_ik's reference: (q2, q3, q4) rad putting the tool at reach r, height z (mm) with approach psi (rad)
    in the arm's plane (scalars or arrays), found by least squares on the kit's FK from seeds on the requested
    elbow side; NaN where no solution reaches the point."""
    robot = robot or rx200()
    r, z, psi = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (r, z, psi)))
    out = np.array([_planar_ik_one(*args, elbow_up, robot) for args in zip(r.ravel(), z.ravel(), psi.ravel(),
                                                                          strict=True)]).reshape(r.shape + (3,))
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
