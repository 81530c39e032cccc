"""The task layer's one executor: every motion of armlab.tasks goes through run(session, plan, what) (Session.run).

Picks, places and put-backs (tasks.handling), move_path's grab_with / drop_with, TaskMachine.execute (and so the
control station's sliders and buttons), teach-and-repeat (tasks.repeat), the move out of the camera's view
(perception.clear_view, on every look), the reach experiment and the events (through tasks.pick / place / put_back
and look) all hand their planning.Plan to run(), which, in this order:

1. takes what is held: the session's held block (its edge and its pose in the tool frame as recorded at the grasp),
   else what the arm itself says it holds (Arm.held_blocks: both backends keep what the executor told them);
2. applies the placement rule (motion_safety.placement_problem) to every release of the plan: where the held block's
   bottom-face centre is when the pads open, by the manufacturer's model (kinematics.fk_pox of the planned joints);
3. checks the whole plan (tasks.precheck.check_whole_plan): every command the guarded arm would send, the links,
   the pads, the held block and the block a close step grasps, against the board and the known blocks;
4. tells the arm what it holds (Arm.set_held_blocks), so each backend's own per-move check covers the held block
   whatever sends the next command;
5. runs the plan on the guarded arm (planning.execute through GuardedArm: stop requests, sag compensation, speed
   checks) and records, right after each gripper step, what is held and what was released (Session.picked,
   Session.released; the arm's held blocks).

Nothing is sent before steps 1-3 pass: a refusal raises MotionRefused (ValueError) naming the step and why, and the
arm has not moved. An emergency stop always wins: the guarded arm asks for it before every command and the backends
re-check it under their lock. A close step the caller did not describe (a Grasp) grasps nothing the kit knows of (a
taught program's close): the session records nothing held then, and the simulator's own truth still checks it.
planning.execute stays the low-level runner; nothing else in armlab.tasks calls it (tests/test_executor.py).
Units: mm, rad; world (board) frame; tool frame = ee_gripper_link.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from armlab import kinematics, motion_safety, planning
from armlab.blocks import block_edge
from armlab.gripper_geometry import GRIPPER
from armlab.station.contract import Arm, MotionRefused

from . import precheck
from .guard import GuardedArm

__all__ = ["PlanRefused", "Mover", "Grasp", "Release", "ArmAlone", "run", "runner", "held_blocks", "releases",
           "check_release", "guarded"]


class PlanRefused(MotionRefused):
    """The executor refused a plan before its first command (the placement rule or the whole-plan check): nothing
    was sent, the arm has not moved. A MotionRefused (so a ValueError)."""


class Mover(Protocol):
    """What the executor runs plans for: a task Session (tasks.session), or ArmAlone over an arm used without one."""

    arm: GuardedArm
    held: Any
    held_in_tool: np.ndarray | None
    known: Any

    def picked(self, block, held: bool, held_in_tool: np.ndarray | None = None, descent=None) -> None:
        """Record a pick that ran (Session.picked)."""

    def released(self, top) -> None:
        """Record that the held block was let go with its top-face centre at `top` (3,) world mm."""


@dataclass(frozen=True)
class Grasp:
    """What a plan's close step picks up.

    Attributes:
        block: the detection Block picked (.position top-face centre world mm, .yaw rad, .size, .color).
        held: its motion_safety.HeldBlock: edge (mm) and T_tool_block (4, 4) mm as the closing pads leave it
            (precheck.held_pose_at_grasp).
        descent: the pick's straight descent (planning trajectory), kept for put_back; None when there is none.
    """

    block: Any
    held: motion_safety.HeldBlock
    descent: Any = None


@dataclass(frozen=True)
class Release:
    """A release of a plan: the plan step (index) that opens the pads, the block let go, and where its bottom-face
    centre is then (3,) world mm with its yaw (rad), by the manufacturer's model of the planned joints."""

    step: int
    block: motion_safety.HeldBlock
    bottom: np.ndarray
    yaw: float


def guarded(arm: Arm) -> GuardedArm:
    """`arm` itself when it is a GuardedArm, else a GuardedArm over it with no sag model (its commands are the
    planned joints): the raw arm of an experiment that measures the uncompensated arm."""
    return arm if isinstance(arm, GuardedArm) else GuardedArm(arm)


@dataclass
class ArmAlone:
    """What the executor needs of a session, for an arm used without one (a replay on an arm, the camera's
    calibration before the session exists): nothing known on the board, nothing held by the session's knowledge (the
    arm says what it holds: Arm.held_blocks)."""

    arm: GuardedArm
    held: None = None
    held_in_tool: None = None
    known: tuple = ()

    def picked(self, block, held: bool, held_in_tool: np.ndarray | None = None, descent=None) -> None:
        """Nothing to record: the arm itself is told what it holds (Arm.set_held_blocks)."""

    def released(self, top) -> None:
        """Nothing to record: nothing held is known but by the arm."""


def runner(value: Mover | Arm) -> Mover:
    """What runs plans for `value`: a task session itself (anything with a GuardedArm `arm` and `known` blocks), or
    ArmAlone over an arm (a GuardedArm, or a backend's Arm wrapped in one with no sag model)."""
    if isinstance(getattr(value, "arm", None), GuardedArm) and hasattr(value, "known"):
        return value
    return ArmAlone(guarded(value))


