"""The event registry: one EventSpec per competition event, found in the event modules themselves.

An event is one module that defines a module-level `EVENT = EventSpec(...)`: its name, levels, time limit (simulated
s), scene per level, detection settings, strategy and scorer (and, for an event whose blocks arrive during the run,
a supply). The registry finds every module of this package that defines one, the events installed distributions
declare in the entry-point group `armlab.events` (a lab's own events, outside the kit: the value names the module,
or its EventSpec as "module:EVENT"), and the modules named in the environment variable ARMLAB_EVENT_MODULES
(comma-separated importable names); register(spec) adds one in the running process. The runner, event_station,
score_event and the command line (`python -m armlab demo --event NAME`) read only the registry, so adding an event
touches no other file.

    # my_event.py, on the path, with ARMLAB_EVENT_MODULES=my_event
    from armlab.tasks.events.registry import EventSpec
    EVENT = EventSpec("corner", "the corner", levels=(1,), time_limit_s=120.0, strategy=Corner, scorer=score_corner,
                      scene=lambda level: "swap")

    # or, installed: the lab's pyproject.toml
    [project.entry-points."armlab.events"]
    corner = "my_event"
"""

from __future__ import annotations

import importlib
import os
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Protocol, runtime_checkable

from armlab.detection import DetectionSettings

__all__ = ["EventSpec", "Strategy", "Supply", "events", "event", "register", "score_event", "max_points",
           "EVENT_MODULES_ENV", "ENTRY_POINT_GROUP"]

EVENT_MODULES_ENV = "ARMLAB_EVENT_MODULES"
ENTRY_POINT_GROUP = "armlab.events"


@runtime_checkable
class Strategy(Protocol):
    """The robot's side of an event: what to move next from what the camera sees.

    next_move(seen) gets every object detected on the board (detection.Block, distractors included) and returns a
    layout.Move or None (nothing left to do, or `stopped` says why). placed(move) hears that the move's place ran.
    cannot_place(why) hears that a picked block could not be placed (it was put back): True to carry on (the
    strategy adapts, e.g. the tower is as high as it goes), False to stop the run. obstacles() lists what the
    strategy has built that the camera may not see in full (planning.Obstacle), for the plans to avoid.
    A class that subclasses Strategy gets the defaults: no stop reason, stop on a failed place, no obstacles."""

    stopped: str = ""

    def next_move(self, seen: list) -> Any: ...

    def placed(self, move: Any) -> None: ...

    def cannot_place(self, why: str) -> bool:
        return False

    def obstacles(self) -> list:
        return []


class Supply(Protocol):
    """Blocks that arrive during an event (to the sky's hand-over): hand_over() puts the next one on the board
    when its spot is free (returns it, or None); score_options() are the scorer's keyword options it implies."""

    def hand_over(self) -> Any: ...

    def score_options(self) -> dict: ...


@dataclass(frozen=True)
class EventSpec:
    """One competition event.

    name: the id (CLI, run_event); title: for people; levels: the valid levels; time_limit_s: the rules' limit
    (simulated s); strategy(level) -> Strategy; scorer(objects, level, held=..., clicked=..., **options) -> Score
    (from the simulator's ground truth, armlab.blocks.ObjectState); scene(level) -> what make_station("sim",
    scene=...) takes (a preset name, a JSON path or a scene dict; default the preset "<name>_<level>");
    detection: the detector's settings for the looks (None: the defaults); supply(world, seed) -> Supply for blocks
    handed over during the run (None: the scene holds every block)."""

    name: str
    title: str
    levels: tuple[int, ...]
    time_limit_s: float
    strategy: Callable[[int], Strategy]
    scorer: Callable[..., Any]
    scene: Callable[[int], Any] | None = None
    detection: DetectionSettings | None = None
    supply: Callable[[Any, int], Supply] | None = None

    def __post_init__(self):
        if not self.name.isidentifier():
            raise ValueError(f"event name {self.name!r} must be an identifier (letters, digits, _)")
        if not self.levels or any(isinstance(v, bool) or not isinstance(v, int) for v in self.levels):
            raise ValueError(f"event {self.name}: levels must be a non-empty tuple of ints, got {self.levels!r}")
        if not self.time_limit_s > 0:
            raise ValueError(f"event {self.name}: time_limit_s must be positive, got {self.time_limit_s!r}")

    def check_level(self, level: int) -> None:
        """ValueError naming the event's levels unless `level` is one of them."""
        if isinstance(level, bool) or level not in self.levels:
            raise ValueError(f"{self.name} has levels {self.levels}, got {level!r}")

    def scene_for(self, level: int):
        """The station's scene for a level (see the class notes)."""
        self.check_level(level)
        return self.scene(level) if self.scene is not None else f"{self.name}_{level}"


