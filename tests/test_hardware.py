"""Contract tests of the real-hardware backends against fake vendor modules (Interbotix ROS 2 API, pyrealsense2).

The fakes record every call in order and model the parts of the vendor behaviour that matter: the Interbotix driver
checks a new command against its stored moving time and its last command (not the measured position), joint states
follow commands only while torque is on, the gripper stops on an object or at its closed limit; the RealSense
pipeline delivers 1024x768 depth that only rs.align(rs.stream.color) brings to the colour image's 1280x720.
"""

from __future__ import annotations

import functools
import importlib.machinery
import importlib.util
import inspect
import json
import os
import select
import signal
import subprocess
import sys
import threading
import time
import types
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import armlab.hardware
from armlab import kinematics, make_station
from armlab.hardware import HardwareUnavailable, interbotix, realsense, ros_session
from armlab.hardware.interbotix import HOLD_TIME_S, RealArm
from armlab.hardware.safety import DEFAULT_BOARD_MARGIN_MM, board_collision, check_move
from armlab.profile import default_moving_time
from armlab.robot import rx200
from armlab.station import Arm, EmergencyStopped, Frame, MotionRefused, RGBDCamera

sys.path.insert(0, os.path.dirname(__file__))
from vendor import ros as fake_ros  # noqa: E402

VENDOR_MODULES = ("interbotix_xs_modules", "interbotix_xs_modules.xs_robot", "interbotix_xs_modules.xs_robot.arm",
                  "interbotix_common_modules", "interbotix_common_modules.common_robot",
                  "interbotix_common_modules.common_robot.robot", "pyrealsense2")
MOTION_CALLS = ("set_trajectory_time", "set_joint_positions", "robot_write_commands", "go_to_home_pose",
                "go_to_sleep_pose", "grasp", "release")
FINGER_LOWER_M, FINGER_UPPER_M = 0.015, 0.037


# ---------------------------------------------------------------------------------------------------------------
# The real Interbotix ROS 2 API: the signatures the fakes must have (Interbotix/interbotix_ros_toolboxes,
# interbotix_xs_modules/xs_robot/{arm,gripper,core}.py and interbotix_common_modules/common_robot/robot.py at the
# commit of tests/vendor/facts.py; tests/test_hardware_vendor.py checks them against those files where cached)
# ---------------------------------------------------------------------------------------------------------------

class UpstreamArm:
    """InterbotixArmXSInterface: the public methods that exist (there is no get_joint_positions)."""

    def set_trajectory_time(self, moving_time=None, accel_time=None): ...
    def set_joint_positions(self, joint_positions, moving_time=None, accel_time=None, blocking=True): ...
    def go_to_home_pose(self, moving_time=None, accel_time=None, blocking=True): ...
    def go_to_sleep_pose(self, moving_time=None, accel_time=None, blocking=True): ...
    def capture_joint_positions(self): ...
    def get_joint_commands(self): ...


class UpstreamGripper:
    """InterbotixGripperXSInterface."""

    def grasp(self, delay=1.0): ...
    def release(self, delay=1.0): ...
    def set_pressure(self, pressure): ...


class UpstreamCore:
    """InterbotixRobotXSCore."""

    def robot_get_joint_states(self): ...
    def robot_torque_enable(self, cmd_type, name, enable): ...
    def robot_reboot_motors(self, cmd_type, name, enable, smart_reboot=False): ...
    def robot_write_commands(self, group_name, commands): ...
    def robot_set_motor_registers(self, cmd_type, name, reg, value): ...


def upstream_manipulator(robot_model, group_name="arm", gripper_name="gripper", robot_name=None, moving_time=2.0,
                         accel_time=0.3, gripper_pressure=0.5, gripper_pressure_lower_limit=150,
                         gripper_pressure_upper_limit=350, topic_joint_states="joint_states",
                         logging_level=fake_ros.LoggingSeverity.INFO, node_name="robot_manipulation", node=None,
                         iterative_update_fk=True, args=None): ...
def upstream_robot_startup(node=None, node_name="interbotix_robot_manipulation", namespace=None): ...
def upstream_robot_shutdown(node=None): ...


# ---------------------------------------------------------------------------------------------------------------
# Fake Interbotix ROS 2 API
# ---------------------------------------------------------------------------------------------------------------

class FakeWorld:
    """The physical arm: measured joints follow commands while torque is on; a hand can move it while off."""

    def __init__(self, log: list):
        self.log = log
        self.q = rx200().sleep.copy()
        self.finger_m = FINGER_UPPER_M
        self.object_width_mm = None    # something between the fingers (mm), or None
        self.torque = True

    def joint_state(self):
        names = list(rx200().joint_names) + ["gripper", "left_finger", "right_finger"]
        return SimpleNamespace(name=names, position=[*map(float, self.q), 0.0, self.finger_m, -self.finger_m])


class FakeCore:
    def __init__(self, world: FakeWorld):
        self.world = world

    def robot_get_joint_states(self):
        return self.world.joint_state()

    def robot_torque_enable(self, cmd_type, name, enable):
        self.world.log.append(("robot_torque_enable", cmd_type, name, bool(enable)))
        self.world.torque = bool(enable)

    def robot_reboot_motors(self, cmd_type, name, enable, smart_reboot=False):
        self.world.log.append(("robot_reboot_motors", cmd_type, name, bool(enable), bool(smart_reboot)))

    def robot_write_commands(self, group_name, commands):
        self.world.log.append(("robot_write_commands", group_name, list(commands)))
        if self.world.torque:
            self.world.q = np.array(commands, float)

    def robot_set_motor_registers(self, cmd_type, name, reg, value):
        assert isinstance(value, int)
        self.world.log.append(("robot_set_motor_registers", cmd_type, name, reg, value))


