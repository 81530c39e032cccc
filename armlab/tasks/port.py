"""The small interface a station's state machine drives (exercise station.machine, notebook 08): the arm's stop,
restart, torque and joints, a command's work and a taught program's replay, over a task session
(tasks.start_session(station)).

A machine of one's own takes a port and calls only these; the kit's TaskMachine runs its commands' work through
`command_work` too, so both do the same thing for a button. The port's stop latch is the guarded arm's stop request:
after halt() every arm command of the session raises EmergencyStopped until restart(). OwnMachine puts a machine of
one's own (press(button, *args)) behind the kit's control station (armlab.ui.station_panel(session,
machine=OwnMachine(session, StationMachine))); its E-STOP halts the arm through the port before the machine hears of
it, so a stop never depends on the machine's code.
Units: mm, rad, s; world (board) frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armlab import planning

from . import click, handling, perception, teach
from .session import Session, as_session

__all__ = ["COMMANDS", "BUTTONS", "command_work", "SessionPort", "OwnMachine"]

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


class OwnMachine:
    """A machine of one's own behind the kit's panel and click-to-grab (the calls they make of a tasks.TaskMachine,
    each one press of a button): `make(port)` builds it over a SessionPort of `session` (e.g. notebook 08's
    StationMachine, exercise station.machine), and it keeps `state`, `history` and `program` ([(joints (5,) rad,
    gripper), ...] or None). estop() halts the arm through the port first (the guarded arm then refuses every arm
    command until the port restarts), then presses the machine's "estop"; what that press raises is kept in
    `estop_error`, never raised: the stop has happened whatever the machine does."""

    def __init__(self, session: Session, make):
        self.port = SessionPort(session)
        self.session, self.station = self.port.session, self.port.session.station
        self.own = make(self.port)
        self.estop_error: BaseException | None = None
        if not callable(getattr(self.own, "press", None)):
            raise TypeError(f"a machine of one's own has press(button, *args), got {type(self.own).__name__}")

    @property
    def state(self) -> str:
        return self.own.state

    @property
    def history(self) -> list[str]:
        return self.own.history

    @property
    def stop_requested(self) -> bool:
        """True from the E-STOP until the machine's reset restarts the port."""
        return self.port.stopped

    @property
    def program(self) -> teach.TeachProgram | None:
        """The machine's taught waypoints as a TeachProgram (None until it holds two or more valid ones)."""
        waypoints = getattr(self.own, "program", None)
        try:
            joints, grippers = zip(*waypoints)
            return teach.TeachProgram(np.asarray(joints, float).reshape(-1, 5), tuple(grippers), "taught")
        except (TypeError, ValueError):
            return None

    def estop(self) -> None:
        self.port.halt()
        try:
            self.own.press("estop")
        except Exception as e:          # the stop has happened: the machine's failure to hear it is its own
            self.estop_error = e

    def reset(self) -> None:
        self.own.press("reset")

    def calibrate(self, intrinsics="checkerboard"):
        return self.own.press("calibrate", intrinsics)

    def detect(self) -> list:
        return self.own.press("detect")

    def execute(self, work) -> Any:
        return self.own.press("execute", work)

    def click_grab(self, uv) -> bool:
        return self.own.press("click-grab", uv)

    def click_drop(self, uv) -> bool:
        return self.own.press("click-drop", uv)

    def teach_start(self, name: str = "") -> None:
        self.own.press("teach")

    def teach_record(self, gripper: str = "open") -> np.ndarray:
        return self.own.press("record", gripper)

    def teach_finish(self):
        """Press "finish"; the program as the panel counts it (an empty tuple when there is none)."""
        self.own.press("finish")
        return self.program or ()

    def repeat(self, program=None):
        return self.own.press("repeat")
