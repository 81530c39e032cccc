"""Behaviour fake of interbotix_common_modules/common_robot/robot.py: the process-global node and its spin thread.

Modelled (tests/vendor/facts.py: global_node_persists, init_if_not_ok, shutdown_calls_rclpy_shutdown, startup_once):
- create_interbotix_global_node() refuses once this module has ever made a global node, and calls rclpy.init() with
  the caller's arguments (by default: rclpy's signal handlers) only when rclpy.ok() is False;
- get_interbotix_global_node() is a NameError before the first node exists;
- robot_startup() spins the node on a daemon thread while rclpy.ok() and refuses a second startup;
- robot_shutdown() destroys the node, calls rclpy.shutdown() (an error when ROS is already down) and joins the
  thread, but leaves the global node and the 'up' flag in place: the process can neither start up again nor make a
  second global node.
"""

from __future__ import annotations

import threading

import rclpy
from interbotix_common_modules.common_robot.exceptions import InterbotixException
from rclpy.duration import Duration
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

JOIN_LIMIT_S = 5.0
_process: dict = {}       # 'node', 'up', 'thread': a key exists once the toolbox has set it, never removed


class InterbotixRobotNode(Node):
    def __init__(self, node_name: str = "interbotix_robot_manipulation", namespace: str | None = None, *args,
                 **kwargs) -> None:
        self.node_name, self.namespace = node_name, namespace
        super().__init__(node_name, *args, namespace=namespace, **kwargs)

    def wait_until_future_complete(self, future, timeout_sec: float | None = None) -> None:
        if not interbotix_is_up():                 # before startup nothing spins: spin here
            rclpy.spin_until_future_complete(self, future, timeout_sec=timeout_sec)
            return
        rate, start = self.create_rate(20.0), self.get_clock().now()
        limit = None if timeout_sec is None or timeout_sec < 0 else Duration(seconds=timeout_sec).nanoseconds
        while not future.done() and (limit is None or self.get_clock().now().nanoseconds - start.nanoseconds < limit):
            rate.sleep()

    def logdebug(self, message: str, **kwargs):
        self.get_logger().debug(message, **kwargs)

    def loginfo(self, message: str, **kwargs):
        self.get_logger().info(message, **kwargs)

    def logwarn(self, message: str, **kwargs):
        self.get_logger().warning(message, **kwargs)

    def logerror(self, message: str, **kwargs):
        self.get_logger().error(message, **kwargs)

    def logfatal(self, message: str, **kwargs):
        self.get_logger().fatal(message, **kwargs)


def create_interbotix_global_node(node_name: str = "interbotix_robot_manipulation", namespace: str = None, *args,
                                  **kwargs) -> InterbotixRobotNode:
    if "node" in _process:
        raise InterbotixException("Tried to create an Interbotix global node but one already exists.")
    if not rclpy.ok():
        rclpy.init(*args, **kwargs)
    _process["node"] = InterbotixRobotNode(node_name, namespace, *args, **kwargs)
    return _process["node"]


def get_interbotix_global_node() -> InterbotixRobotNode:
    if "node" not in _process:
        raise NameError("name '__interbotix_global_node' is not defined")
    return _process["node"]


def interbotix_is_up() -> bool:
    return _process.get("up", False)


def robot_startup(node: InterbotixRobotNode | None = None, node_name: str = "interbotix_robot_manipulation",
                  namespace: str | None = None) -> None:
    if node is None:
        node = get_interbotix_global_node()
        if node is None:
            node = create_interbotix_global_node(node_name=node_name, namespace=namespace)
    if interbotix_is_up():
        raise InterbotixException("Startup has already been requested.")
    _process["up"] = True
    executor = MultiThreadedExecutor()

    def spin() -> None:
        while rclpy.ok():
            executor.add_node(node=node)
            executor.spin()

    _process["thread"] = threading.Thread(target=spin, daemon=True)
    _process["thread"].start()


def robot_shutdown(node: InterbotixRobotNode | None = None) -> None:
    if node is None:
        node = get_interbotix_global_node()
    node.destroy_node()
    rclpy.shutdown()
    if "thread" not in _process:
        raise NameError("name '__interbotix_execution_thread' is not defined")
    _process["thread"].join(JOIN_LIMIT_S)       # the toolbox joins without a timeout; a test must not hang
    assert not _process["thread"].is_alive(), "the toolbox's spin thread did not end after rclpy.shutdown()"
