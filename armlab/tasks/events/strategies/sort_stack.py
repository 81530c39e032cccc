"""Sort 'n stack strategy: small blocks left, large right, into y < 0; at levels 2-3 one rainbow stack per size.

Works from what the robot sees (detection.Block tops). Hidden blocks (under others) are found by unstacking: while a
cube outside its stack stands on something, it is staged on a free spot first (its colour tells nothing about the
hidden one below, so the rainbow order can only be planned once every block is seen). Then, per size, the block of
the earliest rainbow colour not yet stacked goes on top of its stack. The stack's height is believed from what was
placed and checked against the detected top after every move. Units: mm, rad; world (board) frame.
Instructor only (the answer of exercise events.sort_stack; see the package notes).
"""

from __future__ import annotations

import numpy as np

from armlab.blocks import COLORS, block_edge

from ..layout import Move, covered, free_spot, is_stacked
from ..registry import Strategy
from ..scoring import SORT_STACK_LEVELS
from ..sort_stack import STACK_XY

__all__ = ["SortStack", "ROW_XY"]

ROW_XY = {"large": [(140.0, -100.0), (210.0, -100.0), (280.0, -100.0), (140.0, -160.0), (210.0, -160.0)],
          "small": [(-140.0, -100.0), (-200.0, -100.0), (-260.0, -100.0), (-140.0, -150.0), (-200.0, -150.0)]}
AT_SLOT_MM = 20.0          # a detected block this close (x, y) to a destination is there


class SortStack(Strategy):
    """The sort 'n stack strategy for one level (1, 2 or 3); call next_move(seen) until it returns None."""

    event = "sort_stack"

    def __init__(self, level: int):
        if level not in SORT_STACK_LEVELS:
            raise ValueError(f"sort 'n stack has levels {SORT_STACK_LEVELS}, got {level!r}")
        self.level = level
        self.stack: dict[str, list[str]] = {"large": [], "small": []}   # colours placed on each stack (belief)
        self.rows: dict[str, int] = {"large": 0, "small": 0}

    def slots(self) -> list[tuple[float, float]]:
        """Every destination (x, y) this strategy may use (kept free when staging)."""
        if self.level == 1:
            return [xy for s in ROW_XY for xy in ROW_XY[s]]
        return list(STACK_XY.values())

    def _at(self, b, xy) -> bool:
        return bool(np.linalg.norm(np.asarray(b.position[:2]) - np.asarray(xy)) < AT_SLOT_MM)

    def done(self, b) -> bool:
        """True when a seen cube is where it belongs (in its row, or on its stack)."""
        if self.level == 1:
            return any(self._at(b, xy) for xy in ROW_XY[b.size][:self.rows[b.size]])
        return self._at(b, STACK_XY[b.size])

    def _check_stacks(self, seen) -> None:
        """Trust the detected stack tops over the belief when they say fewer blocks stand there. Every object seen
        at a stack counts, a top the detector flags as a distractor too (a stack's top seen at an angle may be): the
        belief is cut only when nothing stands as high as it says."""
        if self.level == 1:
            return
        for size, xy in STACK_XY.items():
            tops = [b for b in seen if self._at(b, xy)]
            levels = int(round(max((b.position[2] for b in tops), default=0.0) / block_edge(size)))
            del self.stack[size][levels:]

    def next_move(self, seen) -> Move | None:
        cubes = [b for b in seen if b.is_block]
        self._check_stacks(seen)
        todo = [b for b in cubes if not self.done(b)]
        if not todo:
            return None
        todo = [b for b in todo if not covered(b, seen)] or todo
        stacked = [b for b in todo if is_stacked(b)]
        if stacked and self.level > 1:       # unstack first: the rainbow order needs every colour seen
            b = max(stacked, key=lambda b: b.position[2])
            return Move(b, free_spot(seen, b.size, b.position, self.slots()), 0.0, "unstack")
        if self.level == 1:
            b = min(todo, key=lambda b: (-b.position[2], np.hypot(*b.position[:2])))
            k = self.rows[b.size]
            if k >= len(ROW_XY[b.size]):
                return None
            x, y = ROW_XY[b.size][k]
            return Move(b, np.array([x, y, 0.0]), 0.0, "sort")
        # the earliest rainbow colour of either size goes next (the large stack first on ties)
        b = min(todo, key=lambda b: (COLORS.index(b.color), b.size != "large"))
        x, y = STACK_XY[b.size]
        z = len(self.stack[b.size]) * block_edge(b.size)
        return Move(b, np.array([x, y, z]), 0.0, "stack")

    def placed(self, move: Move) -> None:
        """Record a place that ran through (the belief the next detection checks)."""
        b = move.block
        if move.why == "stack":
            self.stack[b.size].append(b.color)
        elif move.why == "sort":
            self.rows[b.size] += 1
