"""A fake ROS boundary for running the Interbotix Python API unmodified: rclpy, the message packages and the xs_sdk
driver (with the physical arm), written for armlab's tests from the facts in tests/vendor/facts.py.

What is modelled (the rest is the least that lets the vendor code run):
- messages check their field types as rosidl does (facts: float32_assert, single_command_float32);
- rclpy.init() installs rclpy's SIGINT handler unless told not to; that handler shuts every context down and chains
  to the previous handler (facts: default_signal_handlers, sigint_shuts_contexts); the default context cannot be
  initialised twice (context_init_once); publishing or calling a service after shutdown raises RCLError, and so does
  a second rclpy.shutdown() ("rcl_shutdown already called");
- a wait for a service that is not there: a timed wait returns False, an untimed one, or more than HANG_WAITS timed
  ones in a row, raises Hang (the vendor's constructor would block forever: constructor_blocks); with
  Ros.blocking set, waits really block as rclpy's do (timed ones for their timeout, untimed ones until ROS shuts
  down), for at most BLOCK_LIMIT_S of real time in all, then raise Hang; once ROS is shut down every wait returns at
  once (rclpy's waits loop only while the context is ok: wait_returns_on_shutdown); spin_once without a driver
  raises Hang after HANG_SPINS calls in a row (the constructor's joint-state loop would spin forever);
- the xs_sdk: per-servo Profile_Velocity / Profile_Acceleration registers that a reboot resets to 0
  (reboot_no_restore), every executed group goal recorded with the profile registers it ran with, joint states that
  follow goals while torque is on, a gripper that moves to its limits or stops on an object.
Time inside the fake ROS (clock.sleep_for, rates) is simulated: nothing really sleeps.
"""

from __future__ import annotations

import enum
import signal
import threading
import time
import types
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

ARM_JOINTS = ("waist", "shoulder", "elbow", "wrist_angle", "wrist_rotate")
SLEEP = (0.0, -1.80, 1.55, 0.8, 0.0)
LOWER = (-3.141583, -1.884956, -1.884956, -1.745329, -3.141583)
UPPER = (3.141583, 1.972222, 1.623156, 2.146755, 3.141583)
VELOCITY = (3.141592, 1.0, 3.141592, 3.141592, 3.141592)
FINGER_LOWER_M, FINGER_UPPER_M = 0.015, 0.037
HANG_WAITS = 20
HANG_SPINS = 1000
BLOCK_LIMIT_S = 5.0


class Hang(AssertionError):
    """The vendor code would block forever here."""


class RCLError(RuntimeError):
    """rclpy's error from rcl (rclpy._rclpy_pybind11.RCLError)."""


# --- messages ------------------------------------------------------------------------------------------------------
_PY = {"float32": float, "float64": float, "int16": int, "int32": int, "bool": bool, "string": str}


def _check(name: str, kind: str, value: Any) -> None:
    base = kind.removesuffix("[]")
    py = _PY.get(base)
    if py is None:
        return
    if kind.endswith("[]"):
        assert (isinstance(value, Sequence) and not isinstance(value, str)
                and all(isinstance(v, py) for v in value)), \
            f"The '{name}' field must be a set or sequence and each value of type '{py.__name__}'"
    else:
        assert isinstance(value, py), f"The '{name}' field must be of type '{py.__name__}'"


def message(type_name: str, fields: dict[str, str]) -> type:
    """A message class whose fields check their types on assignment, like rosidl's generated classes."""

    def __init__(self, **kwargs):
        unknown = set(kwargs) - set(fields)
        assert not unknown, f"Invalid arguments passed to constructor: {', '.join(sorted(unknown))}"
        for name, kind in fields.items():
            default = [] if kind.endswith("[]") else (_PY.get(kind, object)() if kind in _PY else None)
            setattr(self, name, kwargs.get(name, default))

    def __setattr__(self, name, value):
        if name in fields:
            _check(name, fields[name], value)
        object.__setattr__(self, name, value)

    def __repr__(self):
        return f"{type_name}({', '.join(f'{k}={getattr(self, k)!r}' for k in fields)})"

    return type(type_name, (), {"__init__": __init__, "__setattr__": __setattr__, "__repr__": __repr__,
                                "FIELDS": dict(fields)})


