"""armlab.motion_safety: the one set of motion rules both arms obey, and the whole-plan check."""

from __future__ import annotations

import re

import numpy as np
import pytest

from armlab import kinematics, motion_safety
from armlab.gripper_geometry import GRIPPER
from armlab.motion_safety import REAL_CLEARANCE, SIM_CLEARANCE, HeldBlock, Segment, check_move, check_plan
from armlab.profile import ACCEL_FRACTION
from armlab.robot import rx200
from armlab.station import MotionRefused

DOWN = np.pi / 2


def above(x, y, z, roll=0.0):
    return kinematics.ik(np.array([x, y, z], float), DOWN, roll)[0]


def test_default_ramp_is_the_one_accel_fraction():
    T, Ta = check_move(rx200().sleep, above(0, 250, 100))
    assert Ta == pytest.approx(ACCEL_FRACTION * T) and ACCEL_FRACTION == pytest.approx(1 / 3)


def test_a_joint_limit_is_refused_naming_the_joint():
    with pytest.raises(MotionRefused, match=r"joint limits\): wrist_angle = .* is outside its limits"):
        check_move(np.zeros(5), [0.0, 0.0, 0.0, -1.9, 0.0])


def test_too_fast_and_too_long_are_refused():
    with pytest.raises(MotionRefused, match="velocity limits.*shoulder would need"):
        check_move(np.zeros(5), [0.0, 1.0, 0.0, 0.0, 0.0], moving_time=0.2)
    with pytest.raises(MotionRefused, match="longer than the servos' time profile allows"):
        check_move(np.zeros(5), [0.0, 0.1, 0.0, 0.0, 0.0], moving_time=40.0)


def test_pads_are_checked_on_both_backends_and_links_keep_the_real_margin():
    start, low = above(0, 250, 60), above(0, 250, 5.0)      # tool 5 mm up: finger tips 3 mm into the board
    for clearance in (SIM_CLEARANCE, REAL_CLEARANCE):
        with pytest.raises(MotionRefused, match="finger pad would go down to z = -3.0 mm|tool point"):
            check_move(start, low, clearance=clearance, gripper=GRIPPER, opening_mm=GRIPPER.max_opening_mm)
    tips_on_board = above(0, 250, GRIPPER.fingertip_mm)     # tips exactly on the board, tool point at 8 mm
    check_move(start, tips_on_board, clearance=SIM_CLEARANCE, gripper=GRIPPER, opening_mm=40.0)
    with pytest.raises(MotionRefused, match=r"tool point would go down to z = 8.0 mm .* board's \+10.0 mm floor"):
        check_move(start, tips_on_board, clearance=REAL_CLEARANCE, gripper=GRIPPER, opening_mm=40.0)
    # without pads (an unknown gripper) only the links are checked
    check_move(start, above(0, 250, 4.0), clearance=SIM_CLEARANCE)


def test_a_held_block_counts_and_a_low_start_may_rise():
    cube = HeldBlock(25.0, np.eye(4), "held red block")     # centred on the tool point: 12.5 mm below it
    start, low = above(0, 250, 60), above(0, 250, 11.0)
    with pytest.raises(MotionRefused, match="held red block would go down to z = -1.5 mm"):
        check_move(start, low, clearance=SIM_CLEARANCE, held=[cube])
    check_move(low, start, clearance=SIM_CLEARANCE, held=[cube])          # rising from below the floor is fine


def test_check_plan_refuses_an_impossible_place_before_the_first_command():
    q0 = above(0, 250, 100)
    cube = (HeldBlock(25.0, np.eye(4)),)
    ok = [Segment(above(100, 250, 100), opening_mm=22.0, held=cube, label="transit"),
          Segment(above(100, 250, 20.0), opening_mm=22.0, held=cube, label="descend")]
    times = check_plan(q0, ok, clearance=SIM_CLEARANCE, gripper=GRIPPER)
    assert len(times) == 2 and all(T > 0 and Ta == pytest.approx(T * ACCEL_FRACTION) for T, Ta in times)
    bad = [ok[0], Segment(above(100, 250, 8.0), opening_mm=22.0, held=cube, label="descend")]
    with pytest.raises(MotionRefused, match=r"plan refused at segment 1 \(descend\) of 2: .*held block would go"):
        check_plan(q0, bad, clearance=SIM_CLEARANCE, gripper=GRIPPER)
    with pytest.raises(ValueError, match="segment 0 must be a motion_safety.Segment"):
        check_plan(q0, [above(0, 250, 50)])


def test_the_path_is_sampled_finely_enough_to_catch_a_dip():
    qa, qb = np.array([0, 1.5, 1.6, 2.0, 0.0]), np.array([0, 0.5, -0.7, 1.4, 0.0])
    s = motion_safety.path_fractions(qa, qb)
    assert s[0] == 0 and s[-1] == 1 and np.max(np.diff(s)) * np.abs(qb - qa).max() <= motion_safety.PATH_STEP_RAD
    assert "wrist joint would go down to z = -45.9 mm" in motion_safety.board_intrusion(qa, qb, REAL_CLEARANCE)
    assert motion_safety.board_intrusion(qb, qb, REAL_CLEARANCE) is None


# ---------------------------------------------------------------------------------------------------------------
# The placement rule
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("spot, edge, yaw, reason", [
    ((0.0, 20.0, 10.0), 38.0, 0.0, r"\(0, 20\) mm is on the robot's base plate \(the plate and a 10 mm margin: "
                                   r"\|x\| <= 65, \|y\| <= 70 mm\)"),
    ((0.0, 85.0, 0.0), 38.0, 0.0, "too close to the robot's base plate for a 38 mm block"),
    ((0.0, 85.0, 0.0), 25.0, 0.0, None),                          # a small block fits there
    ((0.0, 93.0, 0.0), 38.0, np.pi / 4, "too close to the robot's base plate"),   # turned: its corner reaches in
    ((0.0, 93.0, 0.0), 38.0, 0.0, None),
    ((495.0, 300.0, 0.0), 25.0, 0.0, "too close to the board's edge for a 25 mm block"),
    ((520.0, 300.0, 0.0), 0.0, 0.0, r"\(520, 300\) mm is off the board"),
    ((-420.0, 420.0, 0.0), 25.0, 0.0, "out of the arm's reach: 599 mm from the shoulder joint"),
    ((-350.0, -120.0, 0.0), 38.0, 0.3, None),
])
def test_the_placement_rule_names_the_problem(spot, edge, yaw, reason):
    problem = motion_safety.placement_problem(spot, edge, yaw)
    if reason is None:
        assert problem is None
        motion_safety.check_placement(spot, edge, yaw)
    else:
        assert problem is not None and re.search(reason, problem), problem
        with pytest.raises(MotionRefused, match=r"motion refused \(placement\): .*" + reason):
            motion_safety.check_placement(spot, edge, yaw)


def test_the_placement_rule_refuses_malformed_input():
    for bad in ([0.0, 1.0], [np.nan, 200.0, 0.0], "here"):
        with pytest.raises(ValueError, match="placement position"):
            motion_safety.placement_problem(bad)
    with pytest.raises(ValueError, match="edge >= 0"):
        motion_safety.placement_problem([0.0, 200.0, 0.0], -1.0)
