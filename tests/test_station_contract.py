"""One suite, two backends: the simulated station and the real one on the fake vendor modules (tests/test_hardware.py's
fakes of interbotix_xs_modules and pyrealsense2) must keep the same contract (armlab.station.contract): state names,
torque, an emergency stop that wins, limits refused with the joint named, the board refused, frames' shapes and
dtypes, move and grip semantics, the arm knowing what it holds, and the capabilities each declares; and the motion
contract (armlab.station.contract.Arm): a stop from another thread always wins (a looped move_to, and
TaskMachine.estop() during a pick: 200 trials each on each backend, none lost), a stopped blocking move raises, a move
asked for during a non-blocking one waits for it, Ctrl+C holds the arm and closing parks it, a closed station
refuses."""

from __future__ import annotations

import os
import signal
import threading
import time
import warnings

import numpy as np
import pytest
from test_hardware import vendors  # noqa: F401  (the fake vendor modules, a fixture)

from armlab import kinematics, make_station, motion_safety, planning, tasks
from armlab.hardware import interbotix
from armlab.station import (
    BACKENDS,
    STATION_MODULES_ENV,
    Arm,
    Capabilities,
    EmergencyStopped,
    Frame,
    GroundTruth,
    MotionRefused,
    RGBDCamera,
    Station,
    StationClosed,
    backend_names,
    register_backend,
)
from armlab.station import registry as station_registry
from armlab.tasks import GuardedArm
from armlab.transforms import homogeneous

Q_READY = np.array([0.0, -0.5, 0.3, 1.2, 0.0])   # tool well above the board, reachable from sleep
Q_OTHER = np.array([0.6, -0.3, 0.1, 1.3, 0.4])   # another such pose
ATOL = 0.01                                     # rad: the simulator's encoder noise and quantisation
RACE_TRIALS = 200
WALL_CLOCK_REAL_ARM = interbotix.RealArm         # before the vendors fixture puts it on a simulated clock


@pytest.fixture(params=["sim", "real"])
def station(request):
    if request.param == "sim":
        st = make_station("sim", seed=0, scene="empty")
    else:
        vendors = request.getfixturevalue("vendors")
        st = make_station("real")
        st._test_vendors = vendors
    with st:
        yield st


@pytest.fixture(params=["sim", "real"])
def paced_station(request, monkeypatch):
    """A station whose moves take wall-clock time: the simulator in real-time pacing, the real arm (fake driver)
    waiting for its moves on the wall clock."""
    if request.param == "sim":
        st = make_station("sim", seed=0, scene="empty", real_time=True)
    else:
        vendors = request.getfixturevalue("vendors")
        monkeypatch.setattr(interbotix, "RealArm", WALL_CLOCK_REAL_ARM)
        st = make_station("real", warmup_frames=0)
        st._test_vendors = vendors
    with st:
        yield st


def physical_joints(station) -> np.ndarray:
    """Where the arm physically is (5,) rad: the simulator's true joints, the fake driver's joint state."""
    if station.world is not None:
        return station.arm.q_true
    return np.array(station._test_vendors.world.q, float)


def clock_s(station) -> float:
    """The time the backend's moves run on (s): the simulator's clock, the real arm's fake clock."""
    return station.world.time_s if station.world is not None else station._test_vendors.clock.t


def test_the_station_offers_the_contract_types(station):
    assert isinstance(station, Station) and isinstance(station.arm, Arm) and isinstance(station.camera, RGBDCamera)
    assert isinstance(station.capabilities, Capabilities)
    if station.world is not None:
        assert isinstance(station.world, GroundTruth)


def test_state_names_are_the_same_on_both_backends(station):
    arm = station.arm
    assert arm.torque_enabled is True and arm.emergency_stopped is False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # the real arm warns that it falls unless supported
        arm.set_torque(False)
    assert arm.torque_enabled is False
    with pytest.raises(MotionRefused, match="torque is off"):
        arm.move_to(Q_READY)
    arm.set_torque(True)
    assert arm.torque_enabled is True