def service(type_name: str, request: dict[str, str], response: dict[str, str]) -> type:
    return type(type_name, (), {"Request": message(f"{type_name}_Request", request),
                                "Response": message(f"{type_name}_Response", response)})


JointGroupCommand = message("JointGroupCommand", {"name": "string", "cmd": "float32[]"})
JointSingleCommand = message("JointSingleCommand", {"name": "string", "cmd": "float32"})
JointTrajectoryCommand = message("JointTrajectoryCommand", {"cmd_type": "string", "name": "string", "traj": "x"})
JointState = message("JointState", {"header": "x", "name": "string[]", "position": "float64[]",
                                    "velocity": "float64[]", "effort": "float64[]"})
_TARGET = {"cmd_type": "string", "name": "string"}
MotorGains = service("MotorGains", {**_TARGET, **{k: "int32" for k in
                                                  ("kp_pos", "ki_pos", "kd_pos", "k1", "k2", "kp_vel", "ki_vel")}},
                     {})
OperatingModes = service("OperatingModes", {**_TARGET, "mode": "string", "profile_type": "string",
                                            "profile_velocity": "int32", "profile_acceleration": "int32"}, {})
Reboot = service("Reboot", {**_TARGET, "enable": "bool", "smart_reboot": "bool"}, {})
RegisterValues = service("RegisterValues", {**_TARGET, "reg": "string", "value": "int32"}, {"values": "int32[]"})
RobotInfo = service("RobotInfo", _TARGET, {
    "mode": "string", "profile_type": "string", "joint_names": "string[]", "joint_ids": "int16[]",
    "joint_lower_limits": "float32[]", "joint_upper_limits": "float32[]", "joint_velocity_limits": "float32[]",
    "joint_sleep_positions": "float32[]", "joint_state_indices": "int16[]", "num_joints": "int16",
    "name": "string[]"})
TorqueEnable = service("TorqueEnable", {**_TARGET, "enable": "bool"}, {})


# --- the driver and the arm ----------------------------------------------------------------------------------------
@dataclass
class XsSdk:
    """The xs_sdk driver under `namespace` and the physical RX200 it drives."""

    namespace: str = "/rx200"
    up: bool = True
    publishers: int = 1                       # drivers publishing <ns>/joint_states (2 = a shared ROS_DOMAIN_ID)
    mode: str = "position"
    profile_type: str = "time"
    gripper_mode: str = "pwm"
    q: dict = field(default_factory=lambda: dict(zip(ARM_JOINTS, SLEEP, strict=True)))
    finger_m: float = FINGER_UPPER_M
    object_width_mm: float | None = None
    torque: bool = True
    faulty: set = field(default_factory=set)  # servos in an error state (a smart reboot reboots these)
    registers: dict = field(default_factory=lambda: {j: {"Profile_Velocity": 2000, "Profile_Acceleration": 300}
                                                     for j in ARM_JOINTS})
    executed: list = field(default_factory=list)       # (goal, {joint: Profile_Velocity}) of every arm goal run
    log: list = field(default_factory=list)            # every service call and message, in order
    on_register_write: Callable[[], None] | None = None

    def joint_state(self):
        return JointState(name=[*ARM_JOINTS, "gripper", "left_finger", "right_finger"],
                          position=[*(float(self.q[j]) for j in ARM_JOINTS), 0.0, self.finger_m, -self.finger_m])

    def serve(self, name: str, req: Any) -> Any:
        kind = name.rsplit("/", 1)[-1]
        self.log.append((kind, {k: getattr(req, k) for k in type(req).FIELDS}))
        if kind == "get_robot_info":
            if req.name == "arm":
                return RobotInfo.Response(mode=self.mode, profile_type=self.profile_type,
                                          joint_names=list(ARM_JOINTS), joint_lower_limits=list(LOWER),
                                          joint_upper_limits=list(UPPER), joint_velocity_limits=list(VELOCITY),
                                          joint_sleep_positions=list(SLEEP), num_joints=5)
            return RobotInfo.Response(mode=self.gripper_mode, profile_type="velocity", joint_names=["left_finger"],
                                      joint_lower_limits=[FINGER_LOWER_M], joint_upper_limits=[FINGER_UPPER_M],
                                      num_joints=1)
        if kind == "set_motor_registers":
            joints = ARM_JOINTS if req.cmd_type == "group" else (req.name,)
            for j in joints:
                if j in self.registers:
                    self.registers[j][req.reg] = req.value
            if self.on_register_write is not None:
                self.on_register_write()
            return RegisterValues.Response()
        if kind == "get_motor_registers":
            return RegisterValues.Response(values=[self.registers[j][req.reg] for j in ARM_JOINTS])
        if kind == "torque_enable":
            self.torque = req.enable
            return TorqueEnable.Response()
        if kind == "reboot_motors":
            joints = ([j for j in ARM_JOINTS if j in self.faulty or not req.smart_reboot] if req.cmd_type == "group"
                      else [req.name])
            for j in joints:                 # the servo restarts with its RAM registers at their defaults
                if j in self.registers:
                    self.registers[j] = {"Profile_Velocity": 0, "Profile_Acceleration": 0}
                self.faulty.discard(j)
            return Reboot.Response()
        return None

    def receive(self, topic: str, msg: Any) -> None:
        kind = topic.rsplit("/", 1)[-1]
        self.log.append((kind, {k: getattr(msg, k) for k in type(msg).FIELDS}))
        if kind == "joint_group" and msg.name == "arm" and self.torque:
            self.executed.append((list(msg.cmd), {j: self.registers[j]["Profile_Velocity"] for j in ARM_JOINTS}))
            self.q = dict(zip(ARM_JOINTS, msg.cmd, strict=False))   # as the driver: no length check
        elif kind == "joint_single" and msg.name == "gripper":
            if msg.cmd < 0:
                w = self.object_width_mm
                self.finger_m = FINGER_LOWER_M - 0.0004 if w is None else max(FINGER_LOWER_M, w / 2000.0)
            elif msg.cmd > 0:
                self.finger_m = FINGER_UPPER_M


