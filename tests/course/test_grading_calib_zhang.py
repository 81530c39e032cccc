"""Exercise calib.zhang (notebook 01, issue 23, branch lab27a): Zhang's closed-form intrinsics. The blank stub fails
every hidden check, a wrong answer loses calib.zhang only (calib.pinhole, the other cheap exercise of notebook 01,
held at its reference, passes every one of its checks), and the kit's stand-in for the blank exercise and the
reference's input checks behave."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from armlab_course.exercises.markers import stub_lines
from armlab_course.grading.run import Limits

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "course"))
CHEAP = ("calib.zhang", "calib.pinhole")          # notebook 01's exercises whose hidden checks run no simulator


@pytest.fixture(scope="module")
def grader():
    from armlab_course.grading.grade import Grader

    g = Grader(ROOT, Limits(timeout_s=300, cpu_s=200), list(CHEAP))
    yield g
    g.close()


def test_the_blank_stub_fails_every_hidden_check(grader):
    from wrong_answers import reference_bodies

    blank = ["\n".join("    " + line for line in stub_lines("calib.zhang"))] * len(reference_bodies("calib.zhang"))
    got = grader.hidden_checks("calib.zhang", blank)
    assert got and not any(c.passed for c in got), [c.message for c in got]


@pytest.mark.parametrize("round_", [0, 1])
def test_a_wrong_answer_loses_its_own_exercise_only(grader, round_):
    """Each of the two exercises wrong in turn (its round_-th wrong answer of wrong_answers.HIDDEN_WRONG) while the
    other holds the reference: the wrong one fails a hidden check, the other passes every one."""
    from wrong_answers import check_each_wrong_loses_only_its_own

    check_each_wrong_loses_only_its_own(grader, CHEAP, round_)


def _camera_and_views(n_views=4, seed=3):
    from armlab_course.grading.hidden.calib_zhang import _rotation

    rng = np.random.default_rng(seed)
    K = np.array([[900.0, 0.0, 650.0], [0.0, 880.0, 350.0], [0.0, 0.0, 1.0]])
    Hs = []
    for k in range(n_views):
        R = np.diag([1.0, -1.0, -1.0]) @ _rotation([np.cos(k), np.sin(k), 0.0], np.radians(30))
        Hs.append(rng.uniform(-2, 2) * K @ np.column_stack([R[:, 0], R[:, 1], [-100.0, -60.0, 600.0 + 50 * k]]))
    return K, Hs


def test_the_reference_recovers_K_and_refuses_bad_input():
    """The reference of the built notebook (its definitions only), on exact views of a known camera; and its
    ValueErrors: too few views, a matrix that is not 3 x 3, views that leave B undetermined (square-on to the
    camera, or in parallel planes)."""
    from wrong_answers import reference_bodies

    from armlab_course.grading.hidden.calib_zhang import _rotation

    body = reference_bodies("calib.zhang")[0]
    scope = {"np": np}
    exec("def intrinsics_from_homographies(homographies, image_size):\n" + body + "\n    return K\n", scope)
    solve = scope["intrinsics_from_homographies"]
    K, Hs = _camera_and_views()
    assert np.abs(solve(Hs, (1280, 720)) - K).max() < 1e-6
    for bad, why in (([Hs[0]], "two or more"), ([Hs[0], np.eye(2)], "3 x 3"),
                     ([Hs[0], np.full((3, 3), np.nan)], "3 x 3")):
        with pytest.raises(ValueError, match=why):
            solve(bad, (1280, 720))
    square_on = [K @ np.column_stack([[np.cos(a), np.sin(a), 0.0], [np.sin(a), -np.cos(a), 0.0], [0.0, 0.0, 700.0]])
                 for a in (0.1, 0.7, 1.9)]
    parallel = [K @ np.column_stack([R[:, 0], R[:, 1], [-100.0, -60.0, 600.0 + 50 * k]]) for k, R in
                enumerate(np.diag([1.0, -1.0, -1.0]) @ _rotation([1.0, 0.0, 0.0], 0.5) @ _rotation([0.0, 0.0, 1.0], a)
                          for a in (0.0, 1.0, 2.0))]          # tilted, but the three boards in parallel planes
    for degenerate in (square_on, parallel, parallel[:2]):
        with pytest.raises(ValueError, match="do not fix K"):
            solve(degenerate, (1280, 720))


def test_the_blank_stand_in_is_opencvs_initial_guess():
    """references.intrinsics_by_opencv (what the notebook's table and figure use while calib.zhang is blank): the
    principal point at the image centre, focal lengths near the camera's, and not the exercise's answer."""
    from armlab_course.exercises import references

    K, Hs = _camera_and_views(6)
    guess = references.intrinsics_by_opencv(Hs, (1280, 720))
    assert guess.shape == (3, 3) and guess[0, 2] == pytest.approx(639.5, abs=0.6) and \
        guess[1, 2] == pytest.approx(359.5, abs=0.6)
    assert np.abs(np.diag(guess)[:2] / np.diag(K)[:2] - 1).max() < 0.1
