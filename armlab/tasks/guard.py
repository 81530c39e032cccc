"""GuardedArm: what the task layer sends to a station's arm, with sag compensation, stop requests and speed checks.

Wraps any armlab Arm (simulated or real, armlab.station.Arm) and offers the same interface, in PHYSICAL joint angles:
- move_to(q) commands sag.command(q) so the bent arm ends where q puts it (armlab.tasks.sag);
  joint_positions() reports sag.physical(encoder reading), so plans made from it start where they are checked;
- before every command it asks `should_stop()` (e.g. a state machine's emergency-stop flag): when that says True the
  arm is emergency-stopped and EmergencyStopped is raised, so nothing more is sent;
- the compensated command is re-checked against the joint velocity limits (armlab.profile.velocity_violations) and
  the moving time is stretched (ramps in proportion) when the small compensation would make a joint too fast;
- every command sent is recorded in `sent` (q_from, q_cmd, moving_time, accel_time) for checks and plots.
Units: rad, s.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from armlab.profile import velocity_violations
from armlab.station import EmergencyStopped

from .sag import SagModel

__all__ = ["GuardedArm"]

_SPEED_MARGIN = 1.01    # stretch to 1 % under the limit


class GuardedArm:
    """An Arm that compensates sag, honours stop requests and never sends a command above a velocity limit."""

    def __init__(self, arm, sag: SagModel | None = None, should_stop: Callable[[], bool] | None = None):
        self.arm = arm
        self.robot = arm.robot
        self.sag = sag or SagModel()
        self.should_stop = should_stop or (lambda: False)
        self.sent: list[tuple[np.ndarray, np.ndarray, float, float]] = []

    def _check(self, what: str) -> None:
        if self.should_stop():
            self.arm.emergency_stop()
            raise EmergencyStopped(f"{what} refused: an emergency stop was requested; reset first")

    def joint_positions(self) -> np.ndarray:
        """Estimated physical joint angles (5,) rad: the encoder reading plus the predicted sag."""
        return self.sag.physical(self.arm.joint_positions(), self.robot)

    def move_to(self, q, moving_time: float | None = None, accel_time: float | None = None,
                blocking: bool = True) -> None:
        """Move so that the physical joints reach q (5,) rad (see the module notes)."""
        self._check("motion")
        q = np.asarray(q, dtype=float)
        if q.shape != (5,) or not np.all(np.isfinite(q)):
            raise ValueError(f"move_to takes 5 finite joint angles (rad), got {q!r}")
        q_cmd = self.sag.command(q, self.robot)
        q_from = np.asarray(self.arm.joint_positions(), dtype=float)
        if moving_time is not None and velocity_violations(q_from, q_cmd, moving_time, self.robot):
            need = float(np.max(np.abs(q_cmd - q_from) / self.robot.velocity)) * _SPEED_MARGIN
            scale = need / moving_time
            moving_time = need
            accel_time = None if accel_time is None else accel_time * scale
        self.sent.append((q_from, q_cmd, moving_time, accel_time))
        self.arm.move_to(q_cmd, moving_time=moving_time, accel_time=accel_time, blocking=blocking)

    def open_gripper(self) -> None:
        self._check("opening the gripper")
        self.arm.open_gripper()

    def close_gripper(self) -> bool:
        self._check("closing the gripper")
        return self.arm.close_gripper()

    def is_moving(self) -> bool:
        return self.arm.is_moving()

    def wait(self) -> None:
        self.arm.wait()

    def home(self, moving_time: float | None = None) -> None:
        self.move_to(np.asarray(self.robot.home, float), moving_time)

    def sleep(self, moving_time: float | None = None) -> None:
        self.move_to(np.asarray(self.robot.sleep, float), moving_time)

    def set_torque(self, enabled: bool) -> None:
        self.arm.set_torque(enabled)

    def emergency_stop(self) -> None:
        self.arm.emergency_stop()

    def reset(self) -> None:
        self.arm.reset()
