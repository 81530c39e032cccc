"""Sort 'n stack: small blocks left, large right, into y < 0; at levels 2-3 one rainbow stack per size at STACK_XY
(the rules: scoring.score_sort_stack). The strategy is the kit's own where it is installed (the instructor's tree,
armlab.tasks.events.strategies) and the generic search (armlab.tasks.events.search) in the student release, where
writing it is exercise events.sort_stack. Units: mm; world (board) frame.
"""

from __future__ import annotations

from .registry import EventSpec
from .scoring import SORT_STACK_LEVELS, score_sort_stack
from .search import kit_or_search

__all__ = ["STACK_XY", "EVENT"]

STACK_XY = {"large": (200.0, -100.0), "small": (-200.0, -100.0)}      # levels 2-3: one stack per size

EVENT = EventSpec("sort_stack", "sort 'n stack", SORT_STACK_LEVELS, 180.0, kit_or_search("sort_stack", "SortStack"),
                  score_sort_stack)
