"""The checks a joint move must pass before anything is sent to a real arm: position limits, the driver's velocity
rule, a valid time profile, and a board-collision check of the straight joint-space path.

The Interbotix driver moves every joint with the same time-based trapezoidal profile (same moving and accel time),
so all joints stay at the same fraction of their change: the arm follows the straight line q(s) = q0 + s (q1 - q0)
in joint space. The collision check samples that line finely (at most PATH_STEP_RAD of the largest joint change per
sample) and asks that no tracked point (shoulder, elbow, wrist, wrist_rotate, tool point; the links between them are
straight, so their lowest point is one of these) goes below the board surface + a margin. A point that starts below
the margin (after teaching by hand, or at a grasp) may stay where it is or rise, but never sink further.

Units: rad, s, mm; heights are world z (the board surface is z = 0).
"""

from __future__ import annotations

import numpy as np

from armlab.kinematics import check_joints, joint_positions
from armlab.profile import default_moving_time, velocity_violations
from armlab.robot import RobotModel, rx200
from armlab.station.contract import MotionRefused

__all__ = ["TRACKED_POINTS", "DEFAULT_BOARD_MARGIN_MM", "PATH_STEP_RAD", "ACCEL_FRACTION", "MAX_MOVING_TIME_S",
           "path_heights",
           "board_collision", "check_move"]

TRACKED_POINTS: tuple[str, ...] = ("shoulder", "elbow", "wrist", "wrist_rotate", "tool point")  # joint_positions 2..6
DEFAULT_BOARD_MARGIN_MM = 10.0      # the tool point of a top-down grasp of a 25 mm cube sits at 12.5 mm
PATH_STEP_RAD = np.radians(0.25)    # largest joint change between two checked samples of the path
ACCEL_FRACTION = 1 / 3              # accel_time = moving_time / 3 unless the caller chooses
# In time-based profile mode the servos' Profile_Velocity register holds the moving time in ms, at most 32737
# (ROBOTIS e-manual, X-series control table); the driver passes a larger value on and the servo ignores it.
MAX_MOVING_TIME_S = 32.737


def _refuse(reason: str) -> MotionRefused:
    return MotionRefused(f"move refused (nothing was sent): {reason}")


def path_heights(q_from, q_to, robot: RobotModel | None = None,
                 step: float = PATH_STEP_RAD) -> tuple[np.ndarray, np.ndarray]:
    """Samples of the straight joint-space path from q_from to q_to (5,) rad.

    Returns (s, z): s (N,) path fractions from 0 to 1, z (N, 5) world heights (mm) of TRACKED_POINTS at each sample.
    """
    robot = robot or rx200()
    q0 = check_joints(q_from, robot, check_limits=False)
    q1 = check_joints(q_to, robot, check_limits=False)
    n = max(2, int(np.ceil(np.max(np.abs(q1 - q0)) / step)) + 1)
    s = np.linspace(0.0, 1.0, n)
    points = joint_positions(q0 + s[:, None] * (q1 - q0), robot)   # (N, 7, 3)
    return s, points[:, 2:, 2]


def board_collision(q_from, q_to, margin_mm: float = DEFAULT_BOARD_MARGIN_MM,
                    robot: RobotModel | None = None) -> str | None:
    """Why the straight joint path from q_from to q_to hits the board (+ margin_mm), in words; None when it is clear.

    Each tracked point must stay at or above min(margin_mm, its starting height).
    """
    s, z = path_heights(q_from, q_to, robot)
    floor = np.minimum(margin_mm, z[0]) - 1e-6
    depth = z - floor
    if depth.min() >= 0:
        return None
    i, j = np.unravel_index(np.argmin(depth), depth.shape)    # report the deepest intrusion
    return (f"the straight joint-space path would take the {TRACKED_POINTS[j]} down to z = {z[i, j]:.1f} mm "
            f"({100 * s[i]:.0f}% of the way), below the board surface + {margin_mm:.1f} mm margin")


def check_move(q_from, q_to, moving_time: float | None = None, accel_time: float | None = None,
               robot: RobotModel | None = None,
               board_margin_mm: float = DEFAULT_BOARD_MARGIN_MM) -> tuple[float, float]:
    """Validate a move from the measured q_from to q_to (5,) rad; return the (moving_time, accel_time) to send (s).

    Defaults: moving_time = armlab.profile.default_moving_time, accel_time = moving_time / 3. Raises MotionRefused
    (a ValueError) naming the problem: a malformed q_to, a joint limit (which joint), an impossible time profile
    (moving_time in (0, MAX_MOVING_TIME_S], accel_time in [0, moving_time / 2]), a joint faster than its velocity
    limit, or a board collision.
    """
    robot = robot or rx200()
    q_from = check_joints(q_from, robot, check_limits=False)
    try:
        q_to = check_joints(q_to, robot, check_limits=False)
    except ValueError as e:
        raise _refuse(str(e)) from None
    if q_to.ndim != 1 or q_from.ndim != 1:
        raise _refuse(f"a move takes one joint vector (5,) rad, got shape {q_to.shape}")
    limits = robot.limit_violations(q_to)
    if limits:
        raise _refuse("; ".join(limits))
    if moving_time is None:
        moving_time = default_moving_time(q_from, q_to, robot, ACCEL_FRACTION)
    moving_time = float(moving_time)
    if not np.isfinite(moving_time) or moving_time <= 0:
        raise _refuse(f"moving_time must be a positive number of seconds, got {moving_time}")
    if moving_time > MAX_MOVING_TIME_S:
        raise _refuse(f"moving_time {moving_time:g} s is longer than the servos' time profile allows "
                      f"({MAX_MOVING_TIME_S} s): split the move")
    accel_time = moving_time * ACCEL_FRACTION if accel_time is None else float(accel_time)
    if not np.isfinite(accel_time) or not 0 <= accel_time <= moving_time / 2:
        raise _refuse(f"accel_time {accel_time} s must lie in [0, moving_time / 2] = [0, {moving_time / 2:g}] s")
    too_fast = velocity_violations(q_from, q_to, moving_time, robot)
    if too_fast:
        raise _refuse(f"in {moving_time:g} s " + "; ".join(too_fast))
    collision = board_collision(q_from, q_to, board_margin_mm, robot)
    if collision:
        raise _refuse(collision)
    return moving_time, accel_time
