"""The simulated arm's links and fingers as bodies in the world's physics.

Derived from the manufacturer's description (Interbotix `interbotix_xsarm_descriptions`, rx200.urdf.xacro, BSD 3-Clause
licence; its joint offsets are the kit's robot model, data/rx200_pox.csv, and reference rx200.md): the links are
capsules between the joint centres the kit's kinematics gives (kinematics.joint_positions), the gripper's bar a box
from the wrist_rotate joint to the fingers' base (27.575 mm behind the tool point, the description's last offset), and
each finger a plate from there to its tip, its inner face the finger pad (armlab.gripper_geometry). The radii and the
bar's width are the servos' bodies (Dynamixel XM430 / XL430: 28.5-36 x 34-46.5 mm, the ROBOTIS data sheets), not the
description's meshes, which the kit does not ship: an envelope, not the shape of every bracket.

How the arm is driven: its bodies are kinematic (MuJoCo mocap bodies) posed at the simulated arm's physical joint
angles (armlab.sim.arm: commanded motion, backlash, sag), which the camera, the encoders and the station contract all
read; position actuators would be a second model of the same arm, tuned to the first, and could disagree with what
the camera shows. The physics runs while something moves the objects (a release, a push, a grasp) with the arm
standing still, so what the arm's bodies do is be there: a released or toppling block lands on a finger or against
the forearm instead of passing through it. While the arm moves, its pads shove what they run into
(armlab.sim.gripper.push_with_pads); a link that sweeps through a block passes through it (the planners keep the tool
and a held block above the objects; nothing checks the links against them). A part that overlaps an object when the
physics starts (such a sweep left it there) is left out of that run rather than flinging the object out.

Units: mm at this module's interface, world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab import kinematics
from armlab.gripper_geometry import GripperGeometry
from armlab.robot import RobotModel

__all__ = ["ArmPart", "arm_parts", "LINK_RADII_MM", "PALM_MM", "BAR_HALF_MM"]

LINK_RADII_MM = {"upper arm": 18.0, "forearm": 15.0, "wrist": 18.0}   # capsules between joint centres
_LINK_POINTS = {"upper arm": (2, 3), "forearm": (3, 4), "wrist": (4, 5)}   # kinematics.joint_positions' indices
PALM_MM = 27.575             # the fingers' base behind the tool point (the description's last offset)
BAR_HALF_MM = (30.0, 17.0)   # the gripper bar's half extents across (closing direction, tool z)


@dataclass(frozen=True)
class ArmPart:
    """One body of the arm: kind "capsule" (size_mm: radius, half length; its axis the pose's z) or "box" (size_mm:
    half extents along the pose's x, y, z); pose (4, 4) world mm."""

    name: str
    kind: str
    size_mm: tuple[float, ...]
    pose: np.ndarray


def _capsule(name: str, a: np.ndarray, b: np.ndarray, radius: float) -> ArmPart:
    axis = b - a
    length = float(np.linalg.norm(axis))
    z = axis / length
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = (a + b) / 2
    return ArmPart(name, "capsule", (radius, length / 2), T)


def _box(name: str, T_tool: np.ndarray, centre_in_tool, half_mm) -> ArmPart:
    T = T_tool.copy()
    T[:3, 3] = T_tool[:3, :3] @ np.asarray(centre_in_tool, dtype=float) + T_tool[:3, 3]
    return ArmPart(name, "box", tuple(float(h) for h in half_mm), T)


def arm_parts(q, robot: RobotModel, gripper: GripperGeometry, gap_mm: float, hand: bool = True) -> list[ArmPart]:
    """The arm's bodies at physical joint angles q (5,) rad with the pads gap_mm apart: the three link capsules and
    (with hand) the gripper bar and the two fingers, in that order."""
    frames = kinematics.link_frames(q, robot, check_limits=False)
    points = kinematics.frame_points(frames, robot)
    T_tool = frames[-1]
    parts = [_capsule(name, points[i], points[j], LINK_RADII_MM[name]) for name, (i, j) in _LINK_POINTS.items()]
    if not hand:
        return parts
    back = float(np.linalg.norm(points[6] - points[5]))            # wrist_rotate joint to the tool point
    parts.append(_box("gripper bar", T_tool, [-(back + PALM_MM) / 2, 0.0, 0.0],
                      [(back - PALM_MM) / 2, *BAR_HALF_MM]))
    g = gripper
    length = PALM_MM + g.pad_height_mm / 2                         # the fingers' base to their tips
    for sign, name in ((1, "left finger"), (-1, "right finger")):
        parts.append(_box(name, T_tool, [(g.pad_height_mm / 2 - PALM_MM) / 2,
                                         sign * (gap_mm / 2 + g.pad_thickness_mm / 2), 0.0],
                          [length / 2, g.pad_thickness_mm / 2, g.pad_width_mm / 2]))
    return parts