class FakeArmInterface:
    """Mirrors the driver's rules: limits and |goal - last command| / stored moving_time <= velocity limit."""

    def __init__(self, world: FakeWorld, moving_time: float, accel_time: float):
        robot = rx200()
        self.world = world
        self.group_info = SimpleNamespace(joint_names=list(robot.joint_names), joint_lower_limits=list(robot.lower),
                                          joint_upper_limits=list(robot.upper),
                                          joint_velocity_limits=list(robot.velocity),
                                          joint_sleep_positions=list(robot.sleep), num_joints=5,
                                          mode="position", profile_type="time")
        self.moving_time, self.accel_time = moving_time, accel_time
        self.joint_commands = list(world.q)

    def set_trajectory_time(self, moving_time=None, accel_time=None):
        self.world.log.append(("set_trajectory_time", moving_time, accel_time))
        self.moving_time = self.moving_time if moving_time is None else moving_time
        self.accel_time = self.accel_time if accel_time is None else accel_time

    def _driver_accepts(self, q) -> bool:
        gi = self.group_info
        theta = [int(x * 1000) / 1000.0 for x in q]
        return all(lo <= t <= hi and abs(t - c) / self.moving_time <= v for t, c, lo, hi, v in
                   zip(theta, self.joint_commands, gi.joint_lower_limits, gi.joint_upper_limits,
                       gi.joint_velocity_limits, strict=True))

    def set_joint_positions(self, joint_positions, moving_time=None, accel_time=None, blocking=True):
        if not self._driver_accepts(joint_positions):
            self.world.log.append(("driver_refused", list(joint_positions)))
            return False
        self.set_trajectory_time(moving_time, accel_time)
        self.world.log.append(("set_joint_positions", list(joint_positions), moving_time, accel_time, blocking))
        self.joint_commands = list(joint_positions)
        if self.world.torque:
            self.world.q = np.array(joint_positions, float)
        return True

    def go_to_home_pose(self, moving_time=None, accel_time=None, blocking=True):
        self.world.log.append(("go_to_home_pose",))

    def go_to_sleep_pose(self, moving_time=None, accel_time=None, blocking=True):
        self.world.log.append(("go_to_sleep_pose",))

    def capture_joint_positions(self):
        self.world.log.append(("capture_joint_positions",))
        self.joint_commands = list(self.world.q)

    def get_joint_commands(self):
        return list(self.joint_commands)


class FakeGripper:
    left_finger_lower_limit = FINGER_LOWER_M
    left_finger_upper_limit = FINGER_UPPER_M
    gripper_info = SimpleNamespace(mode="pwm")

    def __init__(self, world: FakeWorld):
        self.world = world

    def grasp(self, delay=1.0):
        self.world.log.append(("grasp", delay))
        w = self.world.object_width_mm
        # empty: the driver stops the motor once past the limit (a little overshoot); else the pads meet the object
        self.world.finger_m = FINGER_LOWER_M - 0.0004 if w is None else max(FINGER_LOWER_M, w / 2000.0)

    def release(self, delay=1.0):
        self.world.log.append(("release", delay))
        self.world.finger_m = FINGER_UPPER_M

    def set_pressure(self, pressure):
        self.world.log.append(("set_pressure", pressure))


class SwappedGripper(FakeGripper):
    """A 2022 release of xs_robot/gripper.py: grasp() drives the fingers open, release() closes them."""

    def grasp(self, delay=1.0):
        self.world.log.append(("grasp", delay))
        self.world.finger_m = FINGER_UPPER_M

    def release(self, delay=1.0):
        self.world.log.append(("release", delay))
        self.world.finger_m = FINGER_LOWER_M - 0.0004


class FakeManipulator:
    def __init__(self, world: FakeWorld, **kwargs):
        inspect.signature(upstream_manipulator).bind(**kwargs)      # TypeError for an argument the API lacks
        world.log.append(("InterbotixManipulatorXS", kwargs))
        self.core = FakeCore(world)
        self.arm = FakeArmInterface(world, kwargs.get("moving_time", 2.0), kwargs.get("accel_time", 0.3))
        self.gripper = FakeGripper(world)


# ---------------------------------------------------------------------------------------------------------------
# Fake pyrealsense2
# ---------------------------------------------------------------------------------------------------------------

DEPTH_SCALE_M = 0.00025
COEFFS = [0.11, -0.23, 0.0012, -0.0008, 0.05]


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@functools.cache
def _colour_bgr() -> np.ndarray:
    v, u = np.mgrid[0:720, 0:1280]
    return _read_only(np.stack([u % 256, v % 256, (u + v) % 7 * 30], axis=-1).astype(np.uint8))  # B, G, R differ


@functools.cache
def _aligned_depth() -> np.ndarray:
    raw = np.full((720, 1280), 4000, np.uint16)        # 4000 units * 0.25 mm = 1000 mm
    raw[100:200, 300:400] = 0                           # no return
    raw[0, 0], raw[0, 1], raw[0, 2] = 1, 3962, 65535
    return _read_only(raw)


@functools.cache
def _unaligned_depth() -> np.ndarray:
    return _read_only(np.full((768, 1024), 4000, np.uint16))


class FakeFrame:
    def __init__(self, data, timestamp_ms):
        self._data, self._ts = data, timestamp_ms

    def get_data(self):
        return self._data

    def get_timestamp(self):
        return self._ts

    def __bool__(self):
        return True


class FakeFrameset:
    def __init__(self, color, depth):
        self._color, self._depth = color, depth

    def get_color_frame(self):
        return self._color

    def get_depth_frame(self):
        return self._depth


