"""To the sky: large blocks handed over one at a time at a fixed spot, stacked into one tower as high as possible.

HandOver is the scene's side (the person handing the blocks over, acting on the simulated world): it puts one large
block at HANDOVER_XY (with a little jitter in position and turn, as a hand would) at the start and after every block
that ends on the tower. Sky is the robot's side: it picks the block at the hand-over spot and puts it on the tower at
TOWER_XY, the next level up, always aimed at the same (x, y) so placement errors do not add up (the detected top
face of a tall tower drifts by a few mm per 100 mm of height, more than the arm errs); the tower's height is believed
from what was placed and checked against the detected top while it is below the detector's height limit.
The tower stops when the next level is out of the arm's reach: with the default 50 mm transit clearance the top-down
or tilted approach above a 12-block tower (456 mm) needs the tool at about 530 mm, beyond the RX200's reach at that
radius. Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

import numpy as np

from armlab.blocks import COLORS, ObjectState, block_edge

from .layout import Move

__all__ = ["Sky", "HandOver", "HANDOVER_XY", "TOWER_XY"]

HANDOVER_XY = (-200.0, 150.0)
TOWER_XY = (150.0, 150.0)
NEAR_MM = 40.0


class HandOver:
    """Hands large blocks over at HANDOVER_XY in the simulated world (ROYGBV in turn), up to `supply` blocks."""

    def __init__(self, world, seed: int = 0, supply: int = 24, jitter_mm: float = 4.0,
                 jitter_rad: float = float(np.radians(10.0))):
        self.world, self.supply = world, int(supply)
        self.jitter_mm, self.jitter_rad = float(jitter_mm), float(jitter_rad)
        self.rng = np.random.default_rng(seed)
        self.handed: list[ObjectState] = []

    def waiting(self) -> bool:
        """True while a handed block still stands at the hand-over spot."""
        return any(np.linalg.norm(o.position[:2] - np.asarray(HANDOVER_XY)) < NEAR_MM and o.id not in self.world.held
                   for o in self.world.objects)

    def hand_over(self) -> ObjectState | None:
        """Put the next block at the spot (when the spot is free and blocks are left); returns it."""
        if len(self.handed) >= self.supply or self.waiting():
            return None
        e = block_edge("large")
        xy = np.asarray(HANDOVER_XY) + self.rng.uniform(-self.jitter_mm, self.jitter_mm, 2)
        yaw = float(self.rng.uniform(-self.jitter_rad, self.jitter_rad))
        next_id = max((o.id for o in self.world.objects), default=-1) + 1
        obj = ObjectState(COLORS[len(self.handed) % 6], "large", e, np.array([xy[0], xy[1], e / 2]), yaw, "cube",
                          next_id)
        self.world.add(obj)
        self.handed.append(obj)
        return obj


class Sky:
    """The to-the-sky strategy: the block seen at the hand-over spot goes on top of the tower."""

    event = "sky"
    level = 1

    def __init__(self, level: int = 1):
        if level != 1:
            raise ValueError(f"to the sky has no levels (use 1), got {level!r}")
        self.height = 0                     # blocks on the tower (belief)
        self.top_xy = np.asarray(TOWER_XY, float)
        self.stopped = ""                   # why the tower stopped growing, once it has

    def next_move(self, seen) -> Move | None:
        if self.stopped:
            return None
        e = block_edge("large")
        tops = [b for b in seen if b.is_block and np.linalg.norm(np.asarray(b.position[:2]) - TOWER_XY) < NEAR_MM]
        if tops:                             # the tower's top face is in view: trust it for the count
            self.height = int(round(max(b.position[2] for b in tops) / e))
        handed = [b for b in seen if b.is_block and np.linalg.norm(np.asarray(b.position[:2]) - HANDOVER_XY) < NEAR_MM]
        if not handed:
            return None
        return Move(handed[0], np.array([*self.top_xy, self.height * e]), 0.0, "tower")

    def placed(self, move: Move) -> None:
        self.height += 1

    def unreachable(self, reason: str) -> None:
        self.stopped = reason
