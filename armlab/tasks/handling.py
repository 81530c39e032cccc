"""Handling blocks on a station: look (tasks.look), pick and place a detected block -> plan (armlab.planning's
pick/place plans) -> the session's executor (session.run, tasks.executor). (armlab.planning.pickplace plans; this
module describes what a plan grasps and where it releases, and hands it to the executor.)

Works the same on the simulated and the real station: it uses only the Arm protocol (through the session's
GuardedArm, which compensates sag) and station.camera. Every function takes a Session (tasks.start_session(station):
the camera calibration, the sag model, the known blocks, the held block; see tasks.session) as its first argument.
place() releases the block RELEASE_GAP_MM above the requested bottom height, so a residual arm error never pushes
it into what it is put on (the block drops that little and settles); the release is aimed with the held block's pose
in the tool frame as planned at its grasp (planning.plan_place's held_in_tool): its centre over the spot and its
lowest corner at the release height, so a block picked tilted at long reach, or placed tilted, is not lowered into
the board or what it is put on; a block picked tilted is let go level (its bottom face at the release height) where
the arm can come down at the pitch that levels it, so it does not land on an edge and tip. Every pick and place plan
is checked whole before its first command by the executor (tasks.precheck: the commands the guarded arm would send,
the pads and the held block along them, the sag model and the known blocks; the placement rule at every release): an
impossible one raises MotionRefused with nothing sent.
Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

import numpy as np

from armlab import motion_safety, planning
from armlab.arguments import finite_array, finite_float, plain
from armlab.blocks import SIZES, block_edge

from . import executor, perception, precheck
from .session import Session, as_session

__all__ = ["pick", "place", "put_back", "look", "check_block", "grasping", "pose_at", "RELEASE_GAP_MM"]

RELEASE_GAP_MM = 3.0   # the truly held block lay up to 2.0 mm below the kit's belief of it at a release (233 releases
                       # of the student fuzz, two calibrations; docs/motion-contract.md): 3 mm keeps a millimetre


def look(session: Session) -> perception.Observation:
    """Move the arm out of view (carrying a held block), capture and detect; the blocks seen become the session's
    known obstacles and the observation its last look."""
    session = as_session(session, "tasks.look")
    edge = None if session.held is None else session.held_edge
    held_below = 0.0 if edge is None else edge - planning.default_grasp_depth(edge)
    obs = perception.observe(session.station, session.calibration, session, obstacles=session.known,
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

    Plans with planning.plan_pick around `obstacles` (default: the known blocks) and runs the plan through the
    session's executor (session.run: checked whole first). Returns close_gripper's answer (True when the block is
    held). Raises ValueError when the gripper already holds a block, kinematics.Unreachable (a ValueError) when the
    block cannot be reached and MotionRefused when the whole plan fails the pre-check (nothing moves then), and lets
    the arm's EmergencyStopped through.
    """
    session = as_session(session, "tasks.pick")
    check_block(block)
    if session.held is not None:
        raise ValueError(f"the gripper already holds the {session.held.color} block: place it first")
    edge = block_edge(block.size)
    obs = session.known if obstacles is None else list(obstacles)
    plan = planning.plan_pick(session.arm.joint_positions(), block.position, float(block.yaw), edge, obstacles=obs)
    descent = next(s.trajectory for s in plan.steps if s.label == "descend")
    return grasping(session, plan, block, f"picking the {block.color} block", known=obs, descent=descent)


def grasping(session: Session, plan: planning.Plan, block, what: str, known=None, descent=None) -> bool:
    """Run a plan that grasps the detected `block` with its first close step (tasks.pick, move_path.grab_with):
    the block is modelled as the closing pads will leave it (precheck.held_pose_at_grasp at the joints of the close),
    its own column (the stack it stands on) is no obstacle, and the executor checks the plan whole, runs it and
    records the block as held when close_gripper says so. Returns close_gripper's answer."""
    edge, top, yaw = block_edge(block.size), np.asarray(block.position, float), float(block.yaw)
    held = motion_safety.HeldBlock(edge, precheck.held_pose_at_grasp(pose_at(plan, "close"), top, yaw, edge),
                                   f"held {block.color} block")
    result = session.run(plan, what, grasp=executor.Grasp(block, held, descent), known=known,
                         column=(top[:2], edge / 2))
    return bool(result.holding)


