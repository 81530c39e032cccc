"""armlab.tasks: sag model, guarded arm, pick and place on the realistic simulated station."""

import numpy as np
import pytest

from armlab import kinematics, make_station, tasks
from armlab.profile import velocity_violations
from armlab.station import EmergencyStopped, MotionRefused
from armlab.tasks.sag import SagModel, calibration_poses, fit_sag

# Four blocks: aligned and yawed, both sizes, spread over reach and heading (world mm, yaw rad).
SCENE = {"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
    {"color": "blue", "size": "large", "position_mm": [180.0, 250.0], "yaw_rad": np.radians(35.0)},
    {"color": "green", "size": "small", "position_mm": [0.0, 320.0], "yaw_rad": 0.0},
    {"color": "yellow", "size": "small", "position_mm": [260.0, 60.0], "yaw_rad": np.radians(-30.0)},
]}
TARGETS = np.array([[-250.0, 50.0, 0.0], [-80.0, 130.0, 0.0], [100.0, 140.0, 0.0], [-120.0, 330.0, 0.0]])


@pytest.fixture(scope="module")
def session():
    session = tasks.start_session(make_station("sim", seed=5, scene=SCENE))
    tasks.look(session)
    return session


def _measured_sag(seed=3, noise_mm=0.0):
    st = make_station("sim", seed=seed, scene="empty")
    rng = np.random.default_rng(seed)
    model = tasks.calibrate_sag(st.arm, lambda: st.arm.tool_pose_true()[:3, 3] + rng.normal(0, noise_mm, 3))
    return st, model


def test_sag_fit_predicts_the_simulators_bend_at_new_poses():
    st, model = _measured_sag(noise_mm=1.0)          # touch-off readings with 1 mm errors
    assert model.poses == len(calibration_poses()) and model.rms_mm < 2.5
    rng = np.random.default_rng(1)
    raw, comp = [], []
    for _ in range(12):
        r, th, z = rng.uniform(200, 330), rng.uniform(-1.0, 1.0), rng.uniform(40, 100)
        p = np.array([r * np.sin(th), r * np.cos(th), z])
        q = kinematics.ik(p, np.pi / 2, 0.0)[0]
        for cmd, out in ((q, raw), (model.command(q), comp)):
            st.arm.move_to(kinematics.ik(p + [0, 0, 60], np.pi / 2, 0.0)[0])
            st.arm.move_to(cmd)
            out.append(st.arm.tool_pose_true()[:3, 3] - p)
    raw, comp = np.abs(raw), np.abs(comp)
    assert raw[:, 2].max() > 4.0                        # the arm really sags
    assert comp.max() < 1.5 and comp[:, 2].mean() < 0.8  # and the fitted model takes it out


def test_starting_a_session_touches_no_block_and_the_twin_is_the_same_arm():
    from armlab.tasks.events import event_station

    st = event_station("line_up", 3, seed=1)        # its sag calibration poses used to shove 3 blocks and a stack
    before = [(o.position.copy(), o.yaw) for o in st.world.objects]
    t0 = st.world.time_s
    tasks.start_session(st)
    assert [(o.position.tolist(), o.yaw) for o in st.world.objects] == [(p.tolist(), y) for p, y in before]
    twin = st.arm.empty_board_twin()
    assert twin.world is not st.world and not twin.world.objects and twin.seed == st.arm.seed
    q_a, q = kinematics.ik([-100.0, 300.0, 120.0], 1.2, 0.3)[0], kinematics.ik([150.0, 250.0, 60.0], np.pi / 2)[0]
    assert np.all(q_a != q)                            # every joint ends moving the same way (backlash side)
    for arm in (st.arm, twin):
        arm.move_to(q_a)
        arm.move_to(q)
    assert np.allclose(twin.q_true, st.arm.q_true, atol=1e-9)   # same offsets, sag, backlash: the fit holds here
    assert st.world.time_s - t0 < 30.0                 # calibration (camera view) only, not 30 sag poses


def test_sag_command_inverts_physical():
    model = SagModel(np.array([-1e-4, 2e-5, 1.5e-4, 1e-4, -1e-4, 0.001, -0.02, 0.006, 0.002]))
    q = kinematics.ik([100.0, 300.0, 40.0], np.pi / 2, 0.3)[0]
    assert np.abs(model.physical(model.command(q)) - q).max() < 1e-8