def test_the_task_layer_guard_is_an_arm_with_the_same_state(station):
    guarded = GuardedArm(station.arm)
    assert isinstance(guarded, Arm) and guarded.torque_enabled and not guarded.emergency_stopped
    guarded.emergency_stop()
    assert guarded.emergency_stopped and station.arm.emergency_stopped
    guarded.reset()
    assert not station.arm.emergency_stopped


def test_emergency_stop_wins_until_reset(station):
    arm = station.arm
    before = arm.joint_positions()
    arm.emergency_stop()
    assert arm.emergency_stopped is True
    for command in (lambda: arm.move_to(Q_READY), arm.open_gripper, arm.close_gripper, arm.home):
        with pytest.raises(EmergencyStopped):
            command()
    np.testing.assert_allclose(arm.joint_positions(), before, atol=ATOL)
    arm.reset()
    assert arm.emergency_stopped is False and arm.torque_enabled is True
    arm.move_to(Q_READY)
    np.testing.assert_allclose(arm.joint_positions(), Q_READY, atol=ATOL)


@pytest.mark.parametrize("target, joint", [([0.0, 2.5, 0.0, 0.0, 0.0], "shoulder"),
                                           ([0.0, 0.0, 0.0, -1.9, 0.0], "wrist_angle"),
                                           ([4.0, 0.0, 0.0, 0.0, 0.0], "waist")])
def test_limits_are_refused_naming_the_joint_and_nothing_moves(station, target, joint):
    before = station.arm.joint_positions()
    with pytest.raises(MotionRefused, match=rf"motion refused \(joint limits\): {joint} = .* is outside its limits"):
        station.arm.move_to(target)
    np.testing.assert_allclose(station.arm.joint_positions(), before, atol=ATOL)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("joint", range(5))
def test_non_finite_targets_are_refused_and_nothing_moves(station, value, joint):
    target = Q_READY.copy()
    target[joint] = value
    before = station.arm.joint_positions()
    with pytest.raises(MotionRefused, match=r"motion refused \(bad target\): joint angles contain NaN or infinity"):
        station.arm.move_to(target)
    with pytest.raises(ValueError, match="5 finite joint angles"):
        GuardedArm(station.arm).move_to(target)
    np.testing.assert_allclose(station.arm.joint_positions(), before, atol=ATOL)


def test_a_move_into_the_board_is_refused_the_same_way(station):
    below = kinematics.ik(np.array([0.0, 300.0, -20.0]), np.pi / 2)[0]
    with pytest.raises(MotionRefused, match=r"motion refused \(collision with the board\): the .* would go down"):
        station.arm.move_to(below)
    with pytest.raises(MotionRefused, match="shape"):
        station.arm.move_to([0.0, 0.1, 0.2])
    with pytest.raises(MotionRefused, match="velocity limits.*would need"):
        station.arm.move_to(Q_READY, moving_time=0.3)


def test_the_arm_knows_what_it_holds_and_refuses_it_into_the_board(station):
    """A block the arm is told it holds (what the task layer's executor does at a grasp) is checked along every move
    like the pads: 30 mm along the approach (tool x) beyond the tool point, a move that takes it 10 mm under the board
    is refused naming it with nothing moved, while the same move with nothing held is allowed; open_gripper() forgets
    it."""
    arm = station.arm
    arm.move_to(Q_READY)
    low = kinematics.ik(np.array([0.0, 300.0, 35.0]), np.pi / 2)[0]        # the tool point 35 mm over the board
    block = motion_safety.HeldBlock(30.0, homogeneous(np.eye(3), [30.0, 0.0, 0.0]), "held test block")
    assert arm.held_blocks == ()
    arm.set_held_blocks((block,))
    assert arm.held_blocks == (block,)
    before = physical_joints(station)
    with pytest.raises(MotionRefused, match=r"collision with the board\): the held test block would go down"):
        arm.move_to(low)
    np.testing.assert_allclose(physical_joints(station), before, atol=1e-9)
    with pytest.raises(TypeError, match="HeldBlock"):
        arm.set_held_blocks((np.eye(4),))
    arm.open_gripper()
    assert arm.held_blocks == ()
    arm.move_to(low)
    np.testing.assert_allclose(arm.joint_positions(), low, atol=ATOL)


