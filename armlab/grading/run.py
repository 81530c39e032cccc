"""Run one notebook of a grading work tree under `pytest --nbval` in a bounded subprocess and read its per-cell
results. The subprocess uses the instructor's sanitize file and a configuration the grader writes itself (`-c`,
`--rootdir`, `-p no:cacheprovider`); the child gets a CPU-seconds limit and an address-space cap
(resource.setrlimit, inherited by the notebook's kernel) and the whole process group is killed at the wall-clock
timeout."""

from __future__ import annotations

import json
import os
import re
import resource
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

__all__ = ["DEFAULT_LIMITS", "Limits", "CellResult", "NotebookRun", "run_notebook", "check_cells"]

_CHECK = re.compile(r"^\s*# CHECK[ \t]+(?P<ids>.+?)\s*$", re.MULTILINE)
_CONFIG = "[pytest]\naddopts =\nfilterwarnings =\n    ignore::DeprecationWarning\n"


@dataclass(frozen=True)
class Limits:
    """timeout_s: wall-clock seconds for the notebook run; cpu_s: CPU seconds per process; memory_mb: address space
    per process."""

    timeout_s: float = 300.0
    cpu_s: int = 300
    memory_mb: int = 8192


DEFAULT_LIMITS = Limits()


@dataclass(frozen=True)
class CellResult:
    passed: bool
    message: str = ""


@dataclass
class NotebookRun:
    """cells: per code-cell index (nbval's 'Cell N'), the result; problem: why the run gave no results (timeout,
    crash), '' otherwise."""

    cells: dict[int, CellResult]
    problem: str = ""


def check_cells(notebook: Path) -> dict[int, tuple[str, ...]]:
    """The notebook's CHECK-tagged code cells: code-cell index -> the exercise ids its '# CHECK' line names."""
    nb = json.loads(notebook.read_text(encoding="utf-8"))
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    tags = {}
    for i, cell in enumerate(code):
        found = _CHECK.search("".join(cell["source"]))
        if found:
            tags[i] = tuple(found["ids"].split())
    return tags


def _limit(limits: Limits):
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_CPU, (limits.cpu_s, limits.cpu_s + 5))
        cap = limits.memory_mb * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return apply


def _first_line(text: str, limit: int = 600) -> str:
    """The assertion or error line of a failure report, shortened."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    for ln in lines:
        if re.match(r"^(AssertionError|[A-Za-z_.]*(Error|Exception|Timeout)\b)", ln):
            return ln[:limit]
    return (lines[0] if lines else "failed")[:limit]


def _parse_junit(path: Path) -> dict[int, CellResult]:
    cells = {}
    for case in ET.parse(path).getroot().iter("testcase"):
        found = re.fullmatch(r"Cell (\d+)", case.get("name", ""))
        if not found:
            continue
        bad = case.find("failure")
        if bad is None:
            bad = case.find("error")
        skipped = case.find("skipped") is not None
        if bad is None and not skipped:
            cells[int(found[1])] = CellResult(True)
        else:
            text = (bad.get("message", "") + "\n" + (bad.text or "")) if bad is not None else "skipped"
            cells[int(found[1])] = CellResult(False, _first_line(text))
    return cells


def run_notebook(worktree: Path, notebook: str, limits: Limits = DEFAULT_LIMITS, lax: bool = False) -> NotebookRun:
    """Run `notebook` (relative to `worktree`) under nbval with the instructor's sanitize file; per-cell results.
    lax: --nbval-lax (a cell fails only by raising; for a student's own notebooks, which hold no stored outputs)."""
    config = worktree / ".grader-pytest.ini"
    config.write_text(_CONFIG)
    junit = worktree / ".grader-junit.xml"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST", "ARMLAB_MESHCAT"))}
    env.update(PYTHONPATH=str(worktree), MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-q", "-c", str(config), "--rootdir", str(worktree), "-p",
           "no:cacheprovider", notebook, "--nbval-lax" if lax else "--nbval",
           "--nbval-sanitize-with", "tests/nbval_sanitize.cfg",
           f"--nbval-cell-timeout={int(limits.timeout_s)}", f"--junitxml={junit}"]
    proc = subprocess.Popen(cmd, cwd=worktree, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, start_new_session=True, preexec_fn=_limit(limits))
    try:
        out, _ = proc.communicate(timeout=limits.timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return NotebookRun({}, f"the notebook did not finish within {limits.timeout_s:g} s (wall clock)")
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)       # the kernel and any process the notebook left behind
        except ProcessLookupError:
            pass
    if not junit.is_file():
        tail = out.decode(errors="replace").strip().splitlines()[-3:]
        return NotebookRun({}, f"the notebook run ended without results (exit {proc.returncode}): {' | '.join(tail)}")
    return NotebookRun(_parse_junit(junit))
