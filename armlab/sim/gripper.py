"""The simulated gripper: finger pad geometry, and grasping, holding and pushing by geometry (not magic).

Frames: the tool frame is the manufacturer's ee_gripper_link (x = approach direction out of the gripper, y = the
closing direction across the fingers, z completes a right-handed frame). The two finger pads are boxes centred on
the tool point along x, on either side of it along y: the "left" pad on +y, the "right" pad on -y. Units: mm, rad.

Grasp rule: closing holds a cube only when it lies between the pads, the closing direction is horizontal and across
two opposite faces (cube yaw vs. closing direction, modulo 90 deg, within `align_tol_rad`), and the pads overlap the
cube's sides by at least `min_contact_mm` vertically and across. The pads then centre the cube between them and
square it up. A cube turned further than the tolerance is turned and pushed by the pads but slips out; a pad that
runs into an object shoves it aside (squaring its face against the pad, as a flat pusher does).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.blocks import ObjectState
from armlab.sim.geometry import boxes_overlap, convex_hull, separation_along, wrap_quarter
from armlab.sim.world import World
from armlab.transforms import rot_z

__all__ = ["GripperGeometry", "GraspOutcome", "close_on", "push_with_pads"]

PAD_NAMES = ("left finger pad", "right finger pad")
_PUSH_MARGIN_MM = 0.05       # pads touching a face (closed on a cube) do not count as pushing it


@dataclass(frozen=True)
class GripperGeometry:
    """Finger pad geometry (mm) and grasp tolerances.

    Attributes:
        pad_width_mm: pad extent along tool z (across the fingers' faces).
        pad_height_mm: pad extent along tool x (the approach direction), centred on the tool point, so the finger
            tips reach pad_height_mm / 2 beyond it.
        pad_thickness_mm: pad extent along tool y (the closing direction).
        finger_min_mm, finger_max_mm: travel of each finger's outer face from the centre line (the manufacturer's
            15-37 mm); the gap between the pads is 2 (finger - pad_thickness), 18-62 mm by default, so that both
            the 25 mm and the 38 mm cubes can be held (the lab's modified fingers).
        align_tol_rad: largest misalignment (mod 90 deg) between the closing direction and a cube's face normal
            that still gives a grasp.
        min_contact_mm: least overlap of the pads with the cube's sides, vertically and across, for a grasp.
    """

    pad_width_mm: float = 20.0
    pad_height_mm: float = 16.0
    pad_thickness_mm: float = 6.0
    finger_min_mm: float = 15.0
    finger_max_mm: float = 37.0
    align_tol_rad: float = float(np.radians(10.0))
    min_contact_mm: float = 5.0

    def __post_init__(self):
        for name in ("pad_width_mm", "pad_height_mm", "pad_thickness_mm", "min_contact_mm"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"GripperGeometry.{name} must be a positive number of mm, got {value}")
        if not 0 <= self.finger_min_mm - self.pad_thickness_mm < self.finger_max_mm - self.pad_thickness_mm:
            raise ValueError(f"GripperGeometry: finger travel {self.finger_min_mm}-{self.finger_max_mm} mm with "
                             f"{self.pad_thickness_mm} mm pads leaves no valid gap between the pads")
        if not 0 < self.align_tol_rad < np.pi / 4:
            raise ValueError(f"GripperGeometry.align_tol_rad must be in (0, pi/4), got {self.align_tol_rad}")

    @property
    def min_opening_mm(self) -> float:
        """Gap between the pads when fully closed (mm)."""
        return 2 * (self.finger_min_mm - self.pad_thickness_mm)

    @property
    def max_opening_mm(self) -> float:
        """Gap between the pads when fully open (mm)."""
        return 2 * (self.finger_max_mm - self.pad_thickness_mm)

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


def push_with_pads(world: World, T_tool, geometry: GripperGeometry, opening_mm: float) -> list[ObjectState]:
    """Shove every free object a finger pad runs into out of the pad's way (along the closing direction, away from
    the pad), squaring its face against the pad; returns the objects moved."""
    g = geometry
    T = np.asarray(T_tool, dtype=float)
    R = T[:3, :3]
    centres = g.pad_centres(T, opening_mm)
    corners = g.pad_corners(T, opening_mm)
    reach = np.linalg.norm(g.half_extents)
    moved = []
    for k in range(2):
        for o in world.objects:
            if o.id in world.held or np.linalg.norm(o.position - centres[k]) > reach + o.edge * 0.87:
                continue
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
            pad_poly = convex_hull(corners[k, :, :2])
            need = max(separation_along(p, pad_poly, d) for p in o.footprint_world())
            world.shove(o, d, need + 0.5)
            moved.append(o)
    return moved

