"""The competition events (reference/lab.md): sort 'n stack, line 'em up and to the sky, run autonomously on a
simulated station and scored from the world's ground truth.

    from armlab.tasks.events import run_event
    result = run_event(make_station("sim", seed=0, scene="sort_stack_3"), "sort_stack", level=3)
    print(result.score.table(), result.summary())

Modules: scoring (the rules), layout (shared board geometry), sort_stack / line_up / sky (strategies), runner (the
look-plan-act loop with a time limit), replay (recorded joint trajectory and world snapshots).
"""

from .replay import Recorder, Replay
from .runner import EventResult, MoveLog, make_strategy, run_event
from .scoring import EVENTS, LEVELS, TIME_LIMIT_S, Score, ScoreLine, columns, score_event
from .sky import HANDOVER_XY, TOWER_XY, HandOver

__all__ = ["EVENTS", "LEVELS", "TIME_LIMIT_S", "Score", "ScoreLine", "columns", "score_event", "EventResult",
           "MoveLog", "make_strategy", "run_event", "Recorder", "Replay", "HandOver", "HANDOVER_XY", "TOWER_XY",
           "event_station"]


def event_station(event: str, level: int = 1, seed: int = 0, **options):
    """A simulated station set up for an event: its scene preset (sort_stack_N, line_up_N), or for "sky" an
    empty board (the blocks are handed over by HandOver during the run)."""
    from armlab import make_station

    scene = "empty" if event == "sky" else f"{event}_{level}"
    return make_station("sim", seed=seed, scene=scene, **options)
