"""Run one notebook of a grading work tree under `pytest --nbval` in a bounded subprocess and read its per-cell
results. The subprocess uses the instructor's sanitize file and a configuration the grader writes itself (`-c`,
`--rootdir`, `-p no:cacheprovider`), the grader's nbval guard (armlab.grading.nbval_guard: a dead kernel fails
its cell at once, stream outputs are cut) and a kernel profile of its own whose startup file caps what the kernel
prints (armlab.grading.kernel_startup). Every process of the run (pytest, the notebook's kernel, the hidden
checks' harness) gets a CPU-seconds limit, an address-space cap and a file-size cap (resource.setrlimit in the
child, inherited by everything it starts); its console output goes to a file of which only the end is read, and
the whole process group is killed at the wall-clock timeout."""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

__all__ = ["DEFAULT_LIMITS", "Limits", "CellResult", "NotebookRun", "bounded", "run_notebook", "run_harness",
           "check_cells"]

_CHECK = re.compile(r"^\s*# CHECK[ \t]+(?P<ids>.+?)\s*$", re.MULTILINE)
OUTPUT_TAIL = 20_000               # bytes of a run's console output kept (its end)
FILE_LIMIT = 2**30                  # bytes: no process of a run writes a larger file (RLIMIT_FSIZE)
_MAX_RESULTS_BYTES = 64 * 2**20     # a hidden-check result file larger than this is refused unread
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
    crash) or the cell in which the kernel died, '' otherwise."""

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
        resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT, FILE_LIMIT))
    return apply


_ANSI = re.compile(r"(\x1b|#x1B)\[[0-9;]*m")


def _first_line(text: str, limit: int = 600) -> str:
    """The assertion or error line of a failure report (terminal colours removed), shortened."""
    lines = [ln.strip() for ln in _ANSI.sub("", text).splitlines() if ln.strip()]
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


def _environment(worktree: Path, extra: dict[str, str] | None = None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST", "ARMLAB_MESHCAT"))}
    env.update(PYTHONPATH=str(worktree), MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1", **(extra or {}))
    return env


def _ended(returncode: int) -> str:
    """How a finished process ended, in words."""
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        why = {signal.SIGXCPU: " (the CPU limit)", signal.SIGKILL: " (the CPU limit's hard end, or a kill)"}
        return f"killed by {name}{why.get(-returncode, '')}"
    return f"exit code {returncode}"


def bounded(cmd: list[str], worktree: Path, limits: Limits, env: dict[str, str] | None = None
            ) -> tuple[bool, str, int]:
    """Run `cmd` in `worktree` in a new session under `limits` (with `env` added to the environment); (finished in
    time, the last OUTPUT_TAIL bytes of its output, its return code). The output goes to a file (never all into
    memory); the whole process group (the notebook's kernel, anything it started) is killed at the end."""
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(cmd, cwd=worktree, env=_environment(worktree, env), stdout=log,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True,
                                preexec_fn=_limit(limits))
        try:
            proc.wait(timeout=limits.timeout_s)
            done = True
        except subprocess.TimeoutExpired:
            done = False
        finally:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait()
        size = log.seek(0, os.SEEK_END)
        log.seek(max(0, size - OUTPUT_TAIL))
        out = log.read()
    return done, out.decode(errors="replace"), proc.returncode


def run_harness(worktree: Path, request: dict | list[dict], limits: Limits = DEFAULT_LIMITS
                ) -> tuple[list | None, str]:
    """Call exercises' functions in one bounded subprocess of `worktree` (armlab.grading.harness): for one job (a
    dict) its JSON results per call, for a list of jobs one such list per job; or None and why."""
    req, res = worktree / ".grader-request.json", worktree / ".grader-results.json"
    req.write_text(json.dumps(request))
    res.unlink(missing_ok=True)
    # the grader's own harness file, run as a script so that the work tree needs no copy of it
    harness = Path(__file__).with_name("harness.py")
    launch = f"import runpy, sys; sys.argv = {[str(harness), str(req), str(res)]!r}; " \
             f"runpy.run_path(sys.argv[0], run_name='__main__')"
    done, out, code = bounded([sys.executable, "-c", launch], worktree, limits)
    if not done:
        return None, f"the hidden checks did not finish within {limits.timeout_s:g} s (wall clock)"
    if not res.is_file():
        tail = " | ".join(out.strip().splitlines()[-2:])
        return None, f"the hidden checks' process ended without results ({_ended(code)}); its last output: {tail}"[:600]
    try:
        if res.stat().st_size > _MAX_RESULTS_BYTES:
            raise ValueError(f"more than {_MAX_RESULTS_BYTES // 2**20} MB of results")
        results = json.loads(res.read_text())
        jobs = results if isinstance(request, list) else [results]
        if not isinstance(results, list) or len(jobs) != (len(request) if isinstance(request, list) else 1) or \
                not all(isinstance(job, list) and all(isinstance(r, dict) for r in job) for job in jobs):
            raise ValueError("not a list of results")
        return results, ""
    except (OSError, ValueError) as e:
        tail = " | ".join(out.strip().splitlines()[-2:])
        return None, f"the hidden checks gave no results ({type(e).__name__}: {e}): {tail}"[:600]


def run_notebook(worktree: Path, notebook: str, limits: Limits = DEFAULT_LIMITS, lax: bool = False) -> NotebookRun:
    """Run `notebook` (relative to `worktree`) under nbval with the instructor's sanitize file; per-cell results.
    lax: --nbval-lax (a cell fails only by raising; for a student's own notebooks, which hold no stored outputs)."""
    config = worktree / ".grader-pytest.ini"
    config.write_text(_CONFIG)
    junit = worktree / ".grader-junit.xml"
    cmd = [sys.executable, "-m", "pytest", "-q", "-c", str(config), "--rootdir", str(worktree), "-p",
           "no:cacheprovider", notebook, "--nbval-lax" if lax else "--nbval", "-p", "armlab.grading.nbval_guard",
           "--nbval-sanitize-with", "tests/nbval_sanitize.cfg",
           f"--nbval-cell-timeout={int(limits.timeout_s)}", f"--junitxml={junit}"]
    ipython = worktree / ".grader-ipython"        # the kernel's own IPython profile: the output cap, nothing else
    (ipython / "profile_default/startup").mkdir(parents=True, exist_ok=True)
    shutil.copy2(Path(__file__).with_name("kernel_startup.py"), ipython / "profile_default/startup/00-grader.py")
    done, out, code = bounded(cmd, worktree, limits, {"IPYTHONDIR": str(ipython)})
    if not done:
        return NotebookRun({}, f"the notebook did not finish within {limits.timeout_s:g} s (wall clock)")
    if not junit.is_file():
        tail = out.strip().splitlines()[-3:]
        return NotebookRun({}, f"the notebook run ended without results ({_ended(code)}): {' | '.join(tail)}")
    cells = _parse_junit(junit)
    died = next((f"cell {i}: {c.message}" for i, c in sorted(cells.items()) if "the kernel died" in c.message), "")
    return NotebookRun(cells, died)
