"""The kit's transition of the station's state machine (instructor only: left out of the student release, where it
is the answer of exercise station.transition; the release's machine runs armlab.tasks.machine.latching_transition
instead). The rules it follows are the module notes of armlab.tasks.machine.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from armlab.station.contract import EmergencyStopped

from .states import MachineBusy

__all__ = ["command_transition"]


def command_transition(machine: Any, state: str, action: Callable[[], Any]) -> Any:
    """The kit's transition of one command of `machine` (a tasks.machine.TaskMachine): from "idle" into `state`, run
    `action`, and back to "idle" with its result; refused (EmergencyStopped) in "estop" and (MachineBusy) in any other
    state, with nothing entered; an emergency stop during or at the end of the action leaves the machine in "estop"
    (entered once) and raises EmergencyStopped; any other error returns to "idle" (or stays in "estop" when a stop was
    requested) and propagates."""
    if machine.state != "idle":
        refused = EmergencyStopped if machine.state == "estop" else MachineBusy
        raise refused(f"{state} refused: the machine is in {machine.state!r}"
                      + ("; call reset() first" if refused is EmergencyStopped else ""))
    machine.enter(state)
    ending = "estop"                         # unless the action ends, or fails, with no stop requested
    try:
        result = action()
        if machine.stop_requested:           # stopped between the last command and the end of the action
            raise EmergencyStopped(f"{state} was emergency-stopped")
        ending = "idle"
        return result
    except EmergencyStopped:
        raise
    except BaseException:
        ending = "estop" if machine.stop_requested else "idle"
        raise
    finally:
        if machine.state != ending:          # estop() has entered "estop" already when it came from the button
            machine.enter(ending)
