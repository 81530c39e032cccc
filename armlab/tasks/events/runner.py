"""Run an autonomous event on a station: look, choose a move, pick, place, look again (verify, retry), score.

run_event(session, event, level) runs any registered event (registry.py: "sort_stack", "line_up", "sky", ...) in a task
session the caller started (tasks.start_session(station): camera calibration and, in simulation, the sag fit; not
timed), then loops within the event's time limit (simulated seconds): look with the arm out of view (detect_objects:
blocks AND distractors, which the plans avoid), ask the strategy for the next move, pick (a failed pick is retried after
a new look, up to MAX_PICK_TRIES times per block), place, and record. The robot acts only on what it sees; the score
comes from the simulator's ground truth (scoring.py) at the end, or at the time limit if the run overran it. For the
evaluation tables the truth is also read after each place (the placement error of the block that was held), never fed
back.
Units: mm, rad, s; world (board) frame.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from armlab.blocks import block_edge
from armlab.detection import DetectionSettings
from armlab.kinematics import Unreachable
from armlab.planning import Obstacle
from armlab.station import MotionRefused
from armlab.tasks import handling, perception
from armlab.tasks.session import Session, as_session

from .layout import Move, footprint_radius
from .registry import Strategy, score_event
from .registry import event as event_spec
from .replay import Replay, ReplayRecorder, objects_from_snapshot
from .scoring import Score

__all__ = ["EventResult", "MoveLog", "Look", "run_event", "see", "make_strategy", "MAX_PICK_TRIES"]

MAX_PICK_TRIES = 3


@dataclass(frozen=True)
class MoveLog:
    """One move: what was tried, when (s from the event's start), whether the pick held and the place ran, and the
    placement error (3,) mm of the block's true centre against the target (NaN when not placed)."""

    move: str
    t_start: float
    t_end: float
    picked: bool
    placed: bool
    error_mm: np.ndarray


@dataclass
class EventResult:
    """What an event run did: the score (ground truth), the simulated time it took (s, setup excluded), whether it
    finished within the limit, the moves, the replay, and a note on why it stopped."""

    event: str
    level: int
    score: Score
    time_s: float
    time_limit_s: float
    moves: list[MoveLog] = field(default_factory=list)
    replay: Replay | None = None
    stopped: str = ""
    looks: int = 0

    @property
    def within_limit(self) -> bool:
        return self.time_s <= self.time_limit_s

    @property
    def placement_errors(self) -> np.ndarray:
        """(M, 3) mm: true block centre minus target for every placed move."""
        errs = [m.error_mm for m in self.moves if m.placed and np.all(np.isfinite(m.error_mm))]
        return np.array(errs).reshape(-1, 3)

    def summary(self) -> str:
        return (f"{self.event} level {self.level}: {self.score.points:g} / {self.score.max_points} points, "
                f"{self.time_s:.1f} s simulated (limit {self.time_limit_s:.0f} s), {len(self.moves)} moves, "
                f"{sum(not m.picked for m in self.moves)} failed picks; {self.stopped}")


def make_strategy(event: str, level: int) -> Strategy:
    """The strategy object of a registered event and level (e.g. SortStack, LineUp or Sky)."""
    spec = event_spec(event)
    spec.check_level(level)
    return spec.strategy(level)


@dataclass(frozen=True)
class Look:
    """One look at the board: the frame, its corrected depth (H, W) mm and every object's top face detected."""

    frame: object
    depth: np.ndarray
    objects: list


def see(session: Session, obstacles=(), settings: DetectionSettings | None = None) -> Look:
    """Arm out of the camera's view, one frame, corrected depth, every object's top face (tasks.perception.observe with
    all_objects: distractors included, which the plans avoid), with the session's calibration and guarded arm."""
    session = as_session(session, "see")
    obs = perception.observe(session.station, session.calibration, session, obstacles, all_objects=True,
                             settings=settings)
    return Look(obs.frame, obs.depth, obs.blocks)


def _obstacles(seen, move: Move, extra=()) -> list:
    """Everything standing on the board but the block being moved; a picked stack top leaves its column behind."""
    out = [b for b in seen if b is not move.block]
    b = move.block
    below = float(b.position[2]) - block_edge(b.size)
    if below > 5.0:
        out.append(Obstacle(float(b.position[0]), float(b.position[1]), below, footprint_radius(b)))
    return out + list(extra)


class _WithDefaults(Strategy):
    """A strategy object of one's own, with the Strategy protocol's defaults for what it does not define."""

    def __init__(self, strategy):
        self._strategy = strategy

    def __getattr__(self, name):
        return getattr(self._strategy, name)

    @property
    def stopped(self) -> str:
        return getattr(self._strategy, "stopped", "")

    def next_move(self, seen):
        return self._strategy.next_move(seen)

    def placed(self, move) -> None:
        self._strategy.placed(move)

    def cannot_place(self, why: str) -> bool:
        own = getattr(self._strategy, "cannot_place", None)
        return bool(own(why)) if callable(own) else False

    def obstacles(self) -> list:
        own = getattr(self._strategy, "obstacles", None)
        return list(own()) if callable(own) else []


def _with_protocol_defaults(strategy) -> Strategy:
    missing = [m for m in ("next_move", "placed") if not callable(getattr(strategy, m, None))]
    if missing:
        raise TypeError(f"a strategy needs next_move(seen) and placed(move) methods; {type(strategy).__name__} "
                        f"lacks {' and '.join(missing)}")
    return _WithDefaults(strategy)


def run_event(session: Session, event: str, level: int = 1, time_limit_s: float | None = None, seed: int = 0,
              max_moves: int = 60, record: bool = True, strategy=None) -> EventResult:
    """Run one event autonomously in a session on a simulated station (tasks.start_session(event_station(...)))
    and score it (see the module notes).

    time_limit_s: default the event's (the rules': 180 s sort 'n stack, 600 s the others). seed: the supply's
    jitter (to the sky's hand-over). strategy: default the event's own for the level (make_strategy); yours needs
    next_move(seen) -> Move or None (seen: the detections of a fresh look) and placed(move), called after each
    successful place; what it lacks of the Strategy protocol (stopped, cannot_place, obstacles) takes the defaults.
    """
    session = as_session(session, "run_event")
    station = session.station
    if station.world is None:
        raise ValueError("run_event scores from the simulator's ground truth: it needs a simulated station")
    spec = event_spec(event)
    strategy = make_strategy(event, level) if strategy is None else _with_protocol_defaults(strategy)
    limit = spec.time_limit_s if time_limit_s is None else float(time_limit_s)
    if not limit > 0:
        raise ValueError(f"time_limit_s must be positive, got {time_limit_s}")
    world = station.world
    supply = spec.supply(world, seed) if spec.supply is not None else None
    if supply is not None:
        supply.hand_over()
    t0 = world.time_s
    recorder = ReplayRecorder(station, limit_s=limit) if record else None
    tries: Counter = Counter()
    moves: list[MoveLog] = []
    looks, stopped, board = 0, "", []      # board: what stands where, as last seen and changed since
    for _ in range(max_moves):
        if world.time_s - t0 >= limit:
            stopped = "time is up"
            break
        extra = list(strategy.obstacles())
        seen = see(session, [*board, *extra], spec.detection).objects
        board = list(seen)
        looks += 1
        move = strategy.next_move(seen)
        if move is None:
            stopped = strategy.stopped or "nothing left to do"
            break
        key = (move.block.size, move.block.color)
        if tries[key] >= MAX_PICK_TRIES:
            stopped = f"gave up on the {key[0]} {key[1]} block after {MAX_PICK_TRIES} failed picks"
            break
        obstacles = _obstacles(seen, move, extra)
        t_start = world.time_s - t0
        try:
            held = handling.pick(session, move.block, obstacles=obstacles)
        except Unreachable as e:
            stopped = f"cannot reach the {key[0]} {key[1]} block: {e}"
            break
        if not held:
            tries[key] += 1
            moves.append(MoveLog(move.describe(), t_start, world.time_s - t0, False, False, np.full(3, np.nan)))
            board = list(seen)
            continue
        truth = list(station.arm.holding)[:1]
        try:
            handling.place(session, move.to, move.yaw, obstacles=obstacles, clearance=move.clearance)
        except (Unreachable, MotionRefused) as e:   # e.g. the tower is as high as the arm can stack: put it back
            why = f"cannot place the {key[0]} {key[1]} block ({e})"
            try:       # back down the pick's own line (checked whole first: refused, nothing moves)
                handling.put_back(session)
            except MotionRefused as refused:
                stopped = f"{why}; cannot put it back either ({refused}): the arm holds it where it stopped"
                break
            board = [*obstacles, move.block]
            moves.append(MoveLog(move.describe() + " (cannot place: put back)", t_start, world.time_s - t0, True,
                                 False, np.full(3, np.nan)))
            if strategy.cannot_place(why):
                continue
            stopped = why
            break
        strategy.placed(move)
        board = [*obstacles, Obstacle(float(move.to[0]), float(move.to[1]),
                                      float(move.to[2]) + block_edge(move.block.size), footprint_radius(move.block))]
        err = np.full(3, np.nan)
        if truth:
            o = truth[0]
            err = o.position - (np.asarray(move.to, float) + [0.0, 0.0, o.edge / 2])
        moves.append(MoveLog(move.describe(), t_start, world.time_s - t0, True, True, err))
        if recorder is not None:
            recorder.snapshot(move.describe())
        if supply is not None:
            supply.hand_over()
    else:
        stopped = f"stopped after {max_moves} moves"
    elapsed = world.time_s - t0
    replay = recorder.stop() if recorder is not None else None
    options = supply.score_options() if supply is not None else {}
    if replay is not None and elapsed > limit and recorder.at_limit is not None:
        final = objects_from_snapshot(recorder.at_limit)      # the judges score the board at the time limit
    else:
        final = world.objects
    score = score_event(event, level, final, held=set(world.held), **options)
    return EventResult(event, level, score, elapsed, limit, moves, replay, stopped, looks)
