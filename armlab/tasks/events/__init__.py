"""The competition events (docs/course/competition.md): sort 'n stack, line 'em up and to the sky, run autonomously on a
simulated station and scored from the world's ground truth.

    from armlab.tasks.events import run_event
    result = run_event(make_station("sim", seed=0, scene="sort_stack_3"), "sort_stack", level=3)
    print(result.score.table(), result.summary())

Modules: registry (EventSpec, the Strategy protocol, events(): every event is one module defining EVENT),
scoring (the rules), layout (shared board geometry), sort_stack / line_up / sky (the events: strategy and spec),
runner (the look-plan-act loop with a time limit), replay (recorded joint trajectory and world snapshots).
"""

from .registry import EventSpec, Strategy, event, events, max_points, register, score_event
from .replay import Replay, ReplayRecorder
from .runner import EventResult, MoveLog, make_strategy, run_event
from .scoring import Score, ScoreLine, columns
from .sky import HANDOVER_XY, TOWER_XY, HandOver

__all__ = ["EventSpec", "Strategy", "event", "events", "register", "max_points", "Score", "ScoreLine", "columns",
           "score_event", "EventResult", "MoveLog", "make_strategy", "run_event", "ReplayRecorder", "Replay",
           "HandOver", "HANDOVER_XY", "TOWER_XY", "event_station"]


def event_station(event_name: str, level: int = 1, seed: int = 0, **options):
    """A simulated station set up for a registered event and level: the event's scene (the preset sort_stack_N or
    line_up_N; for "sky" an empty board, the blocks are handed over during the run)."""
    from armlab import make_station

    return make_station("sim", seed=seed, scene=event(event_name).scene_for(level), **options)
