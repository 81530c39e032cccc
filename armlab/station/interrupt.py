"""Ctrl+C (or a Jupyter interrupt: both are SIGINT) while a station with an arm is open, on every backend: hold the
arm where it is, then raise KeyboardInterrupt, so leaving the `with` block (or Station.close()) still parks it.

This matters whenever the arm moves while Python waits on something else: a non-blocking move on the real arm (it is
in the servos and would run to its end) or on the simulator in real-time pacing (its clock follows the wall clock).
The hold replaces the move with where the arm is now. On the real arm ROS keeps running, since rclpy is started
without its own handlers (armlab.hardware.ros_session), so the sleep move can still be sent.

The handler exists only while the station is open and only when it was opened in the main thread (Python delivers
signals there); closing puts the previous handler back (a second Ctrl+C during the sleep move then interrupts the
waiting, not the move). It holds the arm through a weak reference: a station dropped without close() is not kept
alive by its handler, and a handler left behind by one holds nothing.
"""

from __future__ import annotations

import signal
import threading
import traceback
import warnings
import weakref
from collections.abc import Callable

__all__ = ["install_sigint"]


def install_sigint(hold: Callable[[], None], warn_outside_main: bool = True) -> Callable[[], None]:
    """Make SIGINT call hold() (a bound method of the arm, held weakly), then raise KeyboardInterrupt; returns
    restore() (idempotent: puts the previous handler back while ours is still the one installed). Outside the main
    thread nothing is installed (a RuntimeWarning when warn_outside_main)."""
    if threading.current_thread() is not threading.main_thread():
        if warn_outside_main:
            warnings.warn("a station opened outside the main thread: no SIGINT handler, so Ctrl+C will not hold "
                          "the arm", RuntimeWarning, stacklevel=3)
        return lambda: None
    target = weakref.WeakMethod(hold) if hasattr(hold, "__self__") else (lambda: hold)
    previous = signal.getsignal(signal.SIGINT)
    state = {"installed": True}

    def handler(signum, frame) -> None:
        method = target() if state["installed"] else None
        if method is not None:
            try:
                method()
            except BaseException:             # say why, then interrupt all the same
                traceback.print_exc()
        raise KeyboardInterrupt("interrupted: the arm holds its position")

    def restore() -> None:
        if state["installed"]:
            state["installed"] = False
            if signal.getsignal(signal.SIGINT) is handler and threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)

    signal.signal(signal.SIGINT, handler)
    return restore
