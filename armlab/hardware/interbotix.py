"""The real Interbotix RX200 through the manufacturer's ROS 2 Python API, behind armlab.station.contract.Arm.

Safety, in the order a move is handled:
- Every move is checked BEFORE anything is sent (armlab.motion_safety.check_move with the real arm's floors,
  the simulator's too): position limits of armlab.robot.rx200(), the driver's velocity rule
  (armlab.profile.velocity_violations), a valid time profile (moving time at most MAX_MOVING_TIME_S = 32.737 s, the
  servos' Profile_Velocity limit), and the board clearance of the links, the pads (at the measured finger
  opening) and the blocks the arm holds (held_blocks, as the task layer's executor recorded them at the grasp: the
  arm knows what it holds, whatever sends the next command) along the straight joint-space path. A refused move raises
  MotionRefused naming the reason and sends nothing.
- Moving time defaults to armlab.profile.default_moving_time and accel time to ACCEL_FRACTION x moving time.
  The trajectory time is set before set_joint_positions because the driver checks velocities against its stored
  moving time and its last command, not the new ones; if the driver still refuses, MotionRefused says so.
- Moves are sent non-blocking (set_joint_positions(blocking=False)); armlab waits on an event that
  emergency_stop() sets. The check-then-publish of a move, the hold and the register writes run under one lock, and
  emergency_stop() marks the arm stopped before taking it: a stop from another thread (the state machine's) either
  prevents the move's goal from being published or sends its hold after it, never before.
- Emergency stop: torque is NOT cut (the arm would fall onto the board). emergency_stop() commands the measured
  position (the arm stops within HOLD_TIME_S and holds there under torque) and every further motion, gripper
  included, raises EmergencyStopped until reset(). The gripper keeps its state (a held block is not dropped).
  Closing the station while stopped leaves the arm holding where it is (it is not moved to sleep) and warns.
- Ctrl+C: armlab.station.interrupt calls hold() (the measured position, not an e-stop), then KeyboardInterrupt.
- Teaching: set_torque(False) lets the arm be moved by hand (it warns: the arm falls unless supported) and
  joint_positions() reads it; moves are refused until set_torque(True), which first commands the measured position.
- Servo reboots (reboot_motors) reset the servos' RAM registers: Profile_Velocity 0 means no profile at all. The
  vendor writes the profile registers only when a value differs from its Python-side cache (arm.moving_time,
  arm.accel_time), so armlab writes both registers itself after every reboot and at connect, and sets that cache to
  the values written.
- Connect checks the driver's modes: the arm group in 'position' mode with the 'time' profile (with a velocity
  profile moving_time would mean something else), the gripper in 'pwm' or 'current' mode.
- Shutdown (see connect_arm and armlab.hardware.ros_session): the arm goes to its sleep pose; robot_shutdown() runs
  once per process, at exit, after that.

Holding detection: after grasp(), the measured left finger position (the gripper's joint state 'left_finger',
metres from the gripper centre) is compared with the driver's fully-closed limit (gripper.left_finger_lower_limit):
the fingers stopped more than HELD_THRESHOLD_MM before fully closed means something is held. Fingers still within
HELD_THRESHOLD_MM of fully open (gripper.left_finger_upper_limit) after grasp() mean the gripper did not close at all
(no power, wrong operating mode, or a 2022 release of xs_robot/gripper.py, whose grasp() and release() are swapped):
close_gripper() raises RuntimeError saying so rather than report a block that is not there.

The vendor calls (Interbotix/interbotix_ros_toolboxes, branch humble: xs_robot/arm.py, core.py, gripper.py,
interbotix_common_modules/common_robot/robot.py; tests/test_hardware_vendor.py runs this module through those files
at a pinned commit and through a behaviour fake of them that is checked against them, tests/vendor/facts.py lists
the vendor facts relied on):
    InterbotixManipulatorXS(robot_model, group_name, gripper_name, robot_name, moving_time, accel_time,
                            gripper_pressure); robot_startup(); robot_shutdown()
    bot.arm.set_trajectory_time(moving_time, accel_time); bot.arm.set_joint_positions(joint_positions, moving_time,
        accel_time, blocking) -> bool; bot.arm.capture_joint_positions(); bot.arm.get_joint_commands();
        bot.arm.group_info (joint_names, mode, profile_type); bot.arm.moving_time / accel_time (its register cache)
    bot.gripper.grasp(delay); bot.gripper.release(delay); bot.gripper.set_pressure(pressure);
        bot.gripper.gripper_info.mode; bot.gripper.left_finger_lower_limit / _upper_limit (m)
    bot.core.robot_get_joint_states() -> JointState; bot.core.robot_torque_enable(cmd_type, name, enable);
        bot.core.robot_write_commands(group_name, commands); bot.core.robot_reboot_motors(cmd_type, name, enable,
        smart_reboot); bot.core.robot_set_motor_registers(cmd_type, name, reg, value)
Every value put into a ROS message is a Python float (rosidl asserts the type of float32 fields). Measured joints come
from core.robot_get_joint_states() (arm.get_joint_positions() exists only in 2024-11 and later toolboxes). Only ROS 2
is supported: the ROS 1 API (bot.dxl, no robot_startup) and a ROS 2 toolbox older than robot_startup() (2024) are
refused with a clear message.
Units: rad, s, mm in every public method.
"""

