"""The kit's argument checks (armlab.arguments) and the cases issue 24 found: each bad argument raises the kit's
ValueError or TypeError naming it, never OverflowError, AttributeError, ZeroDivisionError, LinAlgError, MemoryError
or numpy's unnamed "could not convert string to float"; numbers in messages print plainly (-10.0)."""

from __future__ import annotations

import numpy as np
import pytest

from armlab import calibration, kinematics, make_station, tasks
from armlab.arguments import finite_array, finite_float, instance_of, int_in_range, plain
from armlab.detection import detect_blocks
from armlab.station import MotionRefused

HUGE = 10**400


@pytest.mark.parametrize("value, error, words", [
    (None, TypeError, "q must be numbers"), ("abc", TypeError, "q must be numbers"),
    ([1, "x", 3], TypeError, "q must be real numbers"), ([[1, 2], [3]], ValueError, "q must be a regular array"),
    ([HUGE, 0, 0], ValueError, "q holds a number too large"), ([True, False, True], TypeError, "booleans"),
    ([1j, 0, 0], TypeError, "complex"), ([0, 0], ValueError, r"q must have shape \(3,\), got shape \(2,\)"),
    ([np.nan, 0, 0], ValueError, "q contains NaN or infinity"), ({"a": 1}, TypeError, "q must be numbers"),
])
def test_finite_array_names_the_argument_and_the_problem(value, error, words):
    with pytest.raises(error, match=words):
        finite_array(value, "q", (3,))


def test_the_scalar_helpers():
    assert finite_float(np.float32(2.5), "x") == 2.5 and int_in_range(np.int64(3), "n", 0, 5) == 3
    for call, error, words in [(lambda: finite_float("1", "x"), TypeError, "x must be a number"),
                               (lambda: finite_float(0, "x", positive=True), ValueError, "x must be a positive"),
                               (lambda: finite_float(HUGE, "x"), ValueError, "x holds a number too large"),
                               (lambda: int_in_range(2.0, "n"), TypeError, "n must be an integer"),
                               (lambda: int_in_range(True, "n"), TypeError, "n must be an integer"),
                               (lambda: int_in_range(HUGE, "n", 0, 10), ValueError, "an integer of 401 digits"),
                               (lambda: instance_of(None, "camera", str), TypeError, "camera must be a str")]:
        with pytest.raises(error, match=words):
            call()
    assert plain(np.float64(-10.0)) == "-10.0" and plain((np.float64(1), np.float64(2))) == "(1.0, 2.0)"


@pytest.fixture(scope="module")
def station():
    return make_station("sim", seed=0)


@pytest.fixture(scope="module")
def session(station):
    return tasks.start_session(station)


def test_the_cases_the_issue_found(station, session):
    frame = station.camera.capture()
    cam = station.camera.truth
    cases = [
        (lambda: kinematics.fk([HUGE, 0, 0, 0, 0]), ValueError, "joint angles hold a number too large"),
        (lambda: kinematics.ik([HUGE, 0, 0], 1.0), ValueError, "position holds a number too large"),
        (lambda: kinematics.ik([0, 300, 30], HUGE), ValueError, "pitch holds a number too large"),
        (lambda: station.arm.move_to([HUGE, 0, 0, 0, 0]), MotionRefused, "joint angles hold a number too large"),
        (lambda: station.arm.move_to(station.arm.joint_positions(), moving_time=HUGE), MotionRefused,
         "moving_time holds a number too large"),
        (lambda: tasks.place(session, [HUGE, 0, 0]), ValueError, "position holds a number too large"),
        (lambda: detect_blocks(frame.rgb, frame.depth, None), TypeError, "camera must be a Camera"),
        (lambda: tasks.pick(session, None), TypeError, "block must be a detected block"),
        (lambda: calibration.fit_depth_correction(frame.depth, cam, step=0), ValueError, "step must be at least 1"),
        (lambda: kinematics.jacobian([0, 0, 0, 0, 0], step=0), ValueError, "step must be a positive number"),
        (lambda: calibration.Calibration(cam).pixel_to_world([[640, 360]], frame.depth, radius=10**6), ValueError,
         "radius must be at least 0 and at most 50"),
        (lambda: kinematics.ik(["1", "2", "x"], 1.0), TypeError, "position must be real numbers"),
        (lambda: cam.project([["a", "b", "c"]]), TypeError, "points_world must be real numbers"),
        (lambda: tasks.click_grab(session, [np.float64(-10.0), "x"]), TypeError, "uv must be real numbers"),
    ]
    for call, error, words in cases:
        with pytest.raises(error, match=words):
            call()


def test_a_click_off_the_image_prints_plain_numbers(session):
    with pytest.raises(tasks.ClickRefused) as err:
        tasks.click_grab(session, (np.float64(-10.0), np.float64(5.0)))
    assert "np.float64" not in str(err.value), str(err.value)