def make_fake_rs(log: list, model: str = "brown_conrady") -> types.ModuleType:
    rs = _module("pyrealsense2")
    rs.stream = SimpleNamespace(color="stream.color", depth="stream.depth")
    rs.format = SimpleNamespace(bgr8="format.bgr8", z16="format.z16")
    rs.distortion = SimpleNamespace(brown_conrady="brown_conrady", inverse_brown_conrady="inverse_brown_conrady",
                                    none="none")
    intrinsics = SimpleNamespace(width=1280, height=720, fx=902.57, fy=903.04, ppx=660.20, ppy=377.16,
                                 coeffs=list(COEFFS), model=model)
    counter = {"frames": 0}

    class config:
        def enable_device(self, serial):
            log.append(("enable_device", serial))

        def enable_stream(self, *args):
            log.append(("enable_stream", *args))

    class pipeline:
        def start(self, cfg):
            log.append(("pipeline.start",))
            color_profile = SimpleNamespace(as_video_stream_profile=lambda: SimpleNamespace(
                get_intrinsics=lambda: intrinsics))
            sensor = SimpleNamespace(get_depth_scale=lambda: DEPTH_SCALE_M)
            return SimpleNamespace(get_device=lambda: SimpleNamespace(first_depth_sensor=lambda: sensor),
                                   get_stream=lambda s: color_profile if s == rs.stream.color else None)

        def wait_for_frames(self, timeout_ms=5000):
            counter["frames"] += 1
            log.append(("wait_for_frames", timeout_ms))
            return FakeFrameset(FakeFrame(_colour_bgr(), 1.5e6 + 33.3 * counter["frames"]),
                                FakeFrame(_unaligned_depth(), 0))

        def stop(self):
            log.append(("pipeline.stop",))

    class align:
        def __init__(self, to):
            log.append(("align", to))
            self.to = to

        def process(self, frames):
            assert self.to == rs.stream.color
            return FakeFrameset(frames.get_color_frame(), FakeFrame(_aligned_depth(), 0))

    rs.config, rs.pipeline, rs.align = config, pipeline, align
    return rs


# ---------------------------------------------------------------------------------------------------------------
# Fixtures
# ---------------------------------------------------------------------------------------------------------------

def _module(name: str, **attrs) -> types.ModuleType:
    module = importlib.util.module_from_spec(importlib.machinery.ModuleSpec(name, None, is_package=True))
    module.__path__ = []
    for key, value in attrs.items():
        setattr(module, key, value)
    return module


def install_fakes(setitem, log: list) -> SimpleNamespace:
    """Put fake vendor modules into sys.modules through setitem(name, module); returns (log, world)."""
    world = FakeWorld(log)

    def robot_startup(node=None, node_name="interbotix_robot_manipulation", namespace=None):
        log.append(("robot_startup",))

    def robot_shutdown(node=None):
        log.append(("robot_shutdown",))

    robot_module = _module("interbotix_common_modules.common_robot.robot", robot_startup=robot_startup,
                           robot_shutdown=robot_shutdown)
    arm_module = _module("interbotix_xs_modules.xs_robot.arm",
                         InterbotixManipulatorXS=lambda **kwargs: FakeManipulator(world, **kwargs))
    for name, module in fake_ros.Ros(fake_ros.XsSdk()).modules.items():     # rclpy and the messages
        setitem(name, module)
    for module in (_module("interbotix_xs_modules"), _module("interbotix_xs_modules.xs_robot"), arm_module,
                   _module("interbotix_common_modules"), _module("interbotix_common_modules.common_robot"),
                   robot_module, make_fake_rs(log)):
        setitem(module.__name__, module)
    return SimpleNamespace(log=log, world=world)


class FakeClock:
    """armlab's waiting for moves, in simulated seconds (RealArm's clock and sleep)."""

    def __init__(self):
        self.t = 100.0
        self.slept = []

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.slept.append(dt)
        self.t += dt


def simulate_armlab_time(setattr_) -> FakeClock:
    """Make every RealArm that connect_arm builds wait on a FakeClock (through setattr_(obj, name, value))."""
    clock = FakeClock()
    setattr_(interbotix, "RealArm", functools.partial(RealArm, clock=clock, sleep=clock.sleep))
    return clock


@pytest.fixture
def vendors(monkeypatch):
    """Fake vendor modules in sys.modules; returns (log, world, clock): armlab's waits for moves are simulated on
    clock. A station a test leaves open does not leave its SIGTERM handler behind, nor a thread."""
    fakes = install_fakes(lambda name, module: monkeypatch.setitem(sys.modules, name, module), [])
    monkeypatch.setattr(armlab.hardware, "atexit", SimpleNamespace(register=lambda f: None,
                                                                   unregister=lambda f: None))
    monkeypatch.setattr(ros_session, "atexit", SimpleNamespace(register=lambda f: None, unregister=lambda f: None))
    monkeypatch.setattr(ros_session, "_session", None)
    monkeypatch.setenv("ROS_DOMAIN_ID", "3")
    fakes.clock = simulate_armlab_time(monkeypatch.setattr)
    handlers = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    threads = set(threading.enumerate())
    yield fakes
    signal.signal(signal.SIGTERM, handlers[0])
    signal.signal(signal.SIGINT, handlers[1])
    for t in set(threading.enumerate()) - threads:
        t.join(timeout=5)
        assert not t.is_alive(), f"the thread {t.name} outlived its test"


def calls(log, *names):
    """The logged calls whose name is in names (all motion-related ones by default)."""
    names = names or MOTION_CALLS
    return [c for c in log if c[0] in names]


@pytest.fixture
def arm(vendors):
    """A RealArm on the fake driver with a fake clock (no real sleeping)."""
    clock = FakeClock()
    bot = FakeManipulator(vendors.world, robot_model="rx200", moving_time=2.0, accel_time=0.3)
    real = RealArm(bot, clock=clock, sleep=clock.sleep)
    real.clock = clock
    return real


Q_READY = np.array([0.0, -0.5, 0.3, 1.2, 0.0])   # tool well above the board, reachable from sleep


# ---------------------------------------------------------------------------------------------------------------
# Lazy imports and clear errors
# ---------------------------------------------------------------------------------------------------------------

# the vendor's packages and the ROS ones they need: none may be imported (nor tried) before a real station connects
IMPORT_GUARDED = ("interbotix_xs_modules", "interbotix_common_modules", "pyrealsense2", "rclpy", "interbotix_xs_msgs",
                  "sensor_msgs", "trajectory_msgs", "modern_robotics")
