"""To the sky strategy: the block seen at the hand-over spot goes on top of the tower at TOWER_XY, the next level
up, always aimed at the same (x, y) so placement errors do not add up; the tower's height is believed from what was
placed and checked against the detected top while it is below the detector's height limit; it stops when the next
level is out of reach (see armlab.tasks.events.sky for the reach and the clearance). Units: mm, rad; world frame.
Instructor only (the answer of exercise events.sky; see the package notes).
"""

from __future__ import annotations

import numpy as np

from armlab.blocks import block_edge
from armlab.planning import Obstacle

from ..layout import Move
from ..registry import Strategy
from ..scoring import SKY_LEVELS
from ..sky import HANDOVER_XY, NEAR_MM, SKY_CLEARANCE_MM, TOWER_RADIUS_MM, TOWER_XY, landing_offset

__all__ = ["Sky"]


class Sky(Strategy):
    """The to-the-sky strategy: the block seen at the hand-over spot goes on top of the tower."""

    event = "sky"
    level = 1

    def __init__(self, level: int = 1):
        if level not in SKY_LEVELS:
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
        aim = self.top_xy - landing_offset(self.height)      # a block let go tilted tips flat: aim so it lands over
        return Move(handed[0], np.array([*aim, self.height * e]), 0.0, "tower", SKY_CLEARANCE_MM)

    def placed(self, move: Move) -> None:
        self.height += 1

    def cannot_place(self, why: str) -> bool:
        """The next level is out of reach: the tower is done (next_move returns None from now on, saying why)."""
        self.stopped = f"the next level is out of reach: {why}"
        return True

    def obstacles(self) -> list:
        """The tower as the strategy believes it (its top is out of the detector's range once it is tall)."""
        return [Obstacle(*TOWER_XY, self.height * block_edge("large"), TOWER_RADIUS_MM)]