def held_blocks(mover: Mover, arm: GuardedArm) -> tuple[motion_safety.HeldBlock, ...]:
    """What the gripper holds for the checks: the session's held block at its recorded pose in the tool frame, else
    what the arm says it holds (Arm.held_blocks), else nothing."""
    if mover.held is not None and mover.held_in_tool is not None:
        return (motion_safety.HeldBlock(block_edge(mover.held.size), np.asarray(mover.held_in_tool, float),
                                        f"held {mover.held.color} block"),)
    return tuple(arm.held_blocks)


def releases(plan: planning.Plan, held: Sequence[motion_safety.HeldBlock], grasp: Grasp | None = None,
             robot=None) -> list[Release]:
    """Every release of `plan` (a gripper "open" while something is carried), starting with `held` in the gripper;
    a "close" picks up grasp.held (nothing known without a Grasp)."""
    carried, q, out = tuple(held), np.asarray(plan.start, float), []
    for k, step in enumerate(plan.steps):
        if isinstance(step, planning.MoveStep):
            q = np.asarray(step.trajectory.end, float)
        elif step.action == "close":
            carried = carried or (() if grasp is None else (grasp.held,))
        else:
            T_tool = kinematics.fk_pox(q, robot, check_limits=False)
            for block in carried:
                T = T_tool @ np.asarray(block.T_tool_block, float)
                bottom = T[:3, 3] - [0.0, 0.0, block.edge_mm / 2]
                out.append(Release(k, block, bottom, float(np.arctan2(T[1, 0], T[0, 0]))))
            carried = ()
    return out


def check_release(bottom, edge_mm: float, yaw: float, what: str) -> None:
    """MotionRefused '<what> refused before moving: <why>' when the placement rule (motion_safety.placement_problem)
    refuses a block of edge_mm with its bottom-face centre at `bottom` (3,) world mm and yaw rad."""
    problem = motion_safety.placement_problem(bottom, edge_mm, yaw)
    if problem:
        raise PlanRefused(f"{what} refused before moving: {problem} (nothing was sent to the arm)")


def _opening(arm: GuardedArm, held: Sequence[motion_safety.HeldBlock]) -> float:
    """The pads' opening (mm) at the plan's start: closed on the held block, else the arm's own reading where it
    offers one (Arm.gripper_opening_mm), else fully open."""
    if held:
        return float(held[0].edge_mm)
    return float(getattr(arm.arm, "gripper_opening_mm", GRIPPER.max_opening_mm))


def run(mover: Mover, plan: planning.Plan, what: str, *, grasp: Grasp | None = None, known: Sequence | None = None,
        column: tuple[np.ndarray, float] | None = None, release_top: np.ndarray | None = None,
        arm: Arm | None = None) -> planning.ExecutionResult:
    """Check `plan` whole, then run it and record what is held (module notes); returns planning.ExecutionResult.

    mover: the task Session (its held block, its known blocks; it records picks and releases), or ArmAlone.
    what: names the motion in a refusal ("placing at (60.0, -100.0, 0.0) mm").
    grasp: what the plan's close step picks up (Grasp), None when it grasps nothing the kit knows of.
    known: the blocks standing on the board (detection Blocks, planning Obstacles); default session.known.
    column: (xy (2,) mm, radius mm) of the column a block is picked from or put back to (a stack, the block's own
        side faces), not an obstacle to the plan; None: every known block is one.
    release_top: where the released block's top-face centre ends (3,) world mm (the spot it lands on); default its
        top at the release pose (it lands no lower).
    arm: the arm to move (default mover.arm); a raw backend arm is wrapped in a GuardedArm with no sag model.
    Raises TypeError for a plan that is not a planning.Plan, PlanRefused (a MotionRefused; nothing sent) when the
    placement rule or the whole-plan check refuses, and lets the arm's own refusals and EmergencyStopped through.
    """
    if not isinstance(plan, planning.Plan):
        raise TypeError(f"{what}: the executor runs a planning.Plan, got {type(plan).__name__}")
    arm = mover.arm if arm is None else guarded(arm)
    held = held_blocks(mover, arm)
    released = releases(plan, held, grasp, arm.robot)
    for r in released:
        check_release(r.bottom, r.block.edge_mm, r.yaw, f"{what} (the release at step {r.step})")
    if column is None:
        boxes = precheck.known_boxes(mover.known if known is None else known)
    else:
        boxes = precheck.known_boxes(mover.known if known is None else known, np.asarray(column[0], float)[:2],
                                     float(column[1]))
    try:
        precheck.check_whole_plan(plan, arm, _opening(arm, held), held=held,
                                  grasped=None if grasp is None else grasp.held, known=boxes, what=what)
    except MotionRefused as e:
        raise PlanRefused(str(e)) from None
    arm.set_held_blocks(held)
    tops = iter([np.asarray(release_top, float)] if release_top is not None else
                [r.bottom + [0.0, 0.0, r.block.edge_mm] for r in released])

    def record(step: planning.GripperStep, answer: bool | None) -> None:
        if step.action == "close":
            if grasp is not None:
                mover.picked(grasp.block, bool(answer), grasp.held.T_tool_block, grasp.descent)
                arm.set_held_blocks((grasp.held,) if answer else ())
            return
        if mover.held is not None:          # this open lets go of the session's block: the next release
            mover.released(next(tops))
        arm.set_held_blocks(())

    return planning.execute(plan, arm, after_gripper=record)
