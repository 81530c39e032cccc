"""Hidden checks of exercise events.line_up: the student's strategy runs line 'em up at every level on hidden seeds,
graded by the event's own score (an open task: outcome only) (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec

LINE_Y = (-110.0, -95.0, -80.0, -65.0, 65.0, 80.0, 95.0, 110.0)    # straight lines along x at these y (mm) ...
FIRST_X = (110.0, 125.0)                                            # ... from these |x| (|y| < |x|), 50 / 40 mm apart
PITCH_MM = {"large": 50.0, "small": 40.0}


def _lines_can_be_clear(level: int, seed: int) -> bool:
    """Whether the board of `seed` leaves room for both lines: some layout of the family above (large on either
    side) has no distractor (which must not be moved) where the open gripper comes down on a slot. A board whose
    distractors block every such layout is not asked of a strategy."""
    from armlab.blocks import COLORS, block_edge
    from armlab.planning.transit import GRIPPER_RADIUS_MM
    from armlab.tasks.events import event_station

    station = event_station("line_up", int(level), seed=int(seed))
    try:
        fixed = [(o.position[:2], max(o.edge, block_edge(o.size)) / np.sqrt(2) + GRIPPER_RADIUS_MM)
                 for o in station.world.objects if not o.is_block]
    finally:
        station.close()
    for x0 in FIRST_X:
        for y in (y for y in LINE_Y if abs(y) < x0):
            for side in (1, -1):
                slots = [np.array([s * (x0 + k * PITCH_MM[size]), y]) for size, s in (("large", side),
                                                                                     ("small", -side))
                         for k in range(len(COLORS))]
                if all(np.linalg.norm(xy - slot) >= r for xy, r in fixed for slot in slots):
                    return True
    return False


def _line_up_seeds(rng):
    # line 'em up at levels 1, 2 and 3 (stacks and distractors) on one fresh seed each; a level-3 board whose
    # distractors leave no room for the lines is drawn again
    cases = []
    for level in (1, 2, 3):
        seed = int(rng.integers(100, 10_000))
        while not _lines_can_be_clear(level, seed):
            seed = int(rng.integers(100, 10_000))
        cases.append([[level, seed]])
    return cases


def _judge_line_up(call, level, seed):
    """Line 'em up at `level` on the judge's own fresh seeded station (_events.run_with_child): [every block a look
    showed in its line, each line's neatness whose blocks were all seen, within the time limit] (1.0 / 0.0; a level-3
    board may hide a block from the detector: _events.seen_scored)."""
    from ._events import run_with_child, seen_scored

    result, strategy = run_with_child(call, "line_up", level, seed)
    return [*seen_scored(result.score, strategy.seen_names), float(result.within_limit)]


SPECS = (HiddenSpec("LineUpStrategy", _line_up_seeds, atol=0, adapter="_call_strategy", judge=_judge_line_up,
                    prelude="definitions", outcome=True,
                    criteria=("every block a look showed in its line", "each line neat", "within the time limit")),)
FORBIDDEN = ("LineUp", "line_slots", "make_strategy", "line_up.EVENT", "SearchStrategy",
             "armlab.tasks.events.strategies")
