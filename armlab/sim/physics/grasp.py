"""A grasp by contact: the servo squeezes the finger pads onto a block, the hand lifts, and friction holds the block,
or does not.

The hand (mjcf.Hand) follows the simulated arm's tool pose kinematically: the simulated arm's joints come from its own
model (commanded motion, backlash, sag; armlab.sim.arm), which the camera, the encoders and the station contract all
read, so the physics follows that arm exactly rather than a second model of it. The pads are driven as the gripper's
servo drives them (gripper_servo): a constant force at the manufacturer's grasp effort, less the back-EMF's damping,
so the grip force does not depend on how far the soft contacts sink in.

A grasp (contact_grip): the pads close from their present gap until they stop (on a block, or at the closed end of
their travel), the hand holds still HOLD_S, lifts LIFT_MM in LIFT_S (a smooth start and stop, peak acceleration
6 LIFT_MM / LIFT_S^2 = 6 m/s^2) and holds again. The block is held when it rose with the hand (at least
LIFT_MM - SLIP_MM); its pose in the tool frame is then the physics world's after the lift: where the closing pads
pushed and turned it (a block turned off the pads is turned square by them, or pinched on its edges), turned
further where the grip could not stop gravity turning it (a block gripped off its centre swings about the closing
axis). The lift tests the grip at one pace: the arm's own lift after the grasp is not simulated with contacts.
Units: mm, rad, N, s at the interface; world frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armlab.blocks import ObjectState
from armlab.gripper_geometry import GripperGeometry
from armlab.sim.physics.arm_bodies import ArmPart
from armlab.sim.physics.engine import Physics
from armlab.sim.physics.gripper_servo import pad_armature_kg, pad_damping_n_s_m, pad_force_n
from armlab.sim.physics.mjcf import Hand
from armlab.transforms import homogeneous, invert_transform

__all__ = ["Grip", "contact_grip", "hand_for", "DEFAULT_PRESSURE", "LIFT_MM", "LIFT_S", "SLIP_MM", "HOLD_S",
           "MAX_CLOSE_S"]

DEFAULT_PRESSURE = 0.5    # the manufacturer's default grasp pressure (rx200.md)
HOLD_S = 0.05             # still, after the pads stopped and after lifting
LIFT_MM = 10.0            # the lift that tests the grip
LIFT_S = 0.1
SLIP_MM = 3.0             # held: the block rose at least LIFT_MM - SLIP_MM
MAX_CLOSE_S = 2.0         # the pads' closing ends after this much physics time even if they still creep
STOPPED_MM_S = 0.5        # the pads count as stopped below this closing speed (for STOPPED_S)
STOPPED_S = 0.02


@dataclass
class Grip:
    """What squeezing and lifting did.

    Attributes:
        held: the block rose with the hand; gap_mm: the gap between the pads at the end (mm);
        force_n: each pad's squeeze (N); rise_mm: how far the block rose in the LIFT_MM lift;
        turn_rad: how far it turned during the lift (rad);
        poses: every object's pose after the lift, (centre (3,) world mm, rotation (3, 3)), in the objects' order;
        T_tool: the tool pose the lift ended at (4, 4) world mm; T_tool_block: the block's pose in that tool frame.
    """

    held: bool
    gap_mm: float
    force_n: float
    rise_mm: float
    turn_rad: float
    poses: list[tuple[np.ndarray, np.ndarray]]
    T_tool: np.ndarray
    T_tool_block: np.ndarray


def hand_for(geometry: GripperGeometry, width_mm: float) -> Hand:
    """The physics' hand for a gripper geometry, its damper taken where the pads meet a block width_mm across."""
    g = geometry
    finger = float(np.clip(width_mm, g.min_opening_mm, g.max_opening_mm)) / 2 + g.pad_thickness_mm
    return Hand(tuple(float(v) for v in g.half_extents), float(g.min_opening_mm), float(g.max_opening_mm),
                round(pad_damping_n_s_m(finger), 3), round(pad_armature_kg(finger), 4))


def _steps(physics: Physics, seconds: float) -> int:
    return max(1, int(round(seconds / physics.model.opt.timestep)))


def contact_grip(objects: Sequence[ObjectState], k: int, T_tool, geometry: GripperGeometry, from_mm: float,
                 width_mm: float, pressure: float = DEFAULT_PRESSURE, lift_s: float = LIFT_S,
                 arm: Sequence[ArmPart] = ()) -> Grip:
    """Squeeze objects[k] (free objects at rest, world mm) between the pads at tool pose T_tool (4, 4) mm, the pads
    closing from from_mm apart with the servo's force at `pressure` (its force taken where they meet a block
    width_mm across: the block's width across the pads), then lift LIFT_MM in lift_s (module notes). arm: the arm's
    links, standing still (arm_bodies without the hand: the gripper here is the hand that lifts)."""
    g = geometry
    T = np.array(T_tool, dtype=float)
    T[:3, 3] = np.round(T[:3, 3], 3)          # to 1 um once, as the physics' inputs are (engine._metres), so the lift's
    #                                           heights, added to it in Python, round the same on every CPU
    force = round(pad_force_n(pressure, float(np.clip(width_mm, g.min_opening_mm, g.max_opening_mm)) / 2
                              + g.pad_thickness_mm), 3)
    physics = Physics(objects, hand=hand_for(g, width_mm), arm=arm)
    physics.set_hand(T, teleport=True)
    physics.set_gap(from_mm)
    physics.squeeze(force)
    still, limit = 0, _steps(physics, MAX_CLOSE_S)
    for _ in range(limit):
        physics.step()
        still = still + 1 if abs(physics.gap_speed_mm_s()) < STOPPED_MM_S else 0
        if still >= _steps(physics, STOPPED_S):
            break
    physics.step(_steps(physics, HOLD_S))
    start = physics.pose(k)
    m = _steps(physics, lift_s)
    T_up = T.copy()
    for i in range(1, m + 1):
        u = i / m
        T_up[2, 3] = T[2, 3] + LIFT_MM * (3 * u ** 2 - 2 * u ** 3)
        physics.set_hand(T_up)
        physics.step()
    physics.step(_steps(physics, HOLD_S))
    poses = [physics.pose(j) for j in range(len(objects))]
    position, R = poses[k]
    turn = np.arccos(np.clip((np.trace(start[1].T @ R) - 1.0) / 2.0, -1.0, 1.0))
    rise = float(position[2] - start[0][2])
    return Grip(bool(rise >= LIFT_MM - SLIP_MM), physics.gap_mm(), force, rise, float(turn), poses, T_up,
                invert_transform(T_up) @ homogeneous(R, position))
