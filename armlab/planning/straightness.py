"""How straight a plan comes down to where its gripper acts: the measure exercise grab.move_path is judged by (its
descent must be a straight vertical line, as notebook 05 asks) and the tests of the kit's descents use.

approach_deviation(plan, action) takes the plan's last move before its first gripper `action` ("close": a grasp,
"open": a release), the tool's final approach, and returns the largest horizontal distance (mm) of the tool point
(ee_gripper_link, by the manufacturer's model kinematics.fk) from the vertical through where that move ends, sampled
at every knot and between them. A Cartesian line (trajectory.cartesian_line) keeps within LINE_TOLERANCE_MM = 0.5 mm
of its line; a joint-space descent bows off it by 1-4 mm. Units: world mm.
"""

from __future__ import annotations

import numpy as np

from armlab import kinematics
from armlab.robot import RobotModel, rx200

from .plan import GripperStep, MoveStep, Plan
from .trajectory import PiecewiseTrajectory

__all__ = ["approach_deviation", "STRAIGHT_TOLERANCE_MM"]

STRAIGHT_TOLERANCE_MM = 0.8     # a final approach that strays further from the vertical is not a straight descent
_SAMPLES = 200                  # samples of a move that is not piecewise linear in joint space


def approach_deviation(plan: Plan, action: str, robot: RobotModel | None = None) -> float:
    """Largest horizontal distance (mm) of the tool from the vertical through the end of the plan's last move before
    its first gripper `action` (module notes). ValueError when the plan has no such action or no move before it."""
    if not isinstance(plan, Plan):
        raise TypeError(f"approach_deviation measures a planning.Plan, got {type(plan).__name__}")
    last = None
    for step in plan.steps:
        if isinstance(step, MoveStep):
            last = step.trajectory
        elif isinstance(step, GripperStep) and step.action == action:
            break
    else:
        raise ValueError(f"the plan never does '{action}' with the gripper: {plan.describe()}")
    if last is None:
        raise ValueError(f"the plan does '{action}' before it moves the arm: there is no approach to measure")
    if isinstance(last, PiecewiseTrajectory):
        t = np.union1d(last.times, 0.5 * (last.times[1:] + last.times[:-1]))
    else:
        t = np.linspace(0.0, last.duration, _SAMPLES + 1)
    q, _ = last.sample(t)
    tool = kinematics.fk(q, robot or rx200(), check_limits=False)[:, :2, 3]
    end = kinematics.fk(np.asarray(last.end, float), robot or rx200(), check_limits=False)[:2, 3]
    return float(np.linalg.norm(tool - end, axis=1).max())
