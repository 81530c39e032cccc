"""The process's one ROS 2 session for the real arm: rclpy started without its signal handlers, the xs_sdk driver
found within a timeout, and one Interbotix bot per process, reused by every make_station("real").

Why one bot per process: the Interbotix API keeps a process-global node that robot_shutdown() does not remove (a
second InterbotixManipulatorXS raises InterbotixException), and rclpy's default context cannot be initialised again
once shut down. So closing a station parks the arm but keeps the session; robot_shutdown() runs once, at interpreter
exit (atexit) or when the process is asked to stop (SIGTERM), always after the arm is parked.

Why no rclpy signal handlers: rclpy's default SIGINT handler shuts every ROS context down, so after a Ctrl+C (or a
Jupyter interrupt) the sleep move could not be sent. armlab initialises rclpy with SignalHandlerOptions.NO (before the
Interbotix API would initialise it with the defaults) and installs its own SIGINT handler while a station is open
(armlab.station.interrupt).

Why a probe: InterbotixManipulatorXS(...) waits forever for the driver's services and joint states. The probe waits
at most `timeout_s` for them on a node of its own and names the missing driver; it also refuses a second driver
publishing the same joint states (two stations sharing one ROS_DOMAIN_ID).

Why the constructor runs on a worker thread: a driver that stops between the probe and the constructor (or answers
but publishes no joint states) would still block the constructor forever. armlab waits for it at most
max(timeout_s, MIN_CONNECT_S); past that, or on Ctrl+C meanwhile, it shuts ROS down, which ends the constructor's
waits (rclpy's waits and the constructor's loops run only while ROS is up) and so the worker thread, and raises.
The process cannot start ROS again, which it could not anyway: the constructor had already created the vendor's
process-global node, which refuses a second creation.
"""

from __future__ import annotations

import atexit
import os
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["DRIVER_TIMEOUT_S", "MIN_CONNECT_S", "DriverNotFound", "RosApi", "start_rclpy", "wait_for_driver",
           "construct_bot", "get_bot", "shutdown_session"]

DRIVER_TIMEOUT_S = 10.0
MIN_CONNECT_S = 5.0       # the constructor's own work: two service calls, a 0.5 s sleep, the first joint state
ABANDON_JOIN_S = 2.0      # how long an abandoned constructor gets to end once ROS is shut down (rclpy polls at 4 Hz)
LAUNCH = "ros2 launch interbotix_xsarm_control xsarm_control.launch.py robot_model:=rx200"


class DriverNotFound(RuntimeError):
    """The Interbotix xs_sdk driver did not answer within the timeout; the message says what to start."""


@dataclass(frozen=True)
class RosApi:
    """The vendor callables the session uses (from armlab.hardware.interbotix.import_interbotix)."""

    manipulator: Callable[..., Any]      # InterbotixManipulatorXS
    robot_startup: Callable[..., None]
    robot_shutdown: Callable[..., None]
    rclpy: Any                           # the rclpy module
    no_signal_handlers: Any              # rclpy.signals.SignalHandlerOptions.NO
    uninstall_signal_handlers: Callable[[], None]
    robot_info_srv: Any                  # interbotix_xs_msgs.srv.RobotInfo


@dataclass
class _Session:
    api: RosApi
    namespace: str
    bot: Any
    up: bool = True


_session: _Session | None = None


def _domain() -> str:
    return os.environ.get("ROS_DOMAIN_ID", "0 (ROS_DOMAIN_ID not set)")


def start_rclpy(api: RosApi) -> None:
    """rclpy.init without signal handlers; if it is already up, its signal handlers are removed."""
    rclpy = api.rclpy
    if rclpy.ok():
        api.uninstall_signal_handlers()
        return
    try:
        rclpy.init(signal_handler_options=api.no_signal_handlers)
    except RuntimeError as e:     # rclpy's default context cannot be initialised twice
        raise RuntimeError(f"ROS was shut down in this Python process and cannot be restarted in it ({e}): "
                           "restart the Python process (Jupyter: restart the kernel)") from e


def wait_for_driver(api: RosApi, namespace: str, timeout_s: float = DRIVER_TIMEOUT_S) -> None:
    """Wait (at most timeout_s) for the xs_sdk driver's services and its joint states under `namespace` (e.g.
    '/rx200'). Raises DriverNotFound naming the driver to start, or RuntimeError when two drivers publish the
    same joint states (two stations on one ROS_DOMAIN_ID)."""
    node = api.rclpy.create_node("armlab_driver_probe")
    try:
        deadline = time.monotonic() + timeout_s
        client = node.create_client(api.robot_info_srv, f"{namespace}/get_robot_info")
        if not client.wait_for_service(timeout_sec=max(0.0, timeout_s)):
            raise DriverNotFound(
                f"no Interbotix xs_sdk driver answers under '{namespace}' in ROS domain {_domain()} (waited "
                f"{timeout_s:g} s): with the arm resting in its sleep pose, start `{LAUNCH}` in another shell "
                "with the same ROS_DOMAIN_ID and the same `source .../setup.bash`")
        topic = f"{namespace}/joint_states"
        while (count := node.count_publishers(topic)) == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        if count == 0:
            raise DriverNotFound(f"the xs_sdk driver under '{namespace}' answers but publishes no {topic} (waited "
                                 f"{timeout_s:g} s): restart `{LAUNCH}`")
        if count > 1:
            raise RuntimeError(f"{count} drivers publish {topic} in ROS domain {_domain()}: another station "
                               "shares this ROS_DOMAIN_ID. Give every station its own (export ROS_DOMAIN_ID=<n> in "
                               "every shell of the station, driver included)")
    finally:
        node.destroy_node()


