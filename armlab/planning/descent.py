"""How the kit's own pick and place plans come down to a block (pickplace, grasp.choose_grasp, tasks.put_back): the
one seam between the kit's planners and exercise grab.move_path, whose answer is a straight descent at the steepest
pitch that can make it.

- `descend(p0, p1, pitch, roll)`: the tool's motion from the hover point p0 down to p1 (or back up: reverse it);
- `approach_reachable(position, top_z, pitch, roll)`: whether that descent can be made from top_z down to position.

The instructor's kit comes straight down (armlab.planning.straight_descent: a Cartesian line, checked reachable all
along it). The student release leaves that module out (it answers the exercise) and the planners use another method
here: a joint chord (trajectory.joint_chord: joints solved at the two ends, interpolated in joint space; the tool bows
a few mm off the vertical between them) that needs only its two ends reachable on one IK branch. Units: world mm,
rad.
"""

from __future__ import annotations

import numpy as np

from armlab import kinematics, slots
from armlab.robot import RobotModel, rx200

from .trajectory import ToolSegment, joint_chord

__all__ = ["descend", "approach_reachable", "straight", "ends_reachable"]

_KIT = "armlab.planning.straight_descent"


def ends_reachable(position, top_z: float, pitch: float, roll: float, robot: RobotModel | None = None) -> bool:
    """True when the tool reaches `position` (3,) world mm and the point above it at height top_z (mm), both at
    pitch and roll (rad) on one IK branch: all a joint chord between them needs (the release's approach test)."""
    p = np.asarray(position, dtype=float)
    ends = np.array([p, [p[0], p[1], max(float(top_z), p[2])]])
    res = kinematics.ik_batch(ends, pitch, roll, robot=robot or rx200())
    return bool(res.success.all() and res.branch[0] == res.branch[1])


def straight() -> bool:
    """Whether the kit's planners come straight down here (the instructor's tree) rather than on a joint chord."""
    return slots.kit_or_standin(_KIT, "descend", None) is not None


def descend(p0, p1, pitch: float, roll: float = 0.0, current=None, robot: RobotModel | None = None) -> ToolSegment:
    """The kit's descent from p0 to p1 (world mm) at pitch and roll (rad), from the IK branch best for `current`
    (module notes); raises kinematics.Unreachable saying where the arm cannot make it."""
    method = slots.kit_or_standin(_KIT, "descend", joint_chord)
    return method(p0, p1, pitch, roll, current=current, robot=robot)


def approach_reachable(position, top_z: float, pitch: float, roll: float, robot: RobotModel | None = None) -> bool:
    """Whether the kit's descent can be made from height top_z (mm) down to `position` (3,) world mm at pitch and roll
    (rad) on one IK branch (module notes)."""
    test = slots.kit_or_standin(_KIT, "approach_reachable", ends_reachable)
    return test(position, top_z, pitch, roll, robot=robot)
