"""The self-check is the grader's public verdict (issues 32 and 37), for every exercise graded by code, its reference
and each of its plausible wrong answers (tests/course/wrong_answers.py):
- for all of them, `self_check(only=EXERCISE)` in a student release holding that region gives nbval the very run the
  grader's does for the same region (Grader.public_checks; both run armlab_course.grading.public): the same sliced
  notebook and tree, byte for byte, the same limits and sandbox (recorded, not run: a fraction of a second each);
- for the cheap notebooks' exercises (CHEAP; every one with ARMLAB_SELF_CHECK_ALL=1), both are run: the same CHECK
  cells pass and fail with the same names and messages; a blank region is blank for both.
What each kept wrong answer's public checks say (a cause named, none, or a pass): test_grading_hints.py."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest
from public_verdicts import CHEAP, HIDDEN_ONLY, HINTS, LIMITS, built_release, waits_for_another
from wrong_answers import HIDDEN_WRONG, ROOT, reference_bodies

from armlab_course.exercises.registry import EXERCISES, exercise
from armlab_course.exercises.release import PUBLIC_NOTEBOOKS
from armlab_course.grading import check, grade, public
from armlab_course.grading.check import self_check
from armlab_course.grading.grade import Grader
from armlab_course.grading.run import Limits, NotebookRun, Runner
from armlab_course.grading.splice import write_regions
from armlab_course.grading.submission import read_submission

CODED = [e.id for e in EXERCISES if e.kind != "written"]
EVERY = os.environ.get("ARMLAB_SELF_CHECK_ALL") == "1"


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    return built_release(tmp_path_factory, "self-check")


@pytest.fixture(scope="module")
def grader():
    with Grader(ROOT, LIMITS, CODED, written=(), parallel=2) as own:
        yield own


def test_a_blank_release_is_blank_for_both(release, grader):
    """Nothing runs for a blank region, on either side: the same result (no check, the same reason) per exercise."""
    mine = self_check(release, LIMITS).results
    graded = grader.grade(read_submission(release, ROOT))
    assert {e: (r.score, r.reason, r.checks) for e, r in mine.items() if e in CODED} == \
        {e: (r.score, r.reason, r.checks) for e, r in graded.items()}
    assert all(r.reason == "not written (blank region)" for r in graded.values())


@dataclass(frozen=True)
class RunInput:
    """What one public-check run is given: the notebook run (its path and bytes after slicing), every other file of
    the run's tree but the notebooks not run (path -> sha256), the notebook the cell labels are read from (before
    slicing), the limits and the kind of sandbox: nbval's command line is made from these alone (Runner.notebook)."""

    notebook: str
    run: str
    tree: tuple[tuple[str, str], ...]
    labelled: str
    limits: Limits
    sandbox: str


NOTEBOOK = re.compile(r"notebooks/[^/]+\.ipynb")


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def recorded_runs(monkeypatch) -> list[RunInput]:
    """Record, instead of running, what each public-check run (Runner.notebook, then public_results) is given."""
    seen: list[RunInput] = []
    runs: list[tuple] = []

    def notebook(runner, worktree: Path, path: str) -> NotebookRun:
        files = [(p, p.relative_to(worktree).as_posix()) for p in sorted(worktree.rglob("*")) if p.is_file()]
        tree = tuple((name, _digest(p)) for p, name in files
                     if not name.startswith(".grader/") and not NOTEBOOK.fullmatch(name))
        runs.append((path, _digest(worktree / path), tree, runner.limits, runner.sandbox.kind))
        return NotebookRun({}, "recorded, not run")

    def results(exercise_id, run, tree, paths):
        path, ran, files, limits, kind = runs.pop()
        labelled = _digest(tree / f"notebooks/{exercise(exercise_id).notebook}.ipynb")
        seen.append(RunInput(path, ran, files, labelled, limits, kind))
        return public.public_results(exercise_id, run, tree, paths)

    monkeypatch.setattr(Runner, "notebook", notebook)
    for module in (check, grade):
        monkeypatch.setattr(module, "public_results", results)
    return seen