IMPORT_CHECK = r'''
import sys
GUARDED = set(sys.argv[1].split(","))
tried = []


class Guard:
    """Notes every attempt to import a guarded package, whether it is installed or not."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in GUARDED:
            tried.append(name)
        return None


sys.meta_path.insert(0, Guard())
import armlab, armlab.station, armlab.hardware, armlab.hardware.interbotix, armlab.hardware.realsense
import armlab.hardware.safety, armlab.hardware.ros_session, armlab.station.interrupt, armlab.hardware.sigterm
import armlab.hardware.record
from armlab import make_station
print(sorted(set(tried) | {m for m in sys.modules if m.split(".")[0] in GUARDED}))
import importlib.util
for name in ("rclpy", "pyrealsense2"):          # the guard does see a lookup, of an installed package or not
    importlib.util.find_spec(name)
print(sorted(set(tried)))
'''


def test_importing_armlab_imports_no_vendor_module():
    assert {m.split(".")[0] for m in VENDOR_MODULES} <= set(IMPORT_GUARDED)
    out = subprocess.run([sys.executable, "-c", IMPORT_CHECK, ",".join(IMPORT_GUARDED)], capture_output=True,
                         text=True, check=True, timeout=60).stdout
    assert out.splitlines() == ["[]", "['pyrealsense2', 'rclpy']"]


def test_no_module_outside_armlab_hardware_imports_a_vendor_package():
    import re
    from pathlib import Path

    package = Path(armlab.hardware.__file__).parent.parent
    pattern = re.compile(r"^\s*(from|import)\s+(pyrealsense2|interbotix_\w+)", re.MULTILINE)
    offenders = [str(p.relative_to(package)) for p in package.rglob("*.py")
                 if "hardware" not in p.relative_to(package).parts and pattern.search(p.read_text())]
    assert offenders == []
    assert pattern.search((package / "hardware" / "interbotix.py").read_text())     # the pattern does match


def test_missing_vendor_modules_name_what_to_install(monkeypatch):
    for name in VENDOR_MODULES + ("interbotix_xs_modules.arm",):
        monkeypatch.setitem(sys.modules, name, None)    # not importable, even on a lab machine
    with pytest.raises(HardwareUnavailable) as err:
        make_station("real")
    message = str(err.value)
    assert isinstance(err.value, ImportError)
    assert "pip install pyrealsense2==2.54.*" in message
    assert "Interbotix ROS 2 Python API" in message and "source /opt/ros/humble/setup.bash" in message
    with pytest.raises(HardwareUnavailable, match="pyrealsense2==2.54") as err:
        make_station("real", arm=False)
    assert "Interbotix" not in str(err.value)


def test_ros1_layout_is_refused_with_its_own_message(monkeypatch):
    ros1 = _module("interbotix_xs_modules")
    monkeypatch.setitem(sys.modules, "interbotix_xs_modules", ros1)
    monkeypatch.setitem(sys.modules, "interbotix_xs_modules.arm", _module("interbotix_xs_modules.arm"))
    monkeypatch.setitem(sys.modules, "interbotix_common_modules", None)
    with pytest.raises(HardwareUnavailable, match="ROS 1"):
        interbotix.import_interbotix()


def test_an_old_ros2_toolbox_without_robot_startup_is_refused_with_its_own_message(monkeypatch):
    for name in ("interbotix_xs_modules", "interbotix_xs_modules.xs_robot", "interbotix_xs_modules.xs_robot.arm"):
        monkeypatch.setitem(sys.modules, name, _module(name))
    monkeypatch.setitem(sys.modules, "interbotix_xs_modules.arm", None)
    monkeypatch.setitem(sys.modules, "interbotix_common_modules", None)
    with pytest.raises(HardwareUnavailable, match="robot_startup/robot_shutdown, added to interbotix_ros_toolboxes"):
        interbotix.import_interbotix()


def _public_methods(cls) -> dict:
    return {name: inspect.signature(f) for name, f in inspect.getmembers(cls, inspect.isfunction)
            if not name.startswith("_")}


@pytest.mark.parametrize("fake, upstream", [(FakeArmInterface, UpstreamArm), (FakeGripper, UpstreamGripper),
                                            (SwappedGripper, UpstreamGripper), (FakeCore, UpstreamCore)])
def test_fakes_have_exactly_the_upstream_methods_and_signatures(fake, upstream):
    # the backend only ever talks to these fakes, so a call to a method the ROS 2 API lacks (get_joint_positions)
    # or with an argument it does not take fails in the tests
    assert _public_methods(fake) == _public_methods(upstream)


def test_module_functions_have_the_upstream_signatures(vendors):
    robot = sys.modules["interbotix_common_modules.common_robot.robot"]
    assert inspect.signature(robot.robot_startup) == inspect.signature(upstream_robot_startup)
    assert inspect.signature(robot.robot_shutdown) == inspect.signature(upstream_robot_shutdown)
    with pytest.raises(TypeError, match="get_joint_positions"):
        FakeManipulator(vendors.world, robot_model="rx200", get_joint_positions=True)


def test_connect_passes_the_manufacturer_arguments_and_starts_up(vendors):
    with make_station("real", gripper_pressure=0.7) as st:
        assert st.kind == "real" and st.world is None
        constructed = calls(vendors.log, "InterbotixManipulatorXS")[0][1]
        assert constructed == dict(robot_model="rx200", group_name="arm", gripper_name="gripper", robot_name=None,
                                   moving_time=2.0, accel_time=0.3, gripper_pressure=0.7)
        assert calls(vendors.log, "robot_startup") == [("robot_startup",)]
        assert calls(vendors.log) == []     # connecting moves nothing
        assert isinstance(st.arm, Arm) and isinstance(st.camera, RGBDCamera)


def _replace_constructor(monkeypatch, constructor) -> None:
    monkeypatch.setattr(sys.modules["interbotix_xs_modules.xs_robot.arm"], "InterbotixManipulatorXS", constructor)