def test_moves_block_or_run_in_the_background_and_reach_their_goal(station):
    arm = station.arm
    arm.move_to(Q_READY)
    assert not arm.is_moving()
    np.testing.assert_allclose(arm.joint_positions(), Q_READY, atol=ATOL)
    arm.move_to(arm.robot.home, moving_time=2.0, blocking=False)
    assert arm.is_moving()
    arm.wait()
    assert not arm.is_moving()
    np.testing.assert_allclose(arm.joint_positions(), 0.0, atol=ATOL)
    arm.sleep()
    np.testing.assert_allclose(arm.joint_positions(), arm.robot.sleep, atol=ATOL)


def test_closing_on_nothing_holds_nothing(station):
    station.arm.move_to(Q_READY)
    station.arm.open_gripper()
    assert station.arm.close_gripper() is False
    station.arm.open_gripper()


def test_frames_have_the_contract_shapes_and_dtypes(station):
    cam = station.camera
    assert cam.K.shape == (3, 3) and cam.dist.shape == (5,) and (cam.width, cam.height) == (1280, 720)
    frame = cam.capture()
    assert isinstance(frame, Frame) and isinstance(frame.timestamp, float)
    assert frame.rgb.shape == (720, 1280, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (720, 1280) and frame.depth.dtype == np.float32
    finite = frame.depth[np.isfinite(frame.depth)]
    assert finite.size > 0.5 * frame.depth.size and finite.min() > 0


def test_capabilities_say_what_only_a_backend_can_do(station):
    caps = station.capabilities
    if station.world is None:                 # hardware: no ground truth, nothing it can calibrate by itself
        assert caps == Capabilities()
        return
    caps.pacing.set_real_time(True)
    assert caps.pacing.is_real_time() and station.arm.real_time and station.world.real_time
    caps.pacing.set_real_time(False)
    assert not caps.pacing.is_real_time()
    station.arm.set_torque(False)
    caps.pose_by_hand(Q_READY)
    np.testing.assert_allclose(station.arm.joint_positions(), Q_READY, atol=ATOL)
    with pytest.raises(MotionRefused, match="through the board"):
        caps.pose_by_hand(kinematics.ik(np.array([0.0, 300.0, -20.0]), np.pi / 2)[0])
    station.arm.set_torque(True)
    assert callable(caps.camera_intrinsics)   # renders its own checkerboard views (~1.5 s: tests/test_calibration)
    reference = caps.sag_reference()
    assert isinstance(reference.arm, Arm) and reference.arm is not station.arm
    assert np.asarray(reference.measure()).shape == (3,)


def test_backends_are_registered_by_name_and_a_new_one_is_one_line():
    assert backend_names()[:2] == ("sim", "real")
    with pytest.raises(ValueError, match=r"unknown station kind 'moon': expected 'sim' or 'real'"):
        make_station("moon")
    with pytest.raises(ValueError, match="already registered"):
        register_backend("sim", lambda **o: None)
    with pytest.raises(ValueError, match="module:function"):
        register_backend("bad", "armlab.sim.make_sim_station")
    register_backend("sim_empty", "armlab.sim:make_sim_station")
    try:
        with make_station("sim_empty", scene="empty") as st:
            assert st.kind == "sim" and st.world.objects == [] and "sim_empty" in backend_names()
    finally:
        del BACKENDS["sim_empty"]


def test_a_labs_own_backend_is_one_module_named_in_the_environment(tmp_path, monkeypatch):
    """A rig outside the kit: one module defining STATION_BACKENDS, named in ARMLAB_STATION_MODULES; no kit file
    changes. A module that does not import, or defines no backends, is named in the error and registers nothing."""
    (tmp_path / "lab_rig.py").write_text(
        "from armlab.sim import make_sim_station\n\n"
        "def make_rig(**options):\n"
        "    return make_sim_station(scene='empty', **options)\n\n"
        "STATION_BACKENDS = {'rig': make_rig}\n")
    (tmp_path / "not_a_rig.py").write_text("BACKENDS = {'rig2': print}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv(STATION_MODULES_ENV, "lab_rig")
    try:
        assert "rig" in backend_names()
        with make_station("rig", seed=1) as st:
            assert st.kind == "sim" and st.world.objects == []
        monkeypatch.setenv(STATION_MODULES_ENV, "lab_rig, not_a_rig")
        with pytest.raises(ValueError, match=r"names 'not_a_rig', which defines no STATION_BACKENDS"):
            backend_names()
        assert "rig2" not in BACKENDS
        monkeypatch.setenv(STATION_MODULES_ENV, "no_such_rig_module")
        with pytest.raises(ImportError, match=r"ARMLAB_STATION_MODULES names 'no_such_rig_module', which does not"):
            make_station("sim")
    finally:
        BACKENDS.pop("rig", None)
        station_registry._imported_modules.discard("lab_rig")


# ---------------------------------------------------------------------------------------------------------------
# The motion contract
# ---------------------------------------------------------------------------------------------------------------

def stop_race(arm, physical, trials: int, seed: int = 0) -> tuple[int, dict[str, int]]:
    """A thread loops move_to between two poses; after a random 0-20 ms the test thread calls emergency_stop().
    Returns (trials in which the arm moved after emergency_stop() returned, how each looping thread ended)."""
    rng = np.random.default_rng(seed)
    lost, ended = 0, {}
    for _ in range(trials):
        arm.reset()
        errors = []
        mover = threading.Thread(target=_capture, args=(errors, _loop_moves, arm))
        mover.start()
        time.sleep(rng.uniform(0.0, 0.02))
        arm.emergency_stop()
        q_stop = physical()
        mover.join(timeout=60)
        assert not mover.is_alive(), "the looping move_to did not end after the stop"
        lost += int(np.abs(physical() - q_stop).max() > 1e-12)
        name = type(errors[0]).__name__ if errors else "nothing"
        ended[name] = ended.get(name, 0) + 1
    arm.reset()
    return lost, ended


def _loop_moves(arm) -> None:
    while True:
        arm.move_to(Q_READY)
        arm.move_to(Q_OTHER)


def test_a_stop_always_wins_the_race_with_a_looped_move(station):
    lost, ended = stop_race(station.arm, lambda: physical_joints(station), RACE_TRIALS)
    print(f"looped move_to stopped ({station.kind}): {lost} of {RACE_TRIALS} lost, the loops ended {ended}")
    assert lost == 0, f"the arm moved after emergency_stop() returned in {lost} of {RACE_TRIALS} trials"
    assert ended == {"EmergencyStopped": RACE_TRIALS}, ended


def test_a_stopped_blocking_move_raises_and_the_arm_holds(paced_station):
    arm = paced_station.arm
    arm.move_to(Q_READY, moving_time=2.0)

    def stop_once_moving():
        while not arm.is_moving():
            time.sleep(0.005)
        time.sleep(0.2)
        arm.emergency_stop()

    stopper = threading.Thread(target=stop_once_moving)
    stopper.start()
    try:
        with pytest.raises(EmergencyStopped, match="during the move"):
            arm.move_to(Q_OTHER, moving_time=3.0)
    finally:
        stopper.join(timeout=10)
    q = physical_joints(paced_station)
    assert not arm.is_moving() and arm.emergency_stopped
    time.sleep(0.3)
    np.testing.assert_allclose(physical_joints(paced_station), q, atol=1e-12)
    arm.reset()


def test_a_move_asked_for_during_a_non_blocking_one_waits_for_it(station):
    arm = station.arm
    arm.move_to(Q_READY)
    t0 = clock_s(station)
    arm.move_to(Q_OTHER, moving_time=2.0, blocking=False)
    arm.move_to(Q_READY, moving_time=1.5, blocking=False)       # waits for the first to end, then starts
    assert clock_s(station) - t0 >= 2.0 - 1e-9 and arm.is_moving()
    arm.wait()
    assert not arm.is_moving() and clock_s(station) - t0 >= 3.5 - 1e-9
    np.testing.assert_allclose(arm.joint_positions(), Q_READY, atol=ATOL)


@pytest.mark.parametrize("blocking", [True, False], ids=["blocking", "non-blocking"])
def test_ctrl_c_during_a_move_holds_the_arm_and_closing_parks_it(paced_station, blocking):
    """Ctrl+C while a blocking move waits, or while Python sleeps during a non-blocking one (the station's SIGINT
    handler, armlab.station.interrupt): the arm holds, then closing parks it."""
    arm = paced_station.arm
    arm.move_to(Q_READY, moving_time=2.0)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))    # Ctrl+C (a Jupyter interrupt)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            arm.move_to(Q_OTHER, moving_time=3.0, blocking=blocking)
            time.sleep(5.0)                           # the interrupt comes here during a non-blocking move
    finally:
        timer.join()
    q = physical_joints(paced_station)
    assert not arm.is_moving() and not arm.emergency_stopped       # a hold, not an emergency stop
    time.sleep(0.5)
    np.testing.assert_allclose(physical_joints(paced_station), q, atol=1e-12)   # still where it was held
    if paced_station.world is not None:
        assert np.abs(q - Q_OTHER).max() > 0.05                     # stopped part-way
    else:                                   # the fake driver jumps to a goal: the hold is sent after it
        names = [c[0] for c in paced_station._test_vendors.log]
        last = {n: len(names) - 1 - names[::-1].index(n) for n in ("set_joint_positions", "robot_write_commands")}
        assert last["robot_write_commands"] > last["set_joint_positions"], names[-6:]
    paced_station.close()
    np.testing.assert_allclose(physical_joints(paced_station), arm.robot.sleep, atol=ATOL)   # parked


