"""Hidden checks of exercise events.line_up: the student's strategy runs line 'em up at every level on hidden seeds,
graded by the event's own score (an open task: outcome only) (armlab_course.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _line_up_seeds(rng):
    # line 'em up at levels 1 and 2 on one fresh seed each, level 3 (stacks and distractors) on two
    return [[[level, int(rng.integers(100, 10_000))]] for level in (1, 2, 3, 3)]


def _judge_line_up(call, level, seed):
    """Line 'em up at `level` on the judge's own fresh seeded station (_events.run_with_child): [full marks, within
    the time limit] (1.0 / 0.0)."""
    from ._events import run_with_child

    result = run_with_child(call, "line_up", level, seed)
    return [float(result.score.full_marks), float(result.within_limit)]


SPECS = (HiddenSpec("LineUpStrategy", _line_up_seeds, atol=0, adapter="_call_strategy", judge=_judge_line_up,
                    prelude="definitions", outcome=True),)
FORBIDDEN = ("LineUp", "line_slots", "make_strategy", "line_up.EVENT", "SearchStrategy",
             "armlab.tasks.events.strategies")
