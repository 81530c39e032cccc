"""A lab's own events and station backends, installed as a distribution, are found through the entry-point groups
`armlab.events` and `armlab.station_backends` (Python's plugin convention; the environment variables
ARMLAB_EVENT_MODULES / ARMLAB_STATION_MODULES still work, tests/test_event_registry.py and
tests/test_station_contract.py). The distribution here is built and installed by pip from a pyproject.toml."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from test_event_registry import TOY_EVENT

from armlab.station import registry as station_registry
from armlab.tasks.events import registry as event_registry

PYPROJECT = textwrap.dedent('''
    [build-system]
    requires = ["setuptools>=68"]
    build-backend = "setuptools.build_meta"

    [project]
    name = "armlab-toy-lab"
    version = "1.0"

    [tool.setuptools]
    py-modules = ["toy_lab_rig", "toy_lab_event"]

    [project.entry-points."armlab.station_backends"]
    toy_rig = "toy_lab_rig:make_rig"

    [project.entry-points."armlab.events"]
    red_spot = "toy_lab_event"
''')

RIG = textwrap.dedent('''
    """A lab's rig: here the simulator on an empty board."""
    from armlab.sim import make_sim_station


    def make_rig(**options):
        return make_sim_station(scene="empty", **options)
''')


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The toy lab's distribution, installed by pip into a folder of its own (not yet on sys.path)."""
    src, target = tmp_path_factory.mktemp("toy_lab"), tmp_path_factory.mktemp("site")
    (src / "pyproject.toml").write_text(PYPROJECT)
    (src / "toy_lab_rig.py").write_text(RIG)
    (src / "toy_lab_event.py").write_text(TOY_EVENT)
    run = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target),
                          str(src)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    assert list(target.glob("armlab_toy_lab-1.0.dist-info/entry_points.txt"))
    return target


@pytest.fixture
def fresh_registries(monkeypatch):
    """Both registries as before any discovery, restored after the test."""
    monkeypatch.setattr(event_registry, "_registered", {})
    monkeypatch.setattr(event_registry, "_discovered", False)
    monkeypatch.setattr(station_registry, "BACKENDS", dict(station_registry.BACKENDS))
    monkeypatch.setattr(station_registry, "_registered_entry_points", set())
    monkeypatch.delenv(event_registry.EVENT_MODULES_ENV, raising=False)
    monkeypatch.delenv(station_registry.STATION_MODULES_ENV, raising=False)


def test_an_installed_backend_is_built_by_name(installed, fresh_registries, monkeypatch):
    assert "toy_rig" not in station_registry.backend_names()        # not installed on this path yet
    monkeypatch.syspath_prepend(str(installed))
    assert station_registry.backend_names()[-1] == "toy_rig"
    assert station_registry.BACKENDS["toy_rig"] == "toy_lab_rig:make_rig"    # imported only when built
    assert "toy_lab_rig" not in sys.modules
    with station_registry.make_station("toy_rig", seed=3) as station:
        assert station.kind == "sim" and station.world.objects == []


def test_an_installed_event_is_registered_and_scored(installed, fresh_registries, monkeypatch):
    assert "red_spot" not in event_registry.events()
    monkeypatch.setattr(event_registry, "_registered", {})
    monkeypatch.setattr(event_registry, "_discovered", False)
    monkeypatch.syspath_prepend(str(installed))
    specs = event_registry.events()
    assert list(specs)[:3] == ["line_up", "sky", "sort_stack"] and "red_spot" in specs     # the kit's first
    assert event_registry.score_event("red_spot", 1, []).max_points == 10


def test_a_bad_entry_point_is_an_error_naming_it(tmp_path, fresh_registries, monkeypatch):
    info = tmp_path / "armlab_broken-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: armlab-broken\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[armlab.events]\nnothing = json\n\n"
                                           "[armlab.station_backends]\nsim = json:loads\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(TypeError, match=r"entry point 'nothing' \(json\) in armlab.events is neither an EventSpec"):
        event_registry.events()
    with pytest.raises(ValueError, match=r"entry point 'sim' of armlab-broken in armlab.station_backends: .*already"):
        station_registry.backend_names()
