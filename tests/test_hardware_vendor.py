"""armlab.hardware.interbotix run through the Interbotix toolbox over a fake ROS boundary, on two backends
(tests/vendor/backends.py):

- "vendor files": the Interbotix Python files (xs_robot/arm.py, core.py, gripper.py, mr_descriptions.py,
  common_robot/robot.py, exceptions.py), unmodified, at the commit pinned in tests/vendor/facts.py, from the cache
  of tests/vendor/sources.py (never from this repository); without that cache these runs skip, saying how to get it;
- "behaviour fake": tests/vendor/behaviour/, armlab's own model of exactly the vendor behaviours these tests depend
  on; it runs on every machine, and wherever the vendor files are cached it is checked against them (same
  signatures for what armlab calls, same service calls, messages, errors and waits under the same calls).

rclpy, the message packages and the xs_sdk driver are the fakes of tests/vendor/ros.py in both. Every wait is on a
simulated clock (armlab's through FakeClock, the toolbox's through the fake ROS clock) or has a short real timeout,
and every thread a test starts is ended and joined.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import inspect
import os
import re
import signal
import sys
import threading
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
from vendor import backends, facts, ros, sources  # noqa: E402
from vendor.backends import BACKENDS, BEHAVIOUR_FAKE, VENDOR_FILES  # noqa: E402

Q_READY = np.array([0.0, -0.5, 0.3, 1.2, 0.0])
ARM = "interbotix_xs_modules.xs_robot.arm"
ROBOT = "interbotix_common_modules.common_robot.robot"
THREAD_JOIN_S = 5.0


class FakeClock:
    """armlab's waiting for moves, in simulated seconds."""

    def __init__(self):
        self.t, self.slept = 100.0, []

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.slept.append(dt)
        self.t += dt


@contextlib.contextmanager
def toolbox_world(backend: str):
    """A fresh fake ROS and driver with the backend's toolbox loaded as the Interbotix modules (skips when the
    backend is not on this machine); yields SimpleNamespace(sdk, ros, modules, backend). On leaving, ROS is shut
    down (ending the toolbox's spin thread: robot.py spins `while rclpy.ok(): executor.spin()`), every thread
    started meanwhile is joined, and the signal handlers are put back."""
    handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    threads = set(threading.enumerate())
    with pytest.MonkeyPatch.context() as mp:
        sdk = ros.XsSdk()
        world = ros.Ros(sdk)
        setitem = functools.partial(mp.setitem, sys.modules)
        for name, module in world.modules.items():
            setitem(name, module)
        mp.setitem(sys.modules, "pyrealsense2", None)
        try:
            modules = backends.load_toolbox(backend, setitem)
        except backends.Unavailable as e:
            pytest.skip(str(e))
        try:
            yield SimpleNamespace(sdk=sdk, ros=world, modules=modules, backend=backend)
        finally:
            world._shutdown_contexts()
            alive = []
            for t in set(threading.enumerate()) - threads:
                t.join(timeout=THREAD_JOIN_S)
                if t.is_alive():
                    alive.append(t.name)
            signal.signal(signal.SIGINT, handlers[0])
            signal.signal(signal.SIGTERM, handlers[1])
            assert not alive, f"threads outlived their test: {alive}"


@pytest.fixture(params=BACKENDS)
def vendor(request, monkeypatch):
    """armlab's real backend over a toolbox (each backend in turn), a fake ROS and driver, armlab's clock simulated;
    returns SimpleNamespace(sdk, ros, modules, backend, clock)."""
    with toolbox_world(request.param) as world:
        monkeypatch.setenv("ROS_DOMAIN_ID", "7")
        no_atexit = SimpleNamespace(register=lambda f: None, unregister=lambda f: None)
        monkeypatch.setattr(armlab.hardware, "atexit", no_atexit)
        monkeypatch.setattr(ros_session, "atexit", no_atexit)
        monkeypatch.setattr(ros_session, "_session", None)
        world.clock = FakeClock()
        monkeypatch.setattr(interbotix, "RealArm", functools.partial(interbotix.RealArm, clock=world.clock,
                                                                     sleep=world.clock.sleep))
        yield world


def rclpy_sigint_installed(world) -> bool:
    return signal.getsignal(signal.SIGINT) == world.ros._rclpy_sigint       # a bound method: == not is


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


def test_the_toolbox_constructor_alone_blocks_without_a_driver(vendor):
    vendor.sdk.up = False
    vendor.ros.init()
    with pytest.raises(ros.Hang):
        vendor.modules[ARM].InterbotixManipulatorXS(robot_model="rx200")


