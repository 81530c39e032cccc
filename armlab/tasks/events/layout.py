"""Board geometry the event strategies share: what a detection occupies, free spots for staging, slot checks.

Everything works on what the robot SEES (armlab.detection.Block: top-face centre in world mm, yaw rad, size,
shape "cube" or "distractor"), never on the simulator's truth. Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.blocks import block_edge
from armlab.lab import lab_config
from armlab.planning import DEFAULT_CLEARANCE_MM

__all__ = ["Move", "footprint_radius", "occupied_by", "free_spot", "free_spots", "is_stacked", "covered", "REACH_MM",
           "GAP_MM"]

REACH_MM = (170.0, 320.0)     # radii where staging spots go: top-down picks and places work well there
GAP_MM = 25.0                 # free space kept around a staged block for the finger pads
TAG_CLEAR_MM = 45.0           # staging spots keep this far from AprilTag centres (recalibration needs the tags)


@dataclass(frozen=True)
class Move:
    """One pick-and-place: the detected block to pick, where its bottom-face centre goes (3,) world mm, the yaw (rad),
    why (e.g. "stage", "stack", "line") and the place's transit clearance (mm, tasks.place)."""

    block: object
    to: np.ndarray
    yaw: float
    why: str
    clearance: float = DEFAULT_CLEARANCE_MM

    def describe(self) -> str:
        b = self.block
        return (f"{self.why}: {b.size} {b.color} from ({b.position[0]:.0f}, {b.position[1]:.0f}, "
                f"{b.position[2]:.0f}) to ({self.to[0]:.0f}, {self.to[1]:.0f}, {self.to[2]:.0f}) mm")


def footprint_radius(b) -> float:
    """Radius (mm) of the circle around a detection's footprint (its measured or nominal edge times sqrt(2)/2)."""
    edge = getattr(b, "edge_mm", None) or block_edge(b.size)
    return float(max(edge, block_edge(b.size)) / np.sqrt(2))


def is_stacked(b, tol_mm: float = 10.0) -> bool:
    """True when a detected cube's top is higher than one block of its size (it stands on something)."""
    return bool(b.position[2] > block_edge(b.size) + tol_mm)


def covered(b, seen, tol_mm: float = 5.0) -> bool:
    """True when another detection stands on b (higher, its centre over b's footprint): b cannot be picked without
    lifting it too (e.g. the visible rim of a large block under a small one)."""
    return any(o is not b and o.position[2] > b.position[2] + tol_mm
               and np.linalg.norm(np.asarray(o.position[:2]) - np.asarray(b.position[:2])) < footprint_radius(b)
               for o in seen)


def occupied_by(xy, radius: float, seen, ignore=()) -> list:
    """The detections whose footprint circle comes within GAP_MM of a circle of `radius` mm around xy (2,)."""
    xy = np.asarray(xy, float)[:2]
    skip = {id(b) for b in ignore}
    return [b for b in seen if id(b) not in skip
            and np.linalg.norm(np.asarray(b.position[:2]) - xy) < radius + footprint_radius(b) + GAP_MM]


def free_spots(seen, size: str, reserved=(), y_min: float = 40.0, step: float = 20.0) -> np.ndarray:
    """Every free board spot (K, 2) world mm for a block of `size` on a grid of `step` mm: within REACH_MM of the
    waist axis, y >= y_min, clear of every detection and of `reserved` points ((x, y) of planned slots), away from
    the AprilTags (K may be 0)."""
    lab = lab_config()
    r_block = block_edge(size) / np.sqrt(2)
    xs = np.arange(lab.board_x[0] + 40, lab.board_x[1] - 40 + 1e-9, step)
    ys = np.arange(max(y_min, lab.board_y[0] + 40), lab.board_y[1] - 40 + 1e-9, step)
    X, Y = np.meshgrid(xs, ys)
    P = np.column_stack([X.ravel(), Y.ravel()])
    r = np.hypot(P[:, 0], P[:, 1])
    ok = (r >= REACH_MM[0]) & (r <= REACH_MM[1])
    tags = np.array(list(lab.tags.centres_mm.values()), float)
    ok &= np.min(np.linalg.norm(P[:, None] - tags[None], axis=2), axis=1) > TAG_CLEAR_MM + r_block
    for b in seen:
        ok &= np.linalg.norm(P - np.asarray(b.position[:2]), axis=1) >= r_block + footprint_radius(b) + GAP_MM
    for q in reserved:
        ok &= np.linalg.norm(P - np.asarray(q, float)[:2], axis=1) >= 2 * r_block + GAP_MM
    return P[ok]


def free_spot(seen, size: str, near, reserved=(), y_min: float = 40.0, step: float = 20.0) -> np.ndarray:
    """A free board spot (3,) world mm (z = 0) for a block of `size` (free_spots), nearest to `near` (2+,). Raises
    ValueError when there is none."""
    cand = free_spots(seen, size, reserved, y_min, step)
    if not len(cand):
        raise ValueError(f"no free spot on the board for a {size} block (every reachable spot is taken)")
    best = cand[np.argmin(np.linalg.norm(cand - np.asarray(near, float)[:2], axis=1))]
    return np.array([best[0], best[1], 0.0])