def test_a_closed_station_refuses_every_command(station):
    arm = station.arm
    arm.move_to(Q_READY)
    station.close()
    np.testing.assert_allclose(arm.joint_positions(), arm.robot.sleep, atol=ATOL)           # parked first
    for command in (lambda: arm.move_to(Q_READY), arm.home, arm.sleep, arm.open_gripper, arm.close_gripper,
                    lambda: arm.set_torque(False), arm.reset):
        with pytest.raises(StationClosed, match="closed"):
            command()
    if station.world is not None:
        with pytest.raises(StationClosed, match="closed"):
            station.camera.capture()
    station.close()                                                # idempotent


def test_closing_while_emergency_stopped_holds_where_it_is(station):
    arm = station.arm
    arm.move_to(Q_READY)
    arm.emergency_stop()
    with pytest.warns(RuntimeWarning, match="emergency-stopped"):
        station.close()
    np.testing.assert_allclose(arm.joint_positions(), Q_READY, atol=ATOL)
    with pytest.raises(StationClosed):
        arm.move_to(Q_OTHER)


MACHINE_TRIALS = 200


def machine_stop_race(session: tasks.Session, plan: planning.Plan, physical, restore, trials: int, window_s: float,
                      seed: int = 0) -> tuple[int, float, int]:
    """TaskMachine.estop() from the test thread 0-window_s into a pick (`plan`, from tasks.pick's planner, run by
    TaskMachine.execute on the guarded arm) while another thread runs it; between trials restore() puts the block
    back where it stood and the arm goes to the plan's start. physical() is where the arm physically is (5,) rad.
    Returns (trials in which the arm moved after estop() returned, the largest such motion in rad, trials stopped
    before the pick's end)."""
    machine = tasks.TaskMachine(session)
    rng = np.random.default_rng(seed)
    lost, worst, stopped = 0, 0.0, 0
    for _ in range(trials):
        session.station.arm.open_gripper()
        restore()
        session.arm.move_to(plan.start)
        errors: list = []
        runner = threading.Thread(target=_capture, args=(errors, machine.execute, plan))
        runner.start()
        time.sleep(rng.uniform(0.0, window_s))
        machine.estop()
        q_stop = physical()
        runner.join(timeout=120)
        assert not runner.is_alive()
        moved = float(np.abs(physical() - q_stop).max())
        lost, worst = lost + int(moved > 1e-12), max(worst, moved)
        stopped += int(bool(errors) and isinstance(errors[0], EmergencyStopped))
        machine.reset()
    return lost, worst, stopped


