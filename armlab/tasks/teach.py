"""Teach and repeat: record waypoints (joint angles + gripper state), save/load them as JSON, replay, plot.

Teaching: torque off (arm.set_torque(False)), pose the arm by hand (on the simulator: arm.move_by_hand(q)), and
record arm.joint_positions() with the gripper state wanted there; Recorder does the bookkeeping. A waypoint's gripper
state is the state after arriving there: replaying moves to each waypoint in turn (a joint move timed by
armlab.planning.timing.moving_time, the lab's pi/4 rad/s rule within the velocity limits) and then opens or closes
the gripper when its state changes. The whole program becomes an armlab.planning.Plan (TeachProgram.to_plan), so it
is run by the task layer's executor (tasks.executor: checked whole before its first command) and plotted (joint
angles against time, as the lab report's figure 10) by planning.plot_plan. Taught readings are torque-off positions
(no sag): replay through the session (session = tasks.start_session(station): its guarded arm) to return to them
despite the sag. Files: JSON {"format":
"armlab-teach/1", "name", "joint_names", "waypoints": [{"q": [5 rad], "gripper": "open" | "closed"}, ...]}, written
atomically, validated on load (TeachFileError names the file and the waypoint). Units: rad, s; world mm for the swap
spots.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armlab import kinematics, planning
from armlab.blocks import block_edge
from armlab.files import read_json, write_json_atomic
from armlab.robot import JOINT_NAMES, RobotModel, rx200
from armlab.schemas import comment, number, strict_object, validate, vector

from . import executor

__all__ = ["GRIPPER_STATES", "TeachProgram", "TeachFileError", "Recorder", "save_teach", "load_teach", "repeat",
           "plot_teach", "swap_waypoints"]

GRIPPER_STATES = ("open", "closed")
_FORMAT = "armlab-teach/1"


class TeachFileError(ValueError):
    """A teach file is missing or malformed; the message names the file and the problem."""


@dataclass(frozen=True)
class TeachProgram:
    """Recorded waypoints: q (N, 5) rad (N >= 2, within the joint limits), gripper (N,) states after each."""

    q: np.ndarray
    gripper: tuple[str, ...]
    name: str = ""

    def __post_init__(self):
        q = np.asarray(self.q, dtype=float)
        grip = tuple(self.gripper)
        if q.ndim != 2 or q.shape[1] != 5:
            raise ValueError(f"waypoints must be an (N, 5) array of joint angles (rad), got shape {q.shape}")
        if q.shape[0] < 2:
            raise ValueError(f"a program needs at least 2 waypoints, got {q.shape[0]}")
        if len(grip) != q.shape[0]:
            raise ValueError(f"{q.shape[0]} waypoints but {len(grip)} gripper states")
        for i, (qi, g) in enumerate(zip(q, grip)):
            if not np.all(np.isfinite(qi)):
                raise ValueError(f"waypoint {i}: joint angles must be finite, got {qi}")
            bad = rx200().limit_violations(qi)
            if bad:
                raise ValueError(f"waypoint {i}: " + "; ".join(bad))
            if g not in GRIPPER_STATES:
                raise ValueError(f"waypoint {i}: gripper state must be one of {GRIPPER_STATES}, got {g!r}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "gripper", grip)

    def __len__(self) -> int:
        return self.q.shape[0]

    def to_plan(self, start=None, scaling: str = "trapezoid", robot: RobotModel | None = None) -> planning.Plan:
        """The program as a Plan: [from `start` (5,) rad to waypoint 0,] set the gripper, then for each next
        waypoint a joint move and a gripper action when its state changes."""
        robot = robot or rx200()
        steps: list = []
        here = self.q[0] if start is None else np.asarray(start, dtype=float)
        for i, (q, g) in enumerate(zip(self.q, self.gripper)):
            if i > 0 or np.abs(q - here).max() > 1e-9:
                steps.append(planning.MoveStep(planning.joint_move(here, q, scaling, robot=robot), f"to waypoint {i}"))
            if i == 0 or g != self.gripper[i - 1]:
                steps.append(planning.GripperStep("close" if g == "closed" else "open", f"at waypoint {i}"))
            here = q
        return planning.Plan(tuple(steps))


class Recorder:
    """Teach by hand: on start the torque goes off; record(gripper) stores the arm's reading; finish() restores the
    torque and returns the TeachProgram."""

    def __init__(self, arm, name: str = ""):
        self.arm, self.name = arm, name
        self.q: list[np.ndarray] = []
        self.gripper: list[str] = []
        arm.set_torque(False)

    def record(self, gripper: str = "open") -> np.ndarray:
        if gripper not in GRIPPER_STATES:
            raise ValueError(f"gripper state must be one of {GRIPPER_STATES}, got {gripper!r}")
        q = np.asarray(self.arm.joint_positions(), dtype=float)
        self.q.append(q)
        self.gripper.append(gripper)
        return q

    def finish(self) -> TeachProgram:
        self.arm.set_torque(True)
        return TeachProgram(np.array(self.q).reshape(-1, 5), tuple(self.gripper), self.name)


def save_teach(program: TeachProgram, path) -> Path:
    """Write a program as JSON atomically (temporary file in the same folder, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {"format": _FORMAT, "name": program.name, "joint_names": list(JOINT_NAMES),
            "waypoints": [{"q": [round(float(v), 6) for v in q], "gripper": g}
                          for q, g in zip(program.q, program.gripper)]}
    return write_json_atomic(path, data)


SCHEMA = strict_object({
    "format": {"const": _FORMAT}, "name": comment(), "joint_names": {"const": list(JOINT_NAMES)},
    "waypoints": vector(strict_object({"q": vector(number(minimum=-100.0, maximum=100.0), 5),
                                       "gripper": {"enum": list(GRIPPER_STATES)}}, required=("q", "gripper"),
                                      allow_comments=False), max_items=100_000)},
    required=("format", "waypoints"))
"""The declared schema of a teach file (armlab.schemas): waypoints of 5 finite joint angles (rad) and a gripper
state each; the joint limits are the program's own check (TeachProgram)."""


def load_teach(path) -> TeachProgram:
    """Read and validate a teach file; TeachFileError names the file and what is wrong (format, shapes, joint
    limits, gripper values)."""
    path = Path(path)
    raw = read_json(path, "teach", TeachFileError)
    if not isinstance(raw, dict) or raw.get("format") != _FORMAT:
        raise TeachFileError(f"{path}: not an armlab teach file (format must be {_FORMAT!r})")
    validate(raw, SCHEMA, path, TeachFileError)
    wps = raw["waypoints"]
    q, grip = [w["q"] for w in wps], [w["gripper"] for w in wps]
    try:
        return TeachProgram(np.array(q, dtype=float).reshape(-1, 5), tuple(grip), str(raw.get("name", "")))
    except ValueError as e:
        raise TeachFileError(f"{path}: {e}") from None


def repeat(mover, program: TeachProgram, scaling: str = "trapezoid") -> planning.ExecutionResult:
    """Replay a program, starting with a joint move from where the arm is to the first waypoint, through the
    executor (tasks.executor: the whole replay is checked before its first command, with what is held).

    mover: a task Session (preferred: its held block and known blocks are checked) or an arm (a GuardedArm such as
    session.arm, or a backend's Arm: what the arm says it holds is checked). A close in the program grasps nothing the
    kit knows of. Raises MotionRefused with nothing sent when the replay is refused."""
    runner = executor.runner(mover)
    plan = program.to_plan(start=np.asarray(runner.arm.joint_positions(), dtype=float), scaling=scaling)
    name = f" {program.name!r}" if program.name else ""
    return executor.run(runner, plan, f"repeating the taught program{name}")


def plot_teach(program: TeachProgram, ax=None):
    """Joint angles against time for one replay (the lab report's figure 10); returns the axes."""
    ax = planning.plot_plan(program.to_plan(), ax=ax)
    ax.set_title(f"teach and repeat{': ' + program.name if program.name else ''}", fontsize=9)
    return ax


def swap_waypoints(hover_mm: float = 100.0, release_gap_mm: float = 6.0) -> tuple[np.ndarray, tuple[str, ...]]:
    """Physical joint poses (N, 5) rad and gripper states of the lab report's swap (large blocks at A (-100, 225)
    and B (100, 225) swapped through (250, 75) mm): A -> intermediate, B -> A, intermediate -> B. Grasps at the
    block centre; releases with the block release_gap_mm above the board; top-down, fingers square to the faces."""
    from armlab.sim.scenes import SWAP_SPOTS_MM  # the exercise's spots (also the "swap" scene's)

    edge = block_edge("large")
    grasp_z, release_z = edge / 2, edge / 2 + release_gap_mm
    moves = [("A", "intermediate"), ("B", "A"), ("intermediate", "B")]
    poses, grip = [], []

    def at(spot, z, state):
        x, y = SWAP_SPOTS_MM[spot]
        roll = planning.face_roll(np.arctan2(y, x), 0.0)
        poses.append(kinematics.ik_pox([x, y, z], np.pi / 2, roll)[0])      # the kit's IK: never a student's
        grip.append(state)

    for src, dst in moves:
        at(src, hover_mm, "open")
        at(src, grasp_z, "closed")
        at(src, hover_mm, "closed")
        at(dst, hover_mm, "closed")
        at(dst, release_z, "open")
        at(dst, hover_mm, "open")
    return np.array(poses), tuple(grip)

