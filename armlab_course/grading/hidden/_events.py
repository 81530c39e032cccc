"""The judge's side of the event strategies (events.sort_stack, events.line_up, events.sky): the event's own runner
on the judge's own fresh seeded station asks the student's strategy, in the child, for each move; the outcome is
scored by the event's own rules from the judge's simulator's ground truth. Units: mm, rad, s; world (board) frame."""

from __future__ import annotations

import numpy as np

__all__ = ["ChildStrategy", "run_with_child", "seen_scored"]


class ChildStrategy:
    """An event's strategy as the judge's runner sees it: each question (next_move, placed, cannot_place,
    obstacles) goes to the student's strategy in the child as plain data (the detections seen), and its answer (a
    move: which block seen, where to, yaw, clearance) comes back as plain data and is checked here."""

    def __init__(self, call, level: int):
        self.call, self.stopped = call, ""
        self.seen_names: set[str] = set()      # "size colour" of every cube any look showed
        call("start", int(level))

    def next_move(self, seen):
        from armlab.tasks.events.layout import Move

        from ._replay import block_to_plain

        self.seen_names |= {f"{b.size} {b.color}" for b in seen if b.is_block}
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
        clearance = float(clearance)
        if not np.isfinite(clearance) or clearance < 0:
            raise ValueError("a move's clearance is a finite number of mm, at least 0")
        return Move(seen[index], to, float(yaw), str(why)[:80], clearance)

    def placed(self, move) -> None:
        self.call("placed")

    def cannot_place(self, why: str) -> bool:
        return bool(self.call("cannot_place", str(why)))

    def obstacles(self) -> list:
        from armlab.planning import Obstacle

        return [Obstacle(*(float(v) for v in o)) for o in self.call("obstacles")[:100]]


def run_with_child(call, event: str, level: int, seed: int):
    """The event at `level` on the judge's own fresh station of `seed` (the supply's jitter seeded alike), run by the
    event's own runner with the student's strategy asked move by move in the child: the EventResult (scored by the
    event's rules from the simulator's truth) and the ChildStrategy (what its looks showed)."""
    from armlab.tasks import start_session
    from armlab.tasks.events import event_station, run_event

    session = start_session(event_station(event, int(level), seed=int(seed)))
    strategy = ChildStrategy(call, int(level))
    return run_event(session, event, int(level), seed=int(seed), strategy=strategy, record=False), strategy


def seen_scored(score, seen_names: set[str]) -> list[float]:
    """What a strategy working from what the robot sees can be held to, from the event's score lines: [every block
    a look showed scored its points, every bonus line (a line's neatness) scored whose blocks all were seen]
    (1.0 / 0.0). A block the detector never showed as a cube (hidden under a distractor, or taken for one) cannot
    be asked of the strategy."""
    blocks = [ln for ln in score.lines if ln.object_id is not None]
    seen_ok = all(ln.points > 0 for ln in blocks if ln.what in seen_names)
    bonus_ok = all(ln.points > 0 for ln in score.lines if ln.object_id is None
                   and all(b.what in seen_names for b in blocks if ln.what.startswith(b.what.split()[0] + " ")))
    return [float(seen_ok), float(bonus_ok)]
