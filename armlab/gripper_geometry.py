"""The gripper's finger geometry: one description that the simulator, the planner and the task layer share.

Frames: the tool frame is the manufacturer's ee_gripper_link (x = approach direction out of the gripper, y = the
closing direction across the fingers, z completes a right-handed frame). The two finger pads are boxes centred on
the tool point along x, on either side of it along y: the "left" pad on +y, the "right" pad on -y. Units: mm, rad.
`GRIPPER` is the kit's gripper (the lab's modified fingers); the simulator grasps with it (armlab.sim.gripper) and the
planner keeps its finger tips (GRIPPER.fingertip_mm beyond the tool point) off the board (armlab.planning).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["GripperGeometry", "GRIPPER"]


@dataclass(frozen=True)
class GripperGeometry:
    """Finger pad geometry (mm). What the pads hold is the simulator's physics' to decide (armlab.sim.gripper).

    Attributes:
        pad_width_mm: pad extent along tool z (across the fingers' faces).
        pad_height_mm: pad extent along tool x (the approach direction), centred on the tool point, so the finger
            tips reach pad_height_mm / 2 beyond it.
        pad_thickness_mm: pad extent along tool y (the closing direction).
        finger_min_mm, finger_max_mm: travel of each finger's outer face from the centre line (the manufacturer's
            15-37 mm); the gap between the pads is 2 (finger - pad_thickness), 18-62 mm by default, so that both
            the 25 mm and the 38 mm cubes can be held (the lab's modified fingers).
    """

    pad_width_mm: float = 20.0
    pad_height_mm: float = 16.0
    pad_thickness_mm: float = 6.0
    finger_min_mm: float = 15.0
    finger_max_mm: float = 37.0

    def __post_init__(self):
        for name in ("pad_width_mm", "pad_height_mm", "pad_thickness_mm"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"GripperGeometry.{name} must be a positive number of mm, got {value}")
        if not 0 <= self.finger_min_mm - self.pad_thickness_mm < self.finger_max_mm - self.pad_thickness_mm:
            raise ValueError(f"GripperGeometry: finger travel {self.finger_min_mm}-{self.finger_max_mm} mm with "
                             f"{self.pad_thickness_mm} mm pads leaves no valid gap between the pads")

    @property
    def min_opening_mm(self) -> float:
        """Gap between the pads when fully closed (mm)."""
        return 2 * (self.finger_min_mm - self.pad_thickness_mm)

    @property
    def max_opening_mm(self) -> float:
        """Gap between the pads when fully open (mm)."""
        return 2 * (self.finger_max_mm - self.pad_thickness_mm)

    @property
    def fingertip_mm(self) -> float:
        """How far (mm) the finger tips reach beyond the tool point along the approach: half a pad."""
        return self.pad_height_mm / 2

    @property
    def half_extents(self) -> np.ndarray:
        """Pad half extents (3,) along tool x, y, z (mm)."""
        return np.array([self.pad_height_mm, self.pad_thickness_mm, self.pad_width_mm]) / 2

    def pad_centres(self, T_tool, opening_mm: float) -> np.ndarray:
        """World centres (..., 2, 3) of the left (+y) and right (-y) pads for tool pose(s) T_tool (..., 4, 4)."""
        T = np.asarray(T_tool, dtype=float)
        off = opening_mm / 2 + self.pad_thickness_mm / 2
        return T[..., None, :3, 3] + np.stack([off * T[..., :3, 1], -off * T[..., :3, 1]], axis=-2)

    def pad_corners(self, T_tool, opening_mm: float) -> np.ndarray:
        """World corners (..., 2, 8, 3) of both pads for tool pose(s) T_tool (..., 4, 4) at an opening (mm)."""
        T = np.asarray(T_tool, dtype=float)
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        local = signs * self.half_extents                                     # (8, 3) in the tool axes
        offsets = np.einsum("...ij,kj->...ki", T[..., :3, :3], local)        # (..., 8, 3)
        return self.pad_centres(T, opening_mm)[..., :, None, :] + offsets[..., None, :, :]


GRIPPER = GripperGeometry()
