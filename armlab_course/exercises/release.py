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
  self-check. A markdown page loses its `<!-- BEGIN INSTRUCTOR ONLY -->` ... `<!-- END INSTRUCTOR ONLY -->` parts
  (what cites the instructor's tools, tests and benchmarks), and the instructor's pages stay out.

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

__all__ = ["RELEASE_EXCLUDES", "STUDENT_README", "RELEASE_MARKER", "RUN_ALL_TAG", "PUBLIC_NOTEBOOKS",
           "student_notebook", "public_notebook", "make_student_release", "released", "raises_while_blank",
           "without_instructor_lines"]

RUN_ALL_TAG = "raises-exception"
CHECK_VERDICT_TAG = "nbval-ignore-output"      # nbval: the cell's output is not compared (public_notebook)
_INSTRUCTOR_ONLY = re.compile(r"^(?:# |<!-- )BEGIN INSTRUCTOR ONLY\b.*?^(?:# |<!-- )END INSTRUCTOR ONLY[^\n]*\n\n?",
                              re.DOTALL | re.MULTILINE)

STUDENT_README = "tools/student/README.md"
RELEASE_MARKER = ".student-release"
# the release's copy of each notebook as the public checks run it (public_notebook): the self-check splices the
# student's regions into it, as the grader does into the release it builds, whatever else the student's copy holds
PUBLIC_NOTEBOOKS = "armlab_course/grading/public_notebooks"
RELEASE_EXCLUDES = (
    "README.md",              # the instructor's (STUDENT_README takes its place)
    ".ci/*",
    "benchmarks/*",
    "notebooks/src/*",        # the notebooks are the students' only copy of their exercises
    "tools/build-notebook",
    "tools/figure_recorder.py",    # build-notebook's kernel startup: records each figure for the figure test
    "tests/test_notebook_figures.py",   # reads the figures stored in the instructor's executed notebooks
    "docs/course/instructor/*",    # the walkthrough of every solution, for the instructor
    # the instructor's pages: grading (the hidden checks, the judge), hubs, the release, the exercises' scaffolding
    # and wrong answers, notebooks 04-08's hidden checks; the maintainers' (the architecture, the numerics, the
    # Python versions, the benchmarks: they cite the instructor's tests, sources and benchmarks); and the history,
    # which cites files of earlier versions. The student README says how to check and submit.
    "docs/grading.md", "docs/hub.md", "docs/release.md", "docs/course-scaffolding.md", "docs/lab-04-08.md",
    "docs/architecture.md", "docs/numerics.md", "docs/python-versions.md", "docs/benchmarks.md", "CHANGELOG.md",
    "tools/course-pictures",       # renders docs/course/img/ (the instructor's, from the solved kit)
    "tools/course-times",          # reads the notebook sources (not in the release) for the time table
    "tools/student-release",
    "tests/course/*",         # the course's own tests (issue 32: apart from the library's): the release builder, the
                              # grader, the registry's docs, the written questions; they hold wrong answers, rubrics
                              # and pieces of solutions, and look for what the instructor's tree has
    "tools/student/*",
    "tests/test_packaging.py",     # builds wheels of the instructor's checkout
    "tests/test_package_table.py",     # reads docs/architecture.md (a maintainers' page, not shipped)
    "tests/test_repeatable.py",    # teaches by hand (the teach.record exercise) to test the simulator's rounding
    "tests/test_notebook_outputs.py",   # checks the instructor's executed notebooks (the release's have no outputs)
    "armlab_course/grading/hidden.py",    # the grader's hidden checks (fresh inputs per exercise)
    "armlab_course/grading/hidden/*",     # (one module per exercise)
    # the grader's side (issue 37): the release keeps only what `python -m armlab check` runs; the hidden checks'
    # child (harness, wire, adapters) comes from the grader's own read-only folder when the instructor grades
    "armlab_course/grading/adapters.py",
    "armlab_course/grading/autograder.py",
    "armlab_course/grading/grade.py",
    "armlab_course/grading/harness.py",
    "armlab_course/grading/judge.py",
    "armlab_course/grading/similarity.py",
    "armlab_course/grading/upload.py",
    "armlab_course/grading/wire.py",
    "tools/autograder/*",          # the Gradescope bundle's scripts (make autograder)
    # -- the kit's twins of exercises: instructor-only code and data that compute an exercise's answer
    "armlab/data/rx200_dh.csv",    # fk.dh_table: the DH table (the engine runs on the PoX model without it)
    "armlab/tasks/transition.py",  # station.transition: the kit's transition (the release latches every failure)
    "armlab/tasks/buttons.py",     # station.machine: the kit's refusal of a teaching button out of turn (the
                                   # release's machine stops the station instead: machine.latching_refusal)
    "armlab/tasks/click_rule.py",  # grab.sequence: the kit's click rule (the release grabs only at a block's centre
                                   # and refuses a drop on the held block's old place: click.centre_click_block)
    "armlab/tasks/kit_move_path.py",   # grab.move_path: the kit's planners with move_path's arguments (the release's
                                       # notebooks plan with the lab report's fixed-height plan: report_move_path)
    "armlab/tasks/events/strategies/*",   # events.*: the kit's strategies (the release's events run the search)
    "tests/test_event_strategies.py",     # their tests
)


def released(name: str) -> bool:
    """Whether the tracked file `name` (repository-relative, '/'-separated) goes into the student release."""
    return not any(fnmatch.fnmatch(name, pattern) for pattern in RELEASE_EXCLUDES)


def without_instructor_lines(text: str) -> str:
    """`text` (the Makefile, or a markdown page) without its sections from a `# BEGIN INSTRUCTOR ONLY` line to the
    next `# END INSTRUCTOR ONLY` line (in markdown `<!-- BEGIN INSTRUCTOR ONLY -->` ... `<!-- END INSTRUCTOR ONLY
    -->`, invisible where the page is rendered); ValueError when the markers do not pair up."""
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


def public_notebook(nb: dict, where: str) -> dict:
    """The notebook the public checks run (the grader's and the self-check's, armlab_course.grading.public): the
    student notebook of `nb` (student_notebook: no cell holds an output or a count), each CHECK cell tagged
    CHECK_VERDICT_TAG. A check cell's asserts are its verdict, not its printout: a valid answer prints other figures
    than the reference did (an open task's run time, a tower's height, a measured error), so nbval compares no
    output of a check cell, and a cell that raises fails whatever its tags say (armlab_course.grading.nbval_guard).
    No stored output is shipped: nothing of the instructor's run reaches the student's checkout."""
    out = student_notebook(nb, where)
    for cell in out["cells"]:
        if cell["cell_type"] == "code" and CHECK_LINE.search("".join(cell["source"])):
            tags = cell.setdefault("metadata", {}).setdefault("tags", [])
            if CHECK_VERDICT_TAG not in tags:
                tags.append(CHECK_VERDICT_TAG)
    return out


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
            if any(CHECK_LINE.search("".join(c["source"])) for c in nb["cells"] if c["cell_type"] == "code"):
                public = out / PUBLIC_NOTEBOOKS / Path(name).name
                public.parent.mkdir(parents=True, exist_ok=True)
                public.write_text(json.dumps(public_notebook(nb, name), indent=1, ensure_ascii=False) + "\n")
            changed = any(find_regions("".join(c["source"]), name) for c in nb["cells"] if c["cell_type"] == "code") \
                or bool(find_answers(["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown"], name))
        elif name == "Makefile" or name.endswith(".md"):
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
