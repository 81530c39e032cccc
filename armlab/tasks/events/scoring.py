"""Scoring of the competition events from a world state (the ground truth), by the rules of docs/course/competition.md.

Every scorer takes the objects on the board (armlab.blocks.ObjectState: centre position in world mm, yaw rad) and
returns a Score with one line per block. Only objects at rest count: an object rests when its bottom face lies on
the board or on the top face of an object under its footprint (within REST_TOL_MM), it is not tilted, and (for a
held object, passed in `held`) it is not in the gripper. Distractors never score.

Rules as implemented (the course rules leave some details open; the choices are stated here):
- Sort 'n stack: small blocks go left (x < 0), large right (x > 0), both into y < 0; +30 per block there.
  Levels 2 and 3: the blocks of each size must form one stack in rainbow order with red at the bottom: a block scores
  when it sits in the column holding most of its size in its area and every block below it is of its size with an
  earlier rainbow colour.
- Line 'em up: the large and the small blocks each in one line standing on the board, in rainbow order read from
  either end. The line of a size is the straight line with the most of its blocks' centres within LINE_TOL_MM
  (exhaustive over pairs, refitted by least squares), and it must hold at least 3 of them (two points always make a
  line) or all of its size when there are fewer; a block scores +30 when its centre is within LINE_TOL_MM of its
  line, its place along the line is its colour's rank among the line's blocks, and the line (outer faces, along its
  direction) is shorter than LINE_MAX_MM. Neatness: +20 per line when every block of the size scores, every centre is
  within NEAT_OFFSET_MM of the line and every block is square to it within NEAT_YAW_RAD.
- To the sky: the tallest column of large blocks standing on the board (not at the hand-over spot, where the blocks
  are handed over, when one is given); 30 points for each of the first 8 blocks,
  50 for each block above.
- Click penalty: an event solved by clicking instead of autonomy scores half (`clicked=True`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from armlab.blocks import COLORS, ObjectState
from armlab.sim.geometry import polygons_overlap, wrap_quarter

__all__ = ["Score", "ScoreLine", "score_sort_stack", "score_line_up", "score_sky", "SORT_STACK_LEVELS",
           "LINE_UP_LEVELS", "SKY_LEVELS", "columns", "REST_TOL_MM", "LINE_TOL_MM", "LINE_MAX_MM", "BLOCK_POINTS",
           "NEATNESS_POINTS", "sky_points"]

SORT_STACK_LEVELS: tuple[int, ...] = (1, 2, 3)    # the levels each scorer knows (the event specs name them)
LINE_UP_LEVELS: tuple[int, ...] = (1, 2, 3)
SKY_LEVELS: tuple[int, ...] = (1,)

REST_TOL_MM = 1.0              # a bottom face this close to a top face (or the board) rests on it
BLOCK_POINTS = 30
NEATNESS_POINTS = 20
LINE_TOL_MM = 30.0             # block centres within this of their line
LINE_MAX_MM = 300.0            # each line shorter than this
MIN_LINE = 3                   # a line holds at least this many blocks (or all of its size when fewer)
NEAT_OFFSET_MM = 10.0          # neatness: centres this close to the line
NEAT_YAW_RAD = float(np.radians(10.0))   # neatness: blocks this square to the line
HANDOVER_RADIUS_MM = 30.0      # to the sky: a column standing this close to the hand-over spot is not the tower
SKY_FIRST, SKY_FIRST_POINTS, SKY_LATER_POINTS = 8, 30, 50


@dataclass(frozen=True)
class ScoreLine:
    """One scored item: the object's id (None for a bonus), what it is, the points it earned and why."""

    object_id: int | None
    what: str
    points: int
    why: str


@dataclass(frozen=True)
class Score:
    """An event's score: points earned, the most possible for this board, and one line per block or bonus."""

    event: str
    level: int
    points: float
    max_points: int
    lines: tuple[ScoreLine, ...] = field(default=())
    clicked: bool = False

    @property
    def full_marks(self) -> bool:
        return self.points >= self.max_points

    def table(self) -> str:
        """The score as a small text table (one row per line, then the total)."""
        rows = [f"{'object':>6}  {'what':<22} {'points':>6}  why"]
        for ln in self.lines:
            oid = "-" if ln.object_id is None else str(ln.object_id)
            rows.append(f"{oid:>6}  {ln.what:<22} {ln.points:>6}  {ln.why}")
        half = " (clicked: half)" if self.clicked else ""
        rows.append(f"{'':>6}  {'total':<22} {self.points:>6g}  of {self.max_points}{half}")
        return "\n".join(rows)


