"""Ctrl+C (or a Jupyter interrupt: both are SIGINT) while a real station with an arm is open: hold the arm where it
is, then raise KeyboardInterrupt, so leaving the `with` block (or Station.close()) still parks it.

A move already sent is in the servos and would run to its end; the hold replaces it with the measured position.
ROS keeps running, since rclpy is started without its own handlers (armlab.hardware.ros_session), so the sleep move
can still be sent. The handler exists only while the station is open and only when it was opened in the main thread;
closing puts the previous handler back (a second Ctrl+C during the sleep move then interrupts the waiting, not the
move, which the servos finish).
"""

from __future__ import annotations

import signal
import threading
import traceback
import warnings
from collections.abc import Callable

__all__ = ["install_sigint"]


def install_sigint(hold: Callable[[], None]) -> Callable[[], None]:
    """Make SIGINT call hold(), then raise KeyboardInterrupt; returns restore() (idempotent, restores the previous
    handler only while ours is still installed). Outside the main thread nothing is installed (RuntimeWarning)."""
    if threading.current_thread() is not threading.main_thread():
        warnings.warn("make_station('real') outside the main thread: no SIGINT handler, so Ctrl+C will not hold "
                      "the arm", RuntimeWarning, stacklevel=3)
        return lambda: None
    previous = signal.getsignal(signal.SIGINT)
    state = {"installed": True}

    def handler(signum, frame) -> None:
        try:
            hold()
        except BaseException:                 # say why, then interrupt all the same
            traceback.print_exc()
        raise KeyboardInterrupt("interrupted: the arm holds its position")

    def restore() -> None:
        if state["installed"]:
            state["installed"] = False
            if signal.getsignal(signal.SIGINT) is handler and threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)

    signal.signal(signal.SIGINT, handler)
    return restore