def test_fit_sag_refuses_bad_input():
    q = calibration_poses()
    p = kinematics.fk(q)[:, :3, 3]
    with pytest.raises(ValueError, match="at least 9 poses"):
        fit_sag(q[:5], p[:5])
    with pytest.raises(ValueError, match=r"\(N, 5\)"):
        fit_sag(q, p[:, :2])
    bad = p.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="finite"):
        fit_sag(q, bad)
    with pytest.raises(ValueError, match="do not determine"):
        fit_sag(np.repeat(q[:1], 12, axis=0), np.repeat(p[:1], 12, axis=0))
    assert np.abs(fit_sag(q, p).params).max() < 1e-9    # an arm that does not sag fits to zero


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_pick_and_place_aligned_and_yawed_blocks_of_both_sizes(session):
    station = session.station
    seen = sorted(session.last.blocks, key=lambda b: b.color)
    assert [b.color for b in seen] == ["blue", "green", "red", "yellow"]
    for block, target in zip(seen, TARGETS, strict=True):
        truth = next(o for o in station.world.blocks if o.color == block.color)
        assert tasks.pick(session, block), f"{block.color} {block.size} not grasped: {station.arm.last_grasp}"
        assert station.arm.holding[0] is truth
        assert tasks.place(session, target)
        bottom = truth.position - [0.0, 0.0, truth.edge / 2]
        err = np.abs(bottom - target)
        assert err[:2].max() < 3.0 and err[2] < 0.5, f"{block.color} placed {err} mm off"
        assert np.abs(truth.tilt).max() < 1e-6            # standing upright, not tipped
    assert not station.arm.holding


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_every_command_sent_respects_the_velocity_limits(session):
    sent = session.arm.sent
    assert len(sent) > 50
    for q_from, q_cmd, T, _ in sent:
        if T is not None:
            assert velocity_violations(q_from, q_cmd, T) == []


def test_guarded_arm_stretches_a_move_the_compensation_makes_too_fast():
    st = make_station("sim", seed=0, scene="empty", realism="ideal")
    st.arm.move_to(kinematics.ik([0.0, 250.0, 100.0], np.pi / 2, 0.0)[0])
    arm = tasks.GuardedArm(st.arm, SagModel(np.array([0, 0, 5e-4, 0, 0, 0, 0, 0, 0])))  # shoulder bends with reach
    stretched = []
    for step in (0.3, -0.3):                              # the shoulder moves the tool out, then back in
        start = arm.joint_positions()
        target = start + [0.0, step, 0.0, 0.0, 0.0]
        T = 0.3 / st.arm.robot.velocity[1]                # exactly at the limit for the uncompensated change
        arm.move_to(target, moving_time=T, accel_time=0.0)
        q_from, q_cmd, T_sent, _ = arm.sent[-1]
        assert T_sent >= T and velocity_violations(q_from, q_cmd, T_sent) == []
        assert np.allclose(arm.joint_positions(), target, atol=1e-6)
        stretched.append(T_sent > T)
    assert any(stretched)


@pytest.mark.parametrize("after", [1, 3, 6])
def test_a_stop_requested_mid_plan_sends_no_further_command(monkeypatch, after):
    # the stop flag alone (as a TaskMachine's, set from another thread) must halt a running pick: GuardedArm asks
    # should_stop() before every command, emergency-stops the arm and raises; nothing after it reaches the arm
    st = make_station("sim", seed=2, scene=SCENE)
    session = tasks.start_session(st)
    obs = tasks.look(session)
    guarded = session.arm
    reached = []
    real_move = st.arm.move_to

    def counting_move(q, *args, **kwargs):
        real_move(q, *args, **kwargs)
        reached.append(np.asarray(q, float))

    monkeypatch.setattr(st.arm, "move_to", counting_move)
    monkeypatch.setattr(st.arm, "close_gripper", lambda: pytest.fail("the gripper closed after the stop request"))
    guarded.should_stop = lambda: len(reached) >= after
    sent_before = len(guarded.sent)
    with pytest.raises(EmergencyStopped, match="emergency stop was requested"):
        tasks.pick(session, obs.blocks[0])
    assert len(reached) == after and len(guarded.sent) - sent_before == after
    assert st.arm.emergency_stopped
    np.testing.assert_allclose(st.arm.joint_positions(), reached[-1], atol=0.01)    # stopped at that command
    assert not st.arm.holding


def test_guarded_arm_recording_lists_the_commands_the_arm_accepted():
    st = make_station("sim", seed=0, scene="empty", realism="ideal")
    arm = tasks.GuardedArm(st.arm)
    arm.open_gripper()                                                  # before the block: not listed
    with arm.recording() as log:
        arm.move_to(st.arm.robot.home, 2.0)
        assert arm.close_gripper() is False
        with pytest.raises(MotionRefused):
            arm.move_to([9.0, 0.0, 0.0, 0.0, 0.0])                     # refused: not listed
    arm.open_gripper()                                                  # after the block: not listed
    assert [c[0] for c in log] == ["move", "close"] and log[0][2] == 2.0 and log[1] == ("close", False)
    np.testing.assert_array_equal(log[0][1], st.arm.robot.home)


def test_a_stop_request_refuses_the_gripper_too():
    st = make_station("sim", seed=2, scene="empty")
    stop = False
    arm = tasks.GuardedArm(st.arm, should_stop=lambda: stop)
    arm.open_gripper()
    stop = True
    for action in (arm.close_gripper, arm.open_gripper, lambda: arm.move_to(st.arm.robot.home, 2.0)):
        with pytest.raises(EmergencyStopped):
            action()
    assert st.arm.emergency_stopped and arm.sent == []


