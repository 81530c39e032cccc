"""Line 'em up: the large and the small blocks each in one straight line, rainbow order, square to it, each line
shorter than 300 mm (the rules: scoring.score_line_up). The strategy is the kit's own where it is installed (the
instructor's tree, armlab.tasks.events.strategies) and the generic search (armlab.tasks.events.search) in the
student release, where writing it is exercise events.line_up. Units: mm; world (board) frame.
"""

from __future__ import annotations

from .registry import EventSpec
from .scoring import LINE_UP_LEVELS, score_line_up
from .search import kit_or_search

__all__ = ["EVENT"]

EVENT = EventSpec("line_up", "line 'em up", LINE_UP_LEVELS, 600.0, kit_or_search("line_up", "LineUp"), score_line_up)
