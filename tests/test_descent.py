"""The kit's descent (armlab.planning.descent): the instructor's planners come straight down (straight_descent), the
student release's on a joint chord (trajectory.joint_chord), and planning.approach_deviation tells them apart, as
exercise grab.move_path's judge does (issue 32: the release's planners are another method than the exercise's)."""

import sys

import numpy as np
import pytest

from armlab import kinematics, planning
from armlab.kinematics import Unreachable
from armlab.planning.trajectory import LINE_TOLERANCE_MM
from armlab.tasks.move_path import move_path, report_move_path

TARGETS = [np.array([r * np.cos(h), r * np.sin(h), top]) for r in (150.0, 250.0, 340.0)
           for h in np.radians([35.0, 90.0, 140.0]) for top in (25.0, 76.0)]


@pytest.fixture
def release_descent(monkeypatch):
    """The planners as the student release has them: the kit's straight descent left out."""
    monkeypatch.setitem(sys.modules, "armlab.planning.straight_descent", None)
    assert not planning.descent.straight()


def _descent(plan):
    return next(s.trajectory for s in plan.steps if s.label == "descend")


def test_the_instructors_planners_come_straight_down():
    assert planning.descent.straight()
    for top in TARGETS:
        plan = planning.plan_pick(planning.CAMERA_CLEAR_POSE, top, 0.3, 25.0)
        assert isinstance(_descent(plan), planning.CartesianSegment)
        assert planning.approach_deviation(plan, "close") <= LINE_TOLERANCE_MM


def test_the_releases_planners_come_down_on_a_joint_chord_the_judge_refuses(release_descent):
    bows = []
    for top in TARGETS:
        plan = planning.plan_pick(planning.CAMERA_CLEAR_POSE, top, 0.3, 25.0)
        down = _descent(plan)
        assert isinstance(down, planning.JointChord)
        # the tool is where the plan says at both ends, posed as planned
        for q, p in ((down.start, down.p0), (down.end, down.p1)):
            np.testing.assert_allclose(kinematics.fk(q)[:3, 3], p, atol=1e-6)
        bows.append(planning.approach_deviation(plan, "close"))
        held = plan.then(planning.plan_place(plan.end, [0.0, 200.0, 0.0], 25.0, 0.0))
        assert planning.approach_deviation(held, "open") > planning.STRAIGHT_TOLERANCE_MM
    assert min(bows) > planning.STRAIGHT_TOLERANCE_MM, f"a joint chord bowed only {min(bows):.2f} mm"


def test_approach_deviation_measures_the_last_move_before_the_action():
    q0 = planning.CAMERA_CLEAR_POSE
    straight = move_path(q0, [250.0, 100.0, 38.0], 0.3, 38.0, "grasp")       # the exercise's reference
    assert planning.approach_deviation(straight, "close") <= LINE_TOLERANCE_MM
    # the lab report's plan comes down its last 100 mm in a joint move, far off the vertical
    assert planning.approach_deviation(report_move_path(q0, [250.0, 100.0, 38.0], 0.3, 38.0, "grasp"), "close") > 2
    with pytest.raises(ValueError, match="never does 'close'"):
        planning.approach_deviation(move_path(q0, [250.0, 100.0, 0.0], 0.3, 38.0, "release"), "close")
    with pytest.raises(ValueError, match="before it moves"):
        planning.approach_deviation(planning.Plan((planning.GripperStep("close", "grasp"), planning.MoveStep(
            planning.joint_move(q0, q0 + [0.2, 0.0, 0.0, 0.0, 0.0]), "turn"))), "close")
    with pytest.raises(TypeError, match="planning.Plan"):
        planning.approach_deviation([], "close")


def test_a_joint_chord_ends_where_asked_and_bows_between():
    p0, p1 = np.array([300.0, 50.0, 120.0]), np.array([300.0, 50.0, 30.0])
    chord = planning.joint_chord(p0, p1, np.pi / 2, 0.2)
    line = planning.cartesian_line(p0, p1, np.pi / 2, 0.2)
    np.testing.assert_allclose(chord.start, line.start, atol=1e-9)
    np.testing.assert_allclose(chord.end, line.end, atol=1e-9)
    assert chord.max_deviation_mm > 1.0 > line.max_deviation_mm
    assert np.all(chord.peak_speed() <= kinematics.rx200().velocity * (1 + 1e-9))
    back = planning.reverse(chord)
    assert isinstance(back, planning.JointChord) and np.array_equal(back.p0, p1)


def test_a_joint_chord_names_the_end_out_of_reach():
    with pytest.raises(Unreachable, match=r"\(600.0, 0.0, 30.0\) mm is out of reach"):
        planning.joint_chord([300.0, 0.0, 30.0], [600.0, 0.0, 30.0], np.pi / 2)
    with pytest.raises(ValueError, match="pitch must be finite"):
        planning.joint_chord([300.0, 0.0, 30.0], [300.0, 0.0, 60.0], np.nan)
