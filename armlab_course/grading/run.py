"""Run student code for grading: a notebook of a grading work tree under `pytest --nbval`, or the hidden checks'
harness, each in the sandbox (armlab_course.grading.sandbox) under the run's limits, and read what it reports.

The child-side files (the nbval plugin, the harness, the kernel's start-up file, the plain-data format and the
adapters; never the hidden checks) are copied once, when the Runner is made, into a folder of the grader's that every
run sees read-only, with a kernelspec of its own (so neither the instructor's nor the student's IPython or Jupyter
settings enter). A notebook run's results come back in a file signed with a key its pytest process reads from its
standard input before any student code starts (HMAC-SHA256): the kernel that runs student code cannot forge the
signature. The hidden checks' child answers the judge (armlab_course.grading.judge) over a pipe instead: what it
says is the student's answer, which the judge checks. The run's console
output goes to a file of which only the end is read; when the run ends or times out, the sandbox's PID namespace
(or, for the unprivileged-user sandbox, a kill of every process of the run's user) ends everything it started.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

from armlab_course.exercises.markers import CHECK_LINE

from .sandbox import Limits, PidsGroup, Sandbox

__all__ = ["DEFAULT_LIMITS", "Limits", "CellResult", "NotebookRun", "Runner", "check_cells", "code_cell_labels",
           "with_cell_labels",
           "verify_signed", "CHILD_FILES"]

OUTPUT_TAIL = 20_000               # bytes of a run's console output kept (its end)
_MAX_RESULTS_BYTES = 64 * 2**20     # a result file larger than this is refused unread
_CONFIG = "[pytest]\naddopts =\nfilterwarnings =\n    ignore::DeprecationWarning\n"
KERNEL_NAME = "armlab-grader"
# the grader's files that run in the child, copied into the run's read-only folder (package armlab_grader)
CHILD_FILES = ("nbval_guard.py", "harness.py", "kernel_startup.py", "child_common.py", "wire.py", "adapters.py")
# of those, what only the hidden checks' child needs (a student release, whose self-check runs no hidden check, may
# leave them out)
HIDDEN_CHILD_FILES = ("harness.py", "wire.py", "adapters.py")
# the environment a run inherits from the grader: locale and the numerics settings, nothing else
_KEEP_ENV = ("PATH", "LANG", "LANGUAGE", "TZ", "PYTHONHASHSEED", "TERM")
_KEEP_PREFIXES = ("LC_", "OPENBLAS", "NPY_", "OPENCV_", "OMP_", "MKL_")


DEFAULT_LIMITS = Limits()


@dataclass(frozen=True)
class CellResult:
    passed: bool
    message: str = ""


@dataclass
class NotebookRun:
    """cells: per code-cell index (nbval's 'Cell N'), the result; problem: why the run gave no results (timeout,
    crash, tampered results) or the cell in which the kernel died, '' otherwise."""

    cells: dict[int, CellResult]
    problem: str = ""


def code_cell_labels(notebook: Path) -> list[str]:
    """Per code cell (nbval's 'Cell N', 0-based among the code cells), how a student finds it in JupyterLab: the
    notebook, the cell's position among all its cells (1-based, markdown included), the execution count JupyterLab
    shows once Restart Kernel and Run All Cells has run every cell, and the cell's first line, e.g.
    '02_forward_kinematics cell 22 ([10] after Run All: # CHECK fk.euler)'."""
    cells = json.loads(Path(notebook).read_text(encoding="utf-8"))["cells"]
    labels = []
    for position, cell in enumerate(cells, start=1):
        if cell["cell_type"] != "code":
            continue
        first = next((line.strip() for line in "".join(cell["source"]).splitlines() if line.strip()), "(empty)")
        first = first if len(first) <= 60 else first[:57] + "..."
        labels.append(f"{Path(notebook).stem} cell {position} ([{len(labels) + 1}] after Run All: {first})")
    return labels


def with_cell_labels(message: str, notebook: Path, labels: list[str] | None = None) -> str:
    """`message` with every frame's "<notebook> cell <i>, line" (i the code-cell index, as a run's frames name a
    cell) written with the cell's label instead (code_cell_labels: how JupyterLab shows it, as the check names say);
    an index past the notebook's code cells stays as it is."""
    stem = Path(notebook).stem
    labels = code_cell_labels(notebook) if labels is None else labels

    def label(match: re.Match) -> str:
        index = int(match[1])
        return labels[index] if index < len(labels) else match[0]

    return re.sub(rf"\b{re.escape(stem)} cell (\d{{1,4}})(?=, line )", label, message)


def check_cells(notebook: Path) -> dict[int, tuple[str, ...]]:
    """The notebook's CHECK-tagged code cells: code-cell index -> the exercise ids its '# CHECK' line names."""
    nb = json.loads(notebook.read_text(encoding="utf-8"))
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    tags = {}
    for i, cell in enumerate(code):
        found = CHECK_LINE.search("".join(cell["source"]))
        if found:
            tags[i] = tuple(found["ids"].split())
    return tags


