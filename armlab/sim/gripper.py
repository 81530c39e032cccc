"""The simulated gripper: grasping by contact physics and pushing with the pads, with the finger pads of
armlab.gripper_geometry.GripperGeometry (the description the planner shares; re-exported here).

Frames: the tool frame is the manufacturer's ee_gripper_link (x = approach direction out of the gripper, y = the
closing direction across the fingers, z completes a right-handed frame). Units: mm, rad.

Grasp (close_on): the cube nearest the tool point between the open pads is squeezed by them in the world's physics
(World.grip: the servo's force, friction, a test lift; armlab.sim.physics.grasp) and is held when it rose with them.
The pads push and turn what they close on: a cube a little off the pads is turned square; one turned further (a large
cube at 30 deg) may be pinched on two edges and held off square (off_square_rad names it). What slips is what the
servo's grip cannot lift; at the manufacturer's pressures that is nothing the kit has met (MuJoCo's cubes have sharp
edges: even pads overlapping a cube's top by 0.2 mm lift it). A pad that runs into an object while the arm moves
shoves it aside (push_with_pads: squaring its face against the pad, as a flat pusher does).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from armlab.blocks import ObjectState
from armlab.gripper_geometry import GripperGeometry
from armlab.sim.geometry import boxes_overlap, convex_hull, separation_along, wrap_quarter
from armlab.sim.physics.grasp import DEFAULT_PRESSURE, LIFT_MM
from armlab.sim.physics.rest import object_rotation
from armlab.sim.world import World
from armlab.transforms import rot_z

__all__ = ["GripperGeometry", "GraspOutcome", "close_on", "push_with_pads", "off_square_rad", "SQUARE_TOLERANCE_RAD"]

SQUARE_TOLERANCE_RAD = float(np.radians(5.0))   # a cube held within this of square to the pads is held square

_PUSH_MARGIN_MM = 0.05       # pads touching a face (closed on a cube) do not count as pushing it
_PREFILTER_MARGIN_MM = 1.0   # push_with_pads' quick test from the tool point leaves this much to spare


@dataclass
class GraspOutcome:
    """What closing the gripper did: the objects now held (the grasped cube first, then what rides on it; empty if
    nothing), the final gap between the pads (mm), and why."""

    held: list[ObjectState]
    opening_mm: float
    reason: str


def _object_box(o: ObjectState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return o.position, rot_z(o.yaw), np.full(3, o.edge / 2)


def off_square_rad(T_tool, obj: ObjectState) -> float:
    """How far (rad, 0..pi/4) a cube's nearest face normal is turned from the pads' closing direction (the tool's y
    axis, T_tool (4, 4)): 0 when the pads lie flat on two opposite faces; a cube pinched on two edges is turned by
    up to 45 deg. Works at any pitch."""
    closing = np.asarray(T_tool, dtype=float)[:3, 1]
    axes = object_rotation(obj)
    return float(np.arccos(min(1.0, float(np.max(np.abs(axes.T @ closing))) / np.linalg.norm(closing))))


def _between(world: World, T: np.ndarray, g: GripperGeometry, opening_mm: float) -> ObjectState | None:
    """The free cube whose centre lies between the open pads nearest the tool point, or None."""
    R, t = T[:3, :3], T[:3, 3]
    best, best_d = None, np.inf
    for o in world.objects:
        if o.id in world.held or not o.is_block:
            continue
        p = R.T @ (o.position - t)
        between = (abs(p[1]) < opening_mm / 2 and abs(p[0]) < (g.pad_height_mm + o.edge) / 2
                   and abs(p[2]) < (g.pad_width_mm + o.edge) / 2)
        if between and np.linalg.norm(p) < best_d:
            best, best_d = o, float(np.linalg.norm(p))
    return best


def _width_across(o: ObjectState, closing: np.ndarray) -> float:
    """A cube's width (mm) along the horizontal part of the closing direction (3,): edge (|cos m| + |sin m|), m its
    yaw off the closing direction (mod 90 deg)."""
    mis = float(wrap_quarter(np.arctan2(closing[1], closing[0]) - o.yaw))
    return o.edge * (abs(np.cos(mis)) + abs(np.sin(mis)))


def close_on(world: World, T_tool, geometry: GripperGeometry, opening_mm: float,
             pressure: float = DEFAULT_PRESSURE) -> GraspOutcome:
    """Close the pads from `opening_mm` at tool pose T_tool (4, 4) (the physical pose), the servo at `pressure`
    (0..1, the manufacturer's): the world's physics decides what is held (module notes). Only cubes are grasped."""
    g = geometry
    T = np.asarray(T_tool, dtype=float)
    o = _between(world, T, g, opening_mm)
    if o is None:
        return GraspOutcome([], g.min_opening_mm, "nothing between the finger pads")
    grip, group = world.grip(o, T, g, opening_mm, _width_across(o, T[:3, 1]), pressure)
    if grip.held:
        turned = off_square_rad(T, o)
        how = "held" if turned <= SQUARE_TOLERANCE_RAD else \
            f"held {np.degrees(turned):.0f} deg off square (pinched on two edges)"
        return GraspOutcome(group, round(grip.gap_mm, 2), f"{how} ({grip.force_n:.1f} N a pad)")
    resting = float(np.clip(_width_across(o, T[:3, 1]), g.min_opening_mm, opening_mm))
    return GraspOutcome([], resting, f"slipped: the {o.size} {o.color} block rose {max(grip.rise_mm, 0.0):.1f} mm "
                                     f"of a {LIFT_MM:.0f} mm test lift between pads squeezing with "
                                     f"{grip.force_n:.1f} N each")


@functools.lru_cache(maxsize=16)
def _pad_reach(g: GripperGeometry) -> float:
    """How far (mm) a pad's corners reach from its centre: the norm of its half extents."""
    return np.linalg.norm(g.half_extents)


def push_with_pads(world: World, T_tool, geometry: GripperGeometry, opening_mm: float) -> list[ObjectState]:
    """Shove every free object a finger pad runs into out of the pad's way (along the closing direction, away from
    the pad), squaring its face against the pad; returns the objects moved."""
    g = geometry
    T = np.asarray(T_tool, dtype=float)
    R = T[:3, :3]
    held = world.held
    free = [o for o in world.objects if o.id not in held]
    if not free:
        return []
    positions = np.array([o.position for o in free])    # the free objects' centres (N, 3), again after a shove
    bound = _pad_reach(g) + 0.87 * np.array([o.edge for o in free])
    # Most steps touch nothing: a pad's centre is `off` from the tool point, so an object farther than its bound + off
    # (+ a margin far above any rounding) from the tool point is beyond its bound from both pads.
    off = (opening_mm / 2 + g.pad_thickness_mm / 2) * np.linalg.norm(T[:3, 1])
    if np.all(np.linalg.norm(positions - T[:3, 3], axis=-1) > bound + (off + _PREFILTER_MARGIN_MM)):
        return []
    centres = g.pad_centres(T, opening_mm)

    def near(k: int) -> list[ObjectState]:
        """The free objects within touching distance of pad k (a vectorised test: most steps touch nothing)."""
        nonlocal positions
        if positions is None:
            positions = np.array([o.position for o in free])
        gap = np.linalg.norm(positions - centres[k], axis=-1)
        return [o for o, close in zip(free, (gap <= bound).tolist(), strict=True) if close]

    corners = None
    moved = []
    for k in range(2):
        if moved:
            positions = None
        for o in near(k):                      # after pad 0's shoves, pad 1 sees where they left the objects
            if not boxes_overlap(centres[k], R, g.half_extents, *_object_box(o), margin=_PUSH_MARGIN_MM):
                continue
            d = R[:2, 1].copy()
            if np.linalg.norm(d) < 1e-6:               # closing axis vertical: push away from the pad's centre
                d = o.position[:2] - centres[k, :2]
            if np.linalg.norm(d) < 1e-9:
                d = np.array([1.0, 0.0])
            d /= np.linalg.norm(d)
            if (o.position[:2] - centres[k, :2]) @ d < 0:
                d = -d
            o.yaw = float(o.yaw + wrap_quarter(np.arctan2(d[1], d[0]) - o.yaw))
            if corners is None:
                corners = g.pad_corners(T, opening_mm)
            pad_poly = convex_hull(corners[k, :, :2])
            need = max(separation_along(p, pad_poly, d) for p in o.footprint_world())
            world.shove(o, d, need + 0.5)
            moved.append(o)
    return moved

