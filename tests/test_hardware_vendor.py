"""armlab.hardware.interbotix run through the vendor's own Python API, unmodified, over a fake ROS boundary.

The Interbotix files (xs_robot/arm.py, core.py, gripper.py, mr_descriptions.py, common_robot/robot.py,
exceptions.py) are executed at the commit pinned in tests/vendor/facts.py, from the cache of tests/vendor/sources.py
(never from this repository); rclpy, the message packages and the xs_sdk driver are the fakes of tests/vendor/ros.py.
Without the cached files these tests skip, saying how to get them.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import re
import signal
import sys
import threading
import types
from types import SimpleNamespace

import numpy as np
import pytest

import armlab.hardware
from armlab import make_station
from armlab.hardware import interbotix, ros_session
from armlab.hardware.interbotix import HOLD_TIME_S
from armlab.hardware.ros_session import DriverNotFound
from armlab.robot import rx200
from armlab.station import EmergencyStopped, MotionRefused

sys.path.insert(0, os.path.dirname(__file__))
from vendor import facts, ros, sources  # noqa: E402

Q_READY = np.array([0.0, -0.5, 0.3, 1.2, 0.0])
PACKAGES = ("interbotix_common_modules", "interbotix_common_modules.common_robot", "interbotix_xs_modules",
            "interbotix_xs_modules.xs_robot")


def load_toolbox(setitem) -> dict[str, types.ModuleType]:
    """Execute the pinned Interbotix files as their own modules (package __init__ files are not needed)."""
    files = {}
    for name, (path, blob) in facts.TOOLBOX_MODULES.items():
        if sources.read(facts.TOOLBOXES, facts.TOOLBOXES_COMMIT, path, blob) is None:
            pytest.skip(f"{facts.TOOLBOXES}@{facts.TOOLBOXES_COMMIT[:7]}:{path} is not cached: {sources.HOW}")
        files[name] = sources.cached(facts.TOOLBOXES, facts.TOOLBOXES_COMMIT, path)
    for name in PACKAGES:
        package = types.ModuleType(name)
        package.__path__ = []
        setitem(name, package)
    setitem("interbotix_common_modules.angle_manipulation", types.ModuleType("angle_manipulation"))
    setitem("modern_robotics", ros.modern_robotics_stub())
    loaded = {}
    for name, file in files.items():
        spec = importlib.util.spec_from_file_location(name, file)
        module = importlib.util.module_from_spec(spec)
        setitem(name, module)
        spec.loader.exec_module(module)
        parent, _, child = name.rpartition(".")
        setattr(sys.modules[parent], child, module)
        loaded[name] = module
    return loaded


class FakeClock:
    """armlab's waiting for moves, in simulated seconds."""

    def __init__(self):
        self.t, self.slept = 100.0, []

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.slept.append(dt)
        self.t += dt


@pytest.fixture
def vendor(monkeypatch):
    """The vendor's Python API over a fake ROS and driver; returns SimpleNamespace(sdk, ros, modules)."""
    sdk = ros.XsSdk()
    world = ros.Ros(sdk)
    setitem = lambda name, module: monkeypatch.setitem(sys.modules, name, module)   # noqa: E731
    for name, module in world.modules.items():
        setitem(name, module)
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)
    modules = load_toolbox(setitem)
    monkeypatch.setenv("ROS_DOMAIN_ID", "7")
    no_atexit = SimpleNamespace(register=lambda f: None, unregister=lambda f: None)
    monkeypatch.setattr(armlab.hardware, "atexit", no_atexit)
    monkeypatch.setattr(ros_session, "atexit", no_atexit)
    monkeypatch.setattr(ros_session, "_session", None)
    clock = FakeClock()
    monkeypatch.setattr(interbotix, "RealArm", functools.partial(interbotix.RealArm, clock=clock, sleep=clock.sleep))
    handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    threads = set(threading.enumerate())
    yield SimpleNamespace(sdk=sdk, ros=world, modules=modules, clock=clock)
    # End the vendor's executor thread: robot.py spins `while rclpy.ok(): executor.spin()`, so the context must
    # report not ok (else the loop spins on at full speed and starves every later test), then spin() returns.
    world._shutdown_contexts()
    for t in set(threading.enumerate()) - threads:
        t.join(timeout=5)
        assert not t.is_alive(), f"the vendor thread {t.name} outlived its test"
    signal.signal(signal.SIGINT, handlers[0])
    signal.signal(signal.SIGTERM, handlers[1])


def arm_station(**options):
    return make_station("real", camera=False, **options)


def goals(sdk):
    return [np.array(goal) for goal, _ in sdk.executed]


