"""Line 'em up strategy: the large and the small blocks each in one straight line, rainbow order, square to it.

Layout: both lines run along x at one of y = LINE_Y (large on one side of the robot, small on the other, red nearest the
base), at a pitch that keeps each line under 300 mm. Along x, at headings within 45 deg of the line, a top-down
gripper placing a block square to the line closes ACROSS the line, so its pads never touch the neighbours. The
layout (side and y) is chosen once from the first look: the one whose slots the fewest distractors (which cannot be
moved) and blocks stand on.

Each move: among the cubes seen that are not in their slot, the highest (stack tops first, so nothing is lifted with
a block on it), then the nearest, whose slot is free goes to its slot; when every such slot is taken by another cube,
that cube is moved to a free spot first. Units: mm, rad; world (board) frame.
Instructor only (the answer of exercise events.line_up; see the package notes).
"""

from __future__ import annotations

import numpy as np

from armlab.blocks import COLORS
from armlab.planning.transit import GRIPPER_RADIUS_MM

from ..layout import Move, covered, footprint_radius, free_spot, is_stacked
from ..registry import Strategy
from ..scoring import LINE_UP_LEVELS

__all__ = ["LineUp", "line_slots", "PITCH_MM"]

PITCH_MM = {"large": 50.0, "small": 40.0}     # 6 large: 5 x 50 + 38 = 288 mm; 6 small: 5 x 40 + 25 = 225 mm
FIRST_X_MM = 110.0                            # |x| of the red slot (nearest the base)
LINE_Y = (-95.0, -80.0, 80.0, 95.0)           # y of the lines tried (|y| < |x| at every slot, within reach)
AT_SLOT_MM = 8.0


def line_slots(large_side: int = 1, y: float = -95.0, colors=COLORS) -> dict[tuple[str, str], np.ndarray]:
    """Slots {(size, colour): (x, y, 0)} in world mm: the large line on side large_side (+1: x > 0, -1: x < 0)."""
    out = {}
    for size, side in (("large", large_side), ("small", -large_side)):
        for k, c in enumerate(colors):
            out[(size, c)] = np.array([side * (FIRST_X_MM + k * PITCH_MM[size]), y, 0.0])
    return out


def _overlaps_slot(b, slot, size) -> bool:
    """True when detection b stands where the open gripper comes down to place a block in the slot (within the
    gripper's radius, GRIPPER_RADIUS_MM, of the slot's centre, plus b's own footprint radius)."""
    return bool(np.linalg.norm(np.asarray(b.position[:2]) - slot[:2]) < footprint_radius(b) + GRIPPER_RADIUS_MM)


class LineUp(Strategy):
    """The line 'em up strategy for one level (1, 2 or 3); call next_move(seen) until it returns None."""

    event = "line_up"

    def __init__(self, level: int):
        if level not in LINE_UP_LEVELS:
            raise ValueError(f"line 'em up has levels {LINE_UP_LEVELS}, got {level!r}")
        self.level = level
        self.slots: dict[tuple[str, str], np.ndarray] | None = None
        self.skipped: set[tuple[str, str]] = set()

    def choose_layout(self, seen) -> None:
        """Pick the side and y whose slots are least taken (distractors count 100, blocks 1)."""
        def cost(slots):
            return sum((100 if not b.is_block else 1) for key, s in slots.items() for b in seen
                       if _overlaps_slot(b, s, key[0]))
        options = [line_slots(side, y) for y in LINE_Y for side in (1, -1)]
        self.slots = min(options, key=cost)

    def done(self, b) -> bool:
        slot = self.slots[(b.size, b.color)]
        return bool(not is_stacked(b) and np.linalg.norm(np.asarray(b.position[:2]) - slot[:2]) < AT_SLOT_MM)

    def next_move(self, seen) -> Move | None:
        if self.slots is None:
            self.choose_layout(seen)
        cubes = [b for b in seen if b.is_block]
        todo = [b for b in cubes if not self.done(b) and (b.size, b.color) not in self.skipped and not covered(b, seen)]
        todo.sort(key=lambda b: (-b.position[2], np.hypot(*b.position[:2])))
        blockers = []
        for b in todo:
            slot = self.slots[(b.size, b.color)]
            taken = [o for o in seen if o is not b and _overlaps_slot(o, slot, b.size)
                     and not (o.is_block and self.done(o))]      # the pads close across the line: neighbours are fine
            if not taken:
                return Move(b, slot.copy(), 0.0, "line")
            blockers += [o for o in taken if o.is_block and not self.done(o)]
        if blockers:
            o = blockers[0]
            return Move(o, free_spot(seen, o.size, o.position, list(self.slots.values())), 0.0, "clear")
        return None

    def placed(self, move: Move) -> None:
        """Nothing to remember: the next look shows where the blocks are."""