def test_the_constructor_runs_on_a_worker_thread_and_its_error_comes_through(vendors, monkeypatch):
    seen = []

    def fails(**kwargs):
        seen.append(threading.current_thread().name)
        raise KeyError("no such group")

    _replace_constructor(monkeypatch, fails)
    with pytest.raises(KeyError, match="no such group"):
        make_station("real", camera=False)
    assert seen == ["armlab-interbotix-connect"]


def test_a_constructor_that_calls_sys_exit_is_an_error_not_an_exit(vendors, monkeypatch):
    def exits(**kwargs):
        sys.exit(1)                 # the vendor's arm interface on a joint-count mismatch (fact joint_count_exit)

    _replace_constructor(monkeypatch, exits)
    with pytest.raises(RuntimeError, match=r"gave up connecting to '/rx200' \(it called sys.exit\(1\)"):
        make_station("real", camera=False)


def test_ctrl_c_while_the_toolbox_connects_ends_its_wait(vendors, monkeypatch):
    rclpy = sys.modules["rclpy"]
    ended = threading.Event()

    def waits_for_the_driver(**kwargs):
        os.kill(os.getpid(), signal.SIGINT)                   # Ctrl+C while the constructor waits
        deadline = time.monotonic() + 5.0
        while rclpy.ok() and time.monotonic() < deadline:     # its waits last only while ROS is up
            time.sleep(0.001)
        ended.set()
        raise AttributeError("'NoneType' object has no attribute 'name'")    # what it does once ROS is down

    _replace_constructor(monkeypatch, waits_for_the_driver)
    with pytest.raises(KeyboardInterrupt):
        make_station("real", camera=False)
    assert ended.is_set() and not rclpy.ok()                 # ROS was shut down to end the wait, which ended
    with pytest.raises(RuntimeError, match="restart the Python process"):
        make_station("real", camera=False)


# ---------------------------------------------------------------------------------------------------------------
# Moves: times sent, refusals
# ---------------------------------------------------------------------------------------------------------------

def test_default_moving_and_accel_times_are_sent(arm, vendors):
    start = arm.joint_positions()
    arm.move_to(Q_READY)
    T = default_moving_time(start, Q_READY)
    Ta = pytest.approx(T / 3, rel=1e-12)
    assert calls(vendors.log) == [("set_trajectory_time", T, Ta), ("set_trajectory_time", T, Ta),
                                  ("set_joint_positions", list(Q_READY), T, Ta, False)]   # armlab waits itself
    vendors.log.clear()
    arm.move_to(rx200().home, moving_time=3.0)
    assert calls(vendors.log)[-1] == ("set_joint_positions", [0.0] * 5, 3.0, 1.0, False)
    vendors.log.clear()
    arm.move_to(Q_READY, moving_time=3.0, accel_time=1.5)
    assert calls(vendors.log)[-1] == ("set_joint_positions", list(Q_READY), 3.0, 1.5, False)
    np.testing.assert_allclose(arm.joint_positions(), Q_READY)


def test_trajectory_time_is_set_before_the_driver_checks_velocity(arm, vendors):
    # a short move leaves the driver's stored moving time at 0.4 s; the next move turns the shoulder by 1 rad,
    # which the driver would refuse at 0.4 s (2.5 rad/s > 1 rad/s) if it were not told the new time first
    arm.move_to(Q_READY)
    q_small = Q_READY + [0.05, 0, 0, 0, 0]
    arm.move_to(q_small, moving_time=0.4)
    q_big = q_small + [0, 1.0, -0.4, -0.4, 0]
    vendors.log.clear()
    arm.move_to(q_big)
    assert "driver_refused" not in [c[0] for c in vendors.log]
    assert calls(vendors.log)[-1][0] == "set_joint_positions"
    np.testing.assert_allclose(arm.joint_positions(), q_big)


@pytest.mark.parametrize("target, options, reason", [
    (np.array([0.0, 2.5, 0.0, 0.0, 0.0]), {}, r"shoulder = .*143\.2 deg.* is outside its limits"),
    (np.array([0.0, 0.0, 0.0, -1.9, 0.0]), {}, r"wrist_angle = .*-108\.9 deg.* is outside its limits"),
    (Q_READY, {"moving_time": 0.5}, "shoulder would need"),
    (Q_READY, {"moving_time": 2.0, "accel_time": 1.2}, "accel_time 1.2 s must lie in"),
    (Q_READY, {"moving_time": -1.0}, "moving_time must be a positive"),
    (kinematics.ik(np.array([0.0, 300.0, -20.0]), np.pi / 2)[0], {}, "tool point would go down to z = -20.0 mm"),
])
def test_refused_moves_send_nothing(arm, vendors, target, options, reason):
    before = arm.joint_positions()
    with pytest.raises(MotionRefused, match=reason) as err:
        arm.move_to(target, **options)
    assert "nothing was sent" in str(err.value)
    assert calls(vendors.log) == []
    np.testing.assert_array_equal(arm.joint_positions(), before)


def test_malformed_target_is_refused_and_sends_nothing(arm, vendors):
    with pytest.raises(MotionRefused, match="shape"):
        arm.move_to([0.0, 0.1, 0.2, 0.3])
    with pytest.raises(MotionRefused, match="shape"):
        arm.move_to(np.zeros((2, 5)))
    with pytest.raises(MotionRefused, match="NaN"):
        arm.move_to([0.0, np.nan, 0.2, 0.3, 0.0])
    assert calls(vendors.log) == []


def test_reset_after_a_stop_while_teaching_returns_torque_without_a_jump(arm, vendors):
    with pytest.warns(RuntimeWarning, match="falls unless supported"):
        arm.set_torque(False)
    vendors.world.q = Q_READY.copy()                            # moved by hand, then the stop button is hit
    arm.emergency_stop()
    assert calls(vendors.log) == []                             # nothing to hold with torque off
    arm.reset()
    assert calls(vendors.log, "robot_write_commands")[-1][2] == list(Q_READY)
    assert vendors.log[-1] == ("robot_torque_enable", "group", "arm", True) and arm.torque_enabled
    arm.home()
    np.testing.assert_allclose(arm.joint_positions(), 0.0)