from __future__ import annotations

import importlib.util
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from armlab import motion_safety
from armlab.gripper_geometry import GRIPPER
from armlab.hardware import HardwareUnavailable
from armlab.hardware.ros_session import DRIVER_TIMEOUT_S, RosApi, get_bot
from armlab.hardware.safety import DEFAULT_BOARD_MARGIN_MM, clearance, pad_opening_mm
from armlab.profile import MIN_MOVING_TIME_S
from armlab.robot import RobotModel, rx200
from armlab.station.contract import EmergencyStopped, MotionRefused, StationClosed
from armlab.station.parking import park_and_close

__all__ = ["HELD_THRESHOLD_MM", "HOLD_TIME_S", "import_interbotix", "RealArm", "connect_arm", "park"]

HELD_THRESHOLD_MM = 2.0          # fingers stopped > 2 mm short of fully closed -> holding something
HOLD_TIME_S = MIN_MOVING_TIME_S  # moving time of the stop-and-hold command (accel = half of it)
GROUP = "arm"
FINGER_JOINT = "left_finger"

INSTALL_HINT = ("the Interbotix ROS 2 Python API (interbotix_xs_modules.xs_robot, "
                "interbotix_common_modules.common_robot) is not importable: install the Interbotix X-Series arm "
                "packages for ROS 2 (the lab's interbotix_ws, e.g. with Trossen's xsarm_amd64_install.sh "
                "-d humble), then `source /opt/ros/humble/setup.bash && source ~/interbotix_ws/install/setup.bash` "
                "in the shell that starts Python, and launch the driver: `ros2 launch interbotix_xsarm_control "
                "xsarm_control.launch.py robot_model:=rx200`")
OLD_ROS2_HINT = ("found interbotix_xs_modules.xs_robot but not interbotix_common_modules.common_robot.robot "
                 "(robot_startup/robot_shutdown, added to interbotix_ros_toolboxes in 2024): update the toolbox "
                 "(git pull in ~/interbotix_ws/src/interbotix_ros_toolboxes, then colcon build)")
ROS1_HINT = ("found the ROS 1 Interbotix API (interbotix_xs_modules.arm, bot.dxl, no robot_startup), which armlab "
             "does not support: install the ROS 2 packages (Humble or later) and source their setup.bash instead")


