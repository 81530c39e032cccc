"""The self-check is the grader's public verdict (issue 37, item 3): for an exercise and each of its plausible wrong
answers (tests/wrong_answers.py), `self_check(only=EXERCISE)` in a student release holding that region passes and
fails the same public CHECK cells, with the same names, as the grader does for the same region. The exercises
tried: those of notebook 02 (a package function and two notebook ones) and the homography of notebook 01 (the
others take the same path; each pair costs a notebook run on both sides)."""

from __future__ import annotations

import shutil

import pytest
from wrong_answers import HIDDEN_WRONG, ROOT, reference_bodies

from armlab_course.exercises import make_student_release
from armlab_course.exercises.registry import exercise
from armlab_course.grading.check import self_check
from armlab_course.grading.grade import Grader
from armlab_course.grading.run import Limits
from armlab_course.grading.splice import write_regions

TRIED = ("fk.dh_link_transform", "fk.dh_table", "fk.euler", "calib.tag_homography")
# A hard-coded homography passes check cell 14 in the self-check and fails it in the grader. Both now run the same
# tree (the release with the region); the difference left is how the cell is compared: the grader compares its
# printed output with the instructor's stored one, the self-check (no stored outputs) only that it does not raise.
# Strict, so that this mark goes when the two agree.
SEAM = pytest.mark.xfail(strict=True, reason="the grader compares check cell 14's output; the self-check cannot")
LIMITS = Limits(timeout_s=300, cpu_s=200)


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    folder = tmp_path_factory.mktemp("self-check") / "release"
    make_student_release(ROOT, folder)
    return folder


@pytest.fixture(scope="module")
def grader():
    with Grader(ROOT, LIMITS, TRIED, parallel=2) as own:
        yield own


@pytest.mark.parametrize("exercise_id", [pytest.param(e, marks=SEAM) if e == "calib.tag_homography" else e
                                         for e in TRIED])
def test_the_self_check_gives_the_graders_public_verdict(exercise_id, release, grader, tmp_path):
    notebook = exercise(exercise_id).notebook
    answers = {"reference": reference_bodies(exercise_id), **HIDDEN_WRONG[exercise_id]}
    verdicts = set()
    for label, bodies in answers.items():
        student = tmp_path / label.replace(" ", "_").replace("'", "")
        shutil.copytree(release, student)
        write_regions(student, exercise_id, bodies)
        mine = self_check(student, LIMITS, only=exercise_id).results[exercise_id]
        graders = grader.grade_exercise(exercise_id, bodies)
        public = [(c.name, c.passed) for c in graders.checks if c.name.startswith(f"{notebook} cell")]
        assert public and [(c.name, c.passed) for c in mine.checks] == public, (label, mine.checks, graders.checks)
        verdicts.add(all(ok for _, ok in public))
    assert True in verdicts, f"{exercise_id}: the reference fails its own public checks"
