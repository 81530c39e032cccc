"""The small interface a station's state machine drives (exercise station.machine, notebook 08): the arm's stop,
restart, torque and joints, a command's work and a taught program's replay, over a task session
(tasks.start_session(station)).

A machine of one's own takes a port and calls only these; the kit's TaskMachine runs its commands' work through
`command_work` too, so both do the same thing for a button. The port's stop latch is the guarded arm's stop request:
after halt() every arm command of the session raises EmergencyStopped until restart().
Units: mm, rad, s; world (board) frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armlab import planning

from . import click, handling, perception, teach
from .session import Session, as_session

__all__ = ["COMMANDS", "BUTTONS", "command_work", "SessionPort"]

COMMANDS: tuple[str, ...] = ("calibrate", "detect", "execute", "click-grab", "click-drop")
BUTTONS: tuple[str, ...] = (*COMMANDS, "teach", "record", "finish", "repeat", "estop", "reset")


def command_work(session: Session, command: str, *args) -> Any:
    """The work of one command (one of COMMANDS) in a session whose arm is guarded:
    "calibrate" [intrinsics]: calibrate the camera again (the session's calibration becomes the new one, returned);
    "detect": look at the board (arm out of view), the detected blocks;
    "execute" work: a planning.Plan run through the session's executor (its ExecutionResult), or a list of (block,
    place position mm) pairs, each picked and placed (the pick answers);
    "click-grab" uv / "click-drop" uv: pick the block under pixel uv / drop the held one on the surface there.
    ValueError naming the command otherwise."""
    if command == "calibrate":
        session.calibration = perception.calibrate_camera(session.station, *(args or ("checkerboard",)), arm=session)
        return session.calibration
    if command == "detect":
        return handling.look(session).blocks
    if command == "execute":
        work, = args
        if isinstance(work, planning.Plan):
            return session.run(work, "the state machine's plan")
        out = []
        for block, position in work:
            out.append(handling.pick(session, block))
            if out[-1]:
                handling.place(session, np.asarray(position, float))
        return out
    if command == "click-grab":
        return click.click_grab(session, *args)
    if command == "click-drop":
        return click.click_drop(session, *args)
    raise ValueError(f"unknown command {command!r}: the commands are {', '.join(COMMANDS)}")


class SessionPort:
    """The port over a task session (module notes): halt(), restart(), set_torque(on), joints(), work(command,
    *args) and replay(joints, grippers)."""

    def __init__(self, session: Session):
        self.session = as_session(session, "SessionPort")
        self.stopped = False
        self.session.arm.should_stop = lambda: self.stopped

    def halt(self) -> None:
        """Stop the arm now; every arm command raises EmergencyStopped until restart()."""
        self.stopped = True
        self.session.station.arm.emergency_stop()

    def restart(self) -> None:
        """Re-initialise the arm after a stop (torque on, where it stopped); arm commands run again."""
        self.session.station.arm.reset()
        self.stopped = False

    def set_torque(self, on: bool) -> None:
        """Torque on (the arm holds its pose) or off (limp: it can be posed by hand, and falls unless held)."""
        self.session.station.arm.set_torque(bool(on))

    def joints(self) -> np.ndarray:
        """The arm's joint angles (5,) rad as it reads them now."""
        return np.asarray(self.session.station.arm.joint_positions(), dtype=float)

    def work(self, command: str, *args) -> Any:
        """Run one command's work (command_work) on the guarded arm."""
        return command_work(self.session, command, *args)

    def replay(self, joints, grippers) -> planning.ExecutionResult:
        """Replay waypoints (N, 5) rad with their gripper states through the executor (teach.repeat)."""
        program = teach.TeachProgram(np.asarray(joints, float).reshape(-1, 5), tuple(grippers), "taught")
        return teach.repeat(self.session, program)