def _name(o: ObjectState) -> str:
    return f"{o.size} {o.color}"


def _rank(color: str) -> int:
    return COLORS.index(color)


# ---------------------------------------------------------------------------------------------------------------
# Resting and columns
# ---------------------------------------------------------------------------------------------------------------

def _supports(objects: list[ObjectState], held: set[int]) -> dict[int, int | None | str]:
    """For each object id: the id of the object it rests on, None for the board, "loose" when it does not rest."""
    out: dict[int, int | None | str] = {}
    for o in objects:
        if o.id in held or np.abs(np.asarray(o.tilt, float)).max() > 1e-6:
            out[o.id] = "loose"
            continue
        if abs(o.bottom_z) <= REST_TOL_MM:
            out[o.id] = None
            continue
        under = [b for b in objects if b is not o and b.id not in held and abs(b.top_z - o.bottom_z) <= REST_TOL_MM
                 and any(polygons_overlap(p, q) for p in o.footprint_world() for q in b.footprint_world())]
        # the support nearest the object's centre (a block bridging two others rests on the one under its centre)
        out[o.id] = min(under, key=lambda b: np.linalg.norm(b.position[:2] - o.position[:2])).id if under else "loose"
    # an object resting on a loose one is loose too
    changed = True
    while changed:
        changed = False
        for k, s in out.items():
            if isinstance(s, int) and out.get(s) == "loose":
                out[k], changed = "loose", True
    return out


def columns(objects: Iterable[ObjectState], held: Iterable[int] = ()) -> list[list[ObjectState]]:
    """The columns standing on the board, each bottom first: for every object at rest with nothing resting on it,
    the chain of objects below it down to the board. Loose objects (floating, tilted, held) are in no column."""
    objects = list(objects)
    sup = _supports(objects, set(held))
    by_id = {o.id: o for o in objects}
    has_child = {s for s in sup.values() if isinstance(s, int)}
    out = []
    for o in objects:
        if sup[o.id] == "loose" or o.id in has_child:
            continue
        chain, cur = [], o
        while cur is not None:
            chain.append(cur)
            s = sup[cur.id]
            cur = by_id[s] if isinstance(s, int) else None
        out.append(chain[::-1])
    return out


# ---------------------------------------------------------------------------------------------------------------
# Sort 'n stack
# ---------------------------------------------------------------------------------------------------------------

def _sort_area_ok(o: ObjectState) -> bool:
    x, y = o.position[:2]
    return bool(y < 0 and (x > 0 if o.size == "large" else x < 0))


def score_sort_stack(objects: Iterable[ObjectState], level: int, held: Iterable[int] = (),
                     clicked: bool = False) -> Score:
    """Sort 'n stack (module notes): +30 per block in its area (and, at levels 2-3, in its rainbow stack)."""
    objects, held, sup, blocks = _board_state("sort_stack", SORT_STACK_LEVELS, level, objects, held)
    cols = columns(objects, held)
    main: dict[str, list[ObjectState]] = {}
    for size in ("large", "small"):
        in_area = [c for c in cols if c and _sort_area_ok(c[0])]
        main[size] = max(in_area, key=lambda c: sum(o.is_block and o.size == size for o in c), default=[])
    lines = []
    for b in blocks:
        if sup[b.id] == "loose":
            lines.append(ScoreLine(b.id, _name(b), 0, "not at rest"))
        elif not _sort_area_ok(b):
            side = "x > 0" if b.size == "large" else "x < 0"
            lines.append(ScoreLine(b.id, _name(b), 0, f"outside its area (y < 0, {side})"))
        elif level == 1:
            lines.append(ScoreLine(b.id, _name(b), BLOCK_POINTS, "in its area"))
        else:
            stack = main[b.size]
            ids = [o.id for o in stack]
            if b.id not in ids:
                lines.append(ScoreLine(b.id, _name(b), 0, f"not in the {b.size} stack"))
                continue
            below = stack[:ids.index(b.id) + 1]
            same = all(o.is_block and o.size == b.size for o in below)
            rainbow = all(_rank(a.color) < _rank(c.color) for a, c in zip(below, below[1:]))
            if same and rainbow:
                lines.append(ScoreLine(b.id, _name(b), BLOCK_POINTS, f"level {len(below)} of the {b.size} stack"))
            else:
                lines.append(ScoreLine(b.id, _name(b), 0, "stack below it is not rainbow order of its size"))
    return _total("sort_stack", level, lines, BLOCK_POINTS * len(blocks), clicked)


