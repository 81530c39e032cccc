"""Hidden checks of exercise station.machine: scripted sessions of the student's StationMachine over a port that logs
what it is asked: random button sequences (commands whose work returns, fails, is stopped by the arm or by the
button, or presses another button; teaching, recording, finishing and repeating; stops and resets), and a stop in
every state; each press's outcome, the state after it, everything the port was asked, the history and the program
are compared with the reference's (armlab_course.grading.hidden). Both run their commands through the kit's stand-in
transition in place of the notebook's run_command (adapters._call_machine), so station.transition's answer counts
for its own exercise only."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec

_BUTTONS = ("calibrate", "detect", "execute", "click-grab", "click-drop", "teach", "record", "finish", "repeat",
            "estop", "reset")
_WEIGHTS = np.array([1, 1, 1, 1, 1, 2.5, 3, 1.5, 1.5, 1, 1.5], float)
_OUTCOMES = ("ok", "arm_stop", "button_stop", "error", "nested")
_OUTCOME_WEIGHTS = np.array([4, 1, 1, 1.5, 1], float)


def _press(rng, button: str) -> list:
    if button == "record":
        return [button, str(rng.choice(["open", "closed"]))]
    return [button, _OUTCOMES[int(rng.choice(len(_OUTCOMES), p=_OUTCOME_WEIGHTS / _OUTCOME_WEIGHTS.sum()))]]


def _stop_in_every_state(rng) -> list:
    """Idle, teach (after a record or two), each command's state and repeat (the button during the work), estop
    itself: a stop, then a refused button, then the reset."""
    script = [["teach", "ok"], ["record", "closed"], ["finish", "ok"]]
    for where in ("idle", "teach", *_BUTTONS[:5], "repeat", "estop"):
        if where == "teach":
            script += [["teach", "ok"], ["record", "open"], ["estop", "ok"]]
        elif where in ("idle", "estop"):
            script += [["estop", "ok"]] * (2 if where == "estop" else 1)
        else:
            script += [[where, "button_stop"]]
        script += [_press(rng, str(rng.choice(_BUTTONS[:9]))), ["reset", "ok"]]
    return script


def _sessions(rng):
    # four checks of three random scripts (15-25 presses each), then one check of the stop in every state
    checks = []
    for _ in range(4):
        calls = []
        for _ in range(3):
            n = int(rng.integers(15, 26))
            buttons = rng.choice(len(_BUTTONS), n, p=_WEIGHTS / _WEIGHTS.sum())
            calls.append([[_press(rng, _BUTTONS[int(b)]) for b in buttons]])
        checks.append(calls)
    checks.append([[_stop_in_every_state(rng)]])
    return checks


SPECS = (HiddenSpec("StationMachine", _sessions, atol=1e-9, adapter="_call_machine", prelude="definitions",
                    what="each press's outcome and state, what the port was asked, the history and the program"),)
# latching_transition is not forbidden: the checks put it in place of run_command (adapters._call_machine)
FORBIDDEN = ("TaskMachine", "command_transition", "armlab.tasks.transition", "armlab.tasks.buttons",
             "refuse_out_of_turn", "latching_refusal", "OwnMachine")
