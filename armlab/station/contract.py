"""The station contract: what every backend (simulated or real) offers, and what the code above it may rely on.

Code above the station (calibration, detection, planning, tasks, notebooks) uses only the types defined here and
never asks which backend it has: what only one backend can do (the simulator's ground truth, its own checkerboard
views, an empty-board twin to fit the sag on) is offered as a Capability (Station.capabilities), None when absent.
The backends (armlab.sim, armlab.hardware) import this module and nothing that builds stations
(armlab.station.registry builds them). Units: mm, rad, s. Images: RGB uint8 (H, W, 3); depth float32 (H, W) mm
(camera-frame Z, NaN where there is no return), aligned to the colour image.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from armlab.robot import RobotModel

__all__ = ["Frame", "Arm", "RGBDCamera", "GroundTruth", "Capabilities", "Pacing", "SagReference", "Station",
           "MotionRefused", "EmergencyStopped", "StationClosed"]


class MotionRefused(ValueError):
    """A move was refused before anything moved; the message says why (joint limit, velocity limit, collision)."""


class EmergencyStopped(RuntimeError):
    """The arm is emergency-stopped: it refuses motion until `reset()` re-initialises it. Also raised by a blocking
    move that a stop ended part-way (the arm holds where it stopped)."""


class StationClosed(RuntimeError):
    """The station was closed (Station.close(), the end of its `with` block): its arm and camera refuse every
    further command; open a new station."""


@dataclass(frozen=True)
class Frame:
    """One RGB-D capture: rgb (H, W, 3) uint8, depth (H, W) float32 mm (NaN = no return), timestamp (s)."""

    rgb: np.ndarray
    depth: np.ndarray
    timestamp: float


@runtime_checkable
class Arm(Protocol):
    """What every arm backend offers (simulated or Interbotix RX200). State names are the same on every backend.

    The motion contract (tests/test_station_contract.py holds both backends to it):
    - a stop always wins: emergency_stop() marks the arm stopped before it takes the arm's lock, and a move re-checks
      the mark under that lock just before it starts, so a stop from another thread either prevents the move or
      halts it; nothing moves after emergency_stop() returns;
    - a blocking move that a stop ends part-way raises EmergencyStopped;
    - a move asked for while a non-blocking one runs waits for it to end, then starts (both backends wait);
    - Ctrl+C (KeyboardInterrupt) while a move runs holds the arm where it is (not an emergency stop) and the
      interrupt propagates; closing the station then parks the arm in its sleep pose (unless emergency-stopped);
    - after the station is closed every command raises StationClosed;
    - the arm knows what it holds: the blocks recorded by set_held_blocks (until open_gripper()) are checked along
      every move like the pads, whatever sends the command.
    """

    robot: RobotModel

    @property
    def torque_enabled(self) -> bool:
        """True when the motors hold the arm (False while it is taught by hand)."""

    @property
    def emergency_stopped(self) -> bool:
        """True after emergency_stop() until reset()."""

    def joint_positions(self) -> np.ndarray:
        """Current (measured) joint positions (5,) rad."""

    def move_to(self, q, moving_time: float | None = None, accel_time: float | None = None,
                blocking: bool = True) -> None:
        """Move to joint positions q (5,) rad with the time-based profile; raises MotionRefused before moving."""

    def is_moving(self) -> bool:
        """True while a non-blocking move is under way."""

    def wait(self) -> None:
        """Block until the current move ends."""

    def home(self, moving_time: float | None = None) -> None:
        """Move to the home pose (all zeros)."""

    def sleep(self, moving_time: float | None = None) -> None:
        """Move to the sleep pose (safe to power off)."""

    def open_gripper(self) -> None:
        """Open the gripper (releasing anything held)."""

    def close_gripper(self) -> bool:
        """Close the gripper; True when something is held between the fingers."""

    def set_torque(self, enabled: bool) -> None:
        """Torque on (holds position) or off (the arm can be moved by hand for teaching)."""

    @property
    def held_blocks(self) -> tuple:
        """What the arm holds, as it was told (set_held_blocks): motion_safety.HeldBlock each (edge mm, pose in the
        tool frame T_tool_block (4, 4) mm); () after open_gripper()."""

    def set_held_blocks(self, blocks) -> None:
        """Record the blocks the gripper holds (the task layer's executor does at each grasp): every later move_to
        checks them against the board like the pads (MotionRefused before anything moves)."""

    def emergency_stop(self) -> None:
        """Halt at once; every further motion raises EmergencyStopped until reset()."""

    def reset(self) -> None:
        """Re-initialise after an emergency stop."""


@runtime_checkable
class RGBDCamera(Protocol):
    """What every camera backend offers (simulated or RealSense L515)."""

    K: np.ndarray       # (3, 3) intrinsics as the device reports them (factory values)
    dist: np.ndarray    # (5,) Brown-Conrady distortion as the device reports it
    width: int
    height: int

    def capture(self) -> Frame:
        """Capture one aligned RGB-D frame."""


@runtime_checkable
class GroundTruth(Protocol):
    """The true scene, for checking a pipeline (the simulated World): every object and the blocks among them, each
    with .color, .size, .edge (mm), .position (3,) centre (world mm) and .yaw (rad). Hardware has none."""

    @property
    def objects(self) -> list:
        """Every object on the board (blocks and distractors)."""

    @property
    def blocks(self) -> list:
        """The blocks among the objects."""


@dataclass(frozen=True)
class SagReference:
    """An arm to fit the gravity-sag model on and a way to measure its true tool point (3,) world mm there: in the
    simulator a twin of the station's arm over an empty board with the ground truth (a stand-in for a lab's
    touch-off measurements)."""

    arm: Arm
    measure: Callable[[], np.ndarray]


@dataclass(frozen=True)
class Pacing:
    """The simulator's clock switch: is_real_time() -> bool, and set_real_time(on): motions take wall-clock time
    (True) or run in simulated time, returning at once (False). Hardware always moves in real time."""

    is_real_time: Callable[[], bool]
    set_real_time: Callable[[bool], None]


@dataclass(frozen=True)
class Capabilities:
    """What a backend offers beyond the Arm and RGBDCamera protocols; None where it does not.

    Attributes:
        camera_intrinsics: () -> (K (3, 3), dist (5,)) calibrated from checkerboard views the backend takes with
            its own camera (the simulator renders them); None: the set is read from the data folder.
        sag_reference: () -> SagReference, to fit the sag on before the first task; None: the sag stays zero until
            the caller fits one (tasks.calibrate_sag with a measuring function).
        pose_by_hand: (q) -> None: with torque off, put the arm at joint angles q (5,) rad as a hand would (the
            simulator's hand; MotionRefused through the board or past a hard stop); None: a person moves the arm.
        pacing: the clock switch (Pacing) of a simulated station; None: motions always take wall-clock time.
    """

    camera_intrinsics: Callable[[], tuple[np.ndarray, np.ndarray]] | None = None
    sag_reference: Callable[[], SagReference] | None = None
    pose_by_hand: Callable[[np.ndarray], None] | None = None
    pacing: Pacing | None = None


@dataclass
class Station:
    """An arm, a camera and (in simulation) the world with its ground truth, with the backend's capabilities.

    `kind` is the backend's name (a label for messages: code above the station never branches on it). arm or camera
    is None when that device was not connected (make_station("real", camera=False)). Use as a context manager (or
    call close()) so the real arm goes to sleep and shuts down cleanly.
    """

    kind: str
    arm: Arm | None
    camera: RGBDCamera | None
    world: GroundTruth | None = None
    capabilities: Capabilities = field(default_factory=Capabilities)
    _closer: Callable[[], None] | None = None

    def close(self) -> None:
        """Release the hardware (the real arm goes to its sleep pose first); idempotent."""
        closer, self._closer = self._closer, None
        if closer is not None:
            closer()

    def __enter__(self) -> Station:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