@pytest.mark.parametrize("exercise_id", CODED)
def test_the_self_check_runs_what_the_grader_runs(exercise_id, release, grader, tmp_path, monkeypatch):
    """For the reference and each kept wrong answer of every exercise graded by code: the self-check of a checkout
    holding that region and the grader's public checks of it give nbval the same run: the same notebook, sliced to
    the same cells, byte for byte, in a tree whose every file (package, data, configuration) is the same, under the
    same limits and sandbox, labelled from the same notebook. (The notebooks not run differ: the self-check's tree
    holds the student's own.) Such a run gives the same verdict and message, as the runs compared by the test below
    show for CHEAP; each case here costs a fraction of a second, as no notebook runs."""
    seen = recorded_runs(monkeypatch)
    answers = {"reference": reference_bodies(exercise_id), **HIDDEN_WRONG[exercise_id]}
    for label, bodies in answers.items():
        student = tmp_path / label.replace(" ", "_").replace("'", "")
        shutil.copytree(release, student)
        write_regions(student, exercise_id, bodies)
        seen.clear()
        self_check(student, LIMITS, only=exercise_id)
        grader.public_checks(exercise_id, bodies)
        assert len(seen) == 2, (label, seen)
        mine, graders = seen
        assert mine.notebook == graders.notebook == f"notebooks/{exercise(exercise_id).notebook}.ipynb"
        assert (mine.run, mine.labelled, mine.limits, mine.sandbox) == \
            (graders.run, graders.labelled, graders.limits, graders.sandbox), label
        differ = sorted(set(mine.tree) ^ set(graders.tree))
        assert not differ, (label, differ[:6])


@pytest.mark.parametrize("exercise_id", [e if e in CHEAP or EVERY else
                                         pytest.param(e, marks=pytest.mark.skip("ARMLAB_SELF_CHECK_ALL=1 runs it"))
                                         for e in CODED])
def test_the_self_check_gives_the_graders_public_verdict(exercise_id, release, grader, tmp_path):
    answers = {"reference": reference_bodies(exercise_id), **HIDDEN_WRONG[exercise_id]}
    verdicts = {}
    for label, bodies in answers.items():
        student = tmp_path / label.replace(" ", "_").replace("'", "")
        shutil.copytree(release, student)
        write_regions(student, exercise_id, bodies)
        mine = self_check(student, LIMITS, only=exercise_id).results[exercise_id]
        public = grader.public_checks(exercise_id, bodies)
        assert public and [(c.name, c.passed, c.message) for c in mine.checks] == \
            [(c.name, c.passed, c.message) for c in public], (label, mine.checks, public)
        verdicts[label] = all(c.passed or waits_for_another(c, exercise_id) for c in public)
        hint = HINTS.get((exercise_id, label))
        failed = [c.message for c in mine.checks if not c.passed]
        if hint:
            assert failed and hint in failed[0], (label, failed)
        elif label != "reference" and (exercise_id, label) not in HIDDEN_ONLY:
            assert failed, (label, "passed its public checks")
    assert verdicts["reference"], f"{exercise_id}: the reference fails its own public checks"


def test_a_check_cell_is_judged_by_its_asserts_not_by_what_it_prints(release, tmp_path):
    """A valid answer prints other figures than the reference did (an open task's run time, a tower's height, a
    measured error): the CHECK cell passes when its asserts pass, whatever it prints. Here fk.euler's check cells in
    the release's public notebook are given a stored output that says something else than the run prints (as the
    instructor's would for another answer), and the reference still passes."""
    student = tmp_path / "student"
    shutil.copytree(release, student)
    write_regions(student, "fk.euler", reference_bodies("fk.euler"))
    path = student / PUBLIC_NOTEBOOKS / "02_forward_kinematics.ipynb"
    nb = json.loads(path.read_text(encoding="utf-8"))
    checks = [c for c in nb["cells"] if c["cell_type"] == "code" and "# CHECK fk.euler" in "".join(c["source"])]
    assert checks
    for count, cell in enumerate(checks, 1):
        cell["execution_count"] = count
        cell["outputs"] = [{"name": "stdout", "output_type": "stream", "text": ["OK: other figures than yours\n"]}]
    path.write_text(json.dumps(nb, indent=1), encoding="utf-8")
    mine = self_check(student, LIMITS, only="fk.euler").results["fk.euler"]
    assert mine.checks and all(c.passed for c in mine.checks), [c.message for c in mine.checks]
