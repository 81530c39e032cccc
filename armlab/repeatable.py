"""Repeatable numerics: results that do not change from one run to the next on the same machine.

OpenCV's iterative solvers (cv2.calibrateCamera, cv2.solvePnP and its refinement) split their sums over worker
threads, and the order in which the partial sums are added then depends on the thread timing: on a 2-core machine
cv2.calibrateCamera returned focal lengths differing by 4e-7 px between two calls on the same corners. Downstream that
moves every world point by ~1e-9 mm, which the simulator's pixel and encoder grids can turn into visible differences.
`opencv_single_thread()` runs such a call on one thread (same answer every time; these calls take milliseconds).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import cv2

__all__ = ["opencv_single_thread"]

_LOCK = threading.Lock()


@contextmanager
def opencv_single_thread() -> Iterator[None]:
    """Run the enclosed OpenCV calls on one thread, then restore the previous thread count (thread-safe)."""
    with _LOCK:
        before = cv2.getNumThreads()
        cv2.setNumThreads(1)
        try:
            yield
        finally:
            cv2.setNumThreads(before)
