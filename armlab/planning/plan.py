"""Plans: ordered steps (joint trajectories and gripper actions) that `execute` runs on any armlab Arm.

A plan is pure data: it knows nothing of the station. `execute(plan, arm)` needs only arm.move_to(q, moving_time,
accel_time), arm.open_gripper(), arm.close_gripper() and (to check the start) arm.joint_positions(); refusals and
emergency stops raised by the arm propagate unchanged, and nothing after the failing command is sent.
Units: rad, rad/s, s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from armlab.robot import JOINT_NAMES

from .trajectory import Trajectory, joint_move

__all__ = ["GRIPPER_TIME_S", "MoveStep", "GripperStep", "Plan", "PlanSample", "ExecutionResult", "execute",
           "sample_plan", "plot_plan", "joint_moves"]

GRIPPER_TIME_S = 1.0      # the manufacturer's grasp()/release() delay: the arm holds still meanwhile
_GRIPPER_ACTIONS = ("open", "close")


def joint_moves(*poses, label: str = "to pose", robot=None) -> Plan:
    """One plan of rest-to-rest joint moves (planning.joint_move, the lab's default timing) from poses[0] through
    each next pose, every pose (5,) rad; the k-th move is labelled f"{label} {k}". ValueError for fewer than two
    poses or a pose outside the joint limits (naming the joint)."""
    if len(poses) < 2:
        raise ValueError(f"joint_moves needs a start and at least one pose to move to, got {len(poses)} pose(s)")
    return Plan(tuple(MoveStep(joint_move(a, b, robot=robot), f"{label} {k + 1}")
                      for k, (a, b) in enumerate(zip(poses[:-1], poses[1:]))))


@dataclass(frozen=True)
class MoveStep:
    """Follow a joint trajectory; label says what the move is for (e.g. "transit", "descend", "lift")."""

    trajectory: Trajectory
    label: str = "move"

    @property
    def duration(self) -> float:
        return self.trajectory.duration


@dataclass(frozen=True)
class GripperStep:
    """Open or close the gripper while the arm holds still for `duration` s."""

    action: str
    label: str = ""
    duration: float = GRIPPER_TIME_S

    def __post_init__(self):
        if self.action not in _GRIPPER_ACTIONS:
            raise ValueError(f"unknown gripper action {self.action!r}: expected one of {_GRIPPER_ACTIONS}")
        if not np.isfinite(self.duration) or self.duration < 0:
            raise ValueError(f"gripper step duration must be a non-negative number of seconds, got {self.duration}")


Step = MoveStep | GripperStep


@dataclass(frozen=True)
class PlanSample:
    """A plan sampled at times t (N,) s: q (N, 5) rad, qdot (N, 5) rad/s, closed (N,) gripper closed after the
    last gripper action so far (the gripper is taken as open before any), step (N,) index of the active step."""

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    closed: np.ndarray
    step: np.ndarray


@dataclass(frozen=True)
class Plan:
    """Steps to run in order. Consecutive moves must join up (each starts where the previous move ended)."""

    steps: tuple[Step, ...]

    def __post_init__(self):
        object.__setattr__(self, "steps", tuple(self.steps))
        moves = [s for s in self.steps if isinstance(s, MoveStep)]
        for i, s in enumerate(self.steps):
            if not isinstance(s, MoveStep | GripperStep):
                raise ValueError(f"plan step {i} is a {type(s).__name__}, expected a MoveStep or a GripperStep")
        if not moves:
            raise ValueError("a plan needs at least one move (its start and end poses come from its moves)")
        for a, b in zip(moves, moves[1:]):
            gap = np.abs(a.trajectory.end - b.trajectory.start).max()
            if gap > 1e-9:
                raise ValueError(f"plan moves do not join up: {b.label!r} starts {gap:.3g} rad away from where "
                                 f"{a.label!r} ends")

    @property
    def start(self) -> np.ndarray:
        """Joint angles (5,) rad where the plan starts."""
        return next(s for s in self.steps if isinstance(s, MoveStep)).trajectory.start

    @property
    def end(self) -> np.ndarray:
        """Joint angles (5,) rad where the plan ends."""
        return next(s for s in reversed(self.steps) if isinstance(s, MoveStep)).trajectory.end

    @property
    def duration(self) -> float:
        """Total time (s), gripper actions included."""
        return float(sum(s.duration for s in self.steps))

    @property
    def step_times(self) -> np.ndarray:
        """Start time (s) of every step, then the end time: (len(steps) + 1,)."""
        return np.concatenate([[0.0], np.cumsum([s.duration for s in self.steps])])

    def then(self, other: Plan) -> Plan:
        """This plan followed by another (which must start where this one ends)."""
        return Plan(self.steps + other.steps)

    def sample(self, t) -> PlanSample:
        """Joint angles, velocities and gripper state at times t (s), vectorised."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1 or not np.all(np.isfinite(t)):
            raise ValueError("plan sample times must be a finite scalar or 1-D array (s)")
        edges = self.step_times
        idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(self.steps) - 1)
        q = np.empty((t.size, 5))
        qd = np.zeros((t.size, 5))
        closed = np.zeros(t.size, bool)
        held_q, state = self.start, False
        for i, step in enumerate(self.steps):
            sel = idx == i
            if isinstance(step, MoveStep):
                if sel.any():
                    q[sel], qd[sel] = step.trajectory.sample(t[sel] - edges[i])
                held_q = step.trajectory.end
            else:
                state = step.action == "close"
                q[sel] = held_q
            closed[sel] = state
        return PlanSample(t, q, qd, closed, idx)

    def describe(self) -> str:
        """One line per step: start time, duration, kind and label (for notebooks and logs)."""
        lines = []
        for t0, s in zip(self.step_times, self.steps):
            kind = f"{s.action} gripper" if isinstance(s, GripperStep) else (
                f"move ({len(s.trajectory.waypoints())} waypoints)")
            lines.append(f"{t0:6.2f} s  {s.duration:5.2f} s  {kind:<22} {s.label}")
        return "\n".join(lines)


