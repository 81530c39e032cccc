"""armlab.tasks.events: scoring by the rules on hand-made world states and the to-the-sky hand-over (the kit's
strategies, instructor only, are tested in test_event_strategies.py)."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.blocks import COLORS, ObjectState, block_edge
from armlab.sim import World
from armlab.tasks.events import HANDOVER_XY, HandOver, columns, score_event
from armlab.tasks.events.scoring import score_line_up, score_sky, score_sort_stack, sky_points
from armlab.tasks.events.sort_stack import STACK_XY


def cube(color, size, x, y, level=0, yaw=0.0, oid=None, shape="cube", below=None):
    """A cube resting on the board (level 0) or on `below` blocks of its size (level k: k edges up)."""
    e = block_edge(size)
    z0 = level * e if below is None else below
    return ObjectState(color, size, e, np.array([x, y, z0 + e / 2]), yaw, shape, 0 if oid is None else oid)


def numbered(objs):
    for i, o in enumerate(objs):
        o.id = i
    assert World(objs).problems() == []          # hand-made states are physically valid
    return objs


# ------------------------------------------------------------------------------------------------ sort 'n stack
def rainbow_stacks(large=("red", "green", "violet"), small=("orange", "yellow", "blue")):
    (lx, ly), (sx, sy) = STACK_XY["large"], STACK_XY["small"]
    return numbered([cube(c, "large", lx, ly, k) for k, c in enumerate(large)]
                    + [cube(c, "small", sx, sy, k) for k, c in enumerate(small)])


def test_sort_stack_full_marks_for_rainbow_stacks_in_their_areas():
    s = score_sort_stack(rainbow_stacks(), level=3)
    assert (s.points, s.max_points, s.full_marks) == (180, 180, True)


def test_sort_stack_out_of_order_block_and_everything_above_it_lose_points():
    s = score_sort_stack(rainbow_stacks(large=("green", "red", "violet")), level=2)
    by_colour = {ln.what: ln.points for ln in s.lines}
    assert by_colour["large green"] == 30 and by_colour["large red"] == 0 and by_colour["large violet"] == 0
    assert s.points == 120
    assert score_sort_stack(rainbow_stacks(large=("green", "red", "violet")), level=1).points == 180  # no order


def test_sort_stack_wrong_side_and_separate_blocks():
    objs = numbered([cube("red", "large", -200, -100), cube("blue", "small", -150, -100),
                     cube("green", "large", 200, 100)])
    s = score_sort_stack(objs, level=1)
    assert [ln.points for ln in s.lines] == [0, 30, 0]
    # level 2: two large blocks side by side in the area are not one stack: only the main stack's block counts
    objs = numbered([cube("red", "large", 150, -100), cube("green", "large", 250, -100)])
    assert score_sort_stack(objs, level=2).points == 30


def test_held_and_tilted_blocks_are_not_at_rest():
    objs = rainbow_stacks()
    assert score_sort_stack(objs, 3, held={objs[1].id}).points == 30 + 90     # large stack stops under the held one
    objs[5].tilt = np.array([0.3, 0.0])
    assert score_sort_stack(objs, 3, held={objs[1].id}).points == 30 + 60


def test_columns_follow_supports_bottom_first():
    objs = rainbow_stacks()
    cols = sorted(columns(objs), key=lambda c: c[0].position[0])
    assert [[o.color for o in c] for c in cols] == [["orange", "yellow", "blue"], ["red", "green", "violet"]]


# ------------------------------------------------------------------------------------------------ line 'em up
def perfect_lines(level=2):
    # both lines along x at y = -95 mm, red nearest the base: large at x = 110, 160, ..., small at -110, -150, ...
    sizes = ("large",) if level == 1 else ("large", "small")
    pitch, side = {"large": 50.0, "small": 40.0}, {"large": 1.0, "small": -1.0}
    return numbered([cube(c, s, side[s] * (110.0 + k * pitch[s]), -95.0) for s in sizes for k, c in enumerate(COLORS)])


def test_line_up_full_marks_and_rules():
    assert score_line_up(perfect_lines(1), 1).points == 200
    objs = perfect_lines(2)
    s = score_line_up(objs, 2)
    assert (s.points, s.max_points) == (400, 400)
    # a block 40 mm off its line loses its 30 and the neatness 20
    objs[2].position[1] += 40.0
    assert score_line_up(objs, 2).points == 400 - 30 - 20
    # swapping two neighbours breaks the rainbow order for both
    objs = perfect_lines(2)
    objs[0].position[0], objs[1].position[0] = objs[1].position[0], objs[0].position[0]
    assert score_line_up(objs, 2).points == 400 - 60 - 20
    # reading the line from the other end is rainbow order too
    objs = perfect_lines(1)
    for o in objs:
        o.position[0] = 500.0 - o.position[0]
    assert score_line_up(objs, 1).points == 200


def test_line_up_line_too_long_and_two_points_are_no_line():
    objs = numbered([cube(c, "large", 60.0 * k - 150, 300.0) for k, c in enumerate(COLORS)])   # 338 mm long
    s = score_line_up(objs, 1)
    assert s.points == 0 and "long" in s.lines[0].why
    objs = numbered([cube("red", "large", 150, 150), cube("blue", "large", -150, 250),
                     cube("green", "large", 250, -100)])
    assert score_line_up(objs, 1).points == 0     # three scattered blocks: no three on a line


def test_line_up_yawed_blocks_are_not_neat():
    objs = perfect_lines(1)
    objs[3].yaw = np.radians(20)
    s = score_line_up(objs, 1)
    assert s.points == 180


# ------------------------------------------------------------------------------------------------ to the sky
def test_sky_points_and_tallest_tower():
    assert [sky_points(n) for n in (0, 1, 8, 9, 12, 20)] == [0, 30, 240, 290, 440, 840]
    tower = [cube(COLORS[k % 6], "large", 150, 150, k) for k in range(10)]
    waiting = cube("red", "large", *HANDOVER_XY)
    objs = numbered([*tower, waiting, cube("blue", "large", 0, 300), cube("red", "large", 0, 300, 1)])
    s = score_sky(objs, n_handed=13, handover_xy=HANDOVER_XY)
    assert s.points == 8 * 30 + 2 * 50 and s.max_points == sky_points(13)
    only_waiting = numbered([cube("red", "large", *HANDOVER_XY)])
    assert score_sky(only_waiting, handover_xy=HANDOVER_XY).points == 0


def test_click_penalty_and_bad_input():
    assert score_event("sort_stack", 3, rainbow_stacks(), clicked=True).points == 90
    with pytest.raises(ValueError, match="unknown event"):
        score_event("juggling", 1, [])
    with pytest.raises(ValueError, match="levels"):
        score_event("sky", 2, [])
    with pytest.raises(ValueError, match="no scoring options"):
        score_event("line_up", 1, [], handover_xy=(0, 0))


def test_handover_supplies_one_block_at_a_time():
    world = World()
    h = HandOver(world, seed=1, supply=3)
    first = h.hand_over()
    assert first is not None and np.linalg.norm(first.position[:2] - HANDOVER_XY) < 6 and first.bottom_z == 0
    assert h.hand_over() is None                      # the spot is taken
    first.position[:2] = (150.0, 150.0)
    assert h.hand_over().color == "orange"