# ---------------------------------------------------------------------------------------------------------------
# The behaviour fake, checked against the vendor files
# ---------------------------------------------------------------------------------------------------------------

# what armlab.hardware calls (see the module docstring of armlab/hardware/interbotix.py); class None: module functions
ARMLAB_CALLS = {
    ARM: {"InterbotixManipulatorXS": ("__init__",),
          "InterbotixArmXSInterface": ("set_trajectory_time", "set_joint_positions", "capture_joint_positions",
                                       "get_joint_commands")},
    "interbotix_xs_modules.xs_robot.gripper": {"InterbotixGripperXSInterface": ("grasp", "release", "set_pressure")},
    "interbotix_xs_modules.xs_robot.core": {"InterbotixRobotXSCore": (
        "robot_get_joint_states", "robot_torque_enable", "robot_write_commands", "robot_reboot_motors",
        "robot_set_motor_registers")},
    ROBOT: {None: ("robot_startup", "robot_shutdown")},
}


def _signature(f) -> list[tuple]:
    """Parameter names, kinds and defaults (annotations are not compared)."""
    return [(p.name, p.kind, p.default) for p in inspect.signature(f).parameters.values()]


def _defined_api(modules: dict) -> list[tuple[str, str | None, str]]:
    """(module, class or None, name) of every public function, class method and __init__ defined in `modules`."""
    api = []
    for name, module in modules.items():
        for attr, obj in vars(module).items():
            if attr.startswith("_") or getattr(obj, "__module__", None) != name:
                continue
            if inspect.isclass(obj):
                if not issubclass(obj, BaseException):
                    api += [(name, attr, m) for m, f in vars(obj).items()
                            if inspect.isfunction(f) and (m == "__init__" or not m.startswith("_"))]
            elif inspect.isfunction(obj):
                api.append((name, None, attr))
    return api


def _signatures(modules: dict, api) -> dict:
    """{(module, class, name): signature, or None where `modules` lack it}."""
    found = {}
    for module, cls, name in api:
        owner = modules.get(module)
        owner = getattr(owner, cls, None) if cls is not None else owner
        f = getattr(owner, name, None)
        found[(module, cls, name)] = None if f is None else _signature(f)
    return found


def test_the_behaviour_fake_has_the_vendor_signatures():
    with toolbox_world(BEHAVIOUR_FAKE) as world:
        api = _defined_api(world.modules)
        fake = _signatures(world.modules, api)
    with toolbox_world(VENDOR_FILES) as world:
        vendor = _signatures(world.modules, api)
    for (module, cls, name), signature in fake.items():
        where = f"{module}.{cls + '.' if cls else ''}{name}"
        assert vendor[(module, cls, name)] is not None, f"{where}: not in the vendor files"
        assert signature == vendor[(module, cls, name)], f"{where}: the vendor's signature differs"
    for module, classes in ARMLAB_CALLS.items():           # the fake models everything armlab calls
        for cls, names in classes.items():
            for name in names:
                assert (module, cls, name) in fake, f"the behaviour fake lacks {module}.{cls or ''}.{name}"


def test_the_upstream_signatures_of_the_call_checking_fakes_are_the_vendor_files():
    import test_hardware as th  # its hand-written stand-ins for the vendor API

    with toolbox_world(VENDOR_FILES) as world:
        arm = world.modules[ARM]
        classes = {th.UpstreamArm: arm.InterbotixArmXSInterface,
                   th.UpstreamGripper: world.modules["interbotix_xs_modules.xs_robot.gripper"]
                   .InterbotixGripperXSInterface,
                   th.UpstreamCore: world.modules["interbotix_xs_modules.xs_robot.core"].InterbotixRobotXSCore}
        for upstream, real in classes.items():
            for name, f in inspect.getmembers(upstream, inspect.isfunction):
                assert _signature(f) == _signature(getattr(real, name)), f"{upstream.__name__}.{name}"
        robot = world.modules[ROBOT]
        assert _signature(th.upstream_robot_startup) == _signature(robot.robot_startup)
        assert _signature(th.upstream_robot_shutdown) == _signature(robot.robot_shutdown)
        assert [("self", inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.empty),
                *_signature(th.upstream_manipulator)] == _signature(arm.InterbotixManipulatorXS.__init__)


