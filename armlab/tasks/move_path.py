"""The lab report's move_path: the motion sequence of click to grab and click to drop, as a plan the kit checks
whole and runs (notebook 05 teaches it; notebook 06 swaps two blocks with it).

`move_path` is the exercise grab.move_path: from the arm's joints it returns a planning.Plan that grasps a cube at a
point or releases the held cube at a point. `grab_with` and `drop_with` run such a plan in a task session
(tasks.start_session(station)) the way tasks.pick and tasks.place run the kit's own (planning.plan_pick / plan_place):
through the session's one executor (session.run, tasks.executor): the placement rule, then the whole plan checked
first (joint limits, speeds, the board and the session's known blocks, the pads and the held block), so a plan that
would hit something raises MotionRefused with nothing sent; then it runs on the session's guarded arm (sag
compensated) and what is held is recorded. Units: mm, rad, s; world (board) frame; tool point = the manufacturer's
ee_gripper_link.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from armlab import kinematics, planning, slots
from armlab.arguments import finite_array, finite_float
from armlab.blocks import block_edge
from armlab.gripper_geometry import GRIPPER
from armlab.kinematics import Unreachable
from armlab.robot import RobotModel, rx200

from . import handling
from .session import Session, as_session

__all__ = ["move_path", "report_move_path", "default_path", "grab_with", "drop_with", "MovePath", "PATH_ACTIONS",
           "TIP_MARGIN_MM", "REPORT_LIFT_MM", "REPORT_APPROACH_MM"]

PATH_ACTIONS = ("grasp", "release")
TIP_MARGIN_MM = 10.0      # the finger tips stay at least this far above what the block stands on (sag: 5-15 mm)
MovePath = Callable[..., planning.Plan]


def move_path(q_start, target, yaw: float, edge: float, action: str,
              clearance: float = planning.DEFAULT_CLEARANCE_MM, robot: RobotModel | None = None) -> planning.Plan:
    """The plan (planning.Plan) from joints q_start (5,) rad that, for action "grasp", picks up the cube of edge
    `edge` mm and yaw `yaw` rad whose top-face centre is `target` (3,) world mm, and for "release", puts the held
    cube's bottom-face centre at `target` with that yaw; the gripper ends `clearance` mm over what it leaves.
    Raises ValueError for bad input (naming it) and kinematics.Unreachable (a ValueError) saying why when the arm
    cannot do it.

    Exercise grab.move_path (notebook 05: the report's move_path, the grasp and release motion as a plan).
    """
    robot = robot or rx200()
    # BEGIN SOLUTION grab.move_path
    if action not in PATH_ACTIONS:
        raise ValueError(f"action must be one of {PATH_ACTIONS}, got {action!r}")
    target = np.asarray(target, dtype=float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise ValueError(f"target must be 3 finite numbers (x, y, z in world mm), got {target!r}")
    if not (np.isfinite(edge) and edge > 0 and np.isfinite(clearance) and clearance >= 0 and np.isfinite(yaw)):
        raise ValueError(f"edge must be > 0 mm, clearance >= 0 mm and yaw finite, got {edge}, {clearance}, {yaw}")
    # the pads grip the cube at its centre unless their tips would then come within the margin of what it stands on
    depth = min(edge / 2, edge - GRIPPER.fingertip_mm - TIP_MARGIN_MM)
    if action == "grasp":
        tool_z = target[2] - depth                       # target: the top face
    else:
        tool_z = target[2] + edge - depth                # target: where the bottom face goes
    low = np.array([target[0], target[1], tool_z])
    hover = low + [0.0, 0.0, clearance + depth]          # the tips (and a held cube) `clearance` over the top
    heading = float(np.arctan2(target[1], target[0]))
    # the steepest pitch whose straight descent the arm can make: top-down where it reaches, tilted further out
    down, last_refusal = None, ""
    for pitch in np.arange(np.pi / 2, np.radians(20.0), -np.radians(1.0)):
        roll = planning.tilted_roll(heading, float(pitch), float(yaw))
        try:
            down = planning.cartesian_line(hover, low, float(pitch), roll, robot=robot)
            break
        except Unreachable as refusal:
            last_refusal = str(refusal)
    if down is None:
        raise Unreachable(f"no pitch reaches straight down to ({low[0]:.1f}, {low[1]:.1f}, {low[2]:.1f}) mm: "
                          f"{last_refusal}")
    steps = [planning.MoveStep(planning.joint_move(q_start, down.start, robot=robot), "to the hover point")]
    if action == "grasp":
        steps.append(planning.GripperStep("open", "open before grasping"))
    steps += [planning.MoveStep(down, "descend"),
              planning.GripperStep("close" if action == "grasp" else "open", action),
              planning.MoveStep(planning.reverse(down), "lift")]
    return planning.Plan(tuple(steps))
    # END SOLUTION


# The lab report's own heights (world mm): the gripper lifted to 275 mm, came down to 150 mm over the block, then to
# half the block's height
REPORT_LIFT_MM = 275.0
REPORT_APPROACH_MM = 150.0


def report_move_path(q_start, target, yaw: float, edge: float, action: str,
                     clearance: float = planning.DEFAULT_CLEARANCE_MM,
                     robot: RobotModel | None = None) -> planning.Plan:
    """The student release's stand-in for a blank move_path: the lab report's own sequence, another method than the
    exercise asks for. Joint moves (joint-space interpolation, not a straight line) through fixed heights: up to
    REPORT_LIFT_MM over the target (as steep as the arm reaches there), top-down from then on: down to
    REPORT_APPROACH_MM, [open], down to the tool point at half the cube's height (the grip through its middle whatever
    its size), act, back up to REPORT_APPROACH_MM. The wrist squares the pads to the board's x and y axes, as the
    report's blocks stood: the block's `yaw` is checked but not used (a turned block is met on its corners).
    Arguments as move_path's (mm, rad, world frame). Raises kinematics.Unreachable saying why where the report's plan
    cannot go: a target out of top-down reach, or a top (of the block, or of the placed block) less than `clearance`
    mm below the fixed approach height (a stack that tall)."""
    robot = robot or rx200()
    if action not in PATH_ACTIONS:
        raise ValueError(f"report_move_path knows the actions {' and '.join(PATH_ACTIONS)}, not {action!r}")
    p = finite_array(target, "target", (3,), "x, y, z in world mm")
    edge = finite_float(edge, "edge", positive=True, what="mm")
    clearance = finite_float(clearance, "clearance", minimum=0.0, what="mm")
    finite_float(yaw, "yaw", what="rad")                              # checked, not used (the docstring)
    top = p[2] if action == "grasp" else p[2] + edge                 # what the gripper leaves behind
    if top + clearance > REPORT_APPROACH_MM:
        raise Unreachable(f"the lab report's plan comes down to a fixed {REPORT_APPROACH_MM:.0f} mm, less than "
                          f"{clearance:.0f} mm over the top at {top:.1f} mm: it cannot work on a stack that tall")
    low_z = p[2] - edge / 2 if action == "grasp" else p[2] + edge / 2     # half the cube's height
    roll = planning.face_roll(float(np.arctan2(p[1], p[0])), 0.0)      # the pads square to the board's axes
    q, poses = np.asarray(q_start, float), []
    for z in (REPORT_LIFT_MM, REPORT_APPROACH_MM, low_z):
        try:
            # the lift point as steep as the arm reaches it there (top-down is out of reach that high further out)
            pitch = kinematics.steepest_pitch([p[0], p[1], z], roll, robot=robot) if z == REPORT_LIFT_MM else np.pi / 2
            q = kinematics.ik([p[0], p[1], z], pitch, roll, current=q, robot=robot)[0]
        except Unreachable as e:
            raise Unreachable(f"the lab report's plan is top-down only, and ({p[0]:.1f}, {p[1]:.1f}, {z:.1f}) mm "
                              f"is out of top-down reach: {e}") from None
        poses.append(q)
    lift, approach, low = poses
    opening = (planning.GripperStep("open", "open the pads over the block"),) if action == "grasp" else ()
    steps = (planning.MoveStep(planning.joint_move(q_start, lift, robot=robot), "up to the report's lift height"),
             planning.MoveStep(planning.joint_move(lift, approach, robot=robot), "down to the report's approach"),
             *opening,
             planning.MoveStep(planning.joint_move(approach, low, robot=robot), "down to half the cube's height"),
             planning.GripperStep("close" if action == "grasp" else "open", action),
             planning.MoveStep(planning.joint_move(low, approach, robot=robot), "back up to the report's approach"))
    return planning.Plan(steps)


def default_path() -> tuple[MovePath, str]:
    """What stands in for a blank move_path in the notebooks' demonstrations, and the one line that says so: the
    kit's own planners (tasks.kit_move_path) where the instructor's tree has them, else the lab report's plan
    (report_move_path: the student release)."""
    path = slots.kit_or_standin("armlab.tasks.kit_move_path", "kit_move_path", report_move_path)
    if path is report_move_path:
        return path, "the lab report's plan stands in: fixed heights, top-down only, joint moves down"
    return path, "the kit's planning.plan_pick / plan_place plan the motion"


def grab_with(session: Session, block, path: MovePath = move_path) -> bool:
    """Pick a detected block (detection.Block) with the plan `path` makes for it (action "grasp"), run like
    tasks.pick's own (handling.grasping: through the session's executor, checked whole first); True when the block
    is held. Raises ValueError when a block is held already and MotionRefused (nothing sent) when the plan would hit
    something or break a limit."""
    session = as_session(session, "grab_with")
    if session.held is not None:
        raise ValueError(f"the gripper already holds the {session.held.color} block: drop it first")
    edge, top, yaw = block_edge(block.size), np.asarray(block.position, float), float(block.yaw)
    plan = path(session.arm.joint_positions(), top, yaw, edge, "grasp")
    if not isinstance(plan, planning.Plan):
        raise TypeError(f"move_path must return a planning.Plan, got {type(plan).__name__}")
    descent = next((s.trajectory for s in plan.steps if isinstance(s, planning.MoveStep) and s.label == "descend"),
                   None)
    return handling.grasping(session, plan, block, f"move_path grasping the {block.color} block", descent=descent)


def drop_with(session: Session, position, yaw: float = 0.0, path: MovePath = move_path) -> bool:
    """Put the held block's bottom-face centre at `position` (3,) world mm with the plan `path` makes (action
    "release"), run like tasks.place's own (the placement rule, the release RELEASE_GAP_MM above the spot, the
    executor's whole-plan check: MotionRefused with nothing sent); True when the plan ran through."""
    session = as_session(session, "drop_with")
    return handling.place(session, position, yaw, path=path)