def pose_at(plan: planning.Plan, action: str) -> np.ndarray:
    """The planned joints (5,) rad where the plan's first gripper `action` ("close" or "open") happens."""
    q = np.asarray(plan.start, float)
    for step in plan.steps:
        if isinstance(step, planning.MoveStep):
            q = step.trajectory.end
        elif step.action == action:
            return np.asarray(q, float)
    raise ValueError(f"the plan never does '{action}' with the gripper: {plan.describe()}")


def put_back(session: Session) -> bool:
    """Put the held block back where it was picked from (after a place that could not be done): a joint move to the
    top of the pick's own descent (where the pick's lift ended), down the same way (planning.descent: the path the block
    came up in the gripper, checked whole with it then) to RELEASE_GAP_MM above the grasp, open, and up again. Run
    through the executor like every plan (the held block's own column, the stack it came from, is not an obstacle to
    it); raises ValueError when nothing picked is held and MotionRefused with nothing sent when even this is refused.
    True when done."""
    session = as_session(session, "tasks.put_back")
    if session.held is None or session.picked_down is None:
        raise ValueError("put_back needs a block picked with tasks.pick in the gripper")
    picked, block, edge = session.picked_down, session.held, session.held_edge
    # the same descent, stopping RELEASE_GAP_MM short of the grasp (the block drops that little, as in place)
    down = planning.descend(picked.p0, picked.p1 + [0.0, 0.0, RELEASE_GAP_MM], picked.pitch, picked.roll,
                            current=picked.start, robot=session.arm.robot)
    q = session.arm.joint_positions()
    plan = planning.Plan((planning.MoveStep(planning.joint_move(q, down.start), "back over the pick spot"),
                          planning.MoveStep(down, "descend"), planning.GripperStep("open", "release"),
                          planning.MoveStep(planning.reverse(down), "lift")))
    top = np.asarray(block.position, float)
    session.run(plan, f"putting the {block.color} block back at ({top[0]:.1f}, {top[1]:.1f}) mm",
                column=(top[:2], edge / 2), release_top=top)
    return True


def place(session: Session, position, yaw: float = 0.0, obstacles=None,
          clearance: float = planning.DEFAULT_CLEARANCE_MM, path=None) -> bool:
    """Put the held block's bottom-face centre at `position` (3,) world mm with yaw (rad); True when the plan ran
    through (the gripper opened there). The block is released RELEASE_GAP_MM above that height (module notes).
    clearance: how far (mm) the held block's bottom passes above the obstacles' tops in transit, and the empty tool
    point ends above the placed block (planning.plan_place). path: a move_path-like planner (q, target, yaw, edge,
    "release") -> Plan to use instead of planning.plan_place (move_path.drop_with). Raises ValueError when nothing is
    held or for bad input, MotionRefused when the placement rule refuses the spot (off the board, on the robot's base
    plate, out of reach: motion_safety.placement_problem, the rule the clicks use), Unreachable when the arm cannot
    get there and MotionRefused when the whole plan fails the pre-check, e.g. the held block would go into a known
    block (nothing moves then)."""
    p = finite_array(position, "position", (3,), "x, y, z of the block's bottom-face centre in world mm")
    yaw = finite_float(yaw, "yaw", what="rad")
    clearance = finite_float(clearance, "clearance", minimum=0.0, what="mm")
    session = as_session(session, "tasks.place")
    edge = session.held_edge
    what = f"placing at ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm"
    executor.check_release(p, edge, float(yaw), what)
    obs = session.known if obstacles is None else list(obstacles)
    release = p + [0.0, 0.0, RELEASE_GAP_MM]
    if path is None:
        plan = planning.plan_place(session.arm.joint_positions(), release, edge, float(yaw), obstacles=obs,
                                   clearance=clearance, held_in_tool=session.held_in_tool)
    else:
        plan = path(session.arm.joint_positions(), release, float(yaw), edge, "release")
        if not isinstance(plan, planning.Plan):
            raise TypeError(f"move_path must return a planning.Plan, got {type(plan).__name__}")
    session.run(plan, what, known=obs, release_top=p + [0.0, 0.0, edge])
    return True