def _capture(errors: list, f, *args) -> None:
    try:
        f(*args)
    except Exception as e:                            # noqa: BLE001 (the caller looks at them)
        errors.append(e)


def test_the_state_machines_estop_wins_during_a_pick():
    station = make_station("sim", seed=1)
    session = tasks.start_session(station)
    block = tasks.TaskMachine(session).detect()[0]
    truth = min(station.world.blocks, key=lambda o: np.hypot(*(o.position[:2] - block.position[:2])))
    pose = (truth.position.copy(), truth.yaw)

    def restore():
        truth.position, truth.yaw = pose[0].copy(), pose[1]

    plan = planning.plan_pick(session.arm.joint_positions(), block.position, float(block.yaw), truth.edge,
                              obstacles=session.known)
    # the stops come 0-1.2 times the pick's own wall time in (the simulator runs it as fast as it can: a fixed
    # window would put most stops after the end on a faster machine or simulator)
    session.arm.move_to(plan.start)
    start = time.perf_counter()
    tasks.TaskMachine(session).execute(plan)
    window = 1.2 * (time.perf_counter() - start)
    station.arm.open_gripper()
    restore()
    lost, worst, stopped = machine_stop_race(session, plan, lambda: station.arm.q_true, restore, MACHINE_TRIALS,
                                             window_s=window)
    print(f"estop during a pick ({station.kind}): {lost} of {MACHINE_TRIALS} lost, {stopped} stopped mid-pick")
    assert lost == 0, f"the arm moved up to {worst:.3f} rad after estop() returned in {lost} of {MACHINE_TRIALS}"
    assert stopped >= MACHINE_TRIALS // 4, f"only {stopped} of {MACHINE_TRIALS} stops came during the pick"


