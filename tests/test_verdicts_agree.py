"""One geometry (issue 33): the executor's whole-plan check and the simulator's per-move check agree on random plans.

On the ideal simulated arm (no sag, backlash, offsets or noise: the kit's belief of where the arm is is the truth),
with the held block's pose in the tool frame and the block standing on the board known exactly as the simulator has
them, random plans (a move over the board, then a move to a random spot beside, over or into the standing block, and
down towards the board) are given to the executor. Whatever the pre-check passes runs through without a refusal from
the simulator (never refused mid-plan); whatever it refuses for the held block, the simulator refuses too (run on the
raw arm, bypassing the executor), unless the held block goes no deeper than the simulator's allowance (the pre-check
keeps PRECHECK_MARGIN_MM of it for detection error). Both verdicts come from motion_safety.held_depths.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from armlab import kinematics, make_station, motion_safety, planning, tasks
from armlab.kinematics import Unreachable
from armlab.station import MotionRefused
from armlab.tasks import GuardedArm, executor, precheck

HELD_XY, STANDING_XY = (-120.0, 220.0), (80.0, 250.0)
SCENE = {"objects": [{"color": "red", "size": "large", "position_mm": list(HELD_XY), "yaw_rad": 0.0},
                     {"color": "blue", "size": "large", "position_mm": list(STANDING_XY), "yaw_rad": 0.3}]}


@pytest.fixture(scope="module")
def world():
    """The ideal simulated station holding the red block, the blue one standing; the session knows both exactly."""
    station = make_station("sim", seed=0, scene=SCENE, realism="ideal")
    session = tasks.Session(station, GuardedArm(station.arm))
    red, blue = (next(o for o in station.world.blocks if o.color == c) for c in ("red", "blue"))
    top = red.position + [0.0, 0.0, red.edge / 2]
    assert tasks.pick(session, SimpleNamespace(position=top, yaw=red.yaw, size=red.size, color="red",
                                               edge_mm=red.edge))
    (held, T_rel), = station.arm._held
    session.held_in_tool = T_rel.copy()                                # the truth: belief and truth are one here
    station.arm.set_held_blocks((motion_safety.HeldBlock(red.edge, T_rel.copy(), "held red block"),))
    session.known = [SimpleNamespace(position=blue.position + [0.0, 0.0, blue.edge / 2], yaw=blue.yaw,
                                     edge_mm=blue.edge, size=blue.size, color="blue")]
    with station:
        w = SimpleNamespace(station=station, session=session, blue=blue, start=session.arm.joint_positions(),
                            blue_pose=(blue.position.copy(), blue.yaw), way_back=[])
        yield w
        restore(w)


def restore(w) -> None:
    """Back to the start pose (raw arm) the way the last plan came, with the blue block where it stood."""
    for q in w.way_back:
        w.station.arm.move_to(q)
    w.way_back = []
    w.blue.position, w.blue.yaw = w.blue_pose[0].copy(), w.blue_pose[1]


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(dx=st.floats(-70.0, 70.0), dy=st.floats(-70.0, 70.0), bottom=st.floats(5.0, 80.0),
       wrist=st.floats(-0.4, 0.4))
def test_the_pre_check_and_the_simulators_check_agree(world, dx, dy, bottom, wrist):
    w = world
    restore(w)
    s = w.session
    xy = np.array(STANDING_XY) + [dx, dy]
    T_tool_block = np.asarray(s.held_in_tool, float)
    try:
        q_over = kinematics.ik([*xy, 160.0], np.pi / 2, wrist, current=w.start)[0]
        lowest_below_tool = -(kinematics.fk_pox(q_over)[:3, :3] @ T_tool_block[:3, 3])[2] + s.held_edge / 2
        q_low = kinematics.ik([*xy, bottom + lowest_below_tool], np.pi / 2, wrist, current=q_over)[0]
    except Unreachable:
        assume(False)                                    # no such plan: the arm cannot get there top-down
    plan = planning.Plan((planning.MoveStep(planning.joint_move(w.start, q_over), "over"),
                          planning.MoveStep(planning.joint_move(q_over, q_low), "down")))
    sent = len(s.arm.sent)
    w.way_back = [q_over, w.start]                 # what restore() retraces when the plan ran
    try:
        s.run(plan, "a random plan")
    except executor.PlanRefused as refusal:
        assert len(s.arm.sent) == sent
        if "held red block" not in str(refusal) or "known block" not in str(refusal):
            return                                                       # refused for the board or the pads
        # the pre-check refused the held block: the simulator refuses it too, unless it is within the margin band
        depth = max_depth(s, plan)
        try:
            planning.execute(plan, w.station.arm)
        except MotionRefused as e:
            assert "held" in str(e), e
            return
        assert depth <= motion_safety.HELD_CONTACT_TOL_MM + 1e-6, \
            f"the pre-check refused ({refusal}) but the simulator ran the plan, {depth:.2f} mm deep"
        return
    # the pre-check passed: the simulator ran every command (a refusal would have raised out of s.run)
    assert len(s.arm.sent) == sent + len(precheck.plan_segments(plan, s.arm, s.held_edge, ()))


def max_depth(session, plan) -> float:
    """The deepest (mm) the held block goes into the known block along the plan, by the one geometry."""
    box = precheck.known_prism(precheck.known_boxes(session.known)[0])
    held = motion_safety.HeldBlock(session.held_edge, np.asarray(session.held_in_tool, float))
    deepest, q = -np.inf, np.asarray(plan.start, float)
    for step in plan.steps:
        q1 = np.asarray(step.trajectory.end, float)
        s = motion_safety.held_path_fractions(q, q1)
        poses = kinematics.fk_pox(q + s[:, None] * (q1 - q), check_limits=False) @ held.T_tool_block
        deepest = max(deepest, float(motion_safety.held_depths(precheck.held_prism(held), poses, box).max()))
        q = q1
    return deepest
