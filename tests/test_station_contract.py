"""One suite, two backends: the simulated station and the real one on the fake vendor modules (tests/test_hardware.py's
fakes of interbotix_xs_modules and pyrealsense2) must keep the same contract (armlab.station.contract): state names,
torque, an emergency stop that wins, limits refused with the joint named, the board refused, frames' shapes and
dtypes, move and grip semantics, and the capabilities each declares."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_hardware import vendors  # noqa: F401  (the fake vendor modules, a fixture)

from armlab import kinematics, make_station
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
    backend_names,
    register_backend,
)
from armlab.station import registry as station_registry
from armlab.tasks import GuardedArm

Q_READY = np.array([0.0, -0.5, 0.3, 1.2, 0.0])   # tool well above the board, reachable from sleep
ATOL = 0.01                                     # rad: the simulator's encoder noise and quantisation


@pytest.fixture(params=["sim", "real"])
def station(request):
    if request.param == "sim":
        st = make_station("sim", seed=0, scene="empty")
    else:
        request.getfixturevalue("vendors")
        st = make_station("real")
    with st:
        yield st


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