def _has_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def import_interbotix() -> RosApi:
    """The vendor callables from the ROS 2 API (InterbotixManipulatorXS, robot_startup, robot_shutdown, rclpy).

    Raises HardwareUnavailable saying what to install when it is missing, or that ROS 1 is not supported.
    """
    try:
        import rclpy
        from interbotix_common_modules.common_robot.robot import robot_shutdown, robot_startup
        from interbotix_xs_modules.xs_robot.arm import InterbotixManipulatorXS
        from interbotix_xs_msgs.srv import RobotInfo
        from rclpy.signals import SignalHandlerOptions, uninstall_signal_handlers
    except ImportError as e:
        if _has_module("interbotix_xs_modules.arm"):
            raise HardwareUnavailable(ROS1_HINT) from e
        if _has_module("interbotix_xs_modules.xs_robot.arm"):
            raise HardwareUnavailable(f"{OLD_ROS2_HINT} ({e})") from e
        raise HardwareUnavailable(f"{INSTALL_HINT} ({e})") from e
    return RosApi(InterbotixManipulatorXS, robot_startup, robot_shutdown, rclpy, SignalHandlerOptions.NO,
                  uninstall_signal_handlers, RobotInfo)


def check_driver_modes(bot: Any) -> None:
    """RuntimeError unless the arm group runs 'position' mode with a 'time' profile and the gripper 'pwm' or
    'current' mode (the driver's motor config, e.g. interbotix_xsarm_control/config/modes.yaml)."""
    info = bot.arm.group_info
    problems = []
    if getattr(info, "mode", None) != "position" or getattr(info, "profile_type", None) != "time":
        problems.append(f"the arm group runs mode {getattr(info, 'mode', None)!r} with profile "
                        f"{getattr(info, 'profile_type', None)!r}, armlab needs 'position' with 'time' (moving_time "
                        "would mean something else)")
    gripper_mode = getattr(getattr(bot.gripper, "gripper_info", None), "mode", None)
    if gripper_mode not in ("pwm", "current"):
        problems.append(f"the gripper runs mode {gripper_mode!r}, armlab needs 'pwm' or 'current'")
    if problems:
        raise RuntimeError("the xs_sdk driver is configured wrongly: " + "; ".join(problems) + ". Launch it with "
                           "the stock modes (`ros2 launch interbotix_xsarm_control xsarm_control.launch.py "
                           "robot_model:=rx200` without a custom mode_configs file)")


