"""The vendor facts the real-arm tests rely on, each pinned to a file at a commit (git blob id recorded).

tests/test_hardware_vendor.py loads the Interbotix Python files below, unmodified, at TOOLBOXES_COMMIT (through
tests/vendor/sources.py, never from this repository) and runs armlab.hardware through them over the fake ROS layer of
tests/vendor/ros.py; it runs the same tests through the behaviour fake of tests/vendor/behaviour/, which models the
toolbox facts listed here (and is compared with the vendor files call by call where they are cached). The fake ROS
layer models the rclpy, rosidl and xs_sdk facts. test_vendor_facts_hold_in_the_pinned_files checks each `evidence`
pattern against the pinned file whenever that file is available.
"""

from __future__ import annotations

from dataclasses import dataclass

TOOLBOXES = "Interbotix/interbotix_ros_toolboxes"
TOOLBOXES_COMMIT = "8ae347e163506c19e9df16c1fa868e426c08eea6"        # branch humble, 2024-12-19
RCLPY = "ros2/rclpy"
RCLPY_COMMIT = "b488272b1ba88c703080bfd605417f013697ee40"            # branch humble
ROSIDL_PYTHON = "ros2/rosidl_python"
ROSIDL_PYTHON_COMMIT = "2507d5dbc1aebe2254d9eac088f007dcaea2ff03"    # branch humble
ROS_CORE = "Interbotix/interbotix_ros_core"
ROS_CORE_COMMIT = "6da9a7c79508835cad17422059dbe70dc3965cc0"         # branch humble
XS_DRIVER = "Interbotix/interbotix_xs_driver"
XS_DRIVER_COMMIT = "c9ce74e54369197b6e07f5608d86882e4affe283"        # branch ros2

_CM = "interbotix_common_toolbox/interbotix_common_modules/interbotix_common_modules"
_XS = "interbotix_xs_toolbox/interbotix_xs_modules/interbotix_xs_modules/xs_robot"

# the Interbotix Python files the tests execute: module name -> (path in TOOLBOXES, git blob id at the commit)
TOOLBOX_MODULES: dict[str, tuple[str, str]] = {
    "interbotix_common_modules.common_robot.exceptions": (f"{_CM}/common_robot/exceptions.py",
                                                          "e27307ad61de2b8fc2aa562e4ffb0f755c9b6c63"),
    "interbotix_common_modules.common_robot.robot": (f"{_CM}/common_robot/robot.py",
                                                     "1d2afa7fa45d5e01b689f0df65c9a55edd183996"),
    "interbotix_xs_modules.xs_robot.mr_descriptions": (f"{_XS}/mr_descriptions.py",
                                                       "4e8a638c9f6b3619cddefc768eb52e8915e6f9c6"),
    "interbotix_xs_modules.xs_robot.core": (f"{_XS}/core.py", "22a60acee721c9bffeeba20004253cb352d107f1"),
    "interbotix_xs_modules.xs_robot.gripper": (f"{_XS}/gripper.py", "ef3808cc6ac9793dfd5a3e19f9744b8784547a87"),
    "interbotix_xs_modules.xs_robot.arm": (f"{_XS}/arm.py", "52184fec1af51916dc682b4017506ac252c2fc0f"),
}


@dataclass(frozen=True)
class Fact:
    id: str
    repo: str
    commit: str
    path: str
    statement: str
    evidence: str          # a regular expression that matches the pinned file (checked by the tests)