# --- rclpy ---------------------------------------------------------------------------------------------------------
class SignalHandlerOptions(enum.IntEnum):
    NO = 0
    SIGINT = 1
    SIGTERM = 2
    ALL = 3


class LoggingSeverity(enum.IntEnum):
    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


class Duration:
    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0):
        self.nanoseconds = int(seconds * 1e9) + int(nanoseconds)

    def __lt__(self, other):
        return self.nanoseconds < other.nanoseconds

    def to_msg(self):
        return types.SimpleNamespace(sec=self.nanoseconds // 10**9, nanosec=self.nanoseconds % 10**9)


class Future:
    def __init__(self):
        self._result, self._done = None, False

    def set_result(self, result):
        self._result, self._done = result, True

    def done(self):
        return self._done

    def result(self):
        return self._result


class Ros:
    """One process's rclpy state, the fake driver it talks to, and the fake rclpy modules."""

    def __init__(self, sdk: XsSdk):
        self.sdk = sdk
        self.initialized = False
        self.is_ok = False
        self.stopped = threading.Event()
        self.blocking = False          # waits for a missing service block (real time) as rclpy's do
        self.waiting = threading.Event()   # set when such a wait starts blocking
        self.blocked_s = 0.0
        self.idle_spins = 0
        self.sim_ns = 0
        self.timers: list[Callable[[], None]] = []
        self.subscriptions: list[tuple[str, Callable]] = []
        self.previous_sigint = None
        self.sigint_installs = 0       # how often rclpy.init() installed rclpy's SIGINT handler
        self.logs: list[tuple[str, str]] = []
        self.nodes: list[Any] = []
        self.modules = self._modules()

    # rclpy module functions
    def init(self, *, args=None, context=None, domain_id=None, signal_handler_options=None):
        if self.initialized:
            raise RuntimeError("Context.init() must only be called once")
        self.initialized = self.is_ok = True
        if signal_handler_options is None:
            signal_handler_options = SignalHandlerOptions.ALL
        if signal_handler_options in (SignalHandlerOptions.ALL, SignalHandlerOptions.SIGINT):
            self.previous_sigint = signal.getsignal(signal.SIGINT)
            signal.signal(signal.SIGINT, self._rclpy_sigint)
            self.sigint_installs += 1

    def _rclpy_sigint(self, signum, frame):
        self._shutdown_contexts()
        previous = self.previous_sigint
        if callable(previous):
            previous(signum, frame)

    def uninstall_signal_handlers(self):
        if signal.getsignal(signal.SIGINT) == self._rclpy_sigint:
            signal.signal(signal.SIGINT, self.previous_sigint)

    def _shutdown_contexts(self):
        self.is_ok = False
        self.stopped.set()

    def ok(self, context=None):
        return self.is_ok

    def shutdown(self, context=None):
        if not self.initialized:
            raise RuntimeError("Context must be initialized before it can be shutdown")
        if not self.is_ok:
            raise RCLError("failed to shutdown: rcl_shutdown already called on the given context")
        self._shutdown_contexts()

    def require_ok(self, what: str):
        if not self.is_ok:
            raise RCLError(f"{what}: the context is invalid (ROS was shut down)")

    def deliver(self):
        state = self.sdk.joint_state()
        for topic, callback in self.subscriptions:
            if topic == f"{self.sdk.namespace}/joint_states" and self.sdk.up:
                callback(state)

    def advance(self, ns: int):
        self.sim_ns += max(0, ns)
        for timer in list(self.timers):
            timer()
        self.deliver()

    def spin_once(self, node, *, executor=None, timeout_sec=None):
        self.idle_spins = 0 if self.sdk.up else self.idle_spins + 1
        if self.idle_spins > HANG_SPINS:
            raise Hang("spin_once() would spin forever: no xs_sdk publishes joint states")
        self.deliver()

    def spin_until_future_complete(self, node, future, executor=None, timeout_sec=None):
        self.deliver()

    def create_node(self, node_name, **kwargs):
        return self.Node(node_name, **kwargs)

    def _modules(self) -> dict[str, types.ModuleType]:
        ros = self

        class Logger:
            def __init__(self, name):
                self.name = name

            def _log(self, level):
                return lambda message, **kw: ros.logs.append((level, str(message)))

            def __getattr__(self, level):
                return self._log(level)

        class Clock:
            def now(self):
                return types.SimpleNamespace(nanoseconds=ros.sim_ns, to_msg=lambda: None)

            def sleep_for(self, duration):
                ros.advance(duration.nanoseconds)
                return True

        class Client:
            def __init__(self, srv_type, srv_name):
                self.srv_type, self.srv_name, self.waits = srv_type, srv_name, 0

            def wait_for_service(self, timeout_sec=None):
                if ros.sdk.up:
                    return True
                if not ros.is_ok:                   # rclpy waits only while the context is ok
                    return False
                if ros.blocking:
                    return self._block(timeout_sec)
                self.waits += 1
                if timeout_sec is None or self.waits > HANG_WAITS:
                    raise Hang(f"wait_for_service({self.srv_name!r}) would block forever: no xs_sdk is running")
                ros.sim_ns += int(timeout_sec * 1e9)
                return False

            def _block(self, timeout_sec):
                budget = BLOCK_LIMIT_S - ros.blocked_s
                wait = budget if timeout_sec is None else min(float(timeout_sec), budget)
                start = time.monotonic()
                ros.waiting.set()
                stopped = ros.stopped.wait(max(0.0, wait))
                ros.blocked_s += time.monotonic() - start
                if stopped:
                    return ros.sdk.up
                if timeout_sec is None or ros.blocked_s >= BLOCK_LIMIT_S:
                    raise Hang(f"wait_for_service({self.srv_name!r}) blocked {ros.blocked_s:.1f} s: no xs_sdk is "
                               "running and ROS was not shut down")
                return False

            def call_async(self, request):
                assert isinstance(request, self.srv_type.Request), f"{request!r} is not a {self.srv_type} request"
                ros.require_ok(f"call to {self.srv_name}")
                future = Future()
                future.set_result(ros.sdk.serve(self.srv_name, request))
                ros.deliver()
                return future

        class Publisher:
            def __init__(self, msg_type, topic):
                self.msg_type, self.topic = msg_type, topic

            def publish(self, msg):
                assert isinstance(msg, self.msg_type), f"{msg!r} is not a {self.msg_type}"
                ros.require_ok(f"Failed to publish on {self.topic}")
                ros.sdk.receive(self.topic, msg)
                ros.deliver()

        class Rate:
            def sleep(self):
                ros.advance(50_000_000)

        class Node:
            def __init__(self, node_name, *args, namespace=None, context=None, **kwargs):
                self.name, self.destroyed = node_name, False
                ros.nodes.append(self)

            def create_client(self, srv_type, srv_name, callback_group=None, **kw):
                return Client(srv_type, srv_name)

            def create_publisher(self, msg_type, topic, qos_profile, callback_group=None, **kw):
                return Publisher(msg_type, topic)

            def create_subscription(self, msg_type, topic, callback, qos_profile, callback_group=None, **kw):
                ros.subscriptions.append((topic, callback))

            def create_timer(self, timer_period_sec, callback, callback_group=None, **kw):
                ros.timers.append(callback)

            def create_rate(self, frequency, clock=None):
                return Rate()

            def get_logger(self):
                return Logger(self.name)

            def get_clock(self):
                return Clock()

            def count_publishers(self, topic):
                return ros.sdk.publishers if ros.sdk.up and topic == f"{ros.sdk.namespace}/joint_states" else 0

            def destroy_node(self):
                self.destroyed = True

        class MultiThreadedExecutor:
            def add_node(self, node):
                return True

            def spin(self):
                while not ros.stopped.wait(0.02):
                    pass

        ros.Node = Node

        def module(name, **attrs):
            m = types.ModuleType(name)
            m.__dict__.update(attrs)
            return m

        rclpy = module("rclpy", init=self.init, ok=self.ok, shutdown=self.shutdown, spin_once=self.spin_once,
                       spin_until_future_complete=self.spin_until_future_complete, create_node=self.create_node,
                       RCLError=RCLError)
        rclpy.__path__ = []
        mods = {
            "rclpy": rclpy,
            "rclpy.node": module("rclpy.node", Node=Node),
            "rclpy.duration": module("rclpy.duration", Duration=Duration),
            "rclpy.task": module("rclpy.task", Future=Future),
            "rclpy.executors": module("rclpy.executors", MultiThreadedExecutor=MultiThreadedExecutor),
            "rclpy.callback_groups": module("rclpy.callback_groups", ReentrantCallbackGroup=lambda: object()),
            "rclpy.constants": module("rclpy.constants", S_TO_NS=1_000_000_000),
            "rclpy.logging": module("rclpy.logging", LoggingSeverity=LoggingSeverity,
                                    set_logger_level=lambda name, level: None),
            "rclpy.signals": module("rclpy.signals", SignalHandlerOptions=SignalHandlerOptions,
                                    uninstall_signal_handlers=self.uninstall_signal_handlers),
            "interbotix_xs_msgs": module("interbotix_xs_msgs"),
            "interbotix_xs_msgs.msg": module("interbotix_xs_msgs.msg", JointGroupCommand=JointGroupCommand,
                                             JointSingleCommand=JointSingleCommand,
                                             JointTrajectoryCommand=JointTrajectoryCommand),
            "interbotix_xs_msgs.srv": module("interbotix_xs_msgs.srv", MotorGains=MotorGains,
                                             OperatingModes=OperatingModes, Reboot=Reboot,
                                             RegisterValues=RegisterValues, RobotInfo=RobotInfo,
                                             TorqueEnable=TorqueEnable),
            "sensor_msgs": module("sensor_msgs"),
            "sensor_msgs.msg": module("sensor_msgs.msg", JointState=JointState),
            "trajectory_msgs": module("trajectory_msgs"),
            "trajectory_msgs.msg": module("trajectory_msgs.msg", JointTrajectory=message("JointTrajectory", {}),
                                          JointTrajectoryPoint=message("JointTrajectoryPoint", {})),
        }
        for name in ("interbotix_xs_msgs", "sensor_msgs", "trajectory_msgs"):
            mods[name].__path__ = []
        return mods


def modern_robotics_stub() -> types.ModuleType:
    """modern_robotics (used by the vendor's pose IK and its FK bookkeeping, which armlab does not use)."""
    import numpy as np

    m = types.ModuleType("modern_robotics")
    m.FKinSpace = lambda M, Slist, thetalist: np.eye(4)
    m.IKinSpace = lambda Slist, M, T, thetalist0, eomg, ev: (thetalist0, False)
    m.TransInv = lambda T: np.linalg.inv(T)
    return m

