"""A pytest plugin the grader loads into its nbval runs (`-p armlab.grading.nbval_guard`, see run.py): a kernel that
dies (os._exit, a signal, the CPU limit) fails the running cell at once instead of leaving nbval waiting for the
cell timeout, and each stream output message is cut to OUTPUT_LIMIT characters (a cell printing hundreds of MB
keeps the run, its report and the grader's memory small; the cell fails its output comparison anyway).

It reaches nbval through pytest's plugin manager (the `nbval` plugin, nbval.plugin, and its RunningKernel), so
nothing here imports nbval: without nbval loaded it does nothing."""

from __future__ import annotations

import time
from queue import Empty

__all__ = ["OUTPUT_LIMIT", "POLL_S", "pytest_configure"]

OUTPUT_LIMIT = 100_000          # characters of one stream message kept
POLL_S = 1.0                    # how often (s) a wait for the kernel checks that it is alive


def _truncated(msg: dict) -> dict:
    content = msg.get("content", {})
    text = content.get("text")
    if msg.get("msg_type") == "stream" and isinstance(text, str) and len(text) > OUTPUT_LIMIT:
        content["text"] = text[:OUTPUT_LIMIT] + f"\n[... {len(text) - OUTPUT_LIMIT} more characters cut by the grader]"
    return msg


def _guard(get_message):
    def guarded_get_message(self, stream, timeout=None):
        """nbval's get_message, waiting in slices of POLL_S and raising RuntimeError once the kernel is dead."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else deadline - time.monotonic()
            wait = POLL_S if left is None else max(0.0, min(POLL_S, left))
            try:
                return _truncated(get_message(self, stream, timeout=wait))
            except Empty:
                if not self.is_alive():
                    raise RuntimeError("the kernel died while running the cell (a crash, os._exit, a signal, or the "
                                       "CPU or memory limit)") from None
                if left is not None and left <= POLL_S:
                    raise

    guarded_get_message.guarded = True
    return guarded_get_message


def pytest_configure(config) -> None:
    """Wrap nbval's RunningKernel.get_message (once) when nbval is loaded."""
    kernel = getattr(config.pluginmanager.get_plugin("nbval"), "RunningKernel", None)
    if kernel is not None and not getattr(kernel.get_message, "guarded", False):
        kernel.get_message = _guard(kernel.get_message)
