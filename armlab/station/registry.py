"""The station backends by name, and `make_station(kind, **options)`, which builds one.

A backend is a function `(**options) -> Station` in a module of its own that implements the contract
(armlab.station.contract). BACKENDS names it as "module:function" and the module is imported only when a station of
that kind is built, so the contract, the backends and this registry import no one in a circle, and
`import armlab` loads no backend. A new backend is one module plus one line here (or `register_backend` from
outside the package, e.g. a course's own rig).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from armlab.station.contract import Station

__all__ = ["BACKENDS", "register_backend", "backend_names", "make_station"]

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


def backend_names() -> tuple[str, ...]:
    """The names make_station accepts, in registration order."""
    return tuple(BACKENDS)


def _factory(kind: str) -> Callable[..., Station]:
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