def verify_signed(path: Path, key: bytes) -> object:
    """The payload of a signed result file (ValueError when it is missing, too large, malformed or its signature is
    not the run's)."""
    if not path.is_file() or path.is_symlink():
        raise ValueError("no result file")
    if path.stat().st_size > _MAX_RESULTS_BYTES:
        raise ValueError(f"more than {_MAX_RESULTS_BYTES // 2**20} MB of results")
    signed = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(signed, dict) or not isinstance(signed.get("payload"), str) or \
            not isinstance(signed.get("hmac"), str):
        raise ValueError("not a signed result file")
    want = hmac.new(key, signed["payload"].encode(), hashlib.sha256).hexdigest()
    if not hmac.compare_digest(want, signed["hmac"]):
        raise ValueError("the results were changed after the run wrote them (the signature does not match)")
    return json.loads(signed["payload"])


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


def tail_of(log) -> str:
    """The last OUTPUT_TAIL bytes of a run's log file, as text."""
    size = log.seek(0, os.SEEK_END)
    log.seek(max(0, size - OUTPUT_TAIL))
    return log.read().decode(errors="replace")


class Runner:
    """Runs notebooks and the hidden checks of grading work trees in `sandbox` under `limits`. Owns the read-only
    folder of child-side files (made now, from the grader's own sources: nothing of the grader is read after student
    code starts); close() removes it."""

    def __init__(self, sandbox: Sandbox, limits: Limits = DEFAULT_LIMITS, hidden_source: Path | None = None):
        """hidden_source: ignored (the hidden checks stay in the judge: nothing of them is copied for the child)."""
        self.sandbox, self.limits = sandbox, limits
        self._tmp = tempfile.TemporaryDirectory(prefix="armlab-grader-")
        self.files = Path(self._tmp.name) / "grader"
        self._write_child_files()

    def close(self) -> None:
        self._tmp.cleanup()

    def _write_child_files(self) -> None:
        lib = self.files / "lib" / "armlab_grader"
        lib.mkdir(parents=True)
        (lib / "__init__.py").write_text('"""The grader\'s child-side files (a read-only copy for the runs)."""\n')
        here = Path(__file__).parent
        for name in CHILD_FILES:
            if name in HIDDEN_CHILD_FILES and not (here / name).is_file():
                continue
            shutil.copy2(here / name, lib / name)
        inside = self.sandbox.grader_inside(self.files)
        startup = f"{inside}/lib/armlab_grader/kernel_startup.py"
        spec = {"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}",
                         f"--IPKernelApp.exec_files={json.dumps([startup])}", "--HistoryManager.enabled=False"],
                "display_name": "armlab grader", "language": "python"}
        kernel = self.files / "share" / "jupyter" / "kernels" / KERNEL_NAME
        kernel.mkdir(parents=True)
        (kernel / "kernel.json").write_text(json.dumps(spec))

    def _environment(self, worktree: Path) -> dict[str, str]:
        home = self.sandbox.home(worktree)
        work, grader = self.sandbox.inside(worktree), self.sandbox.grader_inside(self.files)
        env = {k: v for k, v in os.environ.items() if k in _KEEP_ENV or k.startswith(_KEEP_PREFIXES)}
        env.update(HOME=home, PYTHONPATH=f"{work}{os.pathsep}{grader}/lib", MPLBACKEND="Agg",
                   PYTHONDONTWRITEBYTECODE="1", JUPYTER_PATH=f"{grader}/share/jupyter", IPYTHONDIR=f"{home}/.ipython",
                   MPLCONFIGDIR=f"{home}/.matplotlib", JUPYTER_CONFIG_DIR=f"{home}/.jupyter",
                   JUPYTER_DATA_DIR=f"{home}/.local/share/jupyter", JUPYTER_RUNTIME_DIR=f"{home}/.jupyter-runtime",
                   JUPYTER_PLATFORM_DIRS="1", PYDEVD_DISABLE_FILE_VALIDATION="1", TMPDIR="/tmp")
        env.setdefault("PATH", "/usr/bin:/bin")
        return env

    @contextmanager
    def started(self, cmd: list[str], worktree: Path, limits: Limits | None = None, talk: bool = False):
        """Start `cmd` (paths as seen inside) in the work tree in the sandbox under `limits` (default: the runner's);
        yield (the process, its log: a temporary file with its console output). talk: its standard output is a
        pipe to read (the judge's answers), its standard error the log; otherwise both go to the log. Standard input
        is always a pipe. Everything the run started is gone when the block ends."""
        limits = limits or self.limits
        with self.sandbox.slot(worktree, self.files) as uid:
            argv = self.sandbox.argv(cmd, worktree, self.files, limits, uid)
            group = PidsGroup(limits.max_procs) if PidsGroup.available() else None
            if group is not None:
                argv = group.wrap(argv)
            with tempfile.TemporaryFile() as log:
                proc = subprocess.Popen(argv, cwd=worktree, env=self._environment(worktree),
                                        stdout=subprocess.PIPE if talk else log,
                                        stderr=log if talk else subprocess.STDOUT, stdin=subprocess.PIPE,
                                        start_new_session=True)
                try:
                    yield proc, log
                finally:
                    try:
                        os.killpg(proc.pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
                    proc.wait()
                    for pipe in (proc.stdin, proc.stdout):
                        if pipe is not None:
                            try:
                                pipe.close()
                            except OSError:
                                pass
                    if group is not None:
                        group.close()

    def run(self, cmd: list[str], worktree: Path, stdin: bytes, limits: Limits | None = None
            ) -> tuple[bool, str, int]:
        """Run `cmd` (paths as seen inside) in the work tree in the sandbox with `stdin` under `limits` (default: the
        runner's); (finished in time, the last OUTPUT_TAIL bytes of its output, its return code). Everything the run
        started is gone when this returns."""
        limits = limits or self.limits
        with self.started(cmd, worktree, limits) as (proc, log):
            try:
                proc.stdin.write(stdin)
                proc.stdin.close()
            except (BrokenPipeError, OSError):
                pass
            try:
                proc.wait(timeout=limits.timeout_s)
                done = True
            except subprocess.TimeoutExpired:
                done = False
            out = tail_of(log)
        return done, out, proc.returncode

    def notebook(self, worktree: Path, notebook: str) -> NotebookRun:
        """Run `notebook` (relative to `worktree`) under strict nbval with the instructor's sanitize file (a cell
        passes when it raises nothing and its output matches the stored one; a CHECK cell of a public notebook is
        tagged to be judged by its asserts alone, release.public_notebook); per-cell results."""
        work = self.sandbox.inside(worktree)
        private = worktree / ".grader"
        private.mkdir(exist_ok=True)
        (private / "pytest.ini").write_text(_CONFIG)
        results = private / "results.json"
        cmd = [sys.executable, "-m", "pytest", "-q", "-c", f"{work}/.grader/pytest.ini", "--rootdir", work,
               "-p", "no:cacheprovider", notebook, "--nbval",
               "-p", "armlab_grader.nbval_guard", "--nbval-sanitize-with", "tests/nbval_sanitize.cfg",
               f"--nbval-cell-timeout={int(self.limits.timeout_s)}", f"--nbval-kernel-name={KERNEL_NAME}",
               "--nbval-kernel-startup-timeout=300", f"--armlab-results={work}/.grader/results.json"]
        key = secrets.token_bytes(32)
        done, out, code = self.run(cmd, worktree, key.hex().encode() + b"\n")
        if not done:
            return NotebookRun({}, f"the notebook did not finish within {self.limits.timeout_s:g} s (wall clock)")
        try:
            payload = verify_signed(results, key)
            cells = {int(i): CellResult(bool(ok), str(msg)) for i, (ok, msg) in payload["cells"].items()}
        except (OSError, ValueError, KeyError, TypeError) as e:
            tail = " | ".join(out.strip().splitlines()[-3:])
            return NotebookRun({}, f"the notebook run ended without results ({_ended(code)}; {e}): {tail}"[:600])
        died = next((f"cell {i}: {c.message}" for i, c in sorted(cells.items()) if "the kernel died" in c.message), "")
        return NotebookRun(cells, died)

    def harness(self, worktree: Path, jobs: list[dict], exercises: int = 1) -> tuple[list | None, str]:
        """The hidden checks' jobs (armlab_course.grading.judge.run_jobs: each with its cases and its judge-side
        hook) asked of one sandboxed child of `worktree` (armlab_grader.harness) over the judge's pipe: per job
        {"results": per case {"value": ...} or {"error": ...}, "forbidden": forbidden calls seen}; or None and why
        when the child never answered. The run's wall-clock and CPU limits are the runner's times `exercises` (the
        hidden checks of that many exercises run in this one process)."""
        from .judge import run_jobs

        limits = replace(self.limits, timeout_s=self.limits.timeout_s * max(1, exercises),
                         cpu_s=self.limits.cpu_s * max(1, exercises))
        with self.started([sys.executable, "-m", "armlab_grader.harness"], worktree, limits, talk=True) as (proc, log):
            got, problem = run_jobs(proc, jobs, time.monotonic() + limits.timeout_s)
            if problem:
                proc.kill()
                proc.wait()
                tail = " | ".join(tail_of(log).strip().splitlines()[-2:])
                problem = f"{problem} ({_ended(proc.returncode)}): {tail}"[:600]
        return got, problem
