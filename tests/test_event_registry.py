"""The event registry: an event is one module defining EVENT; the runner, event_station, score_event and the
command line find it there. A toy event written in a temporary module (outside the kit) runs through the CLI and
the runner on the simulator."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from armlab.tasks.events import Strategy, events, make_strategy, register, score_event
from armlab.tasks.events import registry as reg

REPO = Path(__file__).resolve().parents[1]

TOY_EVENT = textwrap.dedent('''
    """A toy event: move the red block of the "swap" scene onto SPOT (x, y world mm); 10 points when it rests there."""
    import numpy as np

    from armlab.tasks.events.layout import Move
    from armlab.tasks.events.registry import EventSpec, Strategy
    from armlab.tasks.events.scoring import Score, ScoreLine

    SPOT = (0.0, 300.0)
    NEAR_MM = 15.0


    def _at_spot(position) -> bool:
        return float(np.hypot(position[0] - SPOT[0], position[1] - SPOT[1])) < NEAR_MM


    class RedToSpot(Strategy):
        def __init__(self, level):
            self.level = level

        def next_move(self, seen):
            red = [b for b in seen if b.is_block and b.color == "red" and not _at_spot(b.position)]
            return Move(red[0], np.array([*SPOT, 0.0]), 0.0, "spot") if red else None

        def placed(self, move):
            pass


    def score_red_spot(objects, level, held=(), clicked=False):
        red = [o for o in objects if o.color == "red" and o.id not in set(held)]
        there = [o for o in red if _at_spot(o.position) and abs(o.position[2] - o.edge / 2) < 1.0]
        lines = tuple(ScoreLine(o.id, "red on the spot", 10, "rests on the spot") for o in there)
        points = 10 * len(there)
        return Score("red_spot", level, points / 2 if clicked else points, 10, lines, clicked)


    EVENT = EventSpec("red_spot", "red to the spot", (1,), 120.0, RedToSpot, score_red_spot,
                      scene=lambda level: "swap")
''')


def test_the_kits_events_are_found_in_their_modules():
    specs = events()
    assert list(specs) == ["line_up", "sky", "sort_stack"]            # module order; none listed by hand
    assert (specs["sort_stack"].levels, specs["sort_stack"].time_limit_s) == ((1, 2, 3), 180.0)
    assert (specs["line_up"].time_limit_s, specs["sky"].levels, specs["sky"].time_limit_s) == (600.0, (1,), 600.0)
    assert [specs[n].scene_for(2 if n != "sky" else 1) for n in specs] == ["line_up_2", "empty", "sort_stack_2"]
    assert specs["sky"].detection.max_levels == 13 and specs["sort_stack"].detection is None
    for name in specs:
        assert isinstance(make_strategy(name, 1), Strategy)
    with pytest.raises(ValueError, match="unknown event 'juggling': expected one of"):
        make_strategy("juggling", 1)
    with pytest.raises(ValueError, match=r"sort_stack has levels \(1, 2, 3\), got 4"):
        make_strategy("sort_stack", 4)


class Toy(Strategy):
    """A strategy that never moves."""

    def __init__(self, level):
        self.level = level

    def next_move(self, seen):
        return None

    def placed(self, move):
        pass


def test_register_refuses_a_second_event_of_the_same_name_and_bad_specs(monkeypatch):
    monkeypatch.setattr(reg, "_registered", dict(events()))
    spec = reg.EventSpec("toy", "toy", (1,), 10.0, Toy, lambda *a, **k: None)
    assert register(spec) is spec and register(spec) is spec and "toy" in events()
    with pytest.raises(ValueError, match="already registered"):
        register(reg.EventSpec("toy", "another toy", (1,), 10.0, Toy, lambda *a, **k: None))
    with pytest.raises(ValueError, match="levels"):
        reg.EventSpec("bad", "bad", (), 10.0, Toy, lambda *a, **k: None)
    with pytest.raises(ValueError, match="time_limit_s"):
        reg.EventSpec("bad", "bad", (1,), 0.0, Toy, lambda *a, **k: None)
    with pytest.raises(ValueError, match="identifier"):
        reg.EventSpec("bad name", "bad", (1,), 1.0, Toy, lambda *a, **k: None)
    with pytest.raises(TypeError, match="EventSpec"):
        register("sort_stack")


def test_a_module_named_in_the_environment_that_does_not_import_is_an_error(monkeypatch):
    monkeypatch.setattr(reg, "_registered", {})
    monkeypatch.setattr(reg, "_discovered", False)
    monkeypatch.setenv(reg.EVENT_MODULES_ENV, "no_such_event_module_xyz")
    with pytest.raises(ImportError, match="ARMLAB_EVENT_MODULES names 'no_such_event_module_xyz'"):
        events()


def test_a_new_event_is_one_module_and_runs_through_the_cli_on_the_simulator(tmp_path, monkeypatch):
    (tmp_path / "toy_red_spot.py").write_text(TOY_EVENT)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(tmp_path)]), "MPLBACKEND": "Agg",
           reg.EVENT_MODULES_ENV: "toy_red_spot"}
    run = subprocess.run([sys.executable, "-m", "armlab", "demo", "--event", "red_spot", "--no-html",
                          "--out", str(tmp_path / "out")], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]          # 0: full marks
    assert "red_spot level 1: 10 / 10 points" in run.stdout, run.stdout[-2000:]
    assert "red on the spot" in run.stdout and (tmp_path / "out" / "replay.npz").is_file()
    # in this process: the same module registered by hand, scored by name; its level checked by its spec
    monkeypatch.setattr(reg, "_registered", dict(events()))
    monkeypatch.syspath_prepend(str(tmp_path))
    import toy_red_spot

    register(toy_red_spot.EVENT)
    assert score_event("red_spot", 1, []).points == 0 and score_event("red_spot", 1, []).max_points == 10
    with pytest.raises(ValueError, match="red_spot has levels"):
        score_event("red_spot", 2, [])
    wrong = subprocess.run([sys.executable, "-m", "armlab", "demo", "--event", "red_spot", "--level", "3"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert wrong.returncode == 2 and "red_spot has levels (1,), got --level 3" in wrong.stderr


def test_without_the_kits_strategies_the_events_run_the_generic_search(monkeypatch):
    """In the student release the kit's strategies (armlab.tasks.events.strategies) are left out: every event's
    strategy is then the one-move search over its own scorer, which moves a block only where the rules pay for it
    and stops, saying so, when no move raises the score."""
    import builtins

    import numpy as np

    from armlab.tasks.events.search import KIT_STRATEGIES, SearchStrategy

    real_import = builtins.__import__

    def without_kit(name, *args, **kwargs):
        if name.startswith(KIT_STRATEGIES):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", without_kit)
    monkeypatch.setattr("importlib.import_module", lambda name, *a: without_kit(name))
    for name in events():
        assert type(make_strategy(name, 1)) is SearchStrategy
    with pytest.raises(ValueError, match="levels"):
        make_strategy("line_up", 4)

    class Seen:
        def __init__(self, color, size, x, y):
            self.color, self.size, self.yaw, self.shape = color, size, 0.0, "cube"
            self.position = np.array([x, y, 38.0 if size == "large" else 25.0])
            self.is_block = True

    search = make_strategy("sort_stack", 1)
    wrong, right = Seen("red", "large", -150.0, 200.0), Seen("blue", "small", -200.0, -120.0)
    move = search.next_move([wrong, right])
    assert move.block is wrong and move.to[1] < 0 and move.to[0] > 0 and move.to[2] == 0.0   # large: y < 0, x > 0
    assert search.next_move([Seen("red", "large", 200.0, -120.0), right]) is None and "no move" in search.stopped
