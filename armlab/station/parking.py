"""How every arm backend ends when its station closes (the motion contract, armlab.station.contract): park in the
sleep pose, torque on first if it was off, unless emergency-stopped (then it holds where it is and a RuntimeWarning
says so); afterwards the arm is closed, whatever happened. One rule for the simulated and the real arm."""

from __future__ import annotations

import warnings

__all__ = ["park_and_close"]


def park_and_close(arm, what: str, advice: str = "") -> None:
    """Park `arm` (an armlab.station.Arm with a writable `closed` flag) and mark it closed; idempotent.

    what: how the warning names the arm ("the simulated arm"); advice: appended to the warning and the error (", support
    it before powering it off"). A refused or failed sleep move still closes the arm and raises RuntimeError."""
    if arm.closed:
        return
    try:
        if arm.emergency_stopped:
            warnings.warn(f"{what} is emergency-stopped: it was not moved to its sleep pose and holds its "
                          f"position{advice}", RuntimeWarning, stacklevel=3)
            return
        if not arm.torque_enabled:
            arm.set_torque(True)
        arm.sleep()
    except Exception as e:
        raise RuntimeError(f"the arm could not go to its sleep pose ({e}){advice}") from e
    finally:
        arm.closed = True