# ---------------------------------------------------------------------------------------------------------------
# The vendor facts, checked against the pinned files
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("fact", facts.FACTS, ids=lambda f: f.id)
def test_vendor_facts_hold_in_the_pinned_files(fact):
    data = sources.read(fact.repo, fact.commit, fact.path)
    if data is None:
        pytest.skip(f"{fact.repo}@{fact.commit[:7]}:{fact.path} is not cached: {sources.HOW}")
    assert re.search(fact.evidence, data.decode()), f"{fact.id}: {fact.statement} -- no longer true in {fact.path}"


def test_the_fake_messages_assert_as_rosidl_does():
    with pytest.raises(AssertionError, match="The 'cmd' field must be of type 'float'"):
        ros.JointSingleCommand(name="gripper", cmd=350)
    with pytest.raises(AssertionError, match="each value of type 'float'"):
        ros.JointGroupCommand(name="arm", cmd=[0.0, 1])
    with pytest.raises(AssertionError, match="'value' field must be of type 'int'"):
        ros.RegisterValues.Request(cmd_type="group", name="arm", reg="Profile_Velocity", value=400.0)


def test_the_vendor_constructor_alone_blocks_without_a_driver(vendor):
    vendor.sdk.up = False
    vendor.ros.init()
    arm_module = vendor.modules["interbotix_xs_modules.xs_robot.arm"]
    with pytest.raises(ros.Hang):
        arm_module.InterbotixManipulatorXS(robot_model="rx200")


# ---------------------------------------------------------------------------------------------------------------
# The five unsafe behaviours of the issue, each through the vendor's code
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("pressure", [0, 1])
def test_1_an_integer_gripper_pressure_works(vendor, pressure):
    with arm_station(gripper_pressure=pressure) as st:
        st.arm.open_gripper()
        assert st.arm.close_gripper() is False
    efforts = [m["cmd"] for kind, m in vendor.sdk.log if kind == "joint_single"]
    assert efforts[0] == -(150.0 + 200.0 * pressure) and all(isinstance(e, float) for e in efforts)


def test_2_a_second_station_in_the_same_process_reuses_the_vendor_bot(vendor):
    with arm_station() as st:
        st.arm.move_to(Q_READY)
    with arm_station() as st2:                     # a notebook cell run again
        st2.arm.move_to(Q_READY)
        assert st2.arm._bot is st.arm._bot
    infos = [m for kind, m in vendor.sdk.log if kind == "get_robot_info" and m["name"] == "arm"]
    assert len(infos) == 1                          # one InterbotixManipulatorXS for the process
    np.testing.assert_allclose(goals(vendor.sdk)[-1], rx200().sleep)
    assert vendor.ros.ok()                          # ROS stays up for the next one ...
    ros_session.shutdown_session()
    assert not vendor.ros.ok()                      # ... and shuts down once, at exit
    with pytest.raises(RuntimeError, match="restart the Python process"):
        arm_station()


def test_a_second_arm_in_the_same_process_is_refused(vendor):
    with arm_station():
        with pytest.raises(RuntimeError, match="one arm per process"):
            arm_station(robot_name="arm2/rx200")


def test_3_ctrl_c_holds_the_arm_then_parks_it(vendor):
    with pytest.raises(KeyboardInterrupt):
        with arm_station() as st:
            st.arm.move_to(Q_READY)
            st.arm.move_to(rx200().home, moving_time=3.0, blocking=False)
            vendor.sdk.q = dict(zip(ros.ARM_JOINTS, 0.5 * Q_READY))      # where the arm is at the Ctrl+C
            vendor.ros.deliver()
            os.kill(os.getpid(), signal.SIGINT)
            pytest.fail("SIGINT did not interrupt")
    executed = goals(vendor.sdk)
    np.testing.assert_allclose(executed[-3], rx200().home)
    np.testing.assert_allclose(executed[-2], 0.5 * Q_READY, atol=1e-6)     # the hold
    np.testing.assert_allclose(executed[-1], rx200().sleep)                # parked after leaving the block
    assert vendor.ros.ok() and signal.getsignal(signal.SIGINT) is not vendor.ros._rclpy_sigint


def test_4_a_motor_reboot_does_not_make_the_next_move_unprofiled(vendor):
    with arm_station() as st:
        st.arm.move_to(Q_READY)
        st.arm.move_to(Q_READY + [0.05, 0, 0, 0, 0], moving_time=HOLD_TIME_S)   # the vendor caches 0.4 s
        vendor.sdk.faulty.add("shoulder")                                      # an overload after a bump
        before = len(vendor.sdk.executed)
        st.arm.reboot_motors()
        st.arm.move_to(Q_READY, moving_time=HOLD_TIME_S)
        after_reboot = vendor.sdk.executed[before:]
    assert len(after_reboot) == 2                                              # the hold, the move
    for goal, profile in after_reboot:
        assert profile == dict.fromkeys(ros.ARM_JOINTS, int(HOLD_TIME_S * 1000)), (goal, profile)


