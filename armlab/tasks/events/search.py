"""The generic strategy: a one-move search over the event's own scorer, for any registered event and level, and
the choice between it and the kit's own strategy (kit_or_search).

SearchStrategy knows nothing of an event but its scorer: from a look it builds the board as seen (each detected top
face a resting object of its size, its centre half an edge below the face), and tries every move of a free cube
(nothing on it) to every free spot of a coarse grid (layout.free_spots, z = 0) and onto every other cube's top,
scoring each resulting board with the event's rules; it makes the move that raises the score most, and stops when
none raises it. It is slow (hundreds of scorings per move) and short-sighted (it never makes a move that pays only
later, such as unstacking), and it is what the student release's events run while an event's strategy exercise is
blank: the kit's own strategies (armlab.tasks.events.strategies) are instructor only. Units: mm, rad; world frame.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

import numpy as np

from armlab.blocks import ObjectState, block_edge

from .layout import Move, covered, free_spots
from .registry import Strategy
from .registry import event as event_spec

__all__ = ["SearchStrategy", "kit_or_search", "KIT_STRATEGIES", "SEARCH_STEP_MM"]

KIT_STRATEGIES = "armlab.tasks.events.strategies"
SEARCH_STEP_MM = 40.0          # the grid of board spots tried


def _seen_as_objects(seen) -> list[ObjectState]:
    """The board as seen: each detection a resting object (a distractor as a cylinder) with its id its index."""
    out = []
    for i, b in enumerate(seen):
        edge = block_edge(b.size)
        centre = np.asarray(b.position, float) - [0.0, 0.0, edge / 2]
        out.append(ObjectState(b.color, b.size, edge, centre, float(b.yaw), "cube" if b.is_block else "cylinder", i))
    return out


class SearchStrategy(Strategy):
    """The generic one-move search for event `event` at `level` (module notes); `stopped` says why it ended."""

    def __init__(self, event: str, level: int):
        spec = event_spec(event)
        spec.check_level(level)
        self.event, self.level, self.stopped = event, level, ""
        self._scorer = spec.scorer
        self._options = spec.supply(None, 0).score_options() if spec.supply is not None else {}

    def _points(self, objects) -> float:
        return float(self._scorer(objects, self.level, **self._options).points)

    def next_move(self, seen) -> Move | None:
        board = _seen_as_objects(seen)
        best, move = self._points(board), None
        for i, b in enumerate(seen):
            if not b.is_block or covered(b, seen):
                continue
            others = [o for o in seen if o is not b]
            spots = [np.array([x, y, 0.0]) for x, y in free_spots(others, b.size, y_min=-1e9, step=SEARCH_STEP_MM)]
            spots += [np.asarray(o.position, float) for o in others if o.is_block and not covered(o, seen)]
            for to in spots:
                trial = list(board)
                trial[i] = ObjectState(b.color, b.size, board[i].edge, to + [0.0, 0.0, board[i].edge / 2], 0.0,
                                       "cube", i)
                points = self._points(trial)
                if points > best + 1e-9:
                    best, move = points, Move(b, to, 0.0, "search")
        if move is None:
            self.stopped = "the search finds no move that raises the score"
        return move

    def placed(self, move: Move) -> None:
        """Nothing to remember: the next look shows the board."""


def kit_or_search(event: str, kit_class: str) -> Callable[[int], Strategy]:
    """The strategy factory of an event: the kit's class `kit_class` of module KIT_STRATEGIES.<event> where it is
    installed (the instructor's tree), a SearchStrategy otherwise (the student release)."""

    def make(level: int) -> Strategy:
        try:
            module = importlib.import_module(f"{KIT_STRATEGIES}.{event}")
        except ModuleNotFoundError as e:
            if e.name not in (KIT_STRATEGIES, f"{KIT_STRATEGIES}.{event}"):
                raise
            return SearchStrategy(event, level)
        return getattr(module, kit_class)(level)

    make.__qualname__ = make.__name__ = f"{event}_strategy"
    return make