@dataclass(frozen=True)
class ExecutionResult:
    """What execute() did: steps run, commands sent, and close_gripper's answers in order (True = holding)."""

    steps: int
    commands: int
    grasps: tuple[bool, ...]

    @property
    def holding(self) -> bool | None:
        """The last close_gripper answer (None when the plan never closed the gripper)."""
        return self.grasps[-1] if self.grasps else None


def execute(plan: Plan, arm, check_start: bool = True, start_tolerance: float = 0.05,
            after_gripper: Callable[[GripperStep, bool | None], None] | None = None) -> ExecutionResult:
    """Run a plan on an arm: move_to for every waypoint of every move, open_gripper / close_gripper for gripper steps.

    The low-level runner: it checks nothing but the start. The task layer never calls it directly; it runs every
    plan through its executor (armlab.tasks.executor), which checks the whole plan first.
    With check_start, refuses (ValueError, nothing sent) when the arm's measured joints are more than
    start_tolerance rad from the plan's start. after_gripper(step, answer) is called right after each gripper step
    (answer: close_gripper's, None for an open), before the next command, so a caller can record what is held.
    Exceptions from the arm (MotionRefused, EmergencyStopped, ...) propagate unchanged, with a note naming the step;
    no later command is sent.
    """
    if not isinstance(plan, Plan):
        raise ValueError(f"execute takes a Plan, got {type(plan).__name__}")
    if check_start:
        q_now = np.asarray(arm.joint_positions(), dtype=float)
        off = np.abs(q_now - plan.start)
        if q_now.shape != (5,) or off.max() > start_tolerance:
            worst = int(np.argmax(off)) if q_now.shape == (5,) else 0
            raise ValueError(f"the arm is not where the plan starts: {JOINT_NAMES[worst]} is {off[worst]:.3f} rad "
                             f"away (tolerance {start_tolerance} rad); plan from arm.joint_positions()")
    commands, grasps = 0, []
    for i, step in enumerate(plan.steps):
        try:
            if isinstance(step, MoveStep):
                for wp in step.trajectory.waypoints():
                    arm.move_to(wp.q, moving_time=wp.moving_time, accel_time=wp.accel_time)
                    commands += 1
            elif step.action == "open":
                arm.open_gripper()
                commands += 1
                if after_gripper is not None:
                    after_gripper(step, None)
            else:
                grasps.append(bool(arm.close_gripper()))
                commands += 1
                if after_gripper is not None:
                    after_gripper(step, grasps[-1])
        except Exception as e:
            if hasattr(e, "add_note"):
                e.add_note(f"while executing plan step {i} ({step.label or type(step).__name__}) after "
                           f"{commands} commands")
            raise
    return ExecutionResult(len(plan.steps), commands, tuple(grasps))


def sample_plan(plan: Plan, dt: float = 0.02) -> PlanSample:
    """The plan sampled every dt s from 0 to its duration (inclusive)."""
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"dt must be a positive number of seconds, got {dt}")
    return plan.sample(np.append(np.arange(0.0, plan.duration, dt), plan.duration))


def plot_plan(plan: Plan, ax=None, dt: float = 0.02):
    """Plot joint angles (rad) against time (s), shading where the gripper is closed; returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(8, 3.6))
    s = sample_plan(plan, dt)
    for j, name in enumerate(JOINT_NAMES):
        ax.plot(s.t, s.q[:, j], label=name)
    edges = plan.step_times
    for i, step in enumerate(plan.steps):
        if isinstance(step, GripperStep):
            ax.axvline(edges[i], color="0.5", lw=0.8, ls=":")
    closed = s.closed.astype(float)
    if closed.any():
        ax.fill_between(s.t, 0, 1, where=s.closed, transform=ax.get_xaxis_transform(), color="0.85", zorder=0,
                        label="gripper closed")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("joint angle (rad)")
    ax.legend(loc="upper right", fontsize=9, ncol=2)
    return ax
