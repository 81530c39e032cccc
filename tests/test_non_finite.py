"""NaN and infinity in joint vectors are refused everywhere a joint vector enters: the robot model's limit check
itself (a NaN compares false with every limit, so a bare `value < lo or value > hi` lets it through), teach files and
programs, kinematics, planning, the motion-safety checks, and both arms behind the task layer's GuardedArm.
Each place is checked on its own, so removing any one guard (e.g. the teach program's own finiteness check) is caught
by the limit check underneath, and a limit check that lets NaN through is caught here directly."""

from __future__ import annotations

import json

import numpy as np
import pytest

from armlab import kinematics, motion_safety, planning
from armlab.robot import JOINT_NAMES, rx200
from armlab.station import MotionRefused
from armlab.tasks import GuardedArm, TeachFileError, teach

BAD_VALUES = [np.nan, np.inf, -np.inf]
Q_OK = np.array([0.0, -0.5, 0.3, 1.2, 0.0])     # well inside every limit


def _with(value: float, joint: int) -> np.ndarray:
    q = Q_OK.copy()
    q[joint] = value
    return q


@pytest.mark.parametrize("value", BAD_VALUES)
@pytest.mark.parametrize("joint", range(5))
def test_limit_violations_names_a_non_finite_joint(value, joint):
    r = rx200()
    bad = r.limit_violations(_with(value, joint))
    assert len(bad) == 1 and bad[0].startswith(f"{JOINT_NAMES[joint]} = ") and "not a finite angle" in bad[0], bad
    assert not r.within_limits(_with(value, joint))
    assert r.limit_violations(Q_OK) == [] and r.within_limits(Q_OK)


def test_limit_violations_refuses_a_wrong_shape():
    with pytest.raises(ValueError, match=r"shape \(5,\)"):
        rx200().limit_violations([0.0, 0.1, 0.2])


def _program() -> teach.TeachProgram:
    return teach.TeachProgram(np.stack([Q_OK, Q_OK + [0.2, 0.1, 0.0, 0.0, 0.0], Q_OK]), ("open", "closed", "open"),
                              "three")


@pytest.mark.parametrize("literal, value", [("NaN", np.nan), ("Infinity", np.inf), ("-Infinity", -np.inf)])
@pytest.mark.parametrize("joint", range(5))
def test_a_teach_file_with_a_non_finite_angle_does_not_load(tmp_path, literal, value, joint):
    path = teach.save_teach(_program(), tmp_path / "p.json")
    data = json.loads(path.read_text())
    data["waypoints"][1]["q"][joint] = value
    text = json.dumps(data)                                  # Python's json writes NaN / Infinity literals
    assert literal in text
    path.write_text(text)
    with pytest.raises(TeachFileError, match=rf"p\.json: waypoints\[1\]\.q\[{joint}\]: .*finite"):
        teach.load_teach(path)


@pytest.mark.parametrize("value", BAD_VALUES)
def test_a_teach_program_refuses_non_finite_waypoints(value):
    q = _program().q.copy()
    q[2, 3] = value
    with pytest.raises(ValueError, match="waypoint 2: .*finite"):
        teach.TeachProgram(q, ("open", "closed", "open"))


@pytest.mark.parametrize("value", BAD_VALUES)
@pytest.mark.parametrize("joint", range(5))
def test_kinematics_and_planning_refuse_non_finite_joints(value, joint):
    q = _with(value, joint)
    for call in (lambda: kinematics.fk(q), lambda: kinematics.check_joints(q),
                 lambda: kinematics.check_joints(q, check_limits=False),
                 lambda: kinematics.fk(np.stack([Q_OK, q])),
                 lambda: planning.joint_move(Q_OK, q), lambda: planning.joint_move(q, Q_OK)):
        with pytest.raises(ValueError, match="NaN or infinity"):
            call()


@pytest.mark.parametrize("value", BAD_VALUES)
@pytest.mark.parametrize("joint", range(5))
def test_motion_safety_refuses_non_finite_targets_and_starts(value, joint):
    q = _with(value, joint)
    with pytest.raises(MotionRefused, match=r"motion refused \(bad target\): .*NaN or infinity"):
        motion_safety.check_target(q)
    with pytest.raises(MotionRefused, match="NaN or infinity"):
        motion_safety.check_move(Q_OK, q, moving_time=2.0)
    with pytest.raises(ValueError, match="NaN or infinity"):
        motion_safety.check_move(q, Q_OK, moving_time=2.0)
    plan = [motion_safety.Segment(Q_OK + 0.05, 2.0), motion_safety.Segment(q, 2.0, label="the bad one")]
    with pytest.raises(MotionRefused, match=r"segment 1 \(the bad one\) of 2: .*NaN or infinity"):
        motion_safety.check_plan(Q_OK, plan)


class _Recorder:
    """The smallest arm: records what it is sent."""

    robot = rx200()

    def __init__(self):
        self.sent = []

    def joint_positions(self):
        return Q_OK.copy()

    def move_to(self, q, moving_time=None, accel_time=None, blocking=True):
        self.sent.append(np.asarray(q, float))


@pytest.mark.parametrize("value", BAD_VALUES)
@pytest.mark.parametrize("joint", range(5))
def test_guarded_arm_sends_nothing_for_a_non_finite_target(value, joint):
    arm = _Recorder()
    guarded = GuardedArm(arm)
    with pytest.raises(ValueError, match="5 finite joint angles"):
        guarded.move_to(_with(value, joint), moving_time=2.0)
    assert arm.sent == [] and guarded.sent == []