_registered: dict[str, EventSpec] = {}
_discovered = False


def register(spec: EventSpec) -> EventSpec:
    """Add an event (ValueError when another event already has its name); returns it."""
    if not isinstance(spec, EventSpec):
        raise TypeError(f"register takes an EventSpec, got {type(spec).__name__}")
    known = _registered.get(spec.name)
    if known is not None and known is not spec:
        raise ValueError(f"an event named {spec.name!r} is already registered")
    _registered[spec.name] = spec
    return spec


def _module_event(name: str) -> None:
    module = importlib.import_module(name)
    spec = getattr(module, "EVENT", None)
    if spec is not None:
        register(spec)


def _entry_point_event(point) -> None:
    """Register the event an installed distribution's entry point names: its EventSpec, or a module defining EVENT.
    ImportError or TypeError naming the entry point otherwise."""
    where = f"entry point {point.name!r} ({point.value}) in {ENTRY_POINT_GROUP}"
    try:
        target = point.load()
    except ImportError as e:
        raise ImportError(f"{where} does not import: {e}") from e
    spec = getattr(target, "EVENT", target)
    if not isinstance(spec, EventSpec):
        raise TypeError(f"{where} is neither an EventSpec nor a module defining EVENT = EventSpec(...)")
    register(spec)


def _discover() -> None:
    global _discovered
    if _discovered:
        return
    _discovered = True
    package = __name__.rsplit(".", 1)[0]
    for info in sorted(pkgutil.iter_modules(importlib.import_module(package).__path__), key=lambda m: m.name):
        _module_event(f"{package}.{info.name}")
    for point in entry_points(group=ENTRY_POINT_GROUP):
        _entry_point_event(point)
    for name in filter(None, (n.strip() for n in os.environ.get(EVENT_MODULES_ENV, "").split(","))):
        try:
            _module_event(name)
        except ImportError as e:
            raise ImportError(f"{EVENT_MODULES_ENV} names {name!r}, which does not import: {e}") from e


def events() -> dict[str, EventSpec]:
    """Every registered event by name, the kit's in the order of their module names, then the others."""
    _discover()
    return dict(_registered)


def event(name: str) -> EventSpec:
    """The spec of event `name`; ValueError naming the known events otherwise."""
    specs = events()
    if name not in specs:
        raise ValueError(f"unknown event {name!r}: expected one of {sorted(specs)}")
    return specs[name]


def score_event(name: str, level: int, objects, held=(), clicked: bool = False, **options):
    """Score a world state (armlab.blocks.ObjectState list) for an event and level by its scorer; options go to the
    scorer (to the sky: n_handed, handover_xy)."""
    spec = event(name)
    spec.check_level(level)
    if options and spec.supply is None:
        raise ValueError(f"{name} takes no scoring options, got {sorted(options)}")
    return spec.scorer(objects, level, held=held, clicked=clicked, **options)


def max_points(name: str, level: int, objects) -> int:
    """The most an event can score on a board with these objects."""
    return score_event(name, level, objects).max_points
