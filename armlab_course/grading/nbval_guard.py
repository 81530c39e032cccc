"""The pytest plugin of the grader's nbval runs (`-p armlab_grader.nbval_guard`, see run.py), running inside the
sandbox in pytest's own process, never in the kernel that runs student code:

- With --armlab-results PATH it reads the run's key from standard input before any kernel starts, makes itself
  undumpable (the kernel's processes cannot read its memory or files through /proc), records every cell's outcome
  and writes them to PATH signed with the key (run.py checks the signature).
- After each cell that passed it sends the kernel a probe (a silent cell printing a fresh nonce): the kernel's guard
  (kernel_startup.py) fails the probe when the cell, or one before it, changed the checks' machinery, and a probe
  whose nonce does not come back means its code never ran as written. Either way the cell fails.
- A cell that raises fails, whatever its tags or nbval comments say (the release tags its exercise and check cells
  "raises-exception" so that JupyterLab's Run All goes on past them; nbval would count them passed when they raise).
- A kernel that dies (os._exit, a signal, the CPU limit) fails the running cell at once instead of leaving nbval
  waiting for the cell timeout, and each stream output message is cut to OUTPUT_LIMIT characters.
- A failed cell's message is its exception's line and the traceback's frames in the student's own code: the
  notebook's cells and the exercise regions of package files (own_frames), never the kit's or the grader's.

It reaches nbval through pytest's plugin manager (the `nbval` plugin and its RunningKernel), so nothing here imports
nbval: without nbval loaded it does nothing but record.
"""

from __future__ import annotations

import re
import secrets
import sys
import time
from pathlib import Path
from queue import Empty

import pytest

from .child_common import close_stdin, first_line, hide_memory, read_key, write_signed

__all__ = ["OUTPUT_LIMIT", "POLL_S", "pytest_addoption", "pytest_configure"]

OUTPUT_LIMIT = 100_000          # characters of one stream message kept
POLL_S = 1.0                    # how often (s) a wait for the kernel checks that it is alive
PROBE_TIMEOUT_S = 120.0
_CELL = re.compile(r"::Cell (\d+)$")
_state: dict = {}
# The key is read when pytest imports this plugin (-p, before its capture makes standard input /dev/null).
_KEY = read_key() if any(a.startswith("--armlab-results") for a in sys.argv) else None


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


def pytest_addoption(parser) -> None:
    parser.addoption("--armlab-results", default=None, help="write the cells' outcomes here, signed (grader only)")


def pytest_configure(config) -> None:
    """Wrap nbval's RunningKernel.get_message (once) when nbval is loaded; take the run's key."""
    kernel = getattr(config.pluginmanager.get_plugin("nbval"), "RunningKernel", None)
    if kernel is not None and not getattr(kernel.get_message, "guarded", False):
        kernel.get_message = _guard(kernel.get_message)
    path = config.getoption("armlab_results")
    if path:
        if _KEY is None:
            raise pytest.UsageError("--armlab-results: the run's key was not on standard input")
        _state.update(key=_KEY, path=path, cells={})
        close_stdin()
        hide_memory()


def _probe(kernel) -> str:
    """'' when the kernel runs a fresh probe cell as written and its guard finds nothing changed; else why not."""
    nonce = secrets.token_hex(16)
    msg_id = kernel.kc.execute(f"print({nonce!r})", silent=True, store_history=False, allow_stdin=False)
    deadline = time.monotonic() + PROBE_TIMEOUT_S
    status, error, seen = None, "", ""
    while status is None:
        msg = kernel.get_message(stream="shell", timeout=max(0.1, deadline - time.monotonic()))
        if msg["parent_header"].get("msg_id") == msg_id:
            status = msg["content"].get("status")
            error = f"{msg['content'].get('ename', '')}: {msg['content'].get('evalue', '')}"
    while True:
        try:
            msg = kernel.get_message(stream="iopub", timeout=max(0.1, deadline - time.monotonic()))
        except Empty:
            break
        if msg["parent_header"].get("msg_id") != msg_id:
            continue
        if msg["msg_type"] == "stream":
            seen += msg["content"].get("text", "")
        if msg["msg_type"] == "status" and msg["content"].get("execution_state") == "idle":
            break
    if status != "ok":
        return error.strip(": ") or "the grader's probe failed"
    if nonce not in seen:
        return "the grader's probe did not run as written: a cell changed how the kernel runs code"
    return ""


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    options = getattr(item, "options", None)
    if _state and isinstance(options, dict):
        # A cell that raises fails the grader's run whatever its tags say: the student release tags its exercise and
        # check cells "raises-exception" (Run All goes on past them in JupyterLab), which nbval would count as passed.
        options["check_exception"] = False
    result = yield
    kernel = getattr(getattr(item, "parent", None), "kernel", None)
    if _state and kernel is not None and _CELL.search(item.nodeid):
        why = _probe(kernel)
        if why:
            raise AssertionError(f"GraderIntegrityError: {why}")
    return result