class RealArm:
    """The RX200 behind the Arm protocol (see the module docstring for the safety rules).

    Args:
        bot: a started InterbotixManipulatorXS (its .arm, .gripper and .core are used).
        robot: the kinematic model whose limits are enforced (default rx200()).
        board_margin_mm: height above the board every joint and the tool point must keep along a move.
        grasp_delay_s: how long grasp()/release() drive the fingers before the position is read.
        held_threshold_mm: see HELD_THRESHOLD_MM.
        clock: monotonic time source (s). sleep: how to wait dt s for a move to end; default: wait on the stop
            event, which emergency_stop() and hold() set (replaceable for tests).
    """

    def __init__(self, bot: Any, robot: RobotModel | None = None,
                 board_margin_mm: float = DEFAULT_BOARD_MARGIN_MM, grasp_delay_s: float = 1.0,
                 held_threshold_mm: float = HELD_THRESHOLD_MM, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] | None = None):
        self.robot = robot or rx200()
        self._bot = bot
        names = tuple(bot.arm.group_info.joint_names)
        if names != self.robot.joint_names:
            raise RuntimeError(f"the driver's arm group has joints {names}, expected {self.robot.joint_names}: "
                               "is the driver running robot_model:=rx200?")
        check_driver_modes(bot)
        self.board_margin_mm = float(board_margin_mm)
        self.grasp_delay_s = float(grasp_delay_s)
        self.held_threshold_mm = float(held_threshold_mm)
        self.finger_closed_mm = 1000.0 * float(bot.gripper.left_finger_lower_limit)
        self.finger_open_mm = 1000.0 * float(bot.gripper.left_finger_upper_limit)
        self._clock = clock
        self._lock = threading.RLock()       # check-then-publish, hold, register writes; re-entrant for SIGINT
        self._stop = threading.Event()       # set by emergency_stop() and hold(): ends a wait for a move
        self._sleep = sleep if sleep is not None else self._stop.wait
        self._move_ends = clock()
        self._estopped = False
        self._torque_on = True
        self._held: tuple[motion_safety.HeldBlock, ...] = ()
        self.closed = False
        with self._lock:
            bot.arm.capture_joint_positions()          # a reused bot: its last command may be stale
            self._write_profile(bot.arm.moving_time, bot.arm.accel_time)

    # --- reading -------------------------------------------------------------------------------------------------
    def _joint_state(self) -> dict[str, float]:
        js = self._bot.core.robot_get_joint_states()
        if js is None:
            raise RuntimeError("no joint states from the xs_sdk driver yet: is `ros2 launch interbotix_xsarm_control "
                               "xsarm_control.launch.py robot_model:=rx200` running?")
        return dict(zip(js.name, js.position))

    def joint_positions(self) -> np.ndarray:
        """Measured joint positions (5,) rad (also while torque is off, for teaching by hand)."""
        return self._arm_joints(self._joint_state())

    def _arm_joints(self, state: dict[str, float]) -> np.ndarray:
        missing = [n for n in self.robot.joint_names if n not in state]
        if missing:
            raise RuntimeError(f"the driver's joint states lack {missing}")
        return np.array([state[n] for n in self.robot.joint_names], dtype=float)

    def finger_position_mm(self) -> float:
        """Measured left finger position (mm from the gripper centre)."""
        state = self._joint_state()
        if FINGER_JOINT not in state:
            raise RuntimeError(f"the driver's joint states lack the gripper finger {FINGER_JOINT!r}")
        return 1000.0 * float(state[FINGER_JOINT])

    @property
    def emergency_stopped(self) -> bool:
        """True between emergency_stop() and reset()."""
        return self._estopped

    @property
    def gripper_opening_mm(self) -> float:
        """The gap between the pads (mm), from the measured finger position."""
        return pad_opening_mm(self.finger_position_mm())

    @property
    def held_blocks(self) -> tuple[motion_safety.HeldBlock, ...]:
        """What the arm holds, as the task layer told it (set_held_blocks); () after open_gripper()."""
        return self._held

    def set_held_blocks(self, blocks) -> None:
        """Record the blocks between the pads (motion_safety.HeldBlock: edge mm, pose in the tool frame, as the task
        layer's executor recorded them at the grasp): every later move checks them against the board like the pads,
        on the commanded angles, before anything is sent. The driver cannot see a block: this is how the arm knows."""
        blocks = tuple(blocks)
        if not all(isinstance(b, motion_safety.HeldBlock) for b in blocks):
            raise TypeError("set_held_blocks takes motion_safety.HeldBlock values (edge mm, T_tool_block (4, 4) mm)")
        self._held = blocks

    @property
    def torque_enabled(self) -> bool:
        """True when the motors hold the arm (False while it is torqued off for teaching)."""
        return self._torque_on

    # --- motion --------------------------------------------------------------------------------------------------
    def _require_open(self) -> None:
        if self.closed:
            raise StationClosed("the station is closed: open a new one with make_station('real')")

    def _require_motion_allowed(self) -> None:
        self._require_open()
        if self._estopped:
            raise EmergencyStopped("the arm is emergency-stopped (holding position): call reset() before moving it")
        if not self._torque_on:
            raise MotionRefused("move refused (nothing was sent): torque is off for teaching; call set_torque(True)")

    def move_to(self, q, moving_time: float | None = None, accel_time: float | None = None,
                blocking: bool = True) -> None:
        """Move to q (5,) rad with the time-based profile (default times: see module docstring).

        Waits for a running non-blocking move to end first. Raises MotionRefused (nothing sent) or EmergencyStopped
        (also when the stop comes while a blocking move runs).
        """
        self._require_motion_allowed()
        self.wait()
        with self._lock:
            self._require_motion_allowed()
            state = self._joint_state()
            q_now = self._arm_joints(state)
            opening = pad_opening_mm(1000.0 * float(state[FINGER_JOINT])) if FINGER_JOINT in state else None
            moving_time, accel_time = motion_safety.check_move(q_now, q, moving_time, accel_time, self.robot,
                                                               clearance(self.board_margin_mm), GRIPPER, opening,
                                                               self._held)
            arm = self._bot.arm
            arm.set_trajectory_time(moving_time, accel_time)
            self._require_motion_allowed()        # a stop that came during the register writes wins
            self._stop.clear()
            sent = arm.set_joint_positions([float(x) for x in np.asarray(q, float)], moving_time=moving_time,
                                           accel_time=accel_time, blocking=False)
            if not sent:
                raise MotionRefused("move refused by the Interbotix driver (nothing was sent): its joint or velocity "
                                    "limits, which it checks against its last command rather than the measured "
                                    "position")
            self._move_ends = self._clock() + moving_time
        if blocking:
            self.wait()
            if self._estopped:
                raise EmergencyStopped("the arm was emergency-stopped during the move (holding position)")

    def is_moving(self) -> bool:
        """True while a move is under way (until its moving time has passed or a stop/hold ended it)."""
        return self._clock() < self._move_ends

    def wait(self) -> None:
        """Block until the current move's moving time has passed, or until emergency_stop()/hold() ends it."""
        remaining = self._move_ends - self._clock()
        if remaining > 0:
            self._sleep(remaining)

    def home(self, moving_time: float | None = None) -> None:
        """Move to the home pose (all zeros), with every check of move_to."""
        self.move_to(self.robot.home, moving_time)

    def sleep(self, moving_time: float | None = None) -> None:
        """Move to the sleep pose (safe to power off), with every check of move_to."""
        self.move_to(self.robot.sleep, moving_time)

    # --- gripper -------------------------------------------------------------------------------------------------
    def open_gripper(self) -> None:
        """Open the gripper (releasing anything held); refused while emergency-stopped or closed."""
        self._require_open()
        if self._estopped:
            raise EmergencyStopped("the arm is emergency-stopped: call reset() before using the gripper")
        self._bot.gripper.release(float(self.grasp_delay_s))
        self._held = ()

    def close_gripper(self) -> bool:
        """Close the gripper; True when the fingers stopped more than held_threshold_mm before fully closed.

        Raises RuntimeError when the fingers are still (nearly) fully open afterwards: the gripper did not close.
        """
        self._require_open()
        if self._estopped:
            raise EmergencyStopped("the arm is emergency-stopped: call reset() before using the gripper")
        self._bot.gripper.grasp(float(self.grasp_delay_s))
        finger = self.finger_position_mm()
        if finger >= self.finger_open_mm - self.held_threshold_mm:
            raise RuntimeError(f"gripper.grasp() did not close the gripper: the left finger is at {finger:.1f} mm, "
                               f"fully open is {self.finger_open_mm:.1f} mm. Check that the gripper is powered and "
                               "in 'pwm' or 'current' mode; 2022 releases of interbotix_xs_modules "
                               "(xs_robot/gripper.py) have grasp() and release() swapped: update "
                               "interbotix_ros_toolboxes")
        return finger > self.finger_closed_mm + self.held_threshold_mm

    # --- torque, stop, reset -------------------------------------------------------------------------------------
    def _write_profile(self, moving_time: float, accel_time: float) -> None:
        """Write Profile_Velocity / Profile_Acceleration (ms) to the arm group and set the vendor's cache to match
        (the vendor skips a register write when its cache already holds the value)."""
        core, arm = self._bot.core, self._bot.arm
        core.robot_set_motor_registers("group", GROUP, "Profile_Velocity", int(round(float(moving_time) * 1000)))
        core.robot_set_motor_registers("group", GROUP, "Profile_Acceleration", int(round(float(accel_time) * 1000)))
        arm.moving_time, arm.accel_time = float(moving_time), float(accel_time)

    def _hold(self) -> None:
        """Command the measured position (the driver's last command is re-synchronised to it first)."""
        with self._lock:
            arm = self._bot.arm
            arm.capture_joint_positions()
            arm.set_trajectory_time(HOLD_TIME_S, HOLD_TIME_S / 2)
            self._bot.core.robot_write_commands(GROUP, [float(x) for x in arm.get_joint_commands()])
            self._move_ends = self._clock()

    def hold(self) -> None:
        """Stop the current move and hold the measured position (not an emergency stop: moves stay allowed)."""
        self._stop.set()
        with self._lock:
            if self._torque_on and not self.closed:
                self._hold()
            self._move_ends = self._clock()

    def set_torque(self, enabled: bool) -> None:
        """Torque on (holding the measured position: no jump back) or off (move the arm by hand to teach).

        Torque off warns: the arm falls onto the board unless someone holds it.
        """
        self._require_open()
        core = self._bot.core
        with self._lock:
            if enabled:
                if not self._torque_on:
                    self._hold()
                core.robot_torque_enable("group", GROUP, True)
                self._torque_on = True
            else:
                warnings.warn("torque off: the arm falls unless supported; hold it before this call",
                              RuntimeWarning, stacklevel=2)
                self._stop.set()
                core.robot_torque_enable("group", GROUP, False)
                self._torque_on = False
                self._move_ends = self._clock()

    def emergency_stop(self) -> None:
        """Stop now and hold the measured position under torque; motion raises EmergencyStopped until reset().

        Safe from any thread: the stop is marked before the lock is taken, so a move being sent either sees it and
        publishes nothing, or has published and the hold goes out after it."""
        self._estopped = True
        self._stop.set()
        with self._lock:
            if self._torque_on:
                self._hold()
            self._move_ends = self._clock()

    def reboot_motors(self, gripper: bool = False) -> None:
        """Reboot the arm's servos that are in an error state (e.g. an overload after a collision: their LEDs blink
        and they stop answering), torque them on again, rewrite their profile registers (a reboot resets them to 0,
        which means no profile) and hold the measured position. gripper=True also reboots the gripper's servo (it
        lets go of a held block while it restarts).

        Refused while emergency-stopped (reset() first) or torqued off for teaching.
        """
        self._require_motion_allowed()
        core = self._bot.core
        with self._lock:
            core.robot_reboot_motors("group", GROUP, True, smart_reboot=True)
            if gripper:
                core.robot_reboot_motors("single", "gripper", True)
            self._write_profile(HOLD_TIME_S, HOLD_TIME_S / 2)
            self._hold()

    def reset(self) -> None:
        """Leave the emergency stop: the arm stays where it is, torque on, the driver's command re-synchronised."""
        self._require_open()
        with self._lock:
            if self._torque_on:
                self._bot.arm.capture_joint_positions()
            else:
                self.set_torque(True)
            self._estopped = False


