"""The station backends by name, and `make_station(kind, **options)`, which builds one.

A backend is a function `(**options) -> Station` in a module of its own that implements the contract
(armlab.station.contract). BACKENDS names it as "module:function" and the module is imported only when a station of
that kind is built, so the contract, the backends and this registry import no one in a circle, and
`import armlab` loads no backend. A new backend is one module: the kit's own get a line in BACKENDS; a lab's own
rig, outside the kit, is found in one of three ways:

- an installed distribution declares it in the entry-point group `armlab.station_backends` (name = the kind, value
  = "module:function", imported only when a station of that kind is built):

      # the rig's pyproject.toml
      [project.entry-points."armlab.station_backends"]
      rig = "my_rig:make_rig_station"

- a module named in the environment variable ARMLAB_STATION_MODULES (comma-separated importable names, imported when
  a station is first built or the backends are listed) defines `STATION_BACKENDS = {kind: factory}`:

      # my_rig.py, on the path, with ARMLAB_STATION_MODULES=my_rig
      STATION_BACKENDS = {"rig": make_rig_station}      # (**options) -> armlab.station.contract.Station

- code calls `register_backend` itself.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from importlib.metadata import entry_points

from armlab.station.contract import Station

__all__ = ["BACKENDS", "register_backend", "backend_names", "make_station", "STATION_MODULES_ENV",
           "ENTRY_POINT_GROUP"]

STATION_MODULES_ENV = "ARMLAB_STATION_MODULES"
ENTRY_POINT_GROUP = "armlab.station_backends"

BACKENDS: dict[str, str] = {
    "sim": "armlab.sim:make_sim_station",            # simulated arm, block world and RGB-D camera
    "real": "armlab.hardware:make_real_station",     # Interbotix RX200 (ROS 2) and RealSense L515
}


def register_backend(kind: str, factory: str | Callable[..., Station]) -> None:
    """Make `make_station(kind, ...)` call factory (a callable, or "module:function" imported when first used).
    Raises ValueError for an empty name or a malformed "module:function" string, and when kind is taken."""
    if not isinstance(kind, str) or not kind.strip():
        raise ValueError(f"a station backend needs a non-empty name, got {kind!r}")
    if isinstance(factory, str) and (factory.count(":") != 1 or not all(factory.split(":"))):
        raise ValueError(f"backend {kind!r}: factory must be a callable or 'module:function', got {factory!r}")
    if not isinstance(factory, str) and not callable(factory):
        raise ValueError(f"backend {kind!r}: factory must be a callable or 'module:function', got {factory!r}")
    if kind in BACKENDS:
        raise ValueError(f"station backend {kind!r} is already registered ({BACKENDS[kind]!r})")
    BACKENDS[kind] = factory


_imported_modules: set[str] = set()      # the ARMLAB_STATION_MODULES already registered in this process


_registered_entry_points: set[tuple[str, str]] = set()     # (kind, "module:function") already registered


def _discover_entry_points() -> None:
    """Register the backends installed distributions declare in the armlab.station_backends group (by their
    "module:function", imported when used). ValueError naming the distribution for a malformed value or a kind
    already taken."""
    for point in entry_points(group=ENTRY_POINT_GROUP):
        if (point.name, point.value) in _registered_entry_points:
            continue
        try:
            register_backend(point.name, point.value)
        except ValueError as e:
            owner = point.dist.name if point.dist is not None else "an installed distribution"
            raise ValueError(f"entry point {point.name!r} of {owner} in {ENTRY_POINT_GROUP}: {e}") from e
        _registered_entry_points.add((point.name, point.value))


def _discover() -> None:
    """Register the backends installed distributions declare (entry points), then those of every module named in
    ARMLAB_STATION_MODULES not yet imported. ImportError naming a module that does not import; ValueError for one
    without a non-empty STATION_BACKENDS dict (nothing of that module is registered then)."""
    _discover_entry_points()
    for name in filter(None, (n.strip() for n in os.environ.get(STATION_MODULES_ENV, "").split(","))):
        if name in _imported_modules:
            continue
        try:
            module = importlib.import_module(name)
        except ImportError as e:
            raise ImportError(f"{STATION_MODULES_ENV} names {name!r}, which does not import: {e}") from e
        backends = getattr(module, "STATION_BACKENDS", None)
        if not isinstance(backends, dict) or not backends:
            raise ValueError(f"{STATION_MODULES_ENV} names {name!r}, which defines no STATION_BACKENDS = "
                             f"{{kind: factory}} dict (got {type(backends).__name__})")
        added: list[str] = []
        try:
            for kind, factory in backends.items():
                register_backend(kind, factory)
                added.append(kind)
        except ValueError as e:
            for kind in added:                  # all of the module's backends or none
                del BACKENDS[kind]
            raise ValueError(f"{STATION_MODULES_ENV}: module {name!r}: {e}") from e
        _imported_modules.add(name)


def backend_names() -> tuple[str, ...]:
    """The names make_station accepts, in registration order (the kit's, then the installed distributions' entry
    points, then ARMLAB_STATION_MODULES')."""
    _discover()
    return tuple(BACKENDS)


def _factory(kind: str) -> Callable[..., Station]:
    _discover()
    entry = BACKENDS.get(kind) if isinstance(kind, str) else None
    if entry is None:
        names = " or ".join(repr(n) for n in BACKENDS)
        raise ValueError(f"unknown station kind {kind!r}: expected {names}")
    if callable(entry):
        return entry
    module, name = entry.split(":")
    return getattr(importlib.import_module(module), name)


def make_station(kind: str = "sim", **options) -> Station:
    """A station of the given kind: "sim" (default, no hardware) or "real" (Interbotix RX200 + RealSense L515), or
    any registered backend (BACKENDS).

    Simulation options: seed (int), scene (preset name, JSON path or dict), realism ("realistic" or "ideal"), ...
    (see armlab.sim.make_sim_station). Real options: see armlab.hardware.make_real_station.
    """
    return _factory(kind)(**options)
