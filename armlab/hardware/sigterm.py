"""Close the real station when the process is asked to stop (SIGTERM: `kill <pid>`, a job scheduler, a notebook
kernel being shut down), so the arm goes to its sleep pose before robot_shutdown() instead of falling onto the board.

atexit does not run on SIGTERM (Python's default action kills the process at once), hence a handler. It is
installed only by make_station("real") with an arm, only from the main thread (Python delivers signals there), and
the handler that was there before is put back when the station closes. After closing, the signal goes on to that
previous handler: a Python handler is called, the default action is re-raised (the process ends killed by SIGTERM,
as the sender expects), an ignored signal stays ignored.

rclpy.init() (run while the Interbotix API starts) installs its own SIGTERM handler from C, which shuts ROS down at
once -- too early to send the sleep move. The station's handler, installed after the API has started, replaces it
while the station is open; Python cannot reinstate a C handler, so closing leaves the default action (by then
robot_shutdown() has stopped ROS anyway).
"""

from __future__ import annotations

import os
import signal
import threading
import traceback
import warnings
from collections.abc import Callable

__all__ = ["install_sigterm"]


def install_sigterm(close: Callable[[], None]) -> Callable[[], None]:
    """Make SIGTERM call close() first; returns restore(), which puts the previous handler back (idempotent, and only
    while ours is still the installed one). Outside the main thread nothing is installed (a RuntimeWarning says
    so) and restore() does nothing."""
    if threading.current_thread() is not threading.main_thread():
        warnings.warn("make_station('real') outside the main thread: no SIGTERM handler, so a `kill` of this process "
                      "will not put the arm to sleep; close the station before stopping the process",
                      RuntimeWarning, stacklevel=3)
        return lambda: None
    previous = signal.getsignal(signal.SIGTERM)
    state = {"installed": True}

    def restore() -> None:
        if state["installed"]:
            state["installed"] = False
            if signal.getsignal(signal.SIGTERM) is handler and threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)

    def handler(signum, frame) -> None:
        restore()
        try:
            close()
        except BaseException:                             # say why, then stop as asked all the same
            traceback.print_exc()
        if callable(previous):
            previous(signum, frame)
        elif previous in (signal.SIG_DFL, None):
            os.kill(os.getpid(), signal.SIGTERM)          # the default action, now that ours is gone

    signal.signal(signal.SIGTERM, handler)
    return restore
