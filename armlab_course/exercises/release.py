"""The student release: a copy of the instructor's repository (its tracked files) that a student can run, edit and
submit.

- Every exercise region (armlab_course.exercises.markers) becomes a stub raising ExerciseNotWritten for its exercise,
  every written answer its prompt line; notebooks lose their outputs and execution counts.
- The cells that raise while an exercise is blank -- the cells holding an exercise region and the check cells
  (`# CHECK <id>`), the only ones (tests/test_blank_release_runs.py) -- carry the cell tag RUN_ALL_TAG
  ("raises-exception", nbformat metadata), which JupyterLab's and Notebook 7's Run All and nbclient honour: the
  error shows in the cell and the run goes on, so "Restart Kernel and Run All Cells…" runs a blank notebook to its
  end, showing each exercise's not-written message. (The grader's and the self-check's nbval runs ignore the tag: a
  check cell that raises fails there; armlab_course.grading.nbval_guard.)
- Only student-facing files go in (RELEASE_EXCLUDES: no instructor README, benchmarks, CI, release tool, notebook
  sources, instructor-only tests); the student README (STUDENT_README) becomes README.md, and the marker file
  .student-release tells the Makefile which tests a release runs.
- The notebooks are the one editable copy of every notebook exercise (their percent-format sources stay behind).
- The Makefile loses its lines from `# BEGIN INSTRUCTOR ONLY` to `# END INSTRUCTOR ONLY` (the targets whose tools
  the release does not ship: notebooks, bench, exercise-docs, student, autograder); its `make check` runs the
  self-check.

    python tools/student-release OUT_DIR      # or: make student
"""

from __future__ import annotations

import fnmatch
import json
import re
import shutil
import subprocess
from pathlib import Path

from .markers import CHECK_LINE, blank_answers, find_answers, find_regions, stub_regions

__all__ = ["RELEASE_EXCLUDES", "STUDENT_README", "RELEASE_MARKER", "RUN_ALL_TAG", "student_notebook",
           "make_student_release", "released", "raises_while_blank", "without_instructor_lines"]

RUN_ALL_TAG = "raises-exception"
_INSTRUCTOR_ONLY = re.compile(r"^# BEGIN INSTRUCTOR ONLY\b.*?^# END INSTRUCTOR ONLY[^\n]*\n\n?",
                              re.DOTALL | re.MULTILINE)

STUDENT_README = "tools/student/README.md"
RELEASE_MARKER = ".student-release"
RELEASE_EXCLUDES = (
    "README.md",              # the instructor's (STUDENT_README takes its place)
    ".ci/*",
    "benchmarks/*",
    "notebooks/src/*",        # the notebooks are the students' only copy of their exercises
    "tools/build-notebook",
    "tools/student-release",
    "tools/student/*",
    "tests/test_exercises.py",     # the release tool's own tests (they look for solutions)
    "tests/test_blank_release_runs.py",   # builds a release from the instructor's checkout and runs it blank
    "tests/test_packaging.py",     # builds wheels of the instructor's checkout
    "tests/test_repeatable.py",    # teaches by hand (the teach.record exercise) to test the simulator's rounding
    "tests/test_notebook_outputs.py",   # checks the instructor's executed notebooks (the release's have no outputs)
    "armlab_course/grading/hidden.py",    # the grader's hidden checks (fresh inputs per exercise)
    "armlab_course/grading/hidden/*",     # (one module per exercise)
    "tools/autograder/*",          # the Gradescope bundle's scripts (make autograder)
    "tests/test_grading*.py",      # the grader's tests (they hold wrong answers and the tricks)
    "tests/wrong_answers.py",      # the wrong answers (pieces of every solution) and the tests that run them
    "tests/test_hidden_checks*.py",
    "tests/test_lab_04_08.py",
    "tests/test_ik_numerical.py",
    "tests/test_slots.py",         # plugs the wrong answers into the engine's slots
    # -- the kit's twins of exercises: instructor-only code and data that compute an exercise's answer
    "armlab/data/rx200_dh.csv",    # fk.dh_table: the DH table (the engine runs on the PoX model without it)
)


