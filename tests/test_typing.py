"""The package is typed for its users' type checkers: it ships py.typed, and every public function or method that
takes a station says it is a `armlab.station.contract.Station`, and one that takes a task session that it is a
`armlab.tasks.Session`."""

from __future__ import annotations

import importlib
import inspect
import typing
from pathlib import Path

from armlab.station.contract import Station
from armlab.tasks.session import Session
from tools import load_tool

ROOT = Path(__file__).resolve().parents[1]


def public_callables():
    for name in load_tool("api-docs").public_modules():       # the modules the API reference documents
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", ()):
            obj = getattr(module, attr, None)
            if inspect.isfunction(obj) and obj.__module__ == name:
                yield f"{name}.{attr}", obj
            elif inspect.isclass(obj) and obj.__module__ == name:
                yield f"{name}.{attr}.__init__", obj.__init__


def test_the_package_ships_py_typed():
    assert (ROOT / "armlab" / "py.typed").is_file()


def test_every_public_station_and_session_parameter_is_typed():
    checked, untyped = {"station": 0, "session": 0}, []
    for where, fn in public_callables():
        try:
            params = inspect.signature(fn).parameters
        except (TypeError, ValueError):
            continue
        for name, wanted in (("station", Station), ("session", Session)):
            if name in params:
                checked[name] += 1
                if typing.get_type_hints(fn).get(name) is not wanted:
                    untyped.append(f"{where}({name})")
    assert checked["station"] >= 5 and checked["session"] >= 15, checked
    assert not untyped, f"station / session parameters without their type: {untyped}"
