"""Issue 14's follow-ups: a pick chooses the pair of faces by its open pads' clearance from the neighbours (an open
pad used to brush a neighbour 60 mm away and turn it), and a block that cannot be placed is put back down the pick's
own line, checked whole first (the event runner's put-back could itself be refused mid-way)."""

from __future__ import annotations

import numpy as np
import pytest

from armlab import make_station, planning, tasks
from armlab.kinematics import Unreachable
from armlab.station import MotionRefused
from armlab.tasks.events import run_event
from armlab.tasks.events.layout import Move


def _scene(*cubes) -> dict:
    return {"objects": [{"color": c, "size": "large", "position_mm": [x, y], "yaw_rad": yaw}
                        for c, x, y, yaw in cubes]}


def test_a_pick_takes_the_other_pair_of_faces_when_an_open_pad_would_brush_a_neighbour():
    # the red block straight ahead, yaw 0: the smaller wrist turn closes the pads along x, and the open pad's outer
    # face (37 mm out) would reach the blue neighbour's corner (60 mm away, turned 0.5 rad: 34 mm out)
    st = make_station("sim", seed=1, scene=_scene(("red", 0.0, 250.0, 0.0), ("blue", 60.0, 250.0, 0.5)))
    session = tasks.start_session(st)
    red = next(b for b in tasks.look(session).blocks if b.color == "red")
    blue = next(o for o in st.world.blocks if o.color == "blue")
    before, yaw = blue.position.copy(), blue.yaw
    obstacles = planning.as_obstacles([b for b in session.known if b.color != "red"])
    target = np.array([*red.position[:2], red.position[2] - 19.0])
    heading = float(np.arctan2(target[1], target[0]))
    smaller = planning.face_roll(heading, float(red.yaw))
    assert planning.pad_clearance(target, heading, smaller, obstacles) < planning.PAD_CLEARANCE_MM
    g = planning.choose_grasp(target, float(red.yaw), obstacles=obstacles)
    assert g.top_down and abs(abs(g.roll - smaller) - np.pi / 2) < 1e-9 and g.misalignment < 1e-9
    assert planning.pad_clearance(target, heading, g.roll, obstacles) > 10.0
    assert tasks.pick(session, red)
    np.testing.assert_allclose(blue.position, before, atol=1e-6)       # not brushed: it stays where it stood
    assert blue.yaw == pytest.approx(yaw, abs=1e-9)


@pytest.fixture(scope="module")
def picked():
    st = make_station("sim", seed=0)
    session = tasks.start_session(st)
    block = next(b for b in tasks.look(session).blocks if b.size == "large")
    truth = min(st.world.blocks, key=lambda o: np.hypot(*(o.position[:2] - block.position[:2])))
    return session, block, truth, truth.position.copy()


def test_a_block_that_cannot_be_placed_is_put_back_where_it_was_picked(picked):
    session, block, truth, start = picked
    st = session.station
    with pytest.raises(ValueError, match="put_back needs a block"):
        tasks.put_back(session)
    assert tasks.pick(session, block)
    with pytest.raises(MotionRefused, match=r"refused before moving: \(0, 700\) mm is off the board"):
        tasks.place(session, (0.0, 700.0, 0.0))                       # the placement rule: nothing moves
    with pytest.raises(Unreachable):
        tasks.place(session, (0.0, -150.0, 0.0))                      # allowed, but the arm cannot get there
    # a put-back that would carry the block into something is refused before moving, still holding it
    saved = session.known
    session.known = [*saved, planning.Obstacle(float(start[0]) + 30.0, float(start[1]), 30.0, 12.0)]
    sent = len(session.arm.sent)
    with pytest.raises(MotionRefused, match="putting the .* block back .* refused before moving"):
        tasks.put_back(session)
    assert len(session.arm.sent) == sent and truth in st.arm.holding
    session.known = saved
    assert tasks.put_back(session) and not st.arm.holding and session.held is None
    assert np.abs(truth.position - start).max() < 1.5, truth.position - start     # back on its spot
    assert tasks.pick(session, block)                                              # and picked again from there
    assert tasks.place(session, (start[0], start[1], 0.0))


class _NowhereToGo:
    """A strategy that moves one block to a spot out of reach, then stops."""

    def __init__(self):
        self.done = False

    def next_move(self, seen):
        if self.done:
            return None
        self.done = True
        block = next(b for b in seen if b.size == "large")
        return Move(block, np.array([0.0, 700.0, 0.0]), 0.0, "test")

    def placed(self, move):
        raise AssertionError("the place cannot have been done")


def test_the_event_runner_puts_a_block_it_cannot_place_back():
    st = make_station("sim", seed=0)
    session = tasks.start_session(st)
    result = run_event(session, "sort_stack", 1, strategy=_NowhereToGo(), record=False)
    (log,) = result.moves
    assert log.picked and not log.placed and log.move.endswith("(cannot place: put back)")
    assert not st.arm.holding and not st.world.problems()
