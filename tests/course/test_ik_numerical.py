"""Exercise ik.numerical (notebook 03, issue 23, branch lab27b): its hidden checks score the blank stub 0 and a wrong
answer loses its own exercise only; the kit's reference paths that stand in for it while it is blank agree with the
kit's own Jacobian and reach a target."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from armlab_course.exercises.markers import stub_lines
from armlab_course.grading.run import Limits

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "course"))
pytest.importorskip("wrong_answers", reason="the instructor's checkout only (the student release leaves it out)")
CHEAP = ("ik.candidates", "ik.numerical")        # notebook 03's exercises graded by code: no simulator run


@pytest.fixture(scope="module")
def grader():
    from armlab_course.grading.grade import Grader

    return Grader(ROOT, Limits(timeout_s=600, cpu_s=400), list(CHEAP))


def test_the_blank_stub_fails_every_hidden_check(grader):
    from wrong_answers import reference_bodies

    blank = ["\n".join("    " + line for line in stub_lines("ik.numerical"))] * len(reference_bodies("ik.numerical"))
    got = grader.hidden_checks_together({"ik.numerical": blank})["ik.numerical"]
    assert got and not any(c.passed for c in got), got


@pytest.mark.parametrize("round_", [0, 1])
def test_a_wrong_answer_loses_its_own_exercise_only(grader, round_):
    """Each of notebook 03's code exercises wrong in turn (its round_-th wrong answer of HIDDEN_WRONG) while the other
    holds the reference: the wrong one fails a hidden check, the other passes every one."""
    from wrong_answers import check_each_wrong_loses_only_its_own

    check_each_wrong_loses_only_its_own(grader, CHEAP, round_)


def test_the_reference_paths_agree_with_the_kit():
    from armlab import kinematics
    from armlab.robot import rx200
    from armlab_course.exercises import references

    robot = rx200()
    rng = np.random.default_rng(27)
    q_true = rng.uniform(0.8 * robot.lower, 0.8 * robot.upper)
    T = kinematics.fk(q_true)
    e = references.pose_error_by_log(kinematics.fk(robot.home), T)
    assert e.shape == (6,) and np.allclose(e[:3], T[:3, 3] - kinematics.fk(robot.home)[:3, 3])
    q, history = references.ik_by_least_squares(T, np.clip(q_true + 0.3, robot.lower, robot.upper), damping=2.0)
    assert np.abs(kinematics.fk(q)[:3, 3] - T[:3, 3]).max() < 1e-6 and history.shape[1] == 2
    assert history[-1, 0] < history[0, 0]
