"""Behaviour fake of interbotix_xs_modules/xs_robot/arm.py: InterbotixManipulatorXS and InterbotixArmXSInterface.

Modelled (tests/vendor/facts.py: register_cache, publish_after_register_writes, limit_check_uses_cached_time,
mode_only_warned, float32_assert):
- the arm keeps a Python-side cache of the profile registers (moving_time, accel_time, s), set from the
  constructor's arguments without writing anything; set_trajectory_time() writes Profile_Velocity /
  Profile_Acceleration (int ms, to the whole group, one blocking service call each) only for a value that differs
  from the cache, and updates the cache before the call;
- set_joint_positions() checks the goal (truncated to 1 mrad) against the joint limits and against the velocity
  limits for |goal - last command| / the CACHED moving time, returns False (nothing sent) when it fails, else
  writes the registers as above and only then publishes the JointGroupCommand (the positions unconverted), and
  sleeps the moving time on the node's clock only when blocking;
- the last command is the last published goal; capture_joint_positions() resets it to the measured positions;
- a group not in 'position' mode with the 'time' profile only gets a log warning.
Not modelled (armlab does not use them): poses, trajectories, single-joint commands, the kinematic model.
"""

from __future__ import annotations

import rclpy
from interbotix_common_modules.common_robot.robot import InterbotixRobotNode
from interbotix_xs_modules.xs_robot.core import InterbotixRobotXSCore
from interbotix_xs_modules.xs_robot.gripper import InterbotixGripperXSInterface
from interbotix_xs_msgs.msg import JointGroupCommand
from interbotix_xs_msgs.srv import RegisterValues, RobotInfo
from rclpy.constants import S_TO_NS
from rclpy.duration import Duration
from rclpy.logging import LoggingSeverity


class InterbotixManipulatorXS:
    def __init__(self, robot_model: str, group_name: str = "arm", gripper_name: str = "gripper",
                 robot_name: str = None, moving_time: float = 2.0, accel_time: float = 0.3,
                 gripper_pressure: float = 0.5, gripper_pressure_lower_limit: int = 150,
                 gripper_pressure_upper_limit: int = 350, topic_joint_states: str = "joint_states",
                 logging_level: LoggingSeverity = LoggingSeverity.INFO, node_name: str = "robot_manipulation",
                 node: InterbotixRobotNode = None, iterative_update_fk: bool = True, args=None) -> None:
        self.core = InterbotixRobotXSCore(robot_model=robot_model, robot_name=robot_name,
                                          topic_joint_states=topic_joint_states, logging_level=logging_level,
                                          node_name=node_name, node=node, args=args)
        self.arm = InterbotixArmXSInterface(self.core, robot_model, group_name, moving_time, accel_time,
                                            iterative_update_fk)
        if gripper_name is not None:
            self.gripper = InterbotixGripperXSInterface(self.core, gripper_name, gripper_pressure,
                                                        gripper_pressure_lower_limit, gripper_pressure_upper_limit)
        self.robot_name = robot_name

    def get_node(self) -> InterbotixRobotNode:
        return self.core.robot_node


class InterbotixArmXSInterface:
    def __init__(self, core: InterbotixRobotXSCore, robot_model: str, group_name: str, moving_time: float = 2.0,
                 accel_time: float = 0.3, iterative_update_fk: bool = True) -> None:
        self.core, self.robot_model, self.group_name = core, robot_model, group_name
        self.moving_time, self.accel_time = moving_time, accel_time        # the register cache
        self.iterative_update_fk = iterative_update_fk
        info = core.srv_get_info.call_async(RobotInfo.Request(cmd_type="group", name=group_name))
        while rclpy.ok() and not info.done():
            rclpy.spin_until_future_complete(core.get_node(), info)
            rclpy.spin_once(core.get_node())
        self.group_info = info.result()
        logger = core.get_node().get_logger()
        if self.group_info.profile_type != "time":
            logger.warn(f"Group '{group_name}' profile_type not set to 'time'.")
        if self.group_info.mode != "position":
            logger.warn(f"Group '{group_name}' operating mode not set to 'position'.")
        self.capture_joint_positions()
        self.set_trajectory_time(self.moving_time, self.accel_time)      # equal to the cache: writes nothing
        self.info_index_map = {name: i for i, name in enumerate(self.group_info.joint_names)}

    def set_trajectory_time(self, moving_time: float = None, accel_time: float = None) -> None:
        for register, attribute, value in (("Profile_Velocity", "moving_time", moving_time),
                                           ("Profile_Acceleration", "accel_time", accel_time)):
            if value is None or value == getattr(self, attribute):
                continue
            setattr(self, attribute, value)
            future = self.core.srv_set_reg.call_async(RegisterValues.Request(
                cmd_type="group", name=self.group_name, reg=register, value=int(value * 1000)))
            self.core.get_node().wait_until_future_complete(future)

    def _check_joint_limits(self, positions: list[float]) -> bool:
        info = self.group_info
        for i, (goal, last) in enumerate(zip(positions, self.joint_commands, strict=False)):   # vendor: no length check
            goal = int(goal * 1000) / 1000.0
            if not info.joint_lower_limits[i] <= goal <= info.joint_upper_limits[i]:
                return False
            if abs(goal - last) / float(self.moving_time) > info.joint_velocity_limits[i]:
                return False
        return True

    def _publish_commands(self, positions: list[float], moving_time: float = None, accel_time: float = None,
                          blocking: bool = True) -> None:
        self.set_trajectory_time(moving_time, accel_time)
        self.joint_commands = list(positions)
        self.core.pub_group.publish(JointGroupCommand(name=self.group_name, cmd=self.joint_commands))
        if blocking:
            self.core.get_node().get_clock().sleep_for(Duration(nanoseconds=int(self.moving_time * S_TO_NS)))

    def set_joint_positions(self, joint_positions: list[float], moving_time: float = None, accel_time: float = None,
                            blocking: bool = True) -> bool:
        if not self._check_joint_limits(joint_positions):
            return False
        self._publish_commands(joint_positions, moving_time, accel_time, blocking)
        return True

    def get_joint_commands(self) -> list[float]:
        return list(self.joint_commands)

    def capture_joint_positions(self) -> None:
        state, index = self.core.joint_states, self.core.js_index_map
        self.joint_commands = [state.position[index[name]] for name in self.group_info.joint_names]

    def get_joint_positions(self) -> list[float]:
        with self.core.js_mutex:
            state, index = self.core.joint_states, self.core.js_index_map
            return [state.position[index[name]] for name in self.group_info.joint_names]
