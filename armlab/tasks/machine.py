"""The station's state machine (the lab's GUI states): idle, estop, calibrate, detect, execute, teach, repeat,
click-grab, click-drop.

Every command runs from "idle" and returns there; "teach" lasts from teach_start() to teach_finish(); a teaching
button pressed out of turn (teach_start outside "idle", teach_record / teach_finish outside "teach") goes to the
machine's refusal (default_refusal(): the kit's armlab.tasks.buttons.refuse_out_of_turn in the instructor's tree, which
refuses it and changes nothing; left out of the student release, where with the kit's transition it answers exercise
station.machine, and the release's latching_refusal stops the station instead). The
emergency stop is honoured at every step: estop() (safe to call from another thread or a callback while a command
runs) halts the arm at once (arm.emergency_stop()), and the guarded arm the commands move through
(tasks.GuardedArm) refuses every further command, so the running command ends with EmergencyStopped and the machine
stays in "estop". An EmergencyStopped raised by the arm itself (a hardware stop) has the same effect. In "estop" every
command is refused (EmergencyStopped) until reset(). Any other error returns the machine to "idle" and propagates.
`history` lists the states entered, in order. The machine drives a task session (tasks.start_session(station)):
its commands move the session's guarded arm, whose stop request is the machine's.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NoReturn

import numpy as np

from armlab import planning
from armlab.slots import kit_or_standin
from armlab.station.contract import EmergencyStopped

from . import teach
from .port import command_work
from .session import Session, as_session
from .states import STATES, MachineBusy

__all__ = ["STATES", "TaskMachine", "MachineBusy", "Transition", "latching_transition", "default_transition",
           "Refusal", "latching_refusal", "default_refusal"]

Transition = Callable[["TaskMachine", str, Callable[[], Any]], Any]
Refusal = Callable[["TaskMachine", str, str], NoReturn]


def latching_transition(machine: TaskMachine, state: str, action: Callable[[], Any]) -> Any:
    """The transition that stands in where the kit's own (armlab.tasks.transition, instructor only) is not installed:
    from "idle" into `state`, run `action`, back to "idle" with its result; refused (EmergencyStopped in "estop",
    MachineBusy elsewhere) with nothing entered; and ANY failure -- a stop, or any other error of the action --
    latches the machine in "estop" until reset() and propagates (a stop at the end raises EmergencyStopped). It is
    stricter than the lab's rule (module notes), which lets an ordinary error return to "idle": every failure needs
    a reset here."""
    if machine.state != "idle":
        refused = EmergencyStopped if machine.state == "estop" else MachineBusy
        raise refused(f"{state} refused: the machine is in {machine.state!r}")
    machine.enter(state)
    failed = True
    try:
        result = action()
        if machine.stop_requested:
            raise EmergencyStopped(f"{state} was emergency-stopped")
        failed = False
        return result
    finally:
        ending = "estop" if failed else "idle"
        if machine.state != ending:
            machine.enter(ending)


def default_transition() -> Transition:
    """The machine's transition when none is given: the kit's command_transition where it is installed (the
    instructor's tree), latching_transition otherwise (the student release)."""
    return kit_or_standin(f"{__package__}.transition", "command_transition", latching_transition)


def latching_refusal(machine: TaskMachine, button: str, wanted: str) -> NoReturn:
    """The refusal that stands in where the kit's own (armlab.tasks.buttons, instructor only) is not installed: a
    teaching button (`button`) pressed while the machine is not in the state it needs (`wanted`) stops the station
    (machine.estop(): the arm halts, the machine latches in "estop" until reset()) and raises EmergencyStopped. It is
    stricter than the lab's rule, which refuses such a button and changes nothing."""
    was = machine.state
    machine.estop()
    raise EmergencyStopped(f"{button} pressed in {was!r} (it needs {wanted!r}): the student release's machine stops "
                           f"the station on a button out of turn; call reset() first")


def default_refusal() -> Refusal:
    """The machine's refusal of a teaching button out of turn: the kit's refuse_out_of_turn where it is installed (the
    instructor's tree), latching_refusal otherwise (the student release)."""
    return kit_or_standin(f"{__package__}.buttons", "refuse_out_of_turn", latching_refusal)


class TaskMachine:
    """The lab's state machine over a task session (tasks.start_session(station), sim or real). `transition` runs
    each command through the states (module notes; default: default_transition()); replace it on an instance with
    your own function of the same signature; `refuse` likewise for a teaching button out of turn (default:
    default_refusal()). `session` is the session driven, `station` its station."""

    def __init__(self, session: Session, transition: Transition | None = None):
        self.session = as_session(session, "TaskMachine")
        self.station = self.session.station
        self.state = "idle"
        self.history: list[str] = ["idle"]
        self.program: teach.TeachProgram | None = None
        self.transition = transition or default_transition()
        self.refuse = default_refusal()
        self._stop = False
        self._recorder: teach.Recorder | None = None

    # -- states ---------------------------------------------------------------------------------------------
    def enter(self, state: str) -> None:
        """Enter `state` (one of STATES) and add it to the history."""
        if state not in STATES:
            raise ValueError(f"unknown state {state!r}: the machine's states are {', '.join(STATES)}")
        self.state = state
        self.history.append(state)

    _enter = enter

    @property
    def stop_requested(self) -> bool:
        """True from estop() until reset()."""
        return self._stop

    def _guarded(self) -> Session:
        """The session, its guarded arm stopping at this machine's stop request."""
        self.session.arm.should_stop = lambda: self._stop
        return self.session

    def _run(self, state: str, action: Callable[[], Any]) -> Any:
        return self.transition(self, state, action)

    # -- safety ---------------------------------------------------------------------------------------------
    def estop(self) -> None:
        """Halt the arm now; every command is refused until reset()."""
        self._stop = True
        self.station.arm.emergency_stop()
        if self.state != "estop":
            self._enter("estop")

    def reset(self) -> None:
        """Leave "estop": re-initialise the arm (torque on, where it stopped) and go to "idle"."""
        self.station.arm.reset()
        self._stop = False
        self._recorder = None
        self._enter("idle")

    # -- commands -------------------------------------------------------------------------------------------
    def calibrate(self, intrinsics="checkerboard"):
        """Calibrate the camera again (tasks.perception.calibrate_camera); the session's calibration becomes the new
        one, which is returned."""
        return self._run("calibrate", lambda: command_work(self._guarded(), "calibrate", intrinsics))

    def detect(self) -> list:
        """Look at the board (arm out of view) and return the detected blocks."""
        return self._run("detect", lambda: command_work(self._guarded(), "detect"))

    def execute(self, work) -> Any:
        """Run a planning.Plan through the session's executor (session.run: checked whole with what is held and known
        before its first command; returns planning.ExecutionResult) or a list of (block, place position) pairs: pick
        each block and place it (returns the list of pick answers)."""
        return self._run("execute", lambda: command_work(self._guarded(), "execute", work))

    def click_grab(self, uv) -> bool:
        """Pick the block under pixel uv of the current frame (tasks.click_grab)."""
        return self._run("click-grab", lambda: command_work(self._guarded(), "click-grab", uv))

    def click_drop(self, uv) -> bool:
        """Drop the held block on the surface under pixel uv of the current frame (tasks.click_drop)."""
        return self._run("click-drop", lambda: command_work(self._guarded(), "click-drop", uv))

    def teach_start(self, name: str = "") -> None:
        """Enter "teach": torque off; pose the arm by hand and call teach_record() at each waypoint."""
        if self.state != "idle":
            self.refuse(self, "teach", "idle")
        self._recorder = teach.Recorder(self.station.arm, name)
        self._enter("teach")

    def teach_record(self, gripper: str = "open") -> np.ndarray:
        """Record the arm's joints (5,) rad with the gripper state wanted there."""
        if self.state != "teach" or self._recorder is None:
            self.refuse(self, "teach_record", "teach")
        return self._recorder.record(gripper)

    def teach_finish(self) -> teach.TeachProgram:
        """Torque back on, leave "teach"; the recorded program becomes `program` (and is returned)."""
        if self.state != "teach" or self._recorder is None:
            self.refuse(self, "teach_finish", "teach")
        rec, self._recorder = self._recorder, None
        try:
            self.program = rec.finish()
        finally:
            self._enter("idle")
        return self.program

    def repeat(self, program: teach.TeachProgram | None = None) -> planning.ExecutionResult:
        """Replay a program (default: the last taught one) through the guarded arm."""
        program = program or self.program
        if program is None:
            raise ValueError("nothing to repeat: teach a program or pass one")
        return self._run("repeat", lambda: teach.repeat(self._guarded(), program))
