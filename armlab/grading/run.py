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

__all__ = ["DEFAULT_LIMITS", "Limits", "CellResult", "NotebookRun", "bounded", "run_notebook", "run_harness",
           "check_cells"]

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


def _environment(worktree: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST", "ARMLAB_MESHCAT"))}
    env.update(PYTHONPATH=str(worktree), MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")
    return env


def bounded(cmd: list[str], worktree: Path, limits: Limits) -> tuple[bool, str]:
    """Run `cmd` in `worktree` in a new session under `limits`; (finished in time, its output). The whole process
    group (the notebook's kernel, anything it started) is killed at the end."""
    proc = subprocess.Popen(cmd, cwd=worktree, env=_environment(worktree), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True,
                            preexec_fn=_limit(limits))
    try:
        out, _ = proc.communicate(timeout=limits.timeout_s)
        done = True
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        done = False
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return done, out.decode(errors="replace")[-20000:]


def run_harness(worktree: Path, request: dict, limits: Limits = DEFAULT_LIMITS) -> tuple[list[dict] | None, str]:
    """Call an exercise's function in a bounded subprocess of `worktree` (armlab.grading.harness): its JSON results
    per call, or None and why."""
    req, res = worktree / ".grader-request.json", worktree / ".grader-results.json"
    req.write_text(json.dumps(request))
    res.unlink(missing_ok=True)
    # the grader's own harness file, run as a script so that the work tree needs no copy of it
    harness = Path(__file__).with_name("harness.py")
    launch = f"import runpy, sys; sys.argv = {[str(harness), str(req), str(res)]!r}; " \
             f"runpy.run_path(sys.argv[0], run_name='__main__')"
    done, out = bounded([sys.executable, "-c", launch], worktree, limits)
    if not done:
        return None, f"the hidden checks did not finish within {limits.timeout_s:g} s (wall clock)"
    try:
        results = json.loads(res.read_text())
        if not isinstance(results, list) or not all(isinstance(r, dict) for r in results):
            raise ValueError("not a list of results")
        return results, ""
    except (OSError, ValueError) as e:
        tail = " | ".join(out.strip().splitlines()[-2:])
        return None, f"the hidden checks gave no results ({type(e).__name__}): {tail}"[:600]


def run_notebook(worktree: Path, notebook: str, limits: Limits = DEFAULT_LIMITS, lax: bool = False) -> NotebookRun:
    """Run `notebook` (relative to `worktree`) under nbval with the instructor's sanitize file; per-cell results.
    lax: --nbval-lax (a cell fails only by raising; for a student's own notebooks, which hold no stored outputs)."""
    config = worktree / ".grader-pytest.ini"
    config.write_text(_CONFIG)
    junit = worktree / ".grader-junit.xml"
    cmd = [sys.executable, "-m", "pytest", "-q", "-c", str(config), "--rootdir", str(worktree), "-p",
           "no:cacheprovider", notebook, "--nbval-lax" if lax else "--nbval",
           "--nbval-sanitize-with", "tests/nbval_sanitize.cfg",
           f"--nbval-cell-timeout={int(limits.timeout_s)}", f"--junitxml={junit}"]
    done, out = bounded(cmd, worktree, limits)
    if not done:
        return NotebookRun({}, f"the notebook did not finish within {limits.timeout_s:g} s (wall clock)")
    if not junit.is_file():
        tail = out.strip().splitlines()[-3:]
        return NotebookRun({}, f"the notebook run ended without results : {' | '.join(tail)}")
    return NotebookRun(_parse_junit(junit))
