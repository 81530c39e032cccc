"""One switch between the simulated and the real lab: `make_station("sim")` or `make_station("real")`.

Code above the station (calibration, detection, planning, tasks, notebooks) uses only the interfaces defined here
and never asks which backend it has. Units: mm, rad, s. Images: RGB uint8 (H, W, 3); depth float32 (H, W) mm
(camera-frame Z, NaN where there is no return), aligned to the colour image.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from armlab.robot import RobotModel

__all__ = ["Frame", "Arm", "RGBDCamera", "Station", "make_station", "MotionRefused", "EmergencyStopped"]


class MotionRefused(ValueError):
    """A move was refused before anything moved; the message says why (joint limit, velocity limit, collision)."""


class EmergencyStopped(RuntimeError):
    """The arm is emergency-stopped: it refuses motion until `reset()` re-initialises it."""


@dataclass(frozen=True)
class Frame:
    """One RGB-D capture: rgb (H, W, 3) uint8, depth (H, W) float32 mm (NaN = no return), timestamp (s)."""

    rgb: np.ndarray
    depth: np.ndarray
    timestamp: float


@runtime_checkable
class Arm(Protocol):
    """What every arm backend offers (simulated or Interbotix RX200)."""

    robot: RobotModel

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


@dataclass
class Station:
    """An arm, a camera and (in simulation) the world with its ground truth.

    `kind` is "sim" or "real". Use as a context manager (or call close()) so the real arm goes to sleep and
    shuts down cleanly.
    """

    kind: str
    arm: Any
    camera: Any
    world: Any = None
    _closer: Any = None

    def close(self) -> None:
        """Release the hardware (the real arm goes to its sleep pose first); idempotent."""
        closer, self._closer = self._closer, None
        if closer is not None:
            closer()

    def __enter__(self) -> Station:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def make_station(kind: str = "sim", **options) -> Station:
    """A station of the given kind: "sim" (default, no hardware) or "real" (Interbotix RX200 + RealSense L515).

    Simulation options: seed (int), scene (preset name, JSON path or dict), realism ("realistic" or "ideal"), ...
    (see armlab.sim.make_sim_station). Real options: see armlab.hardware.make_real_station.
    """
    if kind == "sim":
        from armlab.sim import make_sim_station

        return make_sim_station(**options)
    if kind == "real":
        from armlab.hardware import make_real_station

        return make_real_station(**options)
    raise ValueError(f"unknown station kind {kind!r}: expected 'sim' or 'real'")