class Trace:
    """What a sequence of toolbox calls did, step by step: the outcome (a value or the error's type and message),
    the service calls and messages the driver got, the simulated time the toolbox slept."""

    def __init__(self, world):
        self.world, self.steps = world, []

    def __call__(self, name, action):
        sdk, clock = self.world.sdk, self.world.ros
        start_log, start_ns = len(sdk.log), clock.sim_ns
        try:
            outcome = action()
        except Exception as e:           # AssertionError (message types), RCLError, InterbotixException, Hang, ...
            outcome = ("raised", type(e).__name__, str(e))
        self.steps.append((name, outcome, copy.deepcopy(sdk.log[start_log:]), clock.sim_ns - start_ns))


def session_calls(world, trace: Trace) -> None:
    """One process's use of the toolbox: construct (rclpy started by the toolbox, an int gripper pressure), the
    register cache, the order register writes -> publish, a reboot, message types, a second global node, shutdown."""
    sdk, r = world.sdk, world.ros
    robot, made = world.modules[ROBOT], {}

    def construct():
        bot = made["bot"] = world.modules[ARM].InterbotixManipulatorXS(robot_model="rx200", gripper_pressure=1)
        return dict(cache=(bot.arm.moving_time, bot.arm.accel_time), commands=bot.arm.get_joint_commands(),
                    group=(list(bot.arm.group_info.joint_names), bot.arm.group_info.mode,
                           bot.arm.group_info.profile_type),
                    gripper=(bot.gripper.gripper_info.mode, bot.gripper.left_finger_lower_limit,
                             bot.gripper.left_finger_upper_limit),
                    effort=(bot.gripper.gripper_value, type(bot.gripper.gripper_value).__name__),
                    ros=(r.ok(), rclpy_sigint_installed(world), len(r.nodes)))

    trace("construct", construct)
    bot = made["bot"]
    arm, core, gripper = bot.arm, bot.core, bot.gripper
    trace("startup", lambda: (robot.robot_startup(), robot.interbotix_is_up()))
    for times in ((2.0, 0.3), (0.4, 0.2), (0.4, 0.2), (None, 0.1), (0.4, None)):
        trace(f"set_trajectory_time{times}", lambda t=times: (arm.set_trajectory_time(*t),
                                                             arm.moving_time, arm.accel_time))
    trace("too fast for the cached time", lambda: arm.set_joint_positions(list(Q_READY), moving_time=5.0,
                                                                          accel_time=1.0, blocking=False))
    trace("times, then a non-blocking move", lambda: (arm.set_trajectory_time(3.0, 1.0), arm.set_joint_positions(
        list(Q_READY), moving_time=3.0, accel_time=1.0, blocking=False), arm.get_joint_commands()))
    trace("a blocking move with new times", lambda: arm.set_joint_positions(
        list(Q_READY + [0.05, 0, 0, 0, 0]), moving_time=0.5, accel_time=0.25, blocking=True))
    trace("outside the limits", lambda: arm.set_joint_positions([0.0, 2.5, 0.0, 0.0, 0.0], moving_time=3.0))
    trace("int goals", lambda: arm.set_joint_positions([0, 0, 0, 1, 0], moving_time=3.0, blocking=False))

    def moved_by_hand():
        sdk.q = dict(zip(ros.ARM_JOINTS, [0.2, -0.4, 0.3, 1.1, 0.1], strict=True))
        r.deliver()
        before = arm.get_joint_commands()
        arm.capture_joint_positions()
        return before, arm.get_joint_commands()

    trace("capture", moved_by_hand)

    def reboot():
        sdk.faulty.add("shoulder")
        core.robot_reboot_motors("group", "arm", True, smart_reboot=True)
        arm.set_trajectory_time(arm.moving_time, arm.accel_time)    # the cached values: nothing is rewritten
        return copy.deepcopy(sdk.registers)

    trace("reboot", reboot)
    trace("int register", lambda: core.robot_set_motor_registers("group", "arm", "Profile_Velocity", 500))
    trace("float register", lambda: core.robot_set_motor_registers("group", "arm", "Profile_Velocity", 500.0))
    trace("float commands", lambda: core.robot_write_commands("arm", [0.1, -0.4, 0.3, 1.1, 0.0]))
    trace("int commands", lambda: core.robot_write_commands("arm", [0, 0, 0, 1, 0]))
    trace("torque", lambda: (core.robot_torque_enable("group", "arm", False), sdk.torque,
                             core.robot_torque_enable("group", "arm", True), sdk.torque))
    trace("grasp, int effort", lambda: gripper.grasp(0.1))
    trace("pressure", lambda: (gripper.set_pressure(0.5), gripper.gripper_value))
    trace("grasp", lambda: (gripper.grasp(0.1), sdk.finger_m))
    trace("grasp again", lambda: gripper.grasp(0.1))
    trace("release", lambda: (gripper.release(0.1), sdk.finger_m))
    trace("joint states", lambda: (lambda js: (list(js.name), list(js.position)))(core.robot_get_joint_states()))
    trace("a second manipulator", lambda: world.modules[ARM].InterbotixManipulatorXS(robot_model="rx200"))
    trace("a second startup", robot.robot_startup)
    trace("shutdown", lambda: (robot.robot_shutdown(), r.ok(), [n.destroyed for n in r.nodes]))
    trace("after shutdown", lambda: (robot.get_interbotix_global_node() is bot.core.robot_node,
                                     robot.interbotix_is_up()))
    trace("a new global node", robot.create_interbotix_global_node)
    trace("shutdown again", robot.robot_shutdown)
    trace("publish after shutdown", lambda: core.robot_write_commands("arm", [0.0] * 5))
    trace("register write after shutdown", lambda: arm.set_trajectory_time(1.0, None))
    trace("cache after", lambda: (arm.moving_time, arm.accel_time))


