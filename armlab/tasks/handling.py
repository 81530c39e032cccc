"""Handling blocks on a station: look (tasks.look), pick and place a detected block -> plan (armlab.planning's
pick/place plans) -> execute on the station's arm. (armlab.planning.pickplace plans; this module runs them.)

Works the same on the simulated and the real station: it uses only the Arm protocol (through the session's
GuardedArm, which compensates sag) and station.camera. Every function takes a Session (tasks.start_session(station):
the camera calibration, the sag model, the known blocks, the held block; see tasks.session) as its first argument.
place() releases the block RELEASE_GAP_MM above the requested bottom height, so a residual arm error never pushes
it into what it is put on (the block drops that little and settles); the release is aimed with the held block's pose
in the tool frame as planned at its grasp (planning.plan_place's held_in_tool): its centre over the spot and its
lowest corner at the release height, so a block picked tilted at long reach, or placed tilted, is not lowered into
the board or what it is put on. Every pick and place plan is checked whole before its first command
(tasks.precheck: the commands the guarded arm would send, the pads and the held block along them, the sag model and
the known blocks): an impossible one raises MotionRefused with nothing sent. Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

import numpy as np

from armlab import motion_safety, planning
from armlab.arguments import finite_array, finite_float, plain
from armlab.blocks import SIZES, block_edge
from armlab.gripper_geometry import GRIPPER
from armlab.station.contract import MotionRefused, Station

from . import perception, precheck
from .session import Session, as_session

__all__ = ["pick", "place", "put_back", "look", "check_block", "RELEASE_GAP_MM"]

RELEASE_GAP_MM = 2.0


def look(session: Session) -> perception.Observation:
    """Move the arm out of view (carrying a held block), capture and detect; the blocks seen become the session's
    known obstacles and the observation its last look."""
    session = as_session(session, "tasks.look")
    edge = None if session.held is None else session.held_edge
    held_below = 0.0 if edge is None else edge - planning.default_grasp_depth(edge)
    obs = perception.observe(session.station, session.calibration, session.arm, obstacles=session.known,
                             held_below=held_below)
    session.last = obs
    session.known = list(obs.blocks)
    return obs


def check_block(block, name: str = "block") -> None:
    """TypeError / ValueError naming `name` unless it is a block to pick: a detection.Block (or any object with
    .position (3,) world mm, .yaw rad, .size and .color)."""
    if not all(hasattr(block, a) for a in ("position", "yaw", "size", "color")):
        raise TypeError(f"{name} must be a detected block (detection.Block, from tasks.look or detect_blocks, with "
                        f".position, .yaw, .size and .color), got {type(block).__name__}")
    finite_array(block.position, f"{name}.position", (3,), "world mm of the top-face centre")
    finite_float(block.yaw, f"{name}.yaw", what="rad")
    if block.size not in SIZES:
        raise ValueError(f"{name}.size must be one of {SIZES}, got {plain(block.size)}")


def pick(session: Session, block, obstacles=None) -> bool:
    """Pick a detected block (detection.Block: .position top-face centre world mm, .yaw rad, .size).

    Plans with planning.plan_pick around `obstacles` (default: the known blocks) and runs the plan on the guarded arm.
    Returns close_gripper's answer (True when the block is held). Raises ValueError when the gripper already holds a
    block, kinematics.Unreachable (a ValueError) when the block cannot be reached and MotionRefused when the whole
    plan fails the pre-check (nothing moves then), and lets the arm's EmergencyStopped through.
    """
    session = as_session(session, "tasks.pick")
    check_block(block)
    if session.held is not None:
        raise ValueError(f"the gripper already holds the {session.held.color} block: place it first")
    edge = block_edge(block.size)
    obs = session.known if obstacles is None else list(obstacles)
    plan = planning.plan_pick(session.arm.joint_positions(), block.position, float(block.yaw), edge, obstacles=obs)
    q_grasp = next(s.trajectory for s in plan.steps if s.label == "descend").end
    grasped = motion_safety.HeldBlock(edge, precheck.held_pose_at_grasp(q_grasp, block.position, float(block.yaw),
                                                                        edge), f"picked {block.color} block")
    precheck.check_whole_plan(plan, session.arm, _opening(session.station), grasped=grasped,
                              known=precheck.known_boxes(obs, np.asarray(block.position, float)[:2], edge / 2),
                              what=f"picking the {block.color} block")
    held = bool(planning.execute(plan, session.arm).holding)
    session.picked(block, held, grasped.T_tool_block, next(s.trajectory for s in plan.steps if s.label == "descend"))
    return held


def put_back(session: Session) -> bool:
    """Put the held block back where it was picked from (after a place that could not be done): a joint move to the
    top of the pick's own straight descent (where the pick's lift ended), down that line (the path the block came up
    in the gripper, checked whole with it then) to RELEASE_GAP_MM above the grasp, open, and up again. Checked
    whole before the first command like every plan (the held block's own column, the stack it came from, is not an
    obstacle to it); raises ValueError when nothing picked is held and MotionRefused with nothing sent when even
    this is refused. True when done."""
    session = as_session(session, "tasks.put_back")
    if session.held is None or session.picked_down is None:
        raise ValueError("put_back needs a block picked with tasks.pick in the gripper")
    picked, block, edge = session.picked_down, session.held, session.held_edge
    # the same straight line, stopping RELEASE_GAP_MM short of the grasp (the block drops that little, as in place)
    down = planning.cartesian_line(picked.p0, picked.p1 + [0.0, 0.0, RELEASE_GAP_MM], picked.pitch, picked.roll,
                                   current=picked.start, robot=session.arm.robot)
    q = session.arm.joint_positions()
    plan = planning.Plan((planning.MoveStep(planning.joint_move(q, down.start), "back over the pick spot"),
                          planning.MoveStep(down, "descend"), planning.GripperStep("open", "release"),
                          planning.MoveStep(planning.reverse(down), "lift")))
    held = () if session.held_in_tool is None else (
        motion_safety.HeldBlock(edge, session.held_in_tool, f"held {block.color} block"),)
    top = np.asarray(block.position, float)
    precheck.check_whole_plan(plan, session.arm, edge, held=held,
                              known=precheck.known_boxes(session.known, top[:2], edge / 2),
                              what=f"putting the {block.color} block back at ({top[0]:.1f}, {top[1]:.1f}) mm")
    planning.execute(plan, session.arm)
    session.released(top)
    return True


def _opening(station: Station) -> float:
    """The pads' opening (mm) now: the arm's own reading where it offers one, else fully open."""
    return float(getattr(station.arm, "gripper_opening_mm", GRIPPER.max_opening_mm))


def place(session: Session, position, yaw: float = 0.0, obstacles=None,
          clearance: float = planning.DEFAULT_CLEARANCE_MM) -> bool:
    """Put the held block's bottom-face centre at `position` (3,) world mm with yaw (rad); True when the plan ran
    through (the gripper opened there). clearance: how far (mm) the held block's bottom passes above the obstacles'
    tops in transit, and the empty tool point ends above the placed block (planning.plan_place). Raises ValueError
    when nothing is held or for bad input, MotionRefused when the placement rule refuses the spot (off the board, on
    the robot's base plate, out of reach: motion_safety.placement_problem, the rule the clicks use), Unreachable when
    the arm cannot get there and MotionRefused when the whole plan fails the pre-check, e.g. the held block would go
    into a known block (nothing moves then)."""
    p = finite_array(position, "position", (3,), "x, y, z of the block's bottom-face centre in world mm")
    yaw = finite_float(yaw, "yaw", what="rad")
    clearance = finite_float(clearance, "clearance", minimum=0.0, what="mm")
    session = as_session(session, "tasks.place")
    edge = session.held_edge
    problem = motion_safety.placement_problem(p, edge, float(yaw))
    if problem:
        raise MotionRefused(f"placing at ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm refused before moving: {problem}")
    obs = session.known if obstacles is None else list(obstacles)
    plan = planning.plan_place(session.arm.joint_positions(), p + [0.0, 0.0, RELEASE_GAP_MM], edge, float(yaw),
                               obstacles=obs, clearance=clearance, held_in_tool=session.held_in_tool)
    held = () if session.held_in_tool is None else (
        motion_safety.HeldBlock(edge, session.held_in_tool, f"held {session.held.color} block"),)
    precheck.check_whole_plan(plan, session.arm, edge, held=held, known=precheck.known_boxes(obs),
                              what=f"placing at ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm")
    planning.execute(plan, session.arm)
    session.released(p + [0.0, 0.0, edge])
    return True
