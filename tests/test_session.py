"""The task layer's explicit session (armlab.tasks.session): started by one call that does the calibration and the sag
fit there, passed to everything that needs it; a bare station is refused with a TypeError naming that call, and
nothing is kept on the station."""

from __future__ import annotations

import numpy as np
import pytest

from armlab import make_station, tasks
from armlab.tasks.events import run_event
from armlab.tasks.events.runner import see
from armlab.tasks.experiments import reach_experiment
from armlab.tasks.move_path import drop_with, grab_with
from armlab.ui import ClickToGrab, station_panel
from armlab.ui.click_widget import holding_text, view_is_current

START = r"session = tasks\.start_session\(station\)"


@pytest.fixture(scope="module")
def started():
    station = make_station("sim", seed=0, scene="swap")
    before = dict(vars(station))
    q0, t0 = station.arm.q_true.copy(), station.world.time_s
    session = tasks.start_session(station)
    return station, before, q0, t0, session


def test_starting_a_session_calibrates_and_fits_the_sag_there_and_keeps_nothing_on_the_station(started):
    station, before, q0, t0, session = started
    assert session.station is station and isinstance(session.arm, tasks.GuardedArm)
    assert session.arm.arm is station.arm
    assert session.calibration is not None and "tags" in session.calibration.notes
    assert np.abs(session.arm.sag.params).max() > 0               # fitted on the simulator's empty-board twin
    assert station.world.time_s > t0 and np.abs(station.arm.q_true - q0).max() > 0.01   # it moved out of view
    assert vars(station).keys() == before.keys()                  # no hidden attribute
    assert all(vars(station)[k] is v for k, v in before.items())
    calib, sag = session.calibration, session.arm.sag
    obs = tasks.look(session)                                     # no calibration on first touch: the same ones
    assert session.calibration is calib and session.arm.sag is sag and session.last is obs and obs.blocks


def test_two_sessions_on_one_station_know_their_own_board(started):
    station, _, _, _, session = started
    other = tasks.start_session(station, sag=session.arm.sag, calibration=session.calibration)
    assert other is not session and other.last is None and other.known == []
    tasks.look(other)
    assert other.last is not session.last


def test_a_given_sag_model_and_calibration_are_used_and_nothing_moves(started):
    station, _, _, _, session = started
    q, t = station.arm.q_true.copy(), station.world.time_s
    given = tasks.start_session(station, sag=tasks.SagModel(), calibration=session.calibration)
    assert given.calibration is session.calibration and np.all(given.arm.sag.params == 0)
    assert station.world.time_s == t and np.array_equal(station.arm.q_true, q)
    with pytest.raises(TypeError, match="sag must be a SagModel"):
        tasks.start_session(station, sag="fitted")
    with pytest.raises(TypeError, match="station must be a Station"):
        tasks.start_session(station.arm)


CALLS = {
    "tasks.look": lambda s: tasks.look(s),
    "tasks.pick": lambda s: tasks.pick(s, None),
    "tasks.place": lambda s: tasks.place(s, (0.0, 250.0, 0.0)),
    "tasks.put_back": lambda s: tasks.put_back(s),
    "tasks.click_grab": lambda s: tasks.click_grab(s, (640, 360)),
    "tasks.click_drop": lambda s: tasks.click_drop(s, (640, 360)),
    "tasks.click_world": lambda s: tasks.click_world(s, (640, 360)),
    "tasks.current_view": lambda s: tasks.current_view(s),
    "TaskMachine": lambda s: tasks.TaskMachine(s),
    "grab_with": lambda s: grab_with(s, None),
    "drop_with": lambda s: drop_with(s, (0.0, 250.0, 0.0)),
    "reach_experiment": lambda s: reach_experiment(s, None, lambda: np.zeros(3)),
    "run_event": lambda s: run_event(s, "sort_stack", 1),
    "see": lambda s: see(s),
    "ClickToGrab": lambda s: ClickToGrab(s),
    "station_panel": lambda s: station_panel(s),
    "view_is_current": lambda s: view_is_current(s),
    "holding_text": lambda s: holding_text(s),
}


@pytest.mark.parametrize("name", CALLS)
def test_a_bare_station_is_refused_naming_the_call_that_starts_a_session(name):
    station = make_station("sim", seed=1, scene="swap")
    before, q, t = dict(vars(station)), station.arm.q_true.copy(), station.world.time_s
    with pytest.raises(TypeError, match=START) as refused:
        CALLS[name](station)
    assert str(refused.value).startswith(f"{name} takes a task session, not a station")
    assert station.world.time_s == t and np.array_equal(station.arm.q_true, q)     # nothing moved
    assert vars(station).keys() == before.keys()
    with pytest.raises(TypeError, match=f"{name} takes a task session .*got int"):
        CALLS[name](3)


def test_the_old_hidden_context_is_gone_with_a_pointer_to_the_session():
    for name in ("context", "TaskContext"):
        with pytest.raises(AttributeError, match=START):
            getattr(tasks, name)
