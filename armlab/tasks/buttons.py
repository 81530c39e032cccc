"""The kit's refusal of a teaching button pressed out of turn on the station's state machine (instructor only: left
out of the student release, where with the kit's transition it answers exercise station.machine; the release's
machine runs armlab.tasks.machine.latching_refusal instead). The rules are the module notes of armlab.tasks.machine.
"""

from __future__ import annotations

from typing import Any, NoReturn

from armlab.station.contract import EmergencyStopped

from .states import MachineBusy

__all__ = ["refuse_out_of_turn"]


def refuse_out_of_turn(machine: Any, button: str, wanted: str) -> NoReturn:
    """Refuse `button` of `machine` (a tasks.machine.TaskMachine), which needs the state `wanted`, and change nothing:
    EmergencyStopped when teaching is asked for in "estop" (reset first), MachineBusy otherwise."""
    if wanted == "idle" and machine.state == "estop":
        raise EmergencyStopped(f"{button} refused: the station is emergency-stopped; call reset() first")
    raise MachineBusy(f"{button} refused: the machine is in {machine.state!r}"
                      + (f", not {wanted!r}" if wanted != "idle" else ""))
