"""The kit's descent (instructor only: the student release leaves this file out, issue 32): the tool comes straight
down, on a Cartesian line at one pitch and roll, checked reachable along the whole vertical on one IK branch. With
grasp.choose_grasp's pitch search it answers exercise grab.move_path, so the planners reach it only through the seam
planning.descent, which in the release uses a joint chord instead. Units: world mm, rad."""

from __future__ import annotations

import numpy as np

from armlab import kinematics
from armlab.robot import RobotModel, rx200

from .trajectory import CartesianSegment, cartesian_line

__all__ = ["descend", "approach_reachable"]

_SEGMENT_STEP_MM = 5.0          # spacing of the reachability check along the vertical approach


def descend(p0, p1, pitch: float, roll: float = 0.0, current=None, robot: RobotModel | None = None) -> CartesianSegment:
    """The straight line p0 -> p1 (world mm) at pitch and roll (rad): trajectory.cartesian_line."""
    return cartesian_line(p0, p1, pitch, roll, current=current, robot=robot)


def approach_reachable(position, top_z: float, pitch: float, roll: float, robot: RobotModel | None = None) -> bool:
    """True when every point from `position` (3,) world mm straight up to top_z (mm) is reachable at pitch and roll
    (rad) on one IK branch (sampled every _SEGMENT_STEP_MM)."""
    p = np.asarray(position, dtype=float)
    n = max(2, int(np.ceil((top_z - p[2]) / _SEGMENT_STEP_MM)) + 1)
    pts = np.repeat(p[None], n, axis=0)
    pts[:, 2] = np.linspace(p[2], max(top_z, p[2]), n)
    res = kinematics.ik_batch(pts, pitch, roll, robot=robot or rx200())
    return bool(res.success.all() and np.all(res.branch == res.branch[0]))