def _abandon(api: RosApi, worker: threading.Thread) -> None:
    """End a constructor that still waits: shut ROS down (its waits run only while ROS is up), let the worker end."""
    try:
        if api.rclpy.ok():
            api.rclpy.shutdown()
    except Exception:              # ROS went down meanwhile: the worker ends all the same
        pass
    worker.join(ABANDON_JOIN_S)


def construct_bot(api: RosApi, namespace: str, robot_name: str | None, gripper_pressure: float,
                  timeout_s: float = DRIVER_TIMEOUT_S) -> Any:
    """InterbotixManipulatorXS(...) for rx200, built on a worker thread and waited for at most
    max(timeout_s, MIN_CONNECT_S) (see the module docstring).

    Raises DriverNotFound when it did not finish in time (ROS is then shut down in this process), the constructor's
    own exception when it failed, and RuntimeError when it called sys.exit() (the vendor does on a joint-count
    mismatch) instead of ending the process. On an interrupt while waiting, ROS is shut down and it propagates.
    """
    outcome: dict[str, Any] = {}
    done = threading.Event()

    def construct() -> None:
        try:
            outcome["bot"] = api.manipulator(robot_model="rx200", group_name="arm", gripper_name="gripper",
                                             robot_name=robot_name, moving_time=2.0, accel_time=0.3,
                                             gripper_pressure=float(gripper_pressure))
        except BaseException as e:         # handed to the caller, SystemExit included
            outcome["error"] = e
        finally:
            done.set()

    limit = max(float(timeout_s), MIN_CONNECT_S)
    worker = threading.Thread(target=construct, name="armlab-interbotix-connect", daemon=True)
    try:
        worker.start()
        finished = done.wait(limit)
    except BaseException:                  # Ctrl+C while connecting: do not leave the constructor waiting
        _abandon(api, worker)
        raise
    if not finished:
        _abandon(api, worker)
        raise DriverNotFound(
            f"the xs_sdk driver under '{namespace}' answered, but the Interbotix API did not finish connecting to it "
            f"within {limit:g} s (the driver stopped, or publishes no joint states). ROS was shut down in this "
            f"Python process to end the wait: restart `{LAUNCH}`, then restart the Python process (Jupyter: restart "
            "the kernel)")
    error = outcome.get("error")
    if isinstance(error, SystemExit):
        raise RuntimeError(f"the Interbotix API gave up connecting to '{namespace}' (it called sys.exit({error.code})"
                           "; its log above says why: is the driver running robot_model:=rx200?). Restart the "
                           "Python process (Jupyter: restart the kernel)") from error
    if error is not None:
        raise error
    return outcome["bot"]


def get_bot(api: RosApi, robot_name: str | None, gripper_pressure: float,
            timeout_s: float = DRIVER_TIMEOUT_S) -> Any:
    """The process's started InterbotixManipulatorXS for rx200 under robot_name (default 'rx200'), created on the
    first call (rclpy without signal handlers, driver probed, robot_startup()) and reused afterwards (its gripper
    pressure set to gripper_pressure, a fraction 0..1)."""
    global _session
    namespace = "/" + (robot_name if robot_name is not None else "rx200")
    session = _session
    if session is not None and session.api != api:      # another vendor API (tests): the old one is gone
        session = _session = None
    if session is not None:
        if not session.up or not api.rclpy.ok():
            raise RuntimeError("ROS was shut down in this Python process and cannot be restarted in it: restart "
                               "the Python process (Jupyter: restart the kernel)")
        if session.namespace != namespace:
            raise RuntimeError(f"this Python process already drives the arm '{session.namespace}'; the Interbotix "
                               f"API allows one arm per process: use a new process for '{namespace}'")
        session.bot.gripper.set_pressure(float(gripper_pressure))
        return session.bot
    if "ROS_DOMAIN_ID" not in os.environ:
        warnings.warn("ROS_DOMAIN_ID is not set: every station on this network on the default domain shares "
                      f"'{namespace}'; export ROS_DOMAIN_ID=<station number> in every shell of this station",
                      RuntimeWarning, stacklevel=3)
    start_rclpy(api)
    wait_for_driver(api, namespace, timeout_s)
    bot = construct_bot(api, namespace, robot_name, gripper_pressure, timeout_s)
    api.robot_startup()
    _session = _Session(api, namespace, bot)
    atexit.register(shutdown_session)
    return bot


def shutdown_session() -> None:
    """robot_shutdown() once, if the session is up (park the arm first); idempotent."""
    global _session
    session, _session = _session, None
    if session is not None and session.up:
        session.up = False
        atexit.unregister(shutdown_session)
        if session.api.rclpy.ok():
            session.api.robot_shutdown()
