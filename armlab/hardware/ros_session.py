"""The process's one ROS 2 session for the real arm: rclpy started without its signal handlers, the xs_sdk driver
found within a timeout, and one Interbotix bot per process, reused by every make_station("real").

Why one bot per process: the Interbotix API keeps a process-global node that robot_shutdown() does not remove (a
second InterbotixManipulatorXS raises InterbotixException), and rclpy's default context cannot be initialised again
once shut down. So closing a station parks the arm but keeps the session; robot_shutdown() runs once, at interpreter
exit (atexit) or when the process is asked to stop (SIGTERM), always after the arm is parked.

Why no rclpy signal handlers: rclpy's default SIGINT handler shuts every ROS context down, so after a Ctrl+C (or a
Jupyter interrupt) the sleep move could not be sent. armlab initialises rclpy with SignalHandlerOptions.NO (before the
Interbotix API would initialise it with the defaults) and installs its own SIGINT handler while a station is open
(armlab.hardware.signals).

Why a probe: InterbotixManipulatorXS(...) waits forever for the driver's services and joint states. The probe waits
at most `timeout_s` for them on a node of its own and names the missing driver; it also refuses a second driver
publishing the same joint states (two stations sharing one ROS_DOMAIN_ID).
"""

from __future__ import annotations

import atexit
import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["DRIVER_TIMEOUT_S", "DriverNotFound", "RosApi", "start_rclpy", "wait_for_driver", "get_bot",
           "shutdown_session"]

DRIVER_TIMEOUT_S = 10.0
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
    bot = api.manipulator(robot_model="rx200", group_name="arm", gripper_name="gripper", robot_name=robot_name,
                          moving_time=2.0, accel_time=0.3, gripper_pressure=float(gripper_pressure))
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
