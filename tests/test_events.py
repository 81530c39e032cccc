"""armlab.tasks.events: scoring by the rules on hand-made world states, strategies on hand-made detections, and a
full autonomous run on the simulator (score from the world's truth, time, replay)."""

from __future__ import annotations

import base64
import re
from dataclasses import dataclass

import numpy as np
import pytest
import umsgpack

from armlab import tasks
from armlab.blocks import COLORS, ObjectState, block_edge
from armlab.sim import World
from armlab.tasks.events import HANDOVER_XY, HandOver, Replay, columns, event_station, run_event, score_event
from armlab.tasks.events.line_up import LineUp, line_slots
from armlab.tasks.events.scoring import score_line_up, score_sky, score_sort_stack, sky_points
from armlab.tasks.events.sort_stack import STACK_XY, SortStack


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
    slots = line_slots(1, -95.0)
    sizes = ("large",) if level == 1 else ("large", "small")
    return numbered([cube(c, s, *slots[(s, c)][:2]) for s in sizes for c in COLORS])


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


# ------------------------------------------------------------------------------------------------ strategies
@dataclass
class Seen:
    """A stand-in detection.Block (top-face centre)."""

    color: str
    size: str
    position: np.ndarray
    yaw: float = 0.0
    shape: str = "cube"
    edge_mm: float | None = None

    @property
    def is_block(self):
        return self.shape == "cube"


def seen(color, size, x, y, levels=1, shape="cube"):
    return Seen(color, size, np.array([x, y, levels * block_edge(size)]), shape=shape)


def test_sort_stack_unstacks_before_stacking_in_rainbow_order():
    s = SortStack(3)
    view = [seen("yellow", "small", 100, 200, 2), seen("red", "large", -150, 200), seen("orange", "small", 0, 250)]
    m = s.next_move(view)
    assert m.why == "unstack" and m.block is view[0]
    assert min(np.linalg.norm(m.to[:2] - np.array([x, y])) for x, y in [(100, 200), (-150, 200), (0, 250)]) > 60
    view = [seen("yellow", "small", *m.to[:2]), seen("blue", "large", 100, 200), view[1], view[2]]
    m = s.next_move(view)
    assert (m.why, m.block.color, tuple(m.to)) == ("stack", "red", (*STACK_XY["large"], 0.0))
    s.placed(m)
    view[2] = seen("red", "large", *STACK_XY["large"])
    m = s.next_move(view)
    assert (m.block.color, tuple(m.to)) == ("orange", (*STACK_XY["small"], 0.0))
    # the look shows the large stack empty after all (the red block fell off): the belief follows the look
    s.placed(m)
    m = s.next_move([seen("red", "large", 250, 50), seen("blue", "large", 100, 200)])
    assert m.block.color == "red" and m.to[2] == 0.0


def test_line_up_avoids_distractors_and_clears_taken_slots():
    base = line_slots(1, -95.0)
    s = LineUp(2)
    view = [seen("red", "large", *base[("small", "green")][:2], shape="distractor"),
            seen("red", "large", 0, 250)]
    m = s.next_move(view)
    assert not any(np.linalg.norm(v[:2] - view[0].position[:2]) < 40 for v in s.slots.values())
    assert np.allclose(m.to, s.slots[("large", "red")])
    # a block standing on another block's slot is moved out of the way first
    s = LineUp(1)
    s.slots = base
    view = [seen("orange", "large", *base[("large", "red")][:2]), seen("red", "large", 0, 250)]
    view[0].position[0] += 15.0
    m = s.next_move(view)
    assert m.block is view[0] and m.why in ("line", "clear")


def test_handover_supplies_one_block_at_a_time():
    world = World()
    h = HandOver(world, seed=1, supply=3)
    first = h.hand_over()
    assert first is not None and np.linalg.norm(first.position[:2] - HANDOVER_XY) < 6 and first.bottom_z == 0
    assert h.hand_over() is None                      # the spot is taken
    first.position[:2] = (150.0, 150.0)
    assert h.hand_over().color == "orange"