def before_any_node(world, trace: Trace) -> None:
    robot = world.modules[ROBOT]
    trace("global node", robot.get_interbotix_global_node)
    trace("startup", robot.robot_startup)
    trace("is up", robot.interbotix_is_up)


def rclpy_up_without_handlers(world, trace: Trace) -> None:
    world.ros.init(signal_handler_options=ros.SignalHandlerOptions.NO)
    trace("construct", lambda: (world.modules[ARM].InterbotixManipulatorXS(robot_model="rx200") is not None,
                                rclpy_sigint_installed(world), world.ros.ok()))


def after_rclpy_shutdown(world, trace: Trace) -> None:
    world.ros.init(signal_handler_options=ros.SignalHandlerOptions.NO)
    world.ros.shutdown()
    trace("construct", lambda: world.modules[ARM].InterbotixManipulatorXS(robot_model="rx200"))


def no_driver(world, trace: Trace) -> None:
    world.sdk.up = False
    world.ros.init(signal_handler_options=ros.SignalHandlerOptions.NO)
    trace("construct", lambda: world.modules[ARM].InterbotixManipulatorXS(robot_model="rx200"))


def driver_gone_until_ros_shuts_down(world, trace: Trace) -> None:
    """The constructor blocks (really) while ROS is up; shutting ROS down ends its waits, and it fails."""
    world.sdk.up, world.ros.blocking = False, True
    world.ros.init(signal_handler_options=ros.SignalHandlerOptions.NO)
    result = {}

    def construct():
        try:
            world.modules[ARM].InterbotixManipulatorXS(robot_model="rx200")
        except Exception as e:
            result["error"] = (type(e).__name__, str(e))

    worker = threading.Thread(target=construct)
    worker.start()
    blocked = world.ros.waiting.wait(ros.BLOCK_LIMIT_S)
    world.ros.shutdown()
    worker.join(THREAD_JOIN_S)
    trace("blocked until shut down", lambda: (blocked, worker.is_alive(), result.get("error")))


@pytest.mark.parametrize("calls", [session_calls, before_any_node, rclpy_up_without_handlers, after_rclpy_shutdown,
                                   no_driver, driver_gone_until_ros_shuts_down], ids=lambda f: f.__name__)
def test_the_behaviour_fake_does_what_the_vendor_files_do(calls):
    traces = {}
    for backend in (VENDOR_FILES, BEHAVIOUR_FAKE):
        with toolbox_world(backend) as world:
            trace = Trace(world)
            calls(world, trace)
            traces[backend] = trace.steps
    vendor, fake = traces[VENDOR_FILES], traces[BEHAVIOUR_FAKE]
    assert [step[0] for step in fake] == [step[0] for step in vendor]
    for v, f in zip(vendor, fake, strict=True):
        assert f == v, f"step {v[0]!r}: the behaviour fake did {f[1:]}, the vendor files {v[1:]}"