_CELL_FRAME = re.compile(r"^Cell In\[\d+\], line (\d+)(?:, in ([\w.<>]+))?")
_FILE_FRAME = re.compile(r"^File (\S+?):(\d+), in ([\w.<>]+)")
_ARROW = re.compile(r"^-+> (\d+) ?(.*)$")
_REGION = re.compile(r"^\s*#+\s*(BEGIN|END) SOLUTION\b")
MAX_FRAMES = 8


def _arrow(lines: list[str], start: int, number: int) -> str | None:
    """The code on the traceback's arrow line of line `number`, in the frame that starts at lines[start]."""
    for line in lines[start + 1:start + 40]:
        if _CELL_FRAME.match(line) or _FILE_FRAME.match(line):
            return None
        found = _ARROW.match(line)
        if found and int(found[1]) == number:
            return found[2].rstrip()
    return None


def _here(path: str) -> Path:
    """A traceback's file path (IPython writes the home as ~), resolved."""
    return Path(path).expanduser().resolve()


def _in_region(path: str, number: int) -> bool:
    """Whether line `number` of the work tree's file `path` lies inside an exercise region."""
    try:
        if not _here(path).is_relative_to(Path.cwd().resolve()):
            return False
        inside = False
        for i, line in enumerate(_here(path).read_text(encoding="utf-8").splitlines(), start=1):
            marker = _REGION.match(line)
            if marker:
                inside = marker[1] == "BEGIN"
            elif i == number:
                return inside
    except (OSError, UnicodeDecodeError, ValueError):
        pass
    return False


def own_frames(text: str, sources: list[str], upto: int, notebook: str) -> list[str]:
    """The frames of a failed cell's traceback (IPython's text) in the student's own code, innermost last (at most
    MAX_FRAMES): a notebook cell ("02_forward_kinematics cell 8, line 3, in helper": the latest code cell up to
    `upto` whose line holds the traceback's code) or an exercise region of a package file ("armlab/kinematics.py,
    line 120, in dh_link_transform"). The kit's, the libraries' and the grader's frames are left out."""
    lines = [re.sub(r"(\x1b|#x1B)\[[0-9;]*m", "", line).strip() for line in text.splitlines()]
    frames = []
    for k, line in enumerate(lines):
        cell = _CELL_FRAME.match(line)
        if cell:
            number, code = int(cell[1]), _arrow(lines, k, int(cell[1]))
            for i in range(min(upto, len(sources) - 1), -1, -1):
                held = sources[i].splitlines()
                if code is not None and number <= len(held) and held[number - 1].rstrip() == code:
                    function = (cell[2] or "<module>").rsplit(".", 1)[-1]
                    frames.append(f"{notebook} cell {i}, line {number}, in {function}")
                    break
            continue
        file = _FILE_FRAME.match(line)
        if file and _in_region(file[1], int(file[2])):
            frames.append(f"{_here(file[1]).relative_to(Path.cwd().resolve())}, line {file[2]}, "
                          f"in {file[3].rsplit('.', 1)[-1]}")
    return frames[-MAX_FRAMES:]


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    """A failed cell's report gets `armlab_where`: its traceback's frames in the student's own code (own_frames)."""
    report = yield
    if _state and report.failed and _CELL.search(report.nodeid):
        try:
            sources = [c.source for c in item.parent.nb.cells if c.cell_type == "code"]
            report.armlab_where = own_frames(report.longreprtext, sources, item.cell_num, Path(str(item.fspath)).stem)
        except Exception:                   # noqa: BLE001 -- no frames is a message without them, never a crash
            report.armlab_where = []
    return report


def pytest_runtest_logreport(report) -> None:
    found = _CELL.search(report.nodeid)
    if not _state or not found:
        return
    cell = int(found[1])
    if report.when == "call" or (report.when == "setup" and not report.passed):
        if report.passed:
            _state["cells"][cell] = (True, "")
        elif report.skipped:
            _state["cells"][cell] = (False, "skipped")
        else:
            where = getattr(report, "armlab_where", [])
            message = first_line(report.longreprtext, 300 if where else 600)
            _state["cells"][cell] = (False, f"{message} (in your code: {'; '.join(where)})" if where else message)


def pytest_sessionfinish(session, exitstatus) -> None:
    if _state:
        write_signed(_state["path"], {"cells": _state["cells"]}, _state["key"])
