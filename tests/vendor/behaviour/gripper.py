"""Behaviour fake of interbotix_xs_modules/xs_robot/gripper.py: InterbotixGripperXSInterface (pwm/current gripper).

Modelled (tests/vendor/facts.py: gripper_effort_type, float32_assert, gripper_stops_at_limit):
- the effort is lower + pressure * (upper - lower) with the int limits 150 and 350, kept as computed: an int
  pressure (0 or 1) gives an int effort, and putting it into the JointSingleCommand raises AssertionError;
- grasp() drives the fingers closed with -effort, release() open with +effort, each only when the fingers are not
  already at that limit, then sleeps `delay` on the node's clock; a 50 Hz timer publishes effort 0.0 once the
  moving fingers reach the limit they were driven to;
- the constructor asks the driver for the gripper's info (its finger limits and mode; a mode other than 'pwm' or
  'current' is only warned about) and sleeps 0.5 s.
"""

from __future__ import annotations

import rclpy
from interbotix_xs_modules.xs_robot.core import InterbotixRobotXSCore
from interbotix_xs_msgs.msg import JointSingleCommand
from interbotix_xs_msgs.srv import RobotInfo
from rclpy.constants import S_TO_NS
from rclpy.duration import Duration


class InterbotixGripperXSInterface:
    def __init__(self, core: InterbotixRobotXSCore, gripper_name: str, gripper_pressure: float = 0.5,
                 gripper_pressure_lower_limit: int = 150, gripper_pressure_upper_limit: int = 350) -> None:
        self.core, self.gripper_name, self.gripper_pressure = core, gripper_name, gripper_pressure
        info = core.srv_get_info.call_async(RobotInfo.Request(cmd_type="single", name=gripper_name))
        self.gripper_moving = False
        self.gripper_command = JointSingleCommand(name=gripper_name)
        self.gripper_pressure_lower_limit = gripper_pressure_lower_limit
        self.gripper_pressure_upper_limit = gripper_pressure_upper_limit
        self.set_pressure(gripper_pressure)
        self.tmr_gripper_state = core.get_node().create_timer(timer_period_sec=0.02, callback=self.gripper_state)
        while rclpy.ok() and not info.done():
            rclpy.spin_until_future_complete(core.get_node(), info)
            rclpy.spin_once(core.get_node())
        self.gripper_info = info.result()
        self.left_finger_index = core.js_index_map[self.gripper_info.joint_names[0]]
        self.left_finger_lower_limit = self.gripper_info.joint_lower_limits[0]
        self.left_finger_upper_limit = self.gripper_info.joint_upper_limits[0]
        if self.gripper_info.mode not in ("current", "pwm"):
            core.get_node().get_logger().warn(f"Motor '{gripper_name}' operating mode not set to 'pwm' or 'current'.")
        core.get_node().get_clock().sleep_for(Duration(nanoseconds=int(0.5 * S_TO_NS)))

    def _finger(self) -> float:
        with self.core.js_mutex:
            return self.core.joint_states.position[self.left_finger_index]

    def _short_of_limit(self, effort, finger: float) -> bool:
        return ((effort > 0 and finger < self.left_finger_upper_limit)
                or (effort < 0 and finger > self.left_finger_lower_limit))

    def _at_limit(self, effort, finger: float) -> bool:
        return ((effort > 0 and finger >= self.left_finger_upper_limit)
                or (effort < 0 and finger <= self.left_finger_lower_limit))

    def gripper_state(self) -> None:
        if self.gripper_moving and self._at_limit(self.gripper_command.cmd, self._finger()):
            self.gripper_command.cmd = 0.0
            self.core.pub_single.publish(self.gripper_command)
            self.gripper_moving = False

    def gripper_controller(self, effort: float, delay: float) -> None:
        self.gripper_command.cmd = effort
        if self._short_of_limit(effort, self._finger()):
            self.core.pub_single.publish(self.gripper_command)
            self.gripper_moving = True
            self.core.get_node().get_clock().sleep_for(Duration(nanoseconds=int(delay * S_TO_NS)))

    def set_pressure(self, pressure: float) -> None:
        span = self.gripper_pressure_upper_limit - self.gripper_pressure_lower_limit
        self.gripper_value = self.gripper_pressure_lower_limit + pressure * span

    def release(self, delay: float = 1.0) -> None:
        self.gripper_controller(self.gripper_value, delay)

    def grasp(self, delay: float = 1.0) -> None:
        self.gripper_controller(-self.gripper_value, delay)