# ---------------------------------------------------------------------------------------------------------------
# Line 'em up
# ---------------------------------------------------------------------------------------------------------------

def _fit_line(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total least squares line through points (N, 2): a point on it and its unit direction (x >= 0, or +y)."""
    c = xy.mean(axis=0)
    if len(xy) < 2:
        return c, np.array([1.0, 0.0])
    d = np.linalg.svd(xy - c)[2][0]
    if d[0] < -1e-9 or (abs(d[0]) <= 1e-9 and d[1] < 0):
        d = -d
    return c, d


def _best_line(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(point, direction, inlier mask): the line with the most centres within LINE_TOL_MM (over all pairs)."""
    best = (xy.mean(axis=0), np.array([1.0, 0.0]), np.ones(len(xy), bool))
    if len(xy) < 2:
        return best
    best_n, best_res = -1, np.inf
    for i, j in combinations(range(len(xy)), 2):
        c, d = _fit_line(xy[[i, j]])
        inl = np.abs((xy - c) @ np.array([-d[1], d[0]])) <= LINE_TOL_MM
        c, d = _fit_line(xy[inl])
        off = np.abs((xy - c) @ np.array([-d[1], d[0]]))
        inl = off <= LINE_TOL_MM
        res = float(off[inl].sum())
        if inl.sum() > best_n or (inl.sum() == best_n and res < best_res):
            best_n, best_res, best = int(inl.sum()), res, (c, d, inl)
    return best


def score_line_up(objects: Iterable[ObjectState], level: int, held: Iterable[int] = (),
                  clicked: bool = False) -> Score:
    """Line 'em up (module notes): +30 per block in its size's rainbow line, +20 per neat line."""
    objects, held, sup, blocks = _board_state("line_up", LINE_UP_LEVELS, level, objects, held)
    lines: list[ScoreLine] = []
    sizes = [s for s in ("large", "small") if any(b.size == s for b in blocks)]
    for size in sizes:
        group = [b for b in blocks if b.size == size]
        on_board = [b for b in group if sup[b.id] is None]
        for b in group:
            if sup[b.id] is not None:
                lines.append(ScoreLine(b.id, _name(b), 0, "not standing on the board"))
        if not on_board:
            lines.append(ScoreLine(None, f"{size} line neatness", 0, "no line"))
            continue
        xy = np.array([b.position[:2] for b in on_board])
        c, d, inl = _best_line(xy)
        if inl.sum() < min(MIN_LINE, len(group)):      # two points are always in a line: no line yet
            inl = np.zeros(len(on_board), bool)
        normal = np.array([-d[1], d[0]])
        along = (xy - c) @ d
        members = [b for b, k in zip(on_board, inl) if k]
        if members:
            ext = np.concatenate([np.vstack(b.footprint_world()) for b in members]) - c
            length = float((ext @ d).max() - (ext @ d).min())
        else:
            length = 0.0
        order = [members[k] for k in np.argsort(along[inl], kind="stable")]
        expected = sorted(members, key=lambda b: _rank(b.color))
        forward = [a.id == e.id or a.color == e.color for a, e in zip(order, expected)]
        backward = [a.id == e.id or a.color == e.color for a, e in zip(order[::-1], expected)]
        right = forward if sum(forward) >= sum(backward) else backward[::-1]
        in_place = {b.id: ok for b, ok in zip(order, right)}
        scored = 0
        for b, off in zip(on_board, np.abs((xy - c) @ normal)):
            if b.id not in in_place:
                lines.append(ScoreLine(b.id, _name(b), 0, f"{off:.0f} mm from the {size} line (> {LINE_TOL_MM:.0f})"))
            elif length >= LINE_MAX_MM:
                lines.append(ScoreLine(b.id, _name(b), 0, f"the {size} line is {length:.0f} mm long "
                                                          f"(>= {LINE_MAX_MM:.0f})"))
            elif not in_place[b.id]:
                lines.append(ScoreLine(b.id, _name(b), 0, f"out of rainbow order in the {size} line"))
            else:
                scored += 1
                lines.append(ScoreLine(b.id, _name(b), BLOCK_POINTS, f"in the {size} line, {off:.1f} mm off it"))
        offsets = np.abs((xy - c) @ normal)
        line_yaw = np.arctan2(d[1], d[0])
        square = all(abs(float(wrap_quarter(b.yaw - line_yaw))) <= NEAT_YAW_RAD for b in on_board)
        neat = scored == len(group) and offsets.max() <= NEAT_OFFSET_MM and square
        why = (f"{length:.0f} mm long, centres within {offsets.max():.1f} mm, square" if neat else
               "needs every block in place, centres within 10 mm and faces square to the line within 10 deg")
        lines.append(ScoreLine(None, f"{size} line neatness", NEATNESS_POINTS if neat else 0, why))
    return _total("line_up", level, lines, BLOCK_POINTS * len(blocks) + NEATNESS_POINTS * len(sizes), clicked)


# ---------------------------------------------------------------------------------------------------------------
# To the sky
# ---------------------------------------------------------------------------------------------------------------

def sky_points(n_blocks: int) -> int:
    """Points for a tower of n large blocks: 30 each for the first 8, 50 for each one above."""
    n = int(n_blocks)
    return SKY_FIRST_POINTS * min(n, SKY_FIRST) + SKY_LATER_POINTS * max(n - SKY_FIRST, 0)


def score_sky(objects: Iterable[ObjectState], level: int = 1, held: Iterable[int] = (), clicked: bool = False,
              n_handed: int | None = None, handover_xy=None) -> Score:
    """To the sky: the tallest column of large blocks standing on the board (module notes).

    n_handed: how many blocks were handed over (the most the tower could hold; default: the large blocks present).
    handover_xy: (x, y) world mm of the hand-over spot: a column standing within HANDOVER_RADIUS_MM of it is a block
    waiting to be stacked, not a tower.
    """
    _check_level("sky", SKY_LEVELS, level)
    objects = list(objects)
    cols = columns(objects, held)
    if handover_xy is not None:
        spot = np.asarray(handover_xy, float).reshape(2)
        cols = [c for c in cols if np.linalg.norm(c[0].position[:2] - spot) > HANDOVER_RADIUS_MM]

    def run(col):  # the large blocks from the board up, until anything else
        out = []
        for o in col:
            if not (o.is_block and o.size == "large"):
                break
            out.append(o)
        return out

    tower = max((run(c) for c in cols), key=len, default=[])
    lines = [ScoreLine(o.id, _name(o), SKY_FIRST_POINTS if k < SKY_FIRST else SKY_LATER_POINTS,
                       f"tower level {k + 1}, top at {o.top_z:.0f} mm") for k, o in enumerate(tower)]
    n = sum(o.is_block and o.size == "large" for o in objects) if n_handed is None else int(n_handed)
    return _total("sky", level, lines, sky_points(n), clicked)


# ---------------------------------------------------------------------------------------------------------------

def _check_level(event: str, levels: tuple[int, ...], level: int) -> None:
    if isinstance(level, bool) or level not in levels:
        raise ValueError(f"{event} has levels {levels}, got {level!r}")


def _board_state(event: str, levels: tuple[int, ...], level: int, objects: Iterable[ObjectState],
                 held: Iterable[int]):
    """Check the level; return (objects as a list, held ids as a set, what each object rests on, the blocks)."""
    _check_level(event, levels, level)
    objects, held = list(objects), set(held)
    return objects, held, _supports(objects, held), [o for o in objects if o.is_block]


def _total(event: str, level: int, lines: list[ScoreLine], most: int, clicked: bool) -> Score:
    points = sum(ln.points for ln in lines)
    return Score(event, level, points / 2 if clicked else points, most, tuple(lines), bool(clicked))