def test_collision_check_looks_along_the_path_not_only_at_the_ends(arm, vendors):
    qa, qb = np.array([0, 1.5, 1.6, 2.0, 0.0]), np.array([0, 0.5, -0.7, 1.4, 0.0])
    ends = kinematics.joint_positions(np.stack([qa, qb]))[:, 2:, 2]
    assert ends.min() > DEFAULT_BOARD_MARGIN_MM + 40        # both ends are well clear of the board ...
    assert kinematics.fk(0.5 * (qa + qb))[2, 3] < -20       # ... but half way the tool point is under it
    vendors.world.q = qa
    arm.reset()
    vendors.log.clear()
    with pytest.raises(MotionRefused, match=r"below the board's \+10.0 mm floor"):
        arm.move_to(qb, moving_time=4.0)
    assert calls(vendors.log) == []
    assert board_collision(qa, qb) is not None and board_collision(qb, qb) is None


def test_a_low_start_may_rise_but_not_sink():
    grasp = kinematics.ik(np.array([0.0, 250.0, 5.0]), np.pi / 2)[0]      # tool 5 mm above the board
    lower = kinematics.ik(np.array([0.0, 250.0, 2.0]), np.pi / 2)[0]
    lift = kinematics.ik(np.array([0.0, 250.0, 100.0]), np.pi / 2)[0]
    assert board_collision(grasp, lift) is None
    assert "tool point would go down to z = 2.0 mm" in board_collision(grasp, lower)
    assert "below where it starts (z = 5.0 mm" in board_collision(grasp, lower)
    with pytest.raises(MotionRefused, match="below the board"):
        check_move(lift, grasp)


def test_driver_refusal_is_reported(arm, vendors):
    arm._bot.arm.group_info.joint_upper_limits[3] = 1.0      # the driver's config is tighter than the model
    with pytest.raises(MotionRefused, match="refused by the Interbotix driver"):
        arm.move_to(Q_READY)
    assert not arm.is_moving()


def test_non_blocking_moves_report_motion_and_are_waited_for(arm, vendors):
    arm.move_to(Q_READY, moving_time=2.0, blocking=False)
    assert calls(vendors.log)[-1] == ("set_joint_positions", list(Q_READY), 2.0, pytest.approx(2.0 / 3), False)
    assert arm.is_moving()
    arm.clock.t += 0.5
    assert arm.is_moving()
    arm.move_to(rx200().home, moving_time=3.0, blocking=False)     # waits the remaining 1.5 s first
    assert arm.clock.slept == [pytest.approx(1.5)]
    arm.wait()
    assert arm.clock.slept[-1] == pytest.approx(3.0) and not arm.is_moving()


# ---------------------------------------------------------------------------------------------------------------
# Gripper
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("width_mm, held", [(None, False), (30.0 + 2 * 1.5, False), (30.0 + 2 * 2.5, True),
                                            (38.0, True)])
def test_close_gripper_reports_holding_from_the_finger_position(arm, vendors, width_mm, held):
    vendors.world.object_width_mm = width_mm
    assert arm.close_gripper() is held
    assert calls(vendors.log, "grasp") == [("grasp", 1.0)]
    arm.open_gripper()
    assert calls(vendors.log, "release") == [("release", 1.0)]
    assert arm.finger_position_mm() == pytest.approx(37.0)


def test_a_gripper_that_does_not_close_is_an_error_not_a_held_block(arm, vendors):
    arm._bot.gripper = SwappedGripper(vendors.world)          # grasp() opens: the fingers stay fully open
    vendors.world.object_width_mm = 38.0
    with pytest.raises(RuntimeError, match=r"did not close the gripper.*grasp\(\) and release\(\) swapped"):
        arm.close_gripper()
    assert calls(vendors.log, "grasp") == [("grasp", 1.0)]


def test_reboot_motors_reboots_the_faulty_arm_servos_and_holds(arm, vendors):
    arm.move_to(Q_READY)
    vendors.log.clear()
    arm.reboot_motors()
    assert calls(vendors.log, "robot_reboot_motors", "robot_write_commands") == [
        ("robot_reboot_motors", "group", "arm", True, True), ("robot_write_commands", "arm", list(Q_READY))]
    arm.reboot_motors(gripper=True)
    assert ("robot_reboot_motors", "single", "gripper", True, False) in vendors.log
    arm.emergency_stop()
    vendors.log.clear()
    with pytest.raises(EmergencyStopped):
        arm.reboot_motors()
    assert vendors.log == []


# ---------------------------------------------------------------------------------------------------------------
# Emergency stop, teaching
# ---------------------------------------------------------------------------------------------------------------

def test_emergency_stop_holds_position_and_refuses_motion_until_reset(arm, vendors):
    arm.move_to(Q_READY, moving_time=2.0, blocking=False)
    vendors.world.q = Q_READY - [0, 0.2, 0.1, 0, 0]       # where the arm really is when the button is hit
    vendors.log.clear()
    arm.emergency_stop()
    assert not arm.is_moving()
    assert calls(vendors.log) == [("set_trajectory_time", HOLD_TIME_S, HOLD_TIME_S / 2),
                                  ("robot_write_commands", "arm", list(Q_READY - [0, 0.2, 0.1, 0, 0]))]
    assert calls(vendors.log, "robot_torque_enable") == []   # torque stays on: the arm must not fall
    vendors.log.clear()
    for action in (lambda: arm.move_to(rx200().home), arm.home, arm.sleep, arm.open_gripper, arm.close_gripper):
        with pytest.raises(EmergencyStopped, match="reset"):
            action()
    assert calls(vendors.log) == []
    arm.reset()
    assert vendors.log[-1] == ("capture_joint_positions",)
    arm.home()
    assert calls(vendors.log)[-1][:2] == ("set_joint_positions", [0.0] * 5)


