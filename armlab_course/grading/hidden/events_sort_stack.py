"""Hidden checks of exercise events.sort_stack: the student's strategy runs sort 'n
stack levels 2 and 3 on hidden seeds, graded by the event's own score (an open task: outcome only)
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _sort_stack_seeds(rng):
    # sort 'n stack at levels 2 and 3, two fresh seeds each: one hidden check per run
    return [[[level, int(seed)]] for level in (2, 3) for seed in rng.integers(100, 10_000, 2)]


class _Strategy:
    """The event's strategy as the judge's runner sees it: each question (next_move, placed, cannot_place,
    obstacles) goes to the student's SortStackStrategy in the child as plain data (the detections seen), and its
    answer (a move: which block seen, where to, yaw, clearance) comes back as plain data and is checked here."""

    def __init__(self, call, level: int):
        self.call, self.stopped = call, ""
        call("start", int(level))

    def next_move(self, seen):
        from armlab.tasks.events.layout import Move

        from ._replay import block_to_plain

        got = self.call("next_move", [block_to_plain(b) for b in seen])
        if got[0] is None:
            self.stopped = str(got[1])[:200]
            return None
        index, to, yaw, why, clearance = got
        if isinstance(index, bool) or not isinstance(index, (int, float)) or index != int(index) or \
                not 0 <= index < len(seen):
            raise ValueError("the move names no block of those seen")
        index = int(index)
        to = np.asarray(to, dtype=float)
        if to.shape != (3,) or not np.all(np.isfinite(to)) or not np.isfinite(float(yaw)):
            raise ValueError("a move's target is 3 finite numbers (mm) and its yaw a finite angle")
        return Move(seen[index], to, float(yaw), str(why)[:80], float(clearance))

    def placed(self, move) -> None:
        self.call("placed")

    def cannot_place(self, why: str) -> bool:
        return bool(self.call("cannot_place", str(why)))

    def obstacles(self) -> list:
        from armlab.planning import Obstacle

        return [Obstacle(*(float(v) for v in o)) for o in self.call("obstacles")[:100]]


def _judge_sort_stack(call, level, seed):
    """Sort 'n stack at `level` on the judge's own fresh seeded station, run by the event's own runner with the
    student's strategy asked move by move in the child: [full marks, within the time limit] (1.0 / 0.0), scored by
    the event's rules from the judge's simulator's ground truth."""
    from armlab.tasks import start_session
    from armlab.tasks.events import event_station, run_event

    session = start_session(event_station("sort_stack", int(level), seed=int(seed)))
    result = run_event(session, "sort_stack", int(level), strategy=_Strategy(call, int(level)), record=False)
    return [float(result.score.full_marks), float(result.within_limit)]


SPECS = (HiddenSpec("SortStackStrategy", _sort_stack_seeds, atol=0, adapter="_call_strategy", judge=_judge_sort_stack,
                    prelude="definitions", outcome=True,
                    criteria=("full marks", "within the time limit")),)
FORBIDDEN = ("SortStack", "make_strategy", "sort_stack.EVENT")
