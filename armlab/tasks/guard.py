"""GuardedArm: what the task layer sends to a station's arm, with sag compensation, stop requests and speed checks.

Wraps any armlab Arm (simulated or real, armlab.station.Arm) and offers the same interface, in PHYSICAL joint angles:
- move_to(q) commands sag.command(q) so the bent arm ends where q puts it (armlab.tasks.sag);
  joint_positions() reports sag.physical(encoder reading), so plans made from it start where they are checked;
- before every command it asks `should_stop()` (e.g. a state machine's emergency-stop flag): when that says True the
  arm is emergency-stopped and EmergencyStopped is raised, so nothing more is sent;
- the compensated command is re-checked against the position limits: the planner keeps its targets
  planning.grasp.LIMIT_MARGIN_RAD (0.01 rad) inside them where it can, but a target planned right at a limit can be
  pushed past it by the compensation (a few mrad). Such a command is clipped back onto the limit when it overshoots
  by at most LIMIT_CLIP_RAD and the planned value itself is within the limits (the physical joint then stops that
  little short of the plan); anything else is refused with MotionRefused naming the joint, before anything moves;
- the compensated command is re-checked against the joint velocity limits (armlab.profile.velocity_violations) and
  the moving time is stretched (ramps in proportion) when the small compensation would make a joint too fast. The
  check is made from the encoder reading AND from the last command this guard sent while the arm still sits there
  (the Interbotix driver checks from its last command, the simulator from its motors, which end exactly there; the
  reading differs from both by the encoder's quantisation and noise), with a relative margin of _SPEED_EPS so the
  stretched time passes the driver's rule exactly;
- every command sent is recorded in `sent` (q_from, q_cmd, moving_time, accel_time) for checks and plots; within a
  `with arm.recording() as log:` block every command the arm accepted is also listed as the caller asked for it
  (what a GUI reports of one click).
Units: rad, s.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

from armlab.arguments import finite_array
from armlab.station.contract import EmergencyStopped, MotionRefused

from .sag import SagModel

__all__ = ["GuardedArm", "LIMIT_CLIP_RAD"]

LIMIT_CLIP_RAD = 0.01   # largest overshoot of a position limit by the sag compensation that is clipped (module notes)
_SPEED_EPS = 1e-6       # stretched times are this much (relative) longer than the velocity limit needs
_AT_COMMAND_RAD = 0.02  # the arm still sits at the last command when every joint reads within this of it


class GuardedArm:
    """An Arm that compensates sag, honours stop requests and never sends a command above a velocity limit."""

    def __init__(self, arm, sag: SagModel | None = None, should_stop: Callable[[], bool] | None = None):
        self.arm = arm
        self.robot = arm.robot
        self.sag = sag or SagModel()
        self.should_stop = should_stop or (lambda: False)
        self.sent: list[tuple[np.ndarray, np.ndarray, float, float]] = []
        self._last_cmd: np.ndarray | None = None     # the last command sent, while the arm may still sit there
        self._logs: list[list] = []                  # the open recording() blocks' lists

    @contextmanager
    def recording(self) -> Iterator[list]:
        """Within the block, every command the arm accepted is appended to the list yielded, in order: ("move", q (5,)
        rad as asked, moving_time s as asked or None), ("open",), ("close", held)."""
        log: list = []
        self._logs.append(log)
        try:
            yield log
        finally:
            self._logs.remove(log)

    def _note(self, entry: tuple) -> None:
        for log in self._logs:
            log.append(entry)

    def _check(self, what: str) -> None:
        if self.should_stop():
            self._last_cmd = None
            self.arm.emergency_stop()
            raise EmergencyStopped(f"{what} refused: an emergency stop was requested; reset first")

    @property
    def torque_enabled(self) -> bool:
        """The wrapped arm's state: True when its motors hold it."""
        return self.arm.torque_enabled

    @property
    def emergency_stopped(self) -> bool:
        """The wrapped arm's state: True after an emergency stop until reset()."""
        return self.arm.emergency_stopped

    @property
    def held_blocks(self) -> tuple:
        """What the wrapped arm says it holds (Arm.held_blocks: motion_safety.HeldBlock, edge mm and pose in the
        tool frame); () from an arm that does not keep it (a stand-in)."""
        return tuple(getattr(self.arm, "held_blocks", ()))

    def set_held_blocks(self, blocks) -> None:
        """Tell the wrapped arm what it holds (Arm.set_held_blocks), so its own per-move check covers them; ignored
        by an arm that does not keep it (a stand-in)."""
        setter = getattr(self.arm, "set_held_blocks", None)
        if setter is not None:
            setter(tuple(blocks))

    def joint_positions(self) -> np.ndarray:
        """Estimated physical joint angles (5,) rad: the encoder reading plus the predicted sag."""
        return self.sag.physical(self.arm.joint_positions(), self.robot)

    def move_to(self, q, moving_time: float | None = None, accel_time: float | None = None,
                blocking: bool = True) -> None:
        """Move so that the physical joints reach q (5,) rad (see the module notes)."""
        self._check("motion")
        q = finite_array(q, "q", (5,), "move_to takes 5 finite joint angles in rad")
        q_read = np.asarray(self.arm.joint_positions(), dtype=float)
        starts = [q_read]
        if self._last_cmd is not None and np.abs(q_read - self._last_cmd).max() <= _AT_COMMAND_RAD:
            starts.append(self._last_cmd)
        asked = moving_time
        q_cmd, moving_time, accel_time = self.command_for(q, starts, moving_time, accel_time)
        self.sent.append((q_read, q_cmd, moving_time, accel_time))
        self._last_cmd = None
        self.arm.move_to(q_cmd, moving_time=moving_time, accel_time=accel_time, blocking=blocking)
        self._last_cmd = q_cmd
        self._note(("move", q.copy(), asked))

    def command_for(self, q, starts, moving_time: float | None = None,
                    accel_time: float | None = None) -> tuple[np.ndarray, float | None, float | None]:
        """What move_to(q, moving_time, accel_time) sends from commanded joints `starts` (list of (5,) rad: where
        the arm may be taken to start from): (the compensated command (5,) rad, moving_time s stretched for the
        velocity limits, accel_time s scaled with it). MotionRefused when the command is past a limit by more than
        LIMIT_CLIP_RAD (module notes). Used by move_to and by the task layer's whole-plan pre-check."""
        q = np.asarray(q, dtype=float)
        q_cmd = self._within_limits(q, self.sag.command(q, self.robot))
        if moving_time is not None:
            need = max(float(np.max(np.abs(q_cmd - s) / self.robot.velocity)) for s in starts) * (1 + _SPEED_EPS)
            if need > moving_time:
                scale = need / moving_time
                moving_time = need
                accel_time = None if accel_time is None else accel_time * scale
        return q_cmd, moving_time, accel_time

    def _within_limits(self, q: np.ndarray, q_cmd: np.ndarray) -> np.ndarray:
        """The compensated command q_cmd for planned joints q, clipped onto the limits within LIMIT_CLIP_RAD when q
        itself is within them; MotionRefused otherwise (module notes)."""
        lo, hi = np.asarray(self.robot.lower), np.asarray(self.robot.upper)
        over = np.maximum(lo - q_cmd, q_cmd - hi)
        if np.all(over <= 0):
            return q_cmd
        planned_ok = (q >= lo - 1e-9) & (q <= hi + 1e-9)
        bad = [f"{name}: planned {qi:.6f} rad, compensated {ci:.6f} rad is {o:.4f} rad past its limits "
               f"[{a:.6f}, {b:.6f}]" + ("" if ok else " (the planned value is outside them too)")
               for name, qi, ci, o, a, b, ok in zip(self.robot.joint_names, q, q_cmd, over, lo, hi, planned_ok)
               if o > 0 and (o > LIMIT_CLIP_RAD or not ok)]
        if bad:
            raise MotionRefused("motion refused (joint limits after sag compensation; at most "
                                f"{LIMIT_CLIP_RAD} rad is clipped): " + "; ".join(bad))
        return np.clip(q_cmd, lo, hi)

    def open_gripper(self) -> None:
        self._check("opening the gripper")
        self.arm.open_gripper()
        self._note(("open",))

    def close_gripper(self) -> bool:
        self._check("closing the gripper")
        held = self.arm.close_gripper()
        self._note(("close", bool(held)))
        return held

    def is_moving(self) -> bool:
        return self.arm.is_moving()

    def wait(self) -> None:
        self.arm.wait()

    def home(self, moving_time: float | None = None) -> None:
        self.move_to(np.asarray(self.robot.home, float), moving_time)

    def sleep(self, moving_time: float | None = None) -> None:
        self.move_to(np.asarray(self.robot.sleep, float), moving_time)

    def set_torque(self, enabled: bool) -> None:
        self._last_cmd = None
        self.arm.set_torque(enabled)

    def emergency_stop(self) -> None:
        self._last_cmd = None
        self.arm.emergency_stop()

    def reset(self) -> None:
        self._last_cmd = None
        self.arm.reset()
