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


class _Arm:
    """The stand-in arm: it only hears the stop and the reset."""

    def __init__(self):
        self.stops = 0

    def emergency_stop(self):
        self.stops += 1

    def reset(self):
        pass


class _Station:
    def __init__(self):
        self.arm = _Arm()


def _call_transition(function, script):
    """Per event of the script: [what the call gave (0 the action's result, 1 EmergencyStopped, 2 MachineBusy,
    3 ValueError, 4 anything else or a wrong result), the state after (index in STATES)], then the history (indices)."""
    from armlab.station.contract import EmergencyStopped
    from armlab.tasks.machine import STATES, MachineBusy, TaskMachine
    from armlab.tasks.session import Session

    station = _Station()
    machine = TaskMachine(Session(station, station.arm), transition=function)   # a stand-in session: no calibration

    def command(state, work):
        return machine.transition(machine, state, work)

    def work_of(kind, k):
        if kind == "ok":
            return lambda: k
        if kind == "arm_stop":
            def stop():
                raise EmergencyStopped("the arm stopped")
            return stop
        if kind == "button_stop":
            return lambda: (machine.estop(), k)[1]
        if kind == "error":
            def fail():
                raise ValueError("the work failed")
            return fail
        if kind == "error_after_stop":
            def stop_then_fail():
                machine.estop()
                raise ValueError("the work failed after the stop")
            return stop_then_fail

        def nested():                                  # another command from inside: refused, the outer one goes on
            try:
                command("detect", lambda: -1)
            except MachineBusy:
                return k
            return -2
        return nested

    out = []
    for k, (kind, state) in enumerate(script):
        if kind == "estop":
            machine.estop()
            code = 0
        elif kind == "reset":
            machine.reset()
            code = 0
        else:
            try:
                code = 0 if command(state, work_of(kind, k)) == k else 4
            except EmergencyStopped:
                code = 1
            except MachineBusy:
                code = 2
            except ValueError:
                code = 3
            except Exception:
                code = 4
        out += [float(code), float(STATES.index(machine.state))]
    return out + [float(STATES.index(s)) for s in machine.history]


SPECS = (HiddenSpec("run_command", _scripts, atol=0, adapter="_call_transition", prelude="definitions"),)
FORBIDDEN = ("command_transition", "TaskMachine._run")
