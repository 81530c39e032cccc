"""The simulated gripper: grasping, holding and pushing by geometry (not magic), with the finger pads of
armlab.gripper_geometry.GripperGeometry (the description the planner shares; re-exported here).

Frames: the tool frame is the manufacturer's ee_gripper_link (x = approach direction out of the gripper, y = the
closing direction across the fingers, z completes a right-handed frame). Units: mm, rad.

Grasp rule: closing holds a cube only when it lies between the pads, the closing direction is horizontal and across
two opposite faces (cube yaw vs. closing direction, modulo 90 deg, within `align_tol_rad`), and the pads overlap the
cube's sides by at least `min_contact_mm` vertically and across. The pads then centre the cube between them and
square it up. A cube turned further than the tolerance is turned and pushed by the pads but slips out; a pad that
runs into an object shoves it aside (squaring its face against the pad, as a flat pusher does).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from armlab.blocks import ObjectState
from armlab.gripper_geometry import GripperGeometry
from armlab.sim.geometry import boxes_overlap, convex_hull, separation_along, wrap_quarter
from armlab.sim.world import World
from armlab.transforms import rot_z

__all__ = ["GripperGeometry", "GraspOutcome", "close_on", "push_with_pads"]

_PUSH_MARGIN_MM = 0.05       # pads touching a face (closed on a cube) do not count as pushing it
_PREFILTER_MARGIN_MM = 1.0   # push_with_pads' quick test from the tool point leaves this much to spare


@dataclass
class GraspOutcome:
    """What closing the gripper did: the object now held (None if nothing), the final gap (mm), and why."""

    held: ObjectState | None
    opening_mm: float
    reason: str


def _object_box(o: ObjectState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return o.position, rot_z(o.yaw), np.full(3, o.edge / 2)


def close_on(world: World, T_tool, geometry: GripperGeometry, opening_mm: float) -> GraspOutcome:
    """Close the pads from `opening_mm` at tool pose T_tool (4, 4) (the physical pose) and apply the grasp rule.

    May move the cube between the pads (centred and squared up). Only cubes can be held.
    """
    g = geometry
    T = np.asarray(T_tool, dtype=float)
    R, t = T[:3, :3], T[:3, 3]
    best, best_p = None, None
    for o in world.objects:
        if o.id in world.held or not o.is_block:
            continue
        p = R.T @ (o.position - t)
        between = (abs(p[1]) < opening_mm / 2 and abs(p[0]) < (g.pad_height_mm + o.edge) / 2
                   and abs(p[2]) < (g.pad_width_mm + o.edge) / 2)
        if between and (best_p is None or np.linalg.norm(p) < np.linalg.norm(best_p)):
            best, best_p = o, p
    if best is None:
        return GraspOutcome(None, g.min_opening_mm, "nothing between the finger pads")
    o, p = best, best_p
    y = R[:, 1]
    mis = float(wrap_quarter(np.arctan2(y[1], y[0]) - o.yaw))
    width = o.edge * (abs(np.cos(mis)) + abs(np.sin(mis)))
    resting = float(np.clip(width, g.min_opening_mm, opening_mm))

    tilt = np.arcsin(min(1.0, abs(y[2])))
    if tilt > g.align_tol_rad:
        return GraspOutcome(None, resting, f"the closing direction is tilted {np.degrees(tilt):.1f} deg from "
                                           f"horizontal, so the pads cannot squeeze two opposite faces")
    zs = g.pad_corners(T, opening_mm)[..., 2]
    vertical = min(zs.max(), o.top_z) - max(zs.min(), o.bottom_z)
    if vertical < g.min_contact_mm:
        return GraspOutcome(None, resting if vertical > 0 else g.min_opening_mm,
                            f"the pads overlap the block's sides by only {max(vertical, 0):.1f} mm vertically "
                            f"(need {g.min_contact_mm:.1f} mm): the gripper is too high")
    across = (g.pad_width_mm + o.edge) / 2 - abs(p[2])
    if across < g.min_contact_mm:
        return GraspOutcome(None, resting, f"the pads overlap the block by only {across:.1f} mm across "
                                           f"(need {g.min_contact_mm:.1f} mm)")
    if o.edge < g.min_opening_mm:
        return GraspOutcome(None, g.min_opening_mm, f"the {o.edge:.0f} mm block is narrower than the closed "
                                                    f"gap of {g.min_opening_mm:.0f} mm")
    # The closing pads turn the cube until a face lies flat on a pad, and push it to the middle of the gap.
    o.yaw = float(o.yaw + mis)
    y_h = np.array([y[0], y[1]])
    if abs(p[1]) > 1e-9:
        world.shove(o, -np.sign(p[1]) * y_h, abs(p[1]) * np.linalg.norm(y_h))
    if abs(mis) > g.align_tol_rad:
        return GraspOutcome(None, o.edge, f"the block was {np.degrees(abs(mis)):.1f} deg off the pads (tolerance "
                                          f"{np.degrees(g.align_tol_rad):.1f} deg): the pads turned it and it "
                                          f"slipped out")
    return GraspOutcome(o, o.edge, "held")


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

