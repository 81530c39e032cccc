"""Handling blocks on a station: look (tasks.look), pick and place a detected block -> plan (armlab.planning's
pick/place plans) -> execute on the station's arm. (armlab.planning.pickplace plans; this module runs them.)

Works the same on the simulated and the real station: it uses only the Arm protocol (through a GuardedArm, which
compensates sag) and station.camera. Each station gets a TaskContext on first use (kept on the station object):
- calibration: the camera calibration (perception.calibrate_camera, done once, or set by the caller);
- sag: the sag model (tasks.sag). When the station offers a sag reference (Capabilities.sag_reference: the
  simulator's empty-board twin with its ground truth, a stand-in for a student's touch-off measurements) it is
  fitted on first use from 24 poses; otherwise (the real arm) it stays zero until the caller sets one
  (calibrate_sag with a measuring function, or a saved model);
- known: what stands on the board (detections from the last look, updated by picks and places), the obstacles plans
  avoid; held: the block in the gripper.
place() releases the block RELEASE_GAP_MM above the requested bottom height, so a residual arm error never pushes
it into what it is put on (the block drops that little and settles); the release is aimed with the held block's pose
in the tool frame as planned at its grasp (planning.plan_place's held_in_tool): its centre over the spot and its
lowest corner at the release height, so a block picked tilted at long reach, or placed tilted, is not lowered into
the board or what it is put on. Every pick and place plan is checked whole before its first command
(tasks.precheck: the commands the guarded arm would send, the pads and the held block along them, the sag model and
the known blocks): an impossible one raises MotionRefused with nothing sent. Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from armlab import motion_safety, planning
from armlab.arguments import finite_array, finite_float, instance_of, plain
from armlab.blocks import SIZES, block_edge
from armlab.calibration import Calibration
from armlab.gripper_geometry import GRIPPER
from armlab.planning import Obstacle
from armlab.station import Station
from armlab.station.contract import MotionRefused

from . import perception, precheck
from .guard import GuardedArm
from .sag import SagModel, calibration_poses, fit_sag, hover_pose

__all__ = ["TaskContext", "context", "calibrate_sag", "pick", "place", "put_back", "look", "RELEASE_GAP_MM"]

RELEASE_GAP_MM = 2.0


@dataclass
class TaskContext:
    """Per-station state of the task layer (see the module notes)."""

    arm: GuardedArm
    calibration: Calibration | None = None
    held: object | None = None              # the picked detection Block while it is in the gripper
    known: list = field(default_factory=list)
    last: perception.Observation | None = None
    held_in_tool: np.ndarray | None = None  # T_tool_block (4, 4) mm of the held block as planned at its grasp
    picked_down: object | None = None       # the held block's pick descent (its straight line down), for put_back

    @property
    def held_edge(self) -> float:
        if self.held is None:
            raise ValueError("the gripper holds no block: pick one first")
        return block_edge(self.held.size)


def calibrate_sag(arm, measure: Callable[[], np.ndarray], poses=None) -> SagModel:
    """Fit a SagModel: move the raw arm (no compensation) to each pose (default sag.calibration_poses), passing
    above it first, and call measure() -> tool point (3,) world mm there. Returns the fitted model."""
    poses = calibration_poses(arm.robot) if poses is None else np.asarray(poses, dtype=float)
    q_cmd, measured = [], []
    for q in poses:
        above = hover_pose(q, arm.robot)
        if above is not None:
            arm.move_to(above)
        arm.move_to(q)
        q_cmd.append(np.asarray(arm.joint_positions(), dtype=float))
        measured.append(np.asarray(measure(), dtype=float))
        if above is not None:
            arm.move_to(above)
    return fit_sag(np.array(q_cmd), np.array(measured), arm.robot)


def context(station, intrinsics="checkerboard") -> TaskContext:
    """The station's TaskContext, created (camera calibrated, sag fitted) on first use.

    The sag is fitted when the station offers a reference to fit it on (Capabilities.sag_reference: in simulation
    the same arm over an empty board, measured with the ground truth); otherwise it stays zero until set."""
    ctx = getattr(station, "_tasks_context", None)
    if ctx is None:
        instance_of(station, "station", Station, "what make_station('sim') or make_station('real') returns")
        arm = GuardedArm(station.arm)
        if station.capabilities.sag_reference is not None:
            reference = station.capabilities.sag_reference()
            arm.sag = calibrate_sag(reference.arm, reference.measure)
        ctx = TaskContext(arm)
        ctx.calibration = perception.calibrate_camera(station, intrinsics, arm=arm)
        station._tasks_context = ctx
    return ctx


def look(station) -> perception.Observation:
    """Move the arm out of view (carrying a held block), capture and detect; the blocks seen become the known
    obstacles."""
    ctx = context(station)
    held_below = 0.0 if ctx.held is None else ctx.held_edge - planning.default_grasp_depth(ctx.held_edge)
    obs = perception.observe(station, ctx.calibration, ctx.arm, obstacles=ctx.known, held_below=held_below)
    ctx.last = obs
    ctx.known = list(obs.blocks)
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


def _same(a, b) -> bool:
    pa, pb = np.asarray(a.position if not isinstance(a, Obstacle) else (a.x, a.y, a.top), float), \
        np.asarray(b.position if not isinstance(b, Obstacle) else (b.x, b.y, b.top), float)
    return bool(np.abs(pa - pb).max() < 1.0)


def pick(station, block, obstacles=None) -> bool:
    """Pick a detected block (detection.Block: .position top-face centre world mm, .yaw rad, .size).

    Plans with planning.plan_pick around `obstacles` (default: the known blocks) and runs the plan on the guarded arm.
    Returns close_gripper's answer (True when the block is held). Raises ValueError when the gripper already holds a
    block, kinematics.Unreachable (a ValueError) when the block cannot be reached and MotionRefused when the whole
    plan fails the pre-check (nothing moves then), and lets the arm's EmergencyStopped through.
    """
    check_block(block)
    ctx = context(station)
    if ctx.held is not None:
        raise ValueError(f"the gripper already holds the {ctx.held.color} block: place it first")
    edge = block_edge(block.size)
    obs = ctx.known if obstacles is None else list(obstacles)
    plan = planning.plan_pick(ctx.arm.joint_positions(), block.position, float(block.yaw), edge, obstacles=obs)
    q_grasp = next(s.trajectory for s in plan.steps if s.label == "descend").end
    grasped = motion_safety.HeldBlock(edge, precheck.held_pose_at_grasp(q_grasp, block.position, float(block.yaw),
                                                                        edge), f"picked {block.color} block")
    precheck.check_whole_plan(plan, ctx.arm, _opening(station), grasped=grasped,
                              known=precheck.known_boxes(obs, np.asarray(block.position, float)[:2], edge / 2),
                              what=f"picking the {block.color} block")
    held = bool(planning.execute(plan, ctx.arm).holding)
    ctx.known = [k for k in ctx.known if not _same(k, block)]
    if held:
        ctx.held, ctx.held_in_tool = block, grasped.T_tool_block
        ctx.picked_down = next(s.trajectory for s in plan.steps if s.label == "descend")
    return held


def put_back(station) -> bool:
    """Put the held block back where it was picked from (after a place that could not be done): a joint move to the
    top of the pick's own straight descent (where the pick's lift ended), down that line (the path the block came up
    in the gripper, checked whole with it then) to RELEASE_GAP_MM above the grasp, open, and up again. Checked
    whole before the first command like every plan (the held block's own column, the stack it came from, is not an
    obstacle to it); raises ValueError when nothing picked is held and MotionRefused with nothing sent when even
    this is refused. True when done."""
    ctx = context(station)
    if ctx.held is None or ctx.picked_down is None:
        raise ValueError("put_back needs a block picked with tasks.pick in the gripper")
    picked, block, edge = ctx.picked_down, ctx.held, ctx.held_edge
    # the same straight line, stopping RELEASE_GAP_MM short of the grasp (the block drops that little, as in place)
    down = planning.cartesian_line(picked.p0, picked.p1 + [0.0, 0.0, RELEASE_GAP_MM], picked.pitch, picked.roll,
                                   current=picked.start, robot=ctx.arm.robot)
    q = ctx.arm.joint_positions()
    plan = planning.Plan((planning.MoveStep(planning.joint_move(q, down.start), "back over the pick spot"),
                          planning.MoveStep(down, "descend"), planning.GripperStep("open", "release"),
                          planning.MoveStep(planning.reverse(down), "lift")))
    held = () if ctx.held_in_tool is None else (
        motion_safety.HeldBlock(edge, ctx.held_in_tool, f"held {block.color} block"),)
    top = np.asarray(block.position, float)
    precheck.check_whole_plan(plan, ctx.arm, edge, held=held,
                              known=precheck.known_boxes(ctx.known, top[:2], edge / 2),
                              what=f"putting the {block.color} block back at ({top[0]:.1f}, {top[1]:.1f}) mm")
    planning.execute(plan, ctx.arm)
    ctx.held, ctx.held_in_tool, ctx.picked_down = None, None, None
    ctx.known = [*ctx.known, Obstacle(float(top[0]), float(top[1]), float(top[2]), edge / np.sqrt(2))]
    return True


def _opening(station) -> float:
    """The pads' opening (mm) now: the arm's own reading where it offers one, else fully open."""
    return float(getattr(station.arm, "gripper_opening_mm", GRIPPER.max_opening_mm))


def place(station, position, yaw: float = 0.0, obstacles=None,
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
    ctx = context(station)
    edge = ctx.held_edge
    problem = motion_safety.placement_problem(p, edge, float(yaw))
    if problem:
        raise MotionRefused(f"placing at ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm refused before moving: {problem}")
    obs = ctx.known if obstacles is None else list(obstacles)
    plan = planning.plan_place(ctx.arm.joint_positions(), p + [0.0, 0.0, RELEASE_GAP_MM], edge, float(yaw),
                               obstacles=obs, clearance=clearance, held_in_tool=ctx.held_in_tool)
    held = () if ctx.held_in_tool is None else (
        motion_safety.HeldBlock(edge, ctx.held_in_tool, f"held {ctx.held.color} block"),)
    precheck.check_whole_plan(plan, ctx.arm, edge, held=held, known=precheck.known_boxes(obs),
                              what=f"placing at ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm")
    planning.execute(plan, ctx.arm)
    ctx.held, ctx.held_in_tool, ctx.picked_down = None, None, None
    ctx.known = [*ctx.known, Obstacle(float(p[0]), float(p[1]), float(p[2] + edge), edge / np.sqrt(2))]
    return True
