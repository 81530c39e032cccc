"""Hidden checks of exercise events.sort_stack: the student's strategy runs sort 'n stack at every level on hidden
seeds, graded by the event's own score (an open task: outcome only) (armlab_course.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _sort_stack_seeds(rng):
    # sort 'n stack at level 1 on one fresh seed, at levels 2 and 3 on two each: one hidden check per run
    return [[[1, int(rng.integers(100, 10_000))]]] + \
        [[[level, int(seed)]] for level in (2, 3) for seed in rng.integers(100, 10_000, 2)]


def _judge_sort_stack(call, level, seed):
    """Sort 'n stack at `level` on the judge's own fresh seeded station (_events.run_with_child): [full marks,
    within the time limit] (1.0 / 0.0)."""
    from ._events import run_with_child

    result, _ = run_with_child(call, "sort_stack", level, seed)
    return [float(result.score.full_marks), float(result.within_limit)]


SPECS = (HiddenSpec("SortStackStrategy", _sort_stack_seeds, atol=0, adapter="_call_strategy", judge=_judge_sort_stack,
                    prelude="definitions", outcome=True,
                    criteria=("full marks", "within the time limit")),)
FORBIDDEN = ("SortStack", "make_strategy", "sort_stack.EVENT", "SearchStrategy", "armlab.tasks.events.strategies")