def released(name: str) -> bool:
    """Whether the tracked file `name` (repository-relative, '/'-separated) goes into the student release."""
    return not any(fnmatch.fnmatch(name, pattern) for pattern in RELEASE_EXCLUDES)


def without_instructor_lines(text: str) -> str:
    """`text` (the Makefile) without its sections from a `# BEGIN INSTRUCTOR ONLY` line to the next
    `# END INSTRUCTOR ONLY` line; ValueError when the markers do not pair up."""
    out = _INSTRUCTOR_ONLY.sub("", text)
    if "INSTRUCTOR ONLY" in out:
        raise ValueError("an INSTRUCTOR ONLY marker without its pair")
    return out


def raises_while_blank(source: str, where: str = "<cell>") -> bool:
    """Whether a code cell's source raises while its exercise is blank: it holds an exercise region or a check
    cell's `# CHECK` line."""
    return bool(find_regions(source, where)) or CHECK_LINE.search(source) is not None


def student_notebook(nb: dict, where: str) -> dict:
    """A notebook (nbformat 4 JSON) with its exercise regions stubbed, its written answers blanked, every output
    and count cleared, and the cells that raise while an exercise is blank tagged RUN_ALL_TAG (Run All goes on past
    them)."""
    nb = json.loads(json.dumps(nb))
    for cell in nb["cells"]:
        if cell["cell_type"] == "markdown":
            text = "".join(cell["source"])
            if find_answers([text], where):
                cell["source"] = blank_answers(text, where).splitlines(keepends=True)
            continue
        if cell["cell_type"] != "code":
            continue
        text = "".join(cell["source"])
        if find_regions(text, where):
            cell["source"] = stub_regions(text, where).splitlines(keepends=True)
        if raises_while_blank(text, where):
            tags = cell.setdefault("metadata", {}).setdefault("tags", [])
            if RUN_ALL_TAG not in tags:
                tags.append(RUN_ALL_TAG)
        cell["outputs"], cell["execution_count"] = [], None
    return nb


def make_student_release(repo: Path | str, out: Path | str) -> list[str]:
    """Write the student release of the git checkout `repo` into the new folder `out`; returns the files that hold
    exercises. Refuses to write into an existing folder."""
    repo, out = Path(repo), Path(out)
    if out.exists():
        raise FileExistsError(f"{out} exists: the student release goes into a new folder")
    files = subprocess.run(["git", "-C", str(repo), "ls-files", "-z"], capture_output=True, check=True
                           ).stdout.decode().split("\0")
    stubbed = []
    for name in filter(None, files):
        src, dst = repo / name, out / name
        if not src.is_file() or not released(name):
            continue
        dst.parent.mkdir(parents=True, exist_ok=True)
        if name.endswith(".ipynb"):
            nb = json.loads(src.read_text())
            dst.write_text(json.dumps(student_notebook(nb, name), indent=1, ensure_ascii=False) + "\n")
            changed = any(find_regions("".join(c["source"]), name) for c in nb["cells"] if c["cell_type"] == "code") \
                or bool(find_answers(["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown"], name))
        elif name == "Makefile":
            dst.write_text(without_instructor_lines(src.read_text()))
            changed = False
        elif name.endswith(".py") or name.startswith("tools/"):
            text = src.read_text()
            new_text = stub_regions(text, name)
            dst.write_text(new_text)
            changed = new_text != text
        else:
            shutil.copy2(src, dst)
            changed = False
        if src.stat().st_mode & 0o111:
            dst.chmod(src.stat().st_mode)
        if changed:
            stubbed.append(name)
    shutil.copy2(repo / STUDENT_README, out / "README.md")
    (out / RELEASE_MARKER).write_text("student release: `make test` runs the kit's tests, not the notebooks' checks "
                                      "(those are `make check`)\n")
    return stubbed