def park(arm: RealArm) -> None:
    """Put the arm to sleep (torque on first if it was off) and close it (armlab.station.parking); ROS stays up
    (armlab.hardware.ros_session shuts it down at exit). While emergency-stopped the arm is not moved (it keeps holding
    its position) and a RuntimeWarning says so. A refused or failed sleep move raises RuntimeError telling to put the
    arm down by hand."""
    park_and_close(arm, "the arm", "; support it before powering it off")


def connect_arm(robot_name: str | None = None, gripper_pressure: float = 0.5,
                driver_timeout_s: float = DRIVER_TIMEOUT_S, **arm_options) -> tuple[RealArm, Callable[[], None]]:
    """The RX200 on the process's Interbotix session (started on first use: armlab.hardware.ros_session); return
    (RealArm, closer). The closer = park (ROS stays up for the next station; it shuts down at exit).

    gripper_pressure: 0..1 (sent as a float). driver_timeout_s: how long to wait for the xs_sdk driver (see
    armlab.hardware.ros_session.construct_bot for the constructor's own bound).
    arm_options go to RealArm (board_margin_mm, grasp_delay_s, held_threshold_mm).
    """
    if not 0.0 <= gripper_pressure <= 1.0:
        raise ValueError(f"gripper_pressure must lie in [0, 1], got {gripper_pressure}")
    bot = get_bot(import_interbotix(), robot_name, float(gripper_pressure), driver_timeout_s)
    arm = RealArm(bot, **arm_options)
    return arm, lambda: park(arm)