def test_torque_off_teaching_reads_the_hand_moved_arm(arm, vendors):
    arm.move_to(Q_READY)
    with pytest.warns(RuntimeWarning, match="falls unless supported"):
        arm.set_torque(False)
    assert vendors.log[-1] == ("robot_torque_enable", "group", "arm", False)
    taught = np.array([0.4, 0.2, -0.1, 0.9, 0.3])
    vendors.world.q = taught                                   # a student moves the arm by hand
    np.testing.assert_array_equal(arm.joint_positions(), taught)
    vendors.log.clear()
    with pytest.raises(MotionRefused, match="torque is off"):
        arm.move_to(rx200().home)
    assert calls(vendors.log) == []
    arm.set_torque(True)
    # the goal is set to where the hand left the arm BEFORE torque returns, so it does not jump back to Q_READY
    assert [c[0] for c in vendors.log if c[0] != "set_trajectory_time"] == [
        "capture_joint_positions", "robot_write_commands", "robot_torque_enable"]
    assert calls(vendors.log, "robot_write_commands")[0][2] == list(taught)
    assert vendors.log[-1] == ("robot_torque_enable", "group", "arm", True)
    np.testing.assert_array_equal(arm.joint_positions(), taught)
    arm.move_to(Q_READY)
    np.testing.assert_allclose(arm.joint_positions(), Q_READY)


# ---------------------------------------------------------------------------------------------------------------
# Shutdown order
# ---------------------------------------------------------------------------------------------------------------

def _sleep_then_shutdown(log, at_exit=True):
    """The arm parked, then the camera stopped; ROS (robot_shutdown) only when the process ends (at_exit: run what
    the interpreter runs at exit first)."""
    if at_exit:
        ros_session.shutdown_session()
    order = [c for c in log if c[0] in ("set_joint_positions", "robot_shutdown", "pipeline.stop")]
    assert order[-3][:2] == ("set_joint_positions", list(rx200().sleep))
    assert order[-2:] == [("pipeline.stop",), ("robot_shutdown",)]


def test_context_manager_sleeps_before_shutdown(vendors):
    with make_station("real") as st:
        st.arm.move_to(Q_READY)
    _sleep_then_shutdown(vendors.log)
    st.close()                                                  # idempotent
    assert len(calls(vendors.log, "robot_shutdown")) == 1


def test_exception_inside_with_still_sleeps_before_shutdown(vendors):
    with pytest.raises(KeyError, match="student bug"):
        with make_station("real") as st:
            st.arm.move_to(Q_READY)
            raise KeyError("student bug")
    _sleep_then_shutdown(vendors.log)


def test_atexit_closes_a_station_left_open(vendors, monkeypatch):
    registered = []
    monkeypatch.setattr(armlab.hardware, "atexit", SimpleNamespace(register=registered.append,
                                                                   unregister=registered.remove))
    st = make_station("real")
    st.arm.move_to(Q_READY)
    assert registered == [st.close]
    registered[0]()                                             # what the interpreter does at exit
    _sleep_then_shutdown(vendors.log)
    assert registered == []


def test_close_after_teaching_torques_on_then_sleeps(vendors):
    with make_station("real", camera=False) as st:
        st.arm.move_to(Q_READY)
        with pytest.warns(RuntimeWarning, match="falls unless supported"):
            st.arm.set_torque(False)
        vendors.world.q = np.array([0.3, 0.1, 0.2, 0.8, 0.0])
    ros_session.shutdown_session()
    names = [c[0] for c in vendors.log]
    torque_on = names.index("robot_torque_enable", names.index("robot_torque_enable") + 1)
    assert vendors.log[torque_on] == ("robot_torque_enable", "group", "arm", True)
    assert torque_on < names.index("set_joint_positions", torque_on) < names.index("robot_shutdown")
    np.testing.assert_allclose(vendors.world.q, rx200().sleep)


def test_close_while_emergency_stopped_does_not_move_but_shuts_down(vendors):
    st = make_station("real", camera=False)
    st.arm.move_to(Q_READY)
    st.arm.emergency_stop()
    vendors.log.clear()
    with pytest.warns(RuntimeWarning, match="emergency-stopped"):
        st.close()
    assert vendors.log == []                                     # not moved; ROS stays up until exit
    ros_session.shutdown_session()
    assert [c[0] for c in vendors.log] == ["robot_shutdown"]


def test_a_refused_sleep_still_shuts_down_and_says_so(vendors):
    st = make_station("real", camera=False)
    st.arm.move_to(Q_READY)
    st.arm.board_margin_mm = 200.0                              # the sleep pose's tool point is 74 mm high
    with pytest.raises(RuntimeError, match="could not go to its sleep pose"):
        st.close()
    assert calls(vendors.log)[-1][:2] != ("set_joint_positions", list(rx200().sleep))
    ros_session.shutdown_session()
    assert calls(vendors.log, "robot_shutdown") == [("robot_shutdown",)]


SIGTERM_CHILD = r'''
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[2])
import test_hardware as th


class FileLog(list):
    """Every recorded call also goes to a file at once: the process is killed before it could write it later."""

    def __init__(self, path):
        super().__init__()
        self.file = open(path, "w")

    def append(self, call):
        super().append(call)
        self.file.write(json.dumps(call, default=lambda o: np.asarray(o).tolist()) + "\n")
        self.file.flush()


th.install_fakes(sys.modules.__setitem__, FileLog(sys.argv[1]))
th.simulate_armlab_time(setattr)
from armlab import make_station
station = make_station("real", warmup_frames=0)
station.arm.move_to(th.Q_READY)
print("ready", flush=True)
while True:
    time.sleep(0.05)
'''


