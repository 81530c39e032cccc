"""Obstacles on the board and the clearance rule for transit moves.

An obstacle is a vertical cylinder standing on the board: centre (x, y), radius and top height (world mm), bounding a
block, a stack or a distractor. A joint-space transit is clear when, at every sampled instant, each of the wrist,
wrist_rotate and tool points that is horizontally within (obstacle radius + gripper radius) of an obstacle is at least
`clearance` above its top; the tool point must in addition lift a held block's overhang (`held_below`, how far the
held block hangs below the tool point) over it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab import kinematics
from armlab.blocks import block_edge

from .trajectory import Trajectory

__all__ = ["Obstacle", "as_obstacles", "Clearance", "transit_clearance", "DEFAULT_CLEARANCE_MM",
           "GRIPPER_RADIUS_MM"]

DEFAULT_CLEARANCE_MM = 50.0   # tool point (or held block bottom) above the tops it passes: covers the finger tips
GRIPPER_RADIUS_MM = 45.0      # horizontal half-width of the open gripper (74 mm opening) or a held large block
_CHECKED_POINTS = (4, 5, 6)   # rows of kinematics.joint_positions: wrist, wrist_rotate, tool


@dataclass(frozen=True)
class Obstacle:
    """A vertical cylinder on the board: centre x, y (world mm), top height (mm) and radius (mm)."""

    x: float
    y: float
    top: float
    radius: float

    def __post_init__(self):
        vals = (self.x, self.y, self.top, self.radius)
        if not all(np.isfinite(v) for v in vals) or self.radius < 0:
            raise ValueError(f"obstacle needs finite x, y, top and a non-negative radius (mm), got {vals}")


def _one_obstacle(item, i: int) -> Obstacle:
    if isinstance(item, Obstacle):
        return item
    if hasattr(item, "top_z") and hasattr(item, "footprint_world"):          # blocks.ObjectState: centre position
        polys = np.vstack(item.footprint_world())
        r = float(np.linalg.norm(polys - item.position[:2], axis=1).max())
        return Obstacle(float(item.position[0]), float(item.position[1]), float(item.top_z), r)
    if hasattr(item, "position") and hasattr(item, "size"):                 # detection.Block: top-face centre
        p = np.asarray(item.position, float)
        return Obstacle(float(p[0]), float(p[1]), float(p[2]), block_edge(item.size) / np.sqrt(2))
    a = np.asarray(item, dtype=float) if not isinstance(item, str) else np.array([])
    if a.shape == (4,):
        return Obstacle(*map(float, a))
    raise ValueError(f"obstacle {i}: expected an Obstacle, an ObjectState, a detection Block or (x, y, top, radius) "
                     f"in mm, got {type(item).__name__}")


def as_obstacles(items) -> list[Obstacle]:
    """Obstacles from Obstacle, blocks.ObjectState, detection blocks (top-face position + size) or (x, y, top, r)."""
    if items is None:
        return []
    return [_one_obstacle(item, i) for i, item in enumerate(items)]


@dataclass(frozen=True)
class Clearance:
    """Result of a clearance check: deficit (mm, <= 0 when clear), where (time index) and which obstacle."""

    deficit: float
    sample: int
    obstacle: Obstacle | None

    @property
    def clear(self) -> bool:
        return self.deficit <= 1e-9


def transit_clearance(trajectory: Trajectory, obstacles: list[Obstacle], clearance: float = DEFAULT_CLEARANCE_MM,
                      held_below: float = 0.0, gripper_radius: float = GRIPPER_RADIUS_MM,
                      samples: int | None = None) -> Clearance:
    """How far (mm) the sampled wrist, wrist_rotate and tool points fall short of the clearance rule (module notes).

    Samples every 10 ms of the trajectory (at least 50 samples) unless `samples` is given.
    """
    if not obstacles:
        return Clearance(-np.inf, 0, None)
    n = samples or max(50, int(np.ceil(trajectory.duration / 0.01)) + 1)
    q, _ = trajectory.sample(np.linspace(0.0, trajectory.duration, n))
    pts = kinematics.joint_positions(q)[:, _CHECKED_POINTS]                       # (n, 3, 3)
    obs = np.array([[o.x, o.y, o.top, o.radius] for o in obstacles])            # (m, 4)
    d = np.linalg.norm(pts[:, :, None, :2] - obs[None, None, :, :2], axis=-1)    # (n, 3, m)
    near = d < obs[:, 3] + gripper_radius
    extra = np.array([0.0, 0.0, held_below])[None, :, None]
    need = obs[None, None, :, 2] + clearance + extra                              # (1, 3, m)
    short = np.where(near, need - pts[:, :, None, 2], -np.inf)
    k, _, j = np.unravel_index(int(np.argmax(short)), short.shape)
    worst = float(short[k, :, j].max())
    return Clearance(worst, int(k), obstacles[j] if np.isfinite(worst) else None)
