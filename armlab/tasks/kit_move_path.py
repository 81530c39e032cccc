"""The kit's move_path (instructor only: the student release leaves this file out, issue 32): the kit's own pick and
place planners (planning.plan_pick / plan_place: a rise, a transit raised over what it is given, a straight descent at
the steepest pitch the whole line allows) with move_path's arguments. It answers exercise grab.move_path, so it stands
in for a blank move_path only in the instructor's tree (move_path.default_path); the release's stand-in is the lab
report's fixed-height plan (move_path.report_move_path). Units: mm, rad; world (board) frame."""

from __future__ import annotations

from armlab import planning
from armlab.robot import RobotModel

__all__ = ["kit_move_path"]


def kit_move_path(q_start, target, yaw: float, edge: float, action: str,
                  clearance: float = planning.DEFAULT_CLEARANCE_MM, robot: RobotModel | None = None) -> planning.Plan:
    """planning.plan_pick (action "grasp": `target` the top-face centre) or plan_place ("release": `target` where the
    held cube's bottom-face centre goes) from joints q_start (5,) rad; ValueError for another action."""
    if action == "grasp":
        return planning.plan_pick(q_start, target, yaw, edge, clearance=clearance, robot=robot)
    if action == "release":
        return planning.plan_place(q_start, target, edge, yaw, clearance=clearance, robot=robot)
    raise ValueError(f"action is {action!r}: kit_move_path knows grasp and release")