def test_5_an_emergency_stop_during_a_move_being_sent_wins(vendor):
    with arm_station() as st:
        st.arm.move_to(Q_READY)
        stopper = threading.Thread(target=st.arm.emergency_stop)
        state = {"fired": False}

        def stop_from_another_thread():        # the state machine's thread, between the two register writes
            if not state["fired"]:
                state["fired"] = True
                stopper.start()
                stopper.join(timeout=0.5)      # with the lock the stop waits for the move's check-then-publish

        vendor.sdk.on_register_write = stop_from_another_thread
        try:
            st.arm.move_to(Q_READY + [0.1, 0, 0, 0, 0], moving_time=2.5)   # the vendor accepts it even at 0.4 s
        except EmergencyStopped:
            pass
        stopper.join(timeout=10)
        assert not stopper.is_alive()
        vendor.sdk.on_register_write = None
        assert st.arm.estopped
        last = goals(vendor.sdk)[-1]
        np.testing.assert_allclose(last, Q_READY, atol=1e-6)                   # the hold went out last
        np.testing.assert_allclose(st.arm.joint_positions(), Q_READY, atol=1e-6)
        with pytest.warns(RuntimeWarning, match="emergency-stopped"):
            st.close()


# ---------------------------------------------------------------------------------------------------------------
# Connecting, limits, warnings
# ---------------------------------------------------------------------------------------------------------------

def test_a_missing_driver_is_named_within_the_timeout(vendor):
    vendor.sdk.up = False
    with pytest.raises(DriverNotFound, match=r"no Interbotix xs_sdk driver answers under '/rx200' in ROS domain 7"
                                             r"[\s\S]*ros2 launch interbotix_xsarm_control"):
        arm_station(driver_timeout_s=0.2)


def test_the_camera_is_not_opened_when_the_driver_is_missing(vendor, monkeypatch):
    opened = []
    monkeypatch.setattr(armlab.hardware.realsense, "import_realsense", lambda: None)
    monkeypatch.setattr(armlab.hardware.realsense, "open_camera", lambda **kw: opened.append(kw))
    vendor.sdk.up = False
    with pytest.raises(DriverNotFound):
        make_station("real", driver_timeout_s=0.1)
    assert opened == []


def test_two_drivers_on_one_domain_are_refused(vendor):
    vendor.sdk.publishers = 2
    with pytest.raises(RuntimeError, match="another station shares this ROS_DOMAIN_ID"):
        arm_station()


def test_an_unset_ros_domain_warns(vendor, monkeypatch):
    monkeypatch.delenv("ROS_DOMAIN_ID")
    with pytest.warns(RuntimeWarning, match="ROS_DOMAIN_ID is not set"):
        arm_station().close()


@pytest.mark.parametrize("change, reason", [({"profile_type": "velocity"}, "profile 'velocity'"),
                                            ({"mode": "ext_position"}, "mode 'ext_position'"),
                                            ({"gripper_mode": "position"}, "gripper runs mode 'position'")])
def test_the_driver_mode_is_checked_at_connect(vendor, change, reason):
    for key, value in change.items():
        setattr(vendor.sdk, key, value)
    with pytest.raises(RuntimeError, match=reason):
        arm_station()


def test_rclpy_runs_without_its_signal_handlers(vendor):
    with arm_station():
        assert signal.getsignal(signal.SIGINT) is not vendor.ros._rclpy_sigint
    assert vendor.ros.ok()


def test_moves_longer_than_the_servo_profile_allows_are_refused(vendor):
    with arm_station() as st:
        sent = len(vendor.sdk.executed)
        with pytest.raises(MotionRefused, match="longer than the servos' time profile allows"):
            st.arm.move_to(Q_READY, moving_time=40.0)
        assert len(vendor.sdk.executed) == sent


def test_torque_off_warns_that_the_arm_falls(vendor):
    with arm_station() as st:
        with pytest.warns(RuntimeWarning, match="falls unless supported"):
            st.arm.set_torque(False)
        assert vendor.sdk.torque is False


def test_moves_are_sent_non_blocking_and_waited_for_by_armlab(vendor):
    with arm_station() as st:
        start = vendor.ros.sim_ns
        st.arm.move_to(Q_READY, moving_time=2.0, blocking=False)
        assert vendor.ros.sim_ns == start                   # the vendor never slept: armlab waits
        assert st.arm.is_moving()
        vendor.clock.t += 1.0
        st.arm.wait()
        assert vendor.clock.slept[-1] == pytest.approx(1.0) and not st.arm.is_moving()