FACTS: tuple[Fact, ...] = (
    Fact("gripper_effort_type", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/gripper.py",
         "gripper_value = lower + pressure * (upper - lower) with int limits 150/350, so an int pressure gives an "
         "int effort, which grasp()/release() put into JointSingleCommand.cmd",
         r"gripper_pressure_lower_limit: int = 150[\s\S]*self\.gripper_command\.cmd = effort"),
    Fact("float32_assert", ROSIDL_PYTHON, ROSIDL_PYTHON_COMMIT, "rosidl_generator_py/resource/_msg.py.em",
         "a float32 field's setter asserts isinstance(value, float): \"The '<name>' field must be of type 'float'\"; "
         "a float32[] field asserts every item is a float",
         r"isinstance\(value, @\(get_python_type\(type_\)\)\), \\\s*\"The '@\(member\.name\)' field must be of type"),
    Fact("single_command_float32", ROS_CORE, ROS_CORE_COMMIT,
         "interbotix_ros_xseries/interbotix_xs_msgs/msg/JointSingleCommand.msg",
         "JointSingleCommand.cmd is float32 (JointGroupCommand.cmd is float32[])", r"float32 cmd"),
    Fact("global_node_persists", TOOLBOXES, TOOLBOXES_COMMIT, f"{_CM}/common_robot/robot.py",
         "create_interbotix_global_node() raises InterbotixException when the module global exists; robot_shutdown() "
         "destroys the node but never removes that global (and its __interbotix_is_up = False is a local)",
         r"^(?=[\s\S]*Tried to create an Interbotix global node but one already exists)"
         r"(?=[\s\S]*node\.destroy_node\(\)\s*rclpy\.shutdown\(\)[\s\S]*__interbotix_is_up = False  # noqa: F841)"),
    Fact("init_if_not_ok", TOOLBOXES, TOOLBOXES_COMMIT, f"{_CM}/common_robot/robot.py",
         "the global node calls rclpy.init() (with default signal handlers) only when rclpy.ok() is False",
         r"if not rclpy\.ok\(\):\s*rclpy\.init\(\*args, \*\*kwargs\)"),
    Fact("shutdown_calls_rclpy_shutdown", TOOLBOXES, TOOLBOXES_COMMIT, f"{_CM}/common_robot/robot.py",
         "robot_shutdown() calls rclpy.shutdown(), which raises when ROS is already shut down",
         r"node\.destroy_node\(\)\s*rclpy\.shutdown\(\)"),
    Fact("default_signal_handlers", RCLPY, RCLPY_COMMIT, "rclpy/rclpy/__init__.py",
         "rclpy.init() with signal_handler_options=None installs SIGINT and SIGTERM handlers for the default context",
         r"if context is get_default_context\(\):\s*signal_handler_options = SignalHandlerOptions\.ALL"),
    Fact("sigint_shuts_contexts", RCLPY, RCLPY_COMMIT, "rclpy/src/rclpy/signal_handler.cpp",
         "rclpy's SIGINT handler chains to the previous handler and shuts every context down",
         r"trigger_guard_conditions\(\);\s*rclpy::shutdown_contexts\(\);"),
    Fact("context_init_once", RCLPY, RCLPY_COMMIT, "rclpy/rclpy/context.py",
         "the default context cannot be initialised again after shutdown",
         r"Context\.init\(\) must only be called once"),
    Fact("constructor_blocks", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/core.py",
         "InterbotixRobotXSCore waits for set_operating_modes in 5 s steps while rclpy.ok(), then for the other "
         "services without a timeout, then spins until a JointState arrives: no timeout at all",
         r"while not self\.srv_set_op_modes\.wait_for_service\(timeout_sec=5\.0\) and rclpy\.ok\(\):[\s\S]*"
         r"self\.srv_set_pids\.wait_for_service\(\)[\s\S]*while self\.joint_states is None and rclpy\.ok\(\):"),
    Fact("register_cache", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/arm.py",
         "set_trajectory_time writes Profile_Velocity / Profile_Acceleration (int ms, group) only when the value "
         "differs from self.moving_time / self.accel_time",
         r"if moving_time is not None and moving_time != self\.moving_time:[\s\S]*reg='Profile_Velocity',\s*"
         r"value=int\(moving_time \* 1000\)"),
    Fact("publish_after_register_writes", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/arm.py",
         "_publish_commands calls set_trajectory_time (blocking service calls) before publishing the goal, and "
         "sleeps moving_time only when blocking",
         r"self\.set_trajectory_time\(moving_time, accel_time\)\s*self\.joint_commands = list\(positions\)"
         r"[\s\S]*self\.core\.pub_group\.publish\(joint_commands\)\s*if blocking:"),
    Fact("limit_check_uses_cached_time", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/arm.py",
         "set_joint_positions checks |goal - last command| / the cached self.moving_time against the velocity limits "
         "(goals truncated to 1 mrad) before _publish_commands sets the new trajectory time, and returns False "
         "without sending anything when the check fails",
         r"speed_list = \[\s*abs\(goal - current\) / float\(self\.moving_time\)[\s\S]*"
         r"if self\._check_joint_limits\(joint_positions\):\s*self\._publish_commands\([\s\S]*return False"),
    Fact("startup_once", TOOLBOXES, TOOLBOXES_COMMIT, f"{_CM}/common_robot/robot.py",
         "robot_startup() raises InterbotixException when interbotix_is_up(), which stays True after "
         "robot_shutdown(); it spins the node on a daemon thread 'while rclpy.ok()'",
         r"if interbotix_is_up\(\):\s*raise InterbotixException\('Startup has already been requested\.'\)"
         r"[\s\S]*while rclpy\.ok\(\):\s*__interbotix_executor\.add_node"),
    Fact("gripper_stops_at_limit", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/gripper.py",
         "grasp() publishes -effort and release() +effort only when the left finger is short of that limit, then "
         "sleep delay s; a 0.02 s timer publishes cmd 0.0 once the moving finger reaches it",
         r"timer_period_sec=0\.02, callback=self\.gripper_state[\s\S]*self\.gripper_command\.cmd = float\(0\.0\)"
         r"[\s\S]*self\.gripper_controller\(-self\.gripper_value, delay\)"),
    Fact("wait_returns_on_shutdown", RCLPY, RCLPY_COMMIT, "rclpy/rclpy/client.py",
         "Client.wait_for_service (timeout None: forever) polls every 0.25 s only while the context is ok: shutting "
         "ROS down ends the vendor constructor's waits (armlab.hardware.ros_session.construct_bot relies on it)",
         r"while self\.context\.ok\(\) and not self\.service_is_ready\(\) and timeout_sec > 0\.0:"),
    Fact("joint_count_exit", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/arm.py",
         "the arm interface calls sys.exit(1) when the driver's group has another number of joints than the model "
         "(armlab.hardware.ros_session.construct_bot turns that into a RuntimeError)",
         r"if self\.group_info\.num_joints != self\.robot_des\.Slist\.shape\[1\]:[\s\S]*?sys\.exit\(1\)"),
    Fact("mode_only_warned", TOOLBOXES, TOOLBOXES_COMMIT, f"{_XS}/arm.py",
         "a group whose profile_type is not 'time' or mode not 'position' only gets a log warning",
         r"if self\.group_info\.profile_type != 'time':\s*self\.core\.get_node\(\)\.get_logger\(\)\.warn"),
    Fact("reboot_no_restore", XS_DRIVER, XS_DRIVER_COMMIT, "src/xs_driver.cpp",
         "reboot_motors reboots each servo (dxl_wb.reboot) and only torques it on again: its RAM registers "
         "(Profile_Velocity, Profile_Acceleration) are not written back",
         r"dxl_wb\.reboot\(motor_map\[joint_name\]\.motor_id\);"),
    Fact("profile_zero_infinite", ROS_CORE, ROS_CORE_COMMIT,
         "interbotix_ros_xseries/interbotix_xs_msgs/srv/OperatingModes.srv",
         "in 'time' profile, Profile_Velocity is the moving time in ms and 0 means no limit (no profile)",
         r"'profile_type' is set to 'time', this parameter sets the time span \(in milliseconds\)[\s\S]*"
         r"to have an 'infinite' max limit, set to '0'"),
)
# Not in a repository: the servos' time-based Profile_Velocity holds at most 32737 ms (ROBOTIS e-manual, XM430-W350 /
# XL430-W250 control table, "Profile Velocity(112)"): armlab.hardware.safety.MAX_MOVING_TIME_S.