def test_the_state_machines_estop_wins_during_a_pick_on_the_real_arm(request):
    """The same race on the real arm (fake driver, simulated clock: a pick's plan runs in milliseconds, so the stop
    comes 0-1.2 times the plan's own wall time in). The fake camera shows no board: the session is built without a
    calibration (what a lab without one has; the plan is given)."""
    fakes = request.getfixturevalue("vendors")
    station = make_station("real")
    with station:
        session = tasks.Session(station, GuardedArm(station.arm))
        plan = planning.plan_pick(session.arm.joint_positions(), np.array([0.0, 250.0, 38.0]), 0.3, 38.0)
        session.arm.move_to(plan.start)
        start = time.perf_counter()
        tasks.TaskMachine(session).execute(plan)
        window = 1.2 * (time.perf_counter() - start)
        physical = lambda: np.array(fakes.world.q, float)          # noqa: E731
        lost, worst, stopped = machine_stop_race(session, plan, physical, lambda: None, MACHINE_TRIALS, window)
    print(f"estop during a pick ({station.kind}): {lost} of {MACHINE_TRIALS} lost, {stopped} stopped mid-pick")
    assert lost == 0, f"the arm moved up to {worst:.3f} rad after estop() returned in {lost} of {MACHINE_TRIALS}"
    assert stopped >= MACHINE_TRIALS // 4, f"only {stopped} of {MACHINE_TRIALS} stops came during the pick"
