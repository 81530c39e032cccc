"""The kit's own event strategies (armlab.tasks.events.strategies, instructor only: the answers of the exercises
events.sort_stack, events.line_up and events.sky, left out of the student release with this file): on hand-made
detections, and full autonomous runs on the simulator (score from the world's truth, time, replay)."""

from __future__ import annotations

import base64
import re
from dataclasses import dataclass

import numpy as np
import pytest
import umsgpack

from armlab import tasks
from armlab.blocks import block_edge
from armlab.tasks.events import Replay, Strategy, event_station, make_strategy, run_event, score_event
from armlab.tasks.events.scoring import columns, sky_points
from armlab.tasks.events.sort_stack import STACK_XY
from armlab.tasks.events.strategies.line_up import LineUp, line_slots
from armlab.tasks.events.strategies.sky import Sky
from armlab.tasks.events.strategies.sort_stack import SortStack


def test_the_events_run_the_kits_strategies_where_they_are_installed():
    for name, cls in (("sort_stack", SortStack), ("line_up", LineUp), ("sky", Sky)):
        strategy = make_strategy(name, 1)
        assert type(strategy) is cls and isinstance(strategy, Strategy)
    assert not make_strategy("line_up", 1).cannot_place("too high") and make_strategy("sort_stack", 1).obstacles() == []
    sky = make_strategy("sky", 1)
    assert sky.cannot_place("the tower is too high") and "out of reach" in sky.stopped and sky.next_move([]) is None


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
    from armlab.tasks.events.sky import SKY_CLEARANCE_MM, SKY_TOWER_BLOCKS, TOWER_XY, highest_tool_z

    # the tower spot is where the tool reaches highest along its diagonal (within 1 mm)
    reach = {r: highest_tool_z((r / np.sqrt(2), r / np.sqrt(2))) for r in (100, 140, 170, 200, 240)}
    assert highest_tool_z(TOWER_XY) >= max(reach.values()) - 1.0
    assert highest_tool_z(TOWER_XY, top_down=True) < 300.0          # levels above ~6 blocks come in tilted
    station = event_station("sky", seed=0)
    session = tasks.start_session(station)
    result = run_event(session, "sky", record=False)
    tower = len(result.score.lines)
    e = block_edge("large")
    # On the physics world a block let go tilted (levels above ~6) tips flat on landing, off to one side; the kit's
    # strategy aims it by landing_offset so that it lands over the tower (unaimed, the 9th landed 16 mm off). Seed 0
    # builds 12 levels (440 points): the open finger on a tilted block's low side catches it as it tips (without the
    # arm's bodies in the physics, the 10th fell off: 9 levels)
    assert tower >= SKY_TOWER_BLOCKS and result.score.points == sky_points(tower)
    column = max(columns(station.world.objects), key=len)
    off = [float(np.hypot(*(o.position[:2] - TOWER_XY))) for o in column]
    assert max(off) < 12.0, off                                      # a straight tower (mm from its axis): measured
    # 2026-12-07 with grasps by contact and the arm's bodies, twelve levels within 10.5 mm, the same under the other
    # numerics (a level let go tilted lands against the open finger on its low side)
    assert station.world.would_move() == []                          # what is scored stands by the physics
    assert "out of reach" in result.stopped
    # the hover over a tower of n levels (top + release gap + up to e/2 for a tilted block's lowest edge + edge +
    # clearance) is what placing level n + 1 needs: the tower is as tall as the arm's reach over its spot allows
    hover = lambda level: level * e + RELEASE_GAP_MM + e / 2 + e + SKY_CLEARANCE_MM    # noqa: E731
    assert hover(tower - 1) <= highest_tool_z(TOWER_XY) < hover(tower)
