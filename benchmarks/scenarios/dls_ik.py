"""The obvious alternative to the closed-form IK, for benchmarks/kinematics.py: damped least squares on the full
tool pose (the method notebook 03's exercise ik.numerical derives), kept out of the armlab package: it measures the
kit, it is not part of it (and a student release must not print an exercise's answer). Units: mm, rad; world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab import kinematics
from armlab.arguments import finite_array, finite_float, int_in_range
from armlab.kinematics import IKResult
from armlab.robot import RobotModel, rx200
from armlab.transforms import log_so3

__all__ = ["NumericalIKResult", "ik_numerical"]


@dataclass(frozen=True)
class NumericalIKResult(IKResult):
    """Result of damped least squares IK: q (5,) rad, success, reason ("" on success), iterations, final position
    error (mm)."""

    iterations: int
    position_error_mm: float


def ik_numerical(position, pitch, roll: float = 0.0, q0=None, damping: float = 0.05, tol_mm: float = 1e-6,
                 max_iterations: int = 200, orientation_scale_mm: float = 100.0, max_step: float = 0.2,
                 robot: RobotModel | None = None) -> NumericalIKResult:
    """Damped least squares IK on the full tool pose, from q0 (default home), clamped to the joint limits.

    Iterates dq = J^T (J J^T + damping^2 I)^-1 e, with e the position error (mm) and the orientation error (rad,
    weighted by `orientation_scale_mm`), scaled down so that no joint moves more than `max_step` rad per iteration.
    Converges to one nearby solution, or fails where the closed form succeeds.
    """
    robot = robot or rx200()
    P = finite_array(position, "position", [(3,)], "x, y, z in world mm")
    pitch, roll = finite_float(pitch, "pitch", what="rad"), finite_float(roll, "roll", what="rad")
    damping = finite_float(damping, "damping", positive=True, what="of the damped least squares step")
    tol_mm = finite_float(tol_mm, "tol_mm", positive=True, what="mm")
    max_iterations = int_in_range(max_iterations, "max_iterations", 1, 1_000_000)
    orientation_scale_mm = finite_float(orientation_scale_mm, "orientation_scale_mm", positive=True, what="mm")
    max_step = finite_float(max_step, "max_step", positive=True, what="rad per iteration")
    x, y, _ = P
    heading = np.arctan2(y, x) if np.hypot(x, y) > 1e-9 else robot.dh[0, 0]
    R_target = kinematics.tool_orientation(heading, pitch, roll)
    q = np.array(robot.home if q0 is None else kinematics.check_joints(q0, robot), dtype=float)
    weight = np.array([1, 1, 1, orientation_scale_mm, orientation_scale_mm, orientation_scale_mm], float)
    for it in range(1, max_iterations + 1):
        T = kinematics.fk(q, robot, check_limits=False)
        e = np.concatenate([P - T[:3, 3], log_so3(R_target @ T[:3, :3].T)])
        if np.linalg.norm(e[:3]) < tol_mm and np.linalg.norm(e[3:]) * orientation_scale_mm < tol_mm:
            return NumericalIKResult(q, True, "", it, float(np.linalg.norm(e[:3])))
        J = kinematics.jacobian(q, robot) * weight[:, None]
        ew = e * weight
        dq = J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(6), ew)
        dq *= min(1.0, max_step / max(float(np.abs(dq).max()), 1e-300))  # near singularities the step explodes
        q = np.clip(q + dq, robot.lower, robot.upper)
    err = float(np.linalg.norm(P - kinematics.fk(q, robot, check_limits=False)[:3, 3]))
    why = (f"did not converge in {max_iterations} iterations from q0: the tool ends {err:.3g} mm from "
           f"({P[0]:.1f}, {P[1]:.1f}, {P[2]:.1f}) mm (out of reach, a joint limit, or a seed on another branch)")
    return NumericalIKResult(q, False, why, max_iterations, err)
