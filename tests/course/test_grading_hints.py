"""Every kept wrong answer's public verdict (issue 32: "the two plausible wrong answers kept for every exercise become
tested hints"; tests/course/public_verdicts.py): the self-check of a checkout holding it fails it with the cause
named in the first failing check's message (HINTS), fails it without naming a cause where the check cannot tell one
(CAUSE_UNTOLD), or passes it, the hidden checks failing it (HIDDEN_ONLY). The wrong answers run a notebook's at a
time, a few submissions in all (public_verdicts.rounds: the notebook runs once per submission, sliced to its written
exercises' checks); an exercise and one it NEEDS are never wrong together. The self-check's messages are the
grader's for the same region (test_grading_self_check.py); notebook 02's exercises are held there (CHEAP)."""

from __future__ import annotations

import shutil

import pytest
from public_verdicts import CAUSE_UNTOLD, CHEAP, HIDDEN_ONLY, HINTS, LIMITS, built_release, rounds, waits_for_another
from wrong_answers import HIDDEN_WRONG, reference_bodies

from armlab_course.exercises.registry import exercise
from armlab_course.grading.check import self_check
from armlab_course.grading.splice import write_regions

ROUNDS = rounds([e for e in HIDDEN_WRONG if e not in CHEAP], HIDDEN_WRONG)


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    return built_release(tmp_path_factory, "hints")


def test_every_kept_wrong_answer_has_one_declared_public_verdict():
    kept = {(e, label) for e, answers in HIDDEN_WRONG.items() for label in answers}
    declared = [*HINTS, *CAUSE_UNTOLD, *HIDDEN_ONLY]
    assert len(declared) == len(set(declared)), "a wrong answer is declared twice"
    assert set(declared) == kept, (sorted(kept - set(declared)), sorted(set(declared) - kept))
    run = {(e, label) for r in ROUNDS for e, label in r.items() if label is not None}
    assert run == {(e, label) for e, label in kept if e not in CHEAP}


@pytest.mark.parametrize("submission", ROUNDS,
                         ids=[f"{exercise(next(iter(r))).notebook[:2]}: round {i}" for i, r in enumerate(ROUNDS)])
def test_the_self_check_tells_each_kept_wrong_answer_as_declared(submission, release, tmp_path):
    student = tmp_path / "student"
    shutil.copytree(release, student)
    for exercise_id, label in submission.items():
        write_regions(student, exercise_id,
                      reference_bodies(exercise_id) if label is None else HIDDEN_WRONG[exercise_id][label])
    checked = self_check(student, LIMITS)
    said = {}
    for exercise_id, label in submission.items():
        result = checked.results[exercise_id]
        failed = [c.message for c in result.checks if not c.passed and not waits_for_another(c, exercise_id)]
        said[(exercise_id, label)] = (checked.blocked.get(exercise_id), bool(result.checks), failed[:1])
    problems = []
    for (exercise_id, label), (blocked, ran, failed) in said.items():
        key = (exercise_id, label)
        if blocked or not ran:
            problems.append((key, "blocked" if blocked else "no check ran", blocked))
        elif label is None:
            continue           # the reference another one needs: a wrong answer it builds on may fail it
        elif key in HIDDEN_ONLY:
            if failed:
                problems.append((key, "failed", failed))
        elif key in CAUSE_UNTOLD and not failed:
            problems.append((key, "passed", failed))
        elif key in HINTS:
            if not (failed and HINTS[key] in failed[0]):
                problems.append((key, f"no {HINTS[key]!r}", failed))
        elif key not in CAUSE_UNTOLD:
            problems.append((key, "not declared", failed))
    assert not problems, problems
