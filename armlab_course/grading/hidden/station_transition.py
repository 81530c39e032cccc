"""Hidden checks of exercise station.transition: random sequences of commands whose work returns, fails, is
emergency-stopped by the arm or by the button (during the work), starts another command, or arrives while stopped,
with resets; the student's transition drives a TaskMachine over a stand-in station and every outcome, state and the
whole history are compared with the kit's (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec

_EVENTS = ("ok", "arm_stop", "button_stop", "error", "error_after_stop", "nested", "estop", "reset")
_STATES = ("calibrate", "detect", "execute", "repeat", "click-grab", "click-drop")


def _scripts(rng):
    # four checks of three scripts, 12-20 events each; the kinds weighted so stops, resets and refusals all occur
    weights = np.array([4, 1, 1, 2, 1, 1, 1, 2], float)
    checks = []
    for _ in range(4):
        calls = []
        for _ in range(3):
            n = int(rng.integers(12, 21))
            kinds = rng.choice(len(_EVENTS), n, p=weights / weights.sum())
            calls.append([[[_EVENTS[int(k)], _STATES[int(rng.integers(len(_STATES)))]] for k in kinds]])
        checks.append(calls)
    return checks


SPECS = (HiddenSpec("run_command", _scripts, atol=0, adapter="_call_transition", prelude="definitions",
                    what="what each command gave and the state after it"),)
FORBIDDEN = ("command_transition", "TaskMachine._run")
