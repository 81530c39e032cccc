"""Hidden checks of exercise events.sort_stack: the student's strategy runs sort 'n
stack levels 2 and 3 on hidden seeds, graded by the event's own score (an open task: outcome only)
(armlab_course.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _sort_stack_seeds(rng):
    # sort 'n stack at levels 2 and 3, two fresh seeds each: one hidden check per run
    return [[[level, int(seed)]] for level in (2, 3) for seed in rng.integers(100, 10_000, 2)]


def _call_sort_stack(function, level, seed):
    """The student's strategy class, SortStackStrategy(level), runs the event on a fresh seeded station: [full marks,
    within the time limit] (1.0 / 0.0), scored from the simulator's ground truth."""
    from armlab.tasks import start_session
    from armlab.tasks.events import event_station, run_event

    session = start_session(event_station("sort_stack", int(level), seed=int(seed)))
    result = run_event(session, "sort_stack", int(level), strategy=function(int(level)), record=False)
    return [float(result.score.full_marks), float(result.within_limit)]


SPECS = (HiddenSpec("SortStackStrategy", _sort_stack_seeds, atol=0, adapter="_call_sort_stack",
                    prelude="definitions", outcome=True),)
FORBIDDEN = ("SortStack", "make_strategy", "sort_stack.EVENT")