# ---------------------------------------------------------------------------------------------------------------
# The five unsafe behaviours of the issue, each through the toolbox (vendor files and behaviour fake); the facts
# (tests/vendor/facts.py) each depends on: 1 gripper_effort_type, float32_assert, single_command_float32;
# 2 global_node_persists, shutdown_calls_rclpy_shutdown, context_init_once; 3 init_if_not_ok,
# default_signal_handlers, sigint_shuts_contexts; 4 register_cache, reboot_no_restore, profile_zero_infinite;
# 5 publish_after_register_writes, limit_check_uses_cached_time
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
            vendor.sdk.q = dict(zip(ros.ARM_JOINTS, 0.5 * Q_READY, strict=True))      # where the arm is at the Ctrl+C
            vendor.ros.deliver()
            os.kill(os.getpid(), signal.SIGINT)
            pytest.fail("SIGINT did not interrupt")
    executed = goals(vendor.sdk)
    np.testing.assert_allclose(executed[-3], rx200().home)
    np.testing.assert_allclose(executed[-2], 0.5 * Q_READY, atol=1e-6)     # the hold
    np.testing.assert_allclose(executed[-1], rx200().sleep)                # parked after leaving the block
    assert vendor.ros.ok() and not rclpy_sigint_installed(vendor)


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


class WatchedLock:
    """armlab's move lock, noting when another thread has to wait for it (so a test needs no timed sleep)."""

    def __init__(self, lock, waiting: threading.Event):
        self._lock, self._waiting = lock, waiting

    def __enter__(self):
        if not self._lock.acquire(blocking=False):
            self._waiting.set()
            assert self._lock.acquire(timeout=THREAD_JOIN_S), "armlab's lock was never released"
        return self

    def __exit__(self, *exc):
        self._lock.release()


def test_5_an_emergency_stop_during_a_move_being_sent_wins(vendor):
    with arm_station() as st:
        st.arm.move_to(Q_READY)
        stopper = threading.Thread(target=st.arm.emergency_stop)
        waiting = threading.Event()
        if hasattr(st.arm, "_lock"):
            st.arm._lock = WatchedLock(st.arm._lock, waiting)
        state = {"fired": False}

        def stop_from_another_thread():        # the state machine's thread, between the two register writes
            if not state["fired"]:
                state["fired"] = True
                stopper.start()
                # the stop either runs to its end now, or waits for the move's check-then-publish (armlab's lock)
                while stopper.is_alive() and not waiting.wait(0.001):
                    pass

        vendor.sdk.on_register_write = stop_from_another_thread
        try:
            st.arm.move_to(Q_READY + [0.1, 0, 0, 0, 0], moving_time=2.5)   # the vendor accepts it even at 0.4 s
        except EmergencyStopped:
            pass
        stopper.join(timeout=THREAD_JOIN_S)
        assert not stopper.is_alive()
        vendor.sdk.on_register_write = None
        assert state["fired"] and st.arm.emergency_stopped
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


def test_a_driver_that_stops_while_the_toolbox_connects_is_named_not_waited_for(vendor, monkeypatch):
    probe = ros_session.wait_for_driver

    def probe_then_stop(*args, **kwargs):
        probe(*args, **kwargs)
        vendor.sdk.up = False              # the driver stops right after answering armlab's probe

    monkeypatch.setattr(ros_session, "wait_for_driver", probe_then_stop)
    monkeypatch.setattr(ros_session, "MIN_CONNECT_S", 0.0, raising=False)
    vendor.ros.blocking = True             # the toolbox's waits block as rclpy's do, until ROS shuts down
    with pytest.raises(DriverNotFound, match=r"under '/rx200' answered, but the Interbotix API did not finish "
                                             r"connecting to it within 0.2 s[\s\S]*restart the Python process"):
        arm_station(driver_timeout_s=0.2)
    assert vendor.ros.waiting.is_set() and not vendor.ros.ok()        # it blocked; ROS was shut down to end it
    assert not [t for t in threading.enumerate() if t.name == "armlab-interbotix-connect"]   # the worker ended
    vendor.sdk.up = True
    with pytest.raises(RuntimeError, match="restart the Python process"):
        arm_station()


def test_the_driver_answering_without_joint_states_is_named(vendor):
    vendor.sdk.publishers = 0
    with pytest.raises(DriverNotFound, match=r"answers but publishes no /rx200/joint_states \(waited 0.1 s\)"):
        arm_station(driver_timeout_s=0.1)


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
        assert not rclpy_sigint_installed(vendor)
    assert vendor.ros.ok() and vendor.ros.sigint_installs == 0


def test_rclpy_started_with_its_signal_handlers_before_armlab_loses_them(vendor):
    vendor.ros.init()                          # a notebook that started rclpy itself, with the defaults
    assert rclpy_sigint_installed(vendor)
    with arm_station() as st:
        st.arm.move_to(Q_READY)
    assert not rclpy_sigint_installed(vendor) and vendor.ros.ok()


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