def test_pick_refuses_while_holding_and_place_refuses_when_empty():
    st = make_station("sim", seed=2, scene=SCENE)
    session = tasks.start_session(st)
    obs = tasks.look(session)
    with pytest.raises(ValueError, match="holds no block"):
        tasks.place(session, [0.0, 250.0, 0.0])
    assert tasks.pick(session, obs.blocks[0])
    q = st.arm.joint_positions()
    with pytest.raises(ValueError, match="already holds"):
        tasks.pick(session, obs.blocks[1])
    with pytest.raises(MotionRefused, match="out of the arm's reach"):        # the placement rule
        tasks.place(session, [450.0, 400.0, 0.0])
    assert np.allclose(st.arm.joint_positions(), q, atol=0.005)   # nothing moved


def _guarded_sim_arm(sag_params, **realism):
    """A GuardedArm on a bare simulated arm whose realism is ideal except for the given fields."""
    from dataclasses import replace

    from armlab.sim import ArmRealism, SimArm, World

    arm = SimArm(World(), realism=replace(ArmRealism.preset("ideal"), **realism))
    return tasks.GuardedArm(arm, SagModel(np.array(sag_params, float)))


def test_guard_clips_a_compensated_command_just_past_a_limit_and_refuses_more():
    from armlab.station import MotionRefused
    from armlab.tasks.guard import LIMIT_CLIP_RAD

    upper = kinematics.rx200().upper[3]
    q = np.array([0.0, -0.5, 0.5, upper, 0.0])                     # wrist_angle planned right at its limit
    arm = _guarded_sim_arm([0, 0, 0, 0, 0, 0, 0, 0, -0.003])       # the compensation adds 3 mrad to wrist_angle
    arm.move_to(q)                                                  # the raw arm would refuse 2.149755 rad
    assert arm.sent[-1][1][3] == upper and abs(arm.arm.joint_positions()[3] - upper) < 1e-12
    arm = _guarded_sim_arm([0, 0, 0, 0, 0, 0, 0, 0, -(LIMIT_CLIP_RAD + 0.005)])
    before = arm.arm.joint_positions()
    with pytest.raises(MotionRefused, match=r"wrist_angle: planned 2\.146755 rad, compensated 2\.161755 rad"):
        arm.move_to(q)
    arm = _guarded_sim_arm([0, 0, 0, 0, 0, 0, 0, 0, -0.003])
    with pytest.raises(MotionRefused, match="planned value is outside them too"):
        arm.move_to(q + [0, 0, 0, 0.002, 0])                       # planned past the limit: never clipped
    assert np.array_equal(arm.arm.joint_positions(), before) and arm.sent == []


def test_guard_stretch_passes_the_arms_rule_from_its_last_command_not_only_the_encoder_reading():
    # quantised encoders: the reading of the start differs from where the motors (and the driver's last command) are
    arm = _guarded_sim_arm(np.zeros(9), encoder_ticks=4096)
    step = 2 * np.pi / 4096
    q0 = np.array([0.0, -0.5 + 0.02 * step, 0.5, 0.0, 0.0])
    q0[1] = (np.floor(q0[1] / step) + 0.9) * step                   # reads one tick up, towards the target
    arm.move_to(q0)
    assert arm.arm.joint_positions()[1] > q0[1]
    target = q0 + [0.0, 0.05, 0.0, 0.0, 0.0]
    T = 0.05 / arm.robot.velocity[1]                                # exactly at the shoulder's limit
    arm.move_to(target, moving_time=T, accel_time=0.0)              # was refused: "1.00 rad/s, above its 1.00 rad/s"
    q_from, q_cmd, T_sent, _ = arm.sent[-1]
    assert T_sent > T and velocity_violations(q0, q_cmd, T_sent) == []
    assert np.allclose(arm.arm.joint_positions(), target, atol=step)


def test_look_can_return_every_object_and_the_event_runner_sees_through_it():
    from armlab.sim.scenes import DISTRACTOR_SHAPES
    from armlab.tasks.events.runner import see

    scene = {"objects": [{"color": "red", "size": "large", "position_mm": [-120.0, 220.0]},
                         {"color": "blue", "size": "large", "shape": DISTRACTOR_SHAPES[0],
                          "position_mm": [120.0, 220.0]}]}
    st = make_station("sim", seed=4, scene=scene)
    session = tasks.start_session(st)
    cubes = tasks.perception.observe(st, session.calibration, session.arm).blocks
    everything = tasks.perception.observe(st, session.calibration, session.arm, all_objects=True).blocks
    assert [b.color for b in cubes] == ["red"] and all(b.is_block for b in cubes)
    assert sorted((b.color, b.is_block) for b in everything) == [("blue", False), ("red", True)]
    far = next(b for b in everything if not b.is_block)
    assert abs(far.position[0] - 120.0) < 10 and abs(far.position[1] - 220.0) < 10
    seen = see(session).objects                                     # the runner's look is the same look
    assert sorted((b.color, b.is_block) for b in seen) == [("blue", False), ("red", True)]