# ------------------------------------------------------------------------------------------------ full runs
@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_sort_stack_level_3_runs_to_full_marks_within_the_time_limit(tmp_path):
    station = event_station("sort_stack", 3, seed=0)
    session = tasks.start_session(station)
    result = run_event(session, "sort_stack", 3)
    assert result.score.full_marks, result.score.table()
    assert result.score == score_event("sort_stack", 3, station.world.objects)   # scored from the truth
    assert 0 < result.time_s <= 180 and result.within_limit
    assert np.abs(result.placement_errors[:, :2]).max() < 3.0                   # mm
    r = result.replay
    assert r.q.shape == (len(r.times), 5) and np.all(np.diff(r.times) > 0)
    assert abs(r.duration - result.time_s) < 1e-6
    assert len(r.snapshots) == len(result.moves) + 2
    assert {o.id for o in r.objects_at(0.0)} == {o.id for o in station.world.objects}
    back = Replay.load(r.save(tmp_path / "replay.npz"))
    assert np.array_equal(back.q, r.q) and back.snapshots == r.snapshots
    assert np.array_equal(back.object_poses, r.object_poses, equal_nan=True)
    # the object tracks: the first block moved is lifted off the board while carried and ends where the truth says
    first = result.moves[0]
    moved = [j for j in range(len(r.object_ids)) if np.linalg.norm(r.object_poses[0, j, :2] - r.object_poses[-1, j, :2])
             > 20.0]
    assert moved
    during = (r.times >= first.t_start) & (r.times <= first.t_end)
    lifted = [j for j in moved if np.nanmax(r.object_poses[during, j, 2] - r.object_poses[0, j, 2]) > 30.0]
    assert lifted, "no block was carried during the first move"
    final = {o.id: o.position for o in station.world.objects}
    for j, oid in enumerate(r.object_ids):
        np.testing.assert_allclose(r.object_poses[-1, j, :3], final[int(oid)], atol=1e-9)


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_line_up_level_3_places_its_own_small_blocks_and_scores_full_marks():
    """The line 'em up level-3 run that lost 50 points: its placed small orange cube read 22 x 25 mm (the renderer's
    side face took the top face's edge row), was taken for a distractor blocking the yellow slot, and the line
    stopped. Every block now ends in its line, neat, within 3 mm."""
    station = event_station("line_up", 3, seed=1)
    session = tasks.start_session(station)
    result = run_event(session, "line_up", 3)
    assert result.score.full_marks, result.score.table()
    assert result.within_limit
    assert np.abs(result.placement_errors[:, :2]).max() < 3.0                   # mm


def test_replay_shows_blocks_being_carried_in_the_viewer():
    from armlab.viz import Viewer
    from armlab.viz.viewer import ROOT  # meshcat path: /meshcat/<ROOT>/...

    station = event_station("sort_stack", 1, seed=1)
    session = tasks.start_session(station)
    r = run_event(session, "sort_stack", 1, time_limit_s=25.0).replay
    j = int(np.argmax(np.nanmax(r.object_poses[:, :, 2], axis=0)))       # the block lifted highest
    with Viewer() as viewer:
        r.to_viewer(viewer, fps=5)
        html = viewer.static_html()
    commands = [umsgpack.unpackb(base64.b64decode(b))
                for b in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)]
    anim = [c for c in commands if c["type"] == "set_animation"][-1]
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    clip = clips[f"/meshcat/{ROOT}/objects/{int(r.object_ids[j])}"]
    keys = {t["name"]: t["keys"] for t in clip["tracks"]}[".position"]
    z = np.array([k["value"][2] for k in keys])
    assert z[0] == pytest.approx(r.object_poses[0, j, 2], abs=1e-6) and z.max() > z[0] + 30.0   # carried
    t = np.array([k["time"] for k in keys]) / 5.0
    np.testing.assert_allclose(z, np.interp(t, r.times, r.object_poses[:, j, 2]), atol=1e-6)


def test_time_limit_scores_the_board_at_the_limit():
    station = event_station("sort_stack", 1, seed=1)
    session = tasks.start_session(station)
    result = run_event(session, "sort_stack", 1, time_limit_s=20.0)
    assert result.stopped == "time is up" and not result.within_limit
    assert result.score.points == 30                  # one block placed before 20 s; the rest came too late


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_sky_tower_grows_as_high_as_the_arm_reaches_over_the_best_spot():
    from armlab.tasks import RELEASE_GAP_MM
    from armlab.tasks.events.sky import SKY_CLEARANCE_MM, TOWER_XY, highest_tool_z

    # the tower spot is where the tool reaches highest along its diagonal (within 1 mm)
    reach = {r: highest_tool_z((r / np.sqrt(2), r / np.sqrt(2))) for r in (100, 140, 170, 200, 240)}
    assert highest_tool_z(TOWER_XY) >= max(reach.values()) - 1.0
    assert highest_tool_z(TOWER_XY, top_down=True) < 300.0          # levels above ~6 blocks come in tilted
    station = event_station("sky", seed=0)
    session = tasks.start_session(station)
    result = run_event(session, "sky", record=False)
    tower = len(result.score.lines)
    e = block_edge("large")
    # With contact physics a block released tilted (levels above ~6) lands a few mm off and turned, and the one the
    # arm releases at about 50 deg over a tower of nine topples off it (seed 0: 9 levels; the geometric world, which
    # laid every released block flat, gave 12).
    assert tower >= 8 and result.score.points == sky_points(tower)
    assert station.world.would_move() == []                          # what is scored stands by the physics
    assert "out of reach" in result.stopped
    # the last standing level's hover (top + release gap + up to e/2 for a tilted block's lowest edge + edge +
    # clearance) is within what the arm reaches there (the levels it released higher up fell off)
    hover = lambda level: level * e + RELEASE_GAP_MM + e / 2 + e + SKY_CLEARANCE_MM    # noqa: E731
    assert hover(tower - 1) <= highest_tool_z(TOWER_XY)
