"""Hidden checks of exercise events.sort_stack: the student's strategy runs sort 'n stack at every level on hidden
seeds, graded by the event's own score (an open task: outcome only) (armlab_course.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _needs_unstacking(level: int, seed: int) -> bool:
    """Whether the board of `seed` has a stack in which a block stands above one of its own size and an earlier
    colour: that stack must be taken apart before the lower block can go to its stack in rainbow order (level 3's
    point; about four boards in ten, measured on seeds 100-129)."""
    from armlab.blocks import COLORS
    from armlab.tasks.events import columns, event_station

    station = event_station("sort_stack", int(level), seed=int(seed))
    try:
        stacks = [[o for o in column if o.is_block] for column in columns(station.world.objects)]
    finally:
        station.close()
    return any(above.size == below.size and COLORS.index(above.color) > COLORS.index(below.color)
               for blocks in stacks for k, below in enumerate(blocks) for above in blocks[k + 1:])


def _sort_stack_seeds(rng, draws: int = 100):
    # sort 'n stack at level 1 on one fresh seed, at levels 2 and 3 on two each: one hidden check per run; a level-3
    # board is drawn again (at most `draws` times) until it must be unstacked (_needs_unstacking)
    cases = [[[1, int(rng.integers(100, 10_000))]]] + [[[2, int(s)]] for s in rng.integers(100, 10_000, 2)]
    for _ in range(2):
        seed = int(rng.integers(100, 10_000))
        for _ in range(draws):
            if _needs_unstacking(3, seed):
                break
            seed = int(rng.integers(100, 10_000))
        cases.append([[3, seed]])
    return cases


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