def test_sigterm_puts_the_arm_to_sleep_before_shutdown_then_ends_the_process(tmp_path):
    log_file = tmp_path / "calls.jsonl"
    proc = subprocess.Popen([sys.executable, "-c", SIGTERM_CHILD, str(log_file), str(Path(__file__).parent)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        readable, _, _ = select.select([proc.stdout], [], [], 60)           # never wait for ever
        ready = proc.stdout.readline() if readable else "(nothing within 60 s)"
        assert ready == "ready\n", proc.stderr.read() if proc.poll() is not None else ready
        proc.send_signal(signal.SIGTERM)                  # `kill <pid>`
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == -signal.SIGTERM, proc.stderr.read()       # it still ends as a killed process
    log = [tuple(c) for c in map(json.loads, log_file.read_text().splitlines())]
    names = [c[0] for c in log]
    assert names.count("robot_shutdown") == 1 and names.count("pipeline.stop") == 1 and "driver_refused" not in names
    _sleep_then_shutdown(log, at_exit=False)
    assert names[-2:] == ["pipeline.stop", "robot_shutdown"]
    np.testing.assert_allclose(log[names.index("set_joint_positions")][1], Q_READY)   # the move before the kill


def test_sigterm_handler_chains_to_the_previous_one_and_is_restored_on_close(vendors, monkeypatch):
    seen = []

    def previous_handler(signum, frame):
        seen.append(signum)

    before = signal.signal(signal.SIGTERM, previous_handler)
    try:
        with make_station("real", warmup_frames=0) as st:
            assert signal.getsignal(signal.SIGTERM) is not previous_handler
            st.arm.move_to(Q_READY)
            os.kill(os.getpid(), signal.SIGTERM)
            assert seen == [signal.SIGTERM]               # after the station closed: sleep, camera off, ROS down
            _sleep_then_shutdown(vendors.log, at_exit=False)
            assert signal.getsignal(signal.SIGTERM) is previous_handler
        assert len(calls(vendors.log, "robot_shutdown")) == 1               # leaving the block adds nothing

        install_fakes(lambda name, module: monkeypatch.setitem(sys.modules, name, module), vendors.log)  # new process

        st = make_station("real", camera=False)
        st.close()                                        # a normal close restores the previous handler too
        assert signal.getsignal(signal.SIGTERM) is previous_handler
        with make_station("real", arm=False, warmup_frames=0):
            assert signal.getsignal(signal.SIGTERM) is previous_handler     # no arm: nothing to put to sleep
    finally:
        signal.signal(signal.SIGTERM, before)


# ---------------------------------------------------------------------------------------------------------------
# Camera
# ---------------------------------------------------------------------------------------------------------------

def test_camera_streams_intrinsics_and_frame_conversion(vendors):
    with make_station("real", arm=False, warmup_frames=3) as st:
        cam = st.camera
        assert st.arm is None
        assert calls(vendors.log, "enable_stream") == [
            ("enable_stream", "stream.color", 1280, 720, "format.bgr8", 30),
            ("enable_stream", "stream.depth", 1024, 768, "format.z16", 30)]
        assert calls(vendors.log, "align") == [("align", "stream.color")]
        assert len(calls(vendors.log, "wait_for_frames")) == 3
        np.testing.assert_array_equal(cam.K, [[902.57, 0, 660.20], [0, 903.04, 377.16], [0, 0, 1]])
        np.testing.assert_array_equal(cam.dist, COEFFS)
        assert (cam.width, cam.height) == (1280, 720)
        frame = cam.capture()
    assert isinstance(frame, Frame)
    bgr = _colour_bgr()
    assert frame.rgb.dtype == np.uint8 and frame.rgb.shape == (720, 1280, 3)
    np.testing.assert_array_equal(frame.rgb[..., 0], bgr[..., 2])
    np.testing.assert_array_equal(frame.rgb[..., 2], bgr[..., 0])
    assert frame.depth.dtype == np.float32 and frame.depth.shape == (720, 1280)
    assert frame.depth[0, 0] == pytest.approx(0.25) and frame.depth[0, 1] == pytest.approx(990.5)
    assert frame.depth[0, 2] == pytest.approx(16383.75) and frame.depth[500, 500] == 1000.0
    assert np.isnan(frame.depth[100:200, 300:400]).all() and np.isnan(frame.depth).sum() == 100 * 100
    assert frame.timestamp == pytest.approx((1.5e6 + 33.3 * 4) / 1000.0)
    assert vendors.log[-1] == ("pipeline.stop",)
    with pytest.raises(RuntimeError, match="closed"):
        cam.capture()


def test_camera_serial_selects_the_device(vendors):
    with make_station("real", arm=False, serial="f0220315", warmup_frames=0):
        pass
    assert calls(vendors.log, "enable_device") == [("enable_device", "f0220315")]


def test_non_brown_conrady_intrinsics_warn(monkeypatch):
    rs = make_fake_rs([], model="inverse_brown_conrady")
    intr = SimpleNamespace(fx=900.0, fy=901.0, ppx=640.0, ppy=360.0, coeffs=COEFFS, model="inverse_brown_conrady")
    with pytest.warns(RuntimeWarning, match="not Brown-Conrady"):
        K, dist = realsense.intrinsics_matrix(intr, rs)
    assert K[0, 0] == 900.0 and K[1, 2] == 360.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        realsense.intrinsics_matrix(SimpleNamespace(**{**vars(intr), "model": "brown_conrady"}), rs)


def test_depth_conversion_rejects_bad_input():
    with pytest.raises(ValueError, match="uint16"):
        realsense.depth_to_mm(np.zeros((4, 4), np.float32), DEPTH_SCALE_M)
    with pytest.raises(ValueError, match="depth scale"):
        realsense.depth_to_mm(np.zeros((4, 4), np.uint16), 0.0)


def test_camera_failure_after_start_stops_the_pipeline(vendors, monkeypatch):
    rs = sys.modules["pyrealsense2"]
    monkeypatch.setattr(rs, "align", lambda to: (_ for _ in ()).throw(RuntimeError("usb reset")))
    with pytest.raises(RuntimeError, match="usb reset"):
        make_station("real")
    names = [c[0] for c in vendors.log]
    assert calls(vendors.log, "robot_startup") == [("robot_startup",)]     # the arm connects first ...
    assert "pipeline.stop" in names                                         # ... the camera is released ...
    assert calls(vendors.log)[-1][:2] == ("set_joint_positions", list(rx200().sleep))  # ... and the arm parked
