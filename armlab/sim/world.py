"""The simulated block world: the objects on the board (ground truth), a simulated clock, and simple statics.

Objects are armlab.blocks.ObjectState (cubes and distractors) in the world (board) frame, mm and rad: `position` is
the object's centre, `yaw` its turn about +z. The statics are quasi-static and geometric, not a physics engine:
a released object drops straight down onto the highest object under its footprint (or the board) and rests flat on
it when its centre of mass lies over its supports; otherwise it tips off and lands beside them. A pushed object
slides along the push, carrying whatever is stacked on it and pushing what it runs into.

Time: `time_s` is simulated seconds. `advance(dt)` moves it forward in small steps and tells the listeners (the
simulated arm) so that non-blocking motions progress; with real_time=True `sync()` keeps it in step with the wall
clock.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable

import numpy as np

from armlab.blocks import ObjectState
from armlab.lab import lab_config
from armlab.sim.geometry import convex_hull, point_in_convex, polygons_overlap, separation_along

__all__ = ["World", "SETTLE_TOL_MM", "describe_object"]

SETTLE_TOL_MM = 0.5          # an object counts as resting on a support when its bottom is this close to the top
_MAX_CHAIN = 20              # longest chain of tip-offs or pushes followed before giving up


def describe_object(o: ObjectState) -> str:
    """An object for messages: its id, size, colour, kind and centre (world mm)."""
    kind = "block" if o.is_block else o.shape
    return f"object {o.id} ({o.size} {o.color} {kind} at ({o.position[0]:.1f}, {o.position[1]:.1f}, " \
           f"{o.position[2]:.1f}) mm)"


class World:
    """The board and the objects on it, with a simulated clock.

    Attributes:
        objects: every object (ground truth, world mm / rad); blocks: the cubes only.
        time_s: simulated time (s).
        held: ids of objects held by the gripper (they are exempt from the statics).
        lock: the one re-entrant lock of the simulation: the clock's steps and everything the simulated arm changes
            (a check and the motion it starts, a stop) run under it, so a stop from another thread (a GUI's, a
            timer's) comes either before a move starts or after, never in between. One lock, not one per part: the
            clock calls the arm under it and the arm steps the clock under it, so two locks would deadlock.
    """

    #: longest simulated step (s) the clock takes at once, so listeners see motion in small increments
    max_step_s: float = 0.02

    def __init__(self, objects: Iterable[ObjectState] = (), real_time: bool = False):
        self._objects: list[ObjectState] = []
        self.time_s = 0.0
        self.real_time = bool(real_time)
        self.held: set[int] = set()
        self._listeners: list[Callable[[float], None]] = []
        self._wall = time.monotonic()
        self.lock = threading.RLock()
        for o in objects:
            self.add(o, settle=False)

    # -- contents -------------------------------------------------------------------------------------------
    @property
    def objects(self) -> list[ObjectState]:
        """All objects (cubes and distractors), the ground truth; world mm and rad."""
        return list(self._objects)

    @property
    def blocks(self) -> list[ObjectState]:
        """The cubes only (what the events score), the ground truth; world mm and rad."""
        return [o for o in self._objects if o.is_block]

    def add(self, obj: ObjectState, settle: bool = True) -> ObjectState:
        """Add an object (its id is renumbered if already taken); with settle=True it drops onto its support."""
        if not isinstance(obj, ObjectState):
            raise TypeError(f"World.add takes an armlab.blocks.ObjectState, got {type(obj).__name__}")
        if any(o.id == obj.id for o in self._objects):
            obj.id = max(o.id for o in self._objects) + 1
        self._objects.append(obj)
        if settle:
            self.settle(obj)
        return obj

    def get(self, object_id: int) -> ObjectState:
        """The object with this id (KeyError naming it when there is none)."""
        for o in self._objects:
            if o.id == object_id:
                return o
        raise KeyError(f"no object with id {object_id} in the world")

    # -- clock ----------------------------------------------------------------------------------------------
    def add_listener(self, callback: Callable[[float], None]) -> None:
        """Call `callback(time_s)` after every clock step (the simulated arm uses this)."""
        self._listeners.append(callback)

    def advance(self, dt: float) -> None:
        """Move simulated time forward by dt seconds (>= 0), in steps of at most max_step_s."""
        dt = float(dt)
        if not np.isfinite(dt) or dt < 0:
            raise ValueError(f"World.advance: dt must be a finite number of seconds >= 0, got {dt}")
        with self.lock:
            end = self.time_s + dt
            while self.time_s < end - 1e-12:
                self.time_s = min(end, self.time_s + self.max_step_s)
                for callback in self._listeners:
                    callback(self.time_s)
            self.time_s = end
            self._wall = time.monotonic()

    def sync(self) -> None:
        """In real-time mode, advance the clock by the wall-clock time since the last step; else do nothing."""
        if self.real_time:
            with self.lock:
                self.advance(max(0.0, time.monotonic() - self._wall))

    # -- geometry queries -----------------------------------------------------------------------------------
    @staticmethod
    def footprints_overlap(a: ObjectState, b: ObjectState, margin: float = 0.0) -> bool:
        """True when the top views of two objects overlap (by more than margin mm; negative = closer than)."""
        return any(polygons_overlap(p, q, margin) for p in a.footprint_world() for q in b.footprint_world())

    @classmethod
    def collide(cls, a: ObjectState, b: ObjectState, tol: float = 0.01) -> bool:
        """True when two objects interpenetrate by more than tol mm."""
        z_overlap = min(a.top_z, b.top_z) - max(a.bottom_z, b.bottom_z)
        return z_overlap > tol and cls.footprints_overlap(a, b, tol)

    def _free(self, exclude: Iterable[ObjectState] = ()) -> list[ObjectState]:
        skip = {id(o) for o in exclude}
        return [o for o in self._objects if id(o) not in skip and o.id not in self.held]

    def supports_of(self, obj: ObjectState) -> tuple[float, list[ObjectState]]:
        """The height (mm) obj would rest at (its bottom) and the objects it would rest on ([] = the board)."""
        below = [o for o in self._free([obj]) if o.position[2] < obj.position[2] + 1e-6
                 and self.footprints_overlap(obj, o)]
        top = max((o.top_z for o in below), default=0.0)
        if top <= 0.0:
            return 0.0, []
        return top, [o for o in below if o.top_z > top - SETTLE_TOL_MM]

    def stack_above(self, obj: ObjectState) -> list[ObjectState]:
        """Objects resting on obj, directly or through others, lowest first."""
        out: list[ObjectState] = []
        frontier = [obj]
        while frontier:
            base = frontier.pop()
            for o in self._free([obj, *out]):
                if abs(o.bottom_z - base.top_z) < SETTLE_TOL_MM and self.footprints_overlap(o, base):
                    out.append(o)
                    frontier.append(o)
        return sorted(out, key=lambda o: o.position[2])

    @staticmethod
    def _supported(obj: ObjectState, supports: list[ObjectState]) -> bool:
        if not supports:
            return True
        hull = convex_hull(np.vstack([p for s in supports for p in s.footprint_world()]))
        return len(hull) >= 3 and point_in_convex(obj.position[:2], hull)

    # -- statics --------------------------------------------------------------------------------------------
    def settle(self, obj: ObjectState) -> None:
        """Drop obj straight down onto its support and lay it flat; it tips off (landing beside the support) when
        its centre of mass is not over the support."""
        for _ in range(_MAX_CHAIN):
            obj.tilt = np.zeros(2)
            height, supports = self.supports_of(obj)
            obj.position[2] = height + obj.edge / 2
            if self._supported(obj, supports):
                return
            # Tip off: the object rolls over the support's edge and lands beside it, away from the support.
            centre = np.mean(np.vstack([p for s in supports for p in s.footprint_world()]), axis=0)
            d = obj.position[:2] - centre
            d = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-9 else np.array([1.0, 0.0])
            shift = max(separation_along(p, q, d) for p in obj.footprint_world()
                        for s in supports for q in s.footprint_world())
            obj.position[:2] += d * (shift + 1.0)
            obj.position[2] = height   # it falls from the support's top, then settles again below
        raise RuntimeError(f"{describe_object(obj)} did not come to rest after {_MAX_CHAIN} tip-offs")

    def shove(self, obj: ObjectState, direction, distance: float, _moved: tuple = ()) -> None:
        """Slide obj (and everything stacked on it) horizontally by distance mm along direction (2,), pushing any
        object it runs into, then let the moved objects settle."""
        d = np.asarray(direction, dtype=float)[:2]
        d = d / np.linalg.norm(d)
        group = [obj, *(o for o in self.stack_above(obj) if all(o is not m for m in _moved))]
        for o in group:
            o.position[:2] += d * distance
        if len(_moved) < _MAX_CHAIN:
            for other in self._free([*_moved, *group]):
                hits = [m for m in group if self.collide(m, other)]
                if hits:
                    need = max(separation_along(p, q, d) for m in hits for p in other.footprint_world()
                               for q in m.footprint_world())
                    self.shove(other, d, need + 0.5, (*_moved, *group))
        for o in group:
            if o.id not in self.held:
                self.settle(o)

    # -- validation -----------------------------------------------------------------------------------------
    def problems(self) -> list[str]:
        """Everything physically wrong with the world, in words (empty when valid): objects off the board,
        interpenetrating, floating, or resting where they would tip off. Held objects are exempt from resting."""
        lab = lab_config()
        out = []
        objs = self._objects
        for o in objs:
            pts = np.vstack(o.footprint_world())
            if not np.all(lab.on_board(pts)):
                out.append(f"{describe_object(o)} is not entirely on the board (x in {lab.board_x}, "
                           f"y in {lab.board_y})")
            if o.id in self.held:
                continue
            height, supports = self.supports_of(o)
            if abs(o.bottom_z - height) > SETTLE_TOL_MM:
                out.append(f"{describe_object(o)} does not rest on its support: bottom at {o.bottom_z:.1f} mm, "
                           f"support top at {height:.1f} mm")
            elif not self._supported(o, supports):
                out.append(f"{describe_object(o)} would tip off: its centre is not over the object(s) below it")
        for i, a in enumerate(objs):
            for b in objs[i + 1:]:
                if self.collide(a, b):
                    out.append(f"{describe_object(a)} overlaps {describe_object(b)}")
        ids = [o.id for o in objs]
        if len(set(ids)) != len(ids):
            out.append(f"object ids are not unique: {ids}")
        return out
