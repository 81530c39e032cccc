"""Behaviour fake of interbotix_xs_modules/xs_robot/core.py: InterbotixRobotXSCore, the ROS plumbing to the xs_sdk.

Modelled (tests/vendor/facts.py: constructor_blocks, float32_assert):
- the constructor takes the process-global node (a second one is refused, see robot.py), waits for the driver's
  set_operating_modes service in 5 s steps while rclpy.ok(), then for its other services without a timeout, then
  spins until a joint state arrives while rclpy.ok(): no bound at all while ROS is up;
- every robot_* call is one service request (waited for until it completes) or one published message, built from
  the caller's values unconverted, so the messages' type assertions see exactly what the caller passed.
"""

from __future__ import annotations

import copy
import threading

import rclpy
from interbotix_common_modules.common_robot.robot import InterbotixRobotNode, create_interbotix_global_node
from interbotix_xs_msgs.msg import JointGroupCommand, JointSingleCommand, JointTrajectoryCommand
from interbotix_xs_msgs.srv import MotorGains, OperatingModes, Reboot, RegisterValues, RobotInfo, TorqueEnable
from rclpy.logging import LoggingSeverity, set_logger_level
from sensor_msgs.msg import JointState

_SERVICES = (("srv_set_op_modes", OperatingModes, "set_operating_modes"),
             ("srv_set_pids", MotorGains, "set_motor_pid_gains"),
             ("srv_set_reg", RegisterValues, "set_motor_registers"),
             ("srv_get_reg", RegisterValues, "get_motor_registers"),
             ("srv_get_info", RobotInfo, "get_robot_info"),
             ("srv_torque", TorqueEnable, "torque_enable"),
             ("srv_reboot", Reboot, "reboot_motors"))


class InterbotixRobotXSCore:
    def __init__(self, robot_model: str, robot_name: str | None = None, topic_joint_states: str = "joint_states",
                 logging_level: LoggingSeverity = LoggingSeverity.INFO,
                 node_name: str = "interbotix_robot_manipulation", node: InterbotixRobotNode | None = None,
                 args=None) -> None:
        self.robot_model, self.node_name = robot_model, node_name
        self.robot_name = robot_model if robot_name is None else robot_name
        self.ns = f"/{self.robot_name}" if self.robot_name else ""
        self.robot_node = create_interbotix_global_node() if node is None else node
        set_logger_level(node_name, logging_level)
        self.topic_joint_states = topic_joint_states
        self.joint_states: JointState | None = None
        self.js_mutex = threading.Lock()
        for attribute, srv_type, name in _SERVICES:
            setattr(self, attribute, self.robot_node.create_client(srv_type=srv_type, srv_name=f"{self.ns}/{name}"))
        first, *others = (getattr(self, attribute) for attribute, _, _ in _SERVICES)
        while not first.wait_for_service(timeout_sec=5.0) and rclpy.ok():
            self.robot_node.get_logger().error(f"Failed to find services under namespace '{self.ns}'")
        for client in others:
            client.wait_for_service()
        create = self.robot_node.create_publisher
        self.pub_group = create(msg_type=JointGroupCommand, topic=f"{self.ns}/commands/joint_group", qos_profile=10)
        self.pub_single = create(msg_type=JointSingleCommand, topic=f"{self.ns}/commands/joint_single",
                                 qos_profile=10)
        self.pub_traj = create(msg_type=JointTrajectoryCommand, topic=f"{self.ns}/commands/joint_trajectory",
                               qos_profile=10)
        self.sub_joint_states = self.robot_node.create_subscription(
            msg_type=JointState, topic=f"{self.ns}/{topic_joint_states}", callback=self._joint_state_cb,
            qos_profile=10)
        while self.joint_states is None and rclpy.ok():
            rclpy.spin_once(self.robot_node)
        self.js_index_map = {name: i for i, name in enumerate(self.joint_states.name)}

    def get_node(self) -> InterbotixRobotNode:
        return self.robot_node

    def _request(self, client, request):
        future = client.call_async(request)
        self.robot_node.wait_until_future_complete(future)
        return future.result()

    def robot_set_motor_registers(self, cmd_type: str, name: str, reg: str, value: int) -> None:
        self._request(self.srv_set_reg, RegisterValues.Request(cmd_type=cmd_type, name=name, reg=reg, value=value))

    def robot_get_motor_registers(self, cmd_type: str, name: str, reg: str) -> list[int]:
        return self._request(self.srv_get_reg, RegisterValues.Request(cmd_type=cmd_type, name=name, reg=reg)).values

    def robot_get_robot_info(self, cmd_type: str, name: str):
        return self._request(self.srv_get_info, RobotInfo.Request(cmd_type=cmd_type, name=name))

    def robot_torque_enable(self, cmd_type: str, name: str, enable: bool) -> None:
        self._request(self.srv_torque, TorqueEnable.Request(cmd_type=cmd_type, name=name, enable=enable))

    def robot_reboot_motors(self, cmd_type: str, name: str, enable: bool, smart_reboot: bool = False):
        self._request(self.srv_reboot, Reboot.Request(cmd_type=cmd_type, name=name, enable=enable,
                                                      smart_reboot=smart_reboot))

    def robot_write_commands(self, group_name: str, commands: list[float]) -> None:
        self.pub_group.publish(JointGroupCommand(name=group_name, cmd=commands))

    def robot_write_joint_command(self, joint_name: str, command: float) -> None:
        self.pub_single.publish(JointSingleCommand(name=joint_name, cmd=command))

    def robot_get_joint_states(self) -> JointState:
        with self.js_mutex:
            return copy.deepcopy(self.joint_states)

    def _joint_state_cb(self, msg: JointState) -> None:
        with self.js_mutex:
            self.joint_states = msg
