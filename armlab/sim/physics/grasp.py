"""A grasp by contact: the finger pads squeeze a block and lift it, and friction holds it, or does not.

The pads are kinematic (mocap) boxes that follow the simulated gripper's fingers (their centres and the tool's
rotation from armlab.gripper_geometry.GripperGeometry at the tool pose), not bodies driven by simulated servos: the
simulated arm's joints come from its own model (commanded motion, backlash, sag; armlab.sim.arm), which the camera,
the encoders and the station contract all read, so the physics must follow that arm exactly rather than a second
model of it. A kinematic pad pushes and squeezes what it meets and is never pushed back, as a servo holding its
position nearly is. Squeezing: the pads close until each is SQUEEZE_MM into the block's face (the soft contacts'
penetration sets the grip force, about GRIP_N); lifting: the pads rise LIFT_MM in LIFT_S. The block is held when it
rose with them (within SLIP_MM); its pose in the tool frame is then the physics world's, turned when the grip could
not stop gravity turning it (a block gripped off its centre swings about the closing axis). Units: mm, rad, s at the
interface; world frame.

Measured 2026-12-07 (a large block squeezed top-down at its centre): the grip is 0.21, 0.53, 1.06, 3.47 and 21.4 N a pad
at 0.02, 0.05, 0.1, 0.3 and 1 mm of squeeze; at 0.03-1 mm the block rises with the pads, and gripped 5 or 10 mm off its
centre (along the pads' width) it turns 0.2 or 0.5 deg; at 0.02 mm (0.21 N) the centred block slips 1.1 mm in the 10 mm
lift and the one gripped 10 mm off its centre slips 3.4 mm and turns 8.3 deg. Whether an off-centre grip slips on the
bench thus turns on the gripper's force, which the kit has not measured. Not yet the simulated arm's grasp: SimArm still
holds by the grasp rule of armlab.sim.gripper (issue 36's next step is to decide holding and the held pose here).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armlab.blocks import ObjectState
from armlab.gripper_geometry import GripperGeometry
from armlab.sim.physics.engine import Physics
from armlab.transforms import homogeneous, invert_transform

__all__ = ["Grip", "contact_grip", "SQUEEZE_MM", "LIFT_MM", "LIFT_S", "SLIP_MM", "CLOSE_SPEED_MM_S"]

SQUEEZE_MM = 0.3          # each pad this far into the block's face when closed
CLOSE_SPEED_MM_S = 60.0   # each pad's closing speed
HOLD_S = 0.05             # still, after closing and after lifting
LIFT_MM = 10.0            # the lift that tests the grip
LIFT_S = 0.1
SLIP_MM = 3.0             # held: the block rose at least LIFT_MM - SLIP_MM


@dataclass
class Grip:
    """What squeezing and lifting did: held (the block rose with the pads), T_tool_block (4, 4) the block's pose in the
    tool frame after the lift (mm), the block's rise (mm) and its turn in the pads during the lift (rad)."""

    held: bool
    T_tool_block: np.ndarray
    rise_mm: float
    turn_rad: float


def _step_pads(physics: Physics, g: GripperGeometry, T: np.ndarray, opening_mm: float) -> None:
    physics.set_pads(g.pad_centres(T, opening_mm), T[:3, :3])
    physics.step()


def contact_grip(objects: Sequence[ObjectState], k: int, T_tool, geometry: GripperGeometry, from_mm: float,
                 width_mm: float) -> Grip:
    """Squeeze objects[k] (free objects at rest, world mm) between the pads at tool pose T_tool (4, 4) mm, closing
    them from from_mm to width_mm (the block's width across the pads) less SQUEEZE_MM a side, then lift LIFT_MM."""
    g = geometry
    T = np.asarray(T_tool, dtype=float)
    physics = Physics(objects, pad_half_mm=tuple(g.half_extents))
    physics.set_pads(g.pad_centres(T, from_mm), T[:3, :3], teleport=True)
    dt = physics.model.opt.timestep
    closed = width_mm - 2 * SQUEEZE_MM
    n = max(1, int(np.ceil((from_mm - closed) / 2 / (CLOSE_SPEED_MM_S * dt))))
    for opening in np.linspace(from_mm, closed, n + 1)[1:]:
        _step_pads(physics, g, T, float(opening))
    for _ in range(int(round(HOLD_S / dt))):
        _step_pads(physics, g, T, closed)
    start = physics.pose(k)
    m = max(1, int(round(LIFT_S / dt)))
    T_up = T.copy()
    for i in range(1, m + 1):
        u = i / m
        T_up[2, 3] = T[2, 3] + LIFT_MM * (3 * u ** 2 - 2 * u ** 3)
        _step_pads(physics, g, T_up, closed)
    for _ in range(int(round(HOLD_S / dt))):
        _step_pads(physics, g, T_up, closed)
    position, R = physics.pose(k)
    turn = np.arccos(np.clip((np.trace(start[1].T @ R) - 1.0) / 2.0, -1.0, 1.0))
    T_tool_block = invert_transform(T_up) @ homogeneous(R, position)
    return Grip(bool(position[2] - start[0][2] >= LIFT_MM - SLIP_MM), T_tool_block,
                float(position[2] - start[0][2]), float(turn))

