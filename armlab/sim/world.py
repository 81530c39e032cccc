"""The simulated block world: the objects on the board (ground truth), a simulated clock, and their physics.

Objects are armlab.blocks.ObjectState (cubes and distractors) in the world (board) frame, mm and rad: `position` is
the object's centre, `yaw` its turn about +z, `tilt` (roll, pitch) non-zero only for an object the physics left
leaning. Whatever moves the objects runs MuJoCo's contact dynamics (armlab.sim.physics) until everything rests: a
released object falls from where it is and topples when the centre of mass of everything it carries is not over
what bears it; a pushed object is driven by a kinematic plate, carrying by friction what is stacked on it and pushing
what it runs into. There are no geometric statics: the world's validation (problems) asks the physics too.

Time: `time_s` is simulated seconds. `advance(dt)` moves it forward in small steps and tells the listeners (the
simulated arm) so that non-blocking motions progress; with real_time=True `sync()` keeps it in step with the wall
clock. The physics of a release or a push runs to rest within the step that caused it (its own time is not added to
the clock: blocks settle in well under the gripper's opening time).
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Iterable

import numpy as np

from armlab.blocks import ObjectState
from armlab.gripper_geometry import GripperGeometry
from armlab.lab import lab_config
from armlab.sim.geometry import boxes_overlap, polygons_overlap
from armlab.sim.physics import Physics
from armlab.sim.physics.arm_bodies import ArmPart
from armlab.sim.physics.grasp import LIFT_MM, SLIP_MM, Grip, contact_grip
from armlab.sim.physics.rest import apply_rest_pose, object_rotation
from armlab.transforms import invert_transform, rpy_from_matrix

__all__ = ["World", "SETTLE_TOL_MM", "describe_object"]

SETTLE_TOL_MM = 0.5          # an object counts as resting on a support when its bottom is this close to the top
PLACE_DROP_MM = 60.0         # an object added higher than this above its support is set down on it, not dropped
LEAN_TOL_MM = 0.1           # collide(): what a leaning object may sink into another (soft contacts)
STAY_MM = 1.0                # problems(): an object the physics moves further than this would not stay


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
        held: ids of objects held by the gripper (they are exempt from the physics).
        arm: what tells the physics where the arm's bodies are (armlab.sim.physics.arm_bodies: arm_parts(hand)
            -> list of ArmPart), set by the simulated arm standing in this world; None: no arm.
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
        self.arm: Callable[[bool], list[ArmPart]] | None = None
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
        """True when two objects interpenetrate by more than tol mm (a leaning one as its tilted bounding box, by more
        than LEAN_TOL_MM at least: its pose is the physics', whose soft contacts sink a few hundredths of a mm; a
        fallen tower left a block leaning 1.3 deg 0.01-0.05 mm into another)."""
        if np.any(a.tilt) or np.any(b.tilt):
            return boxes_overlap(a.position, object_rotation(a), np.full(3, a.edge / 2),
                                 b.position, object_rotation(b), np.full(3, b.edge / 2), max(tol, LEAN_TOL_MM))
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

    def _support_top(self, obj: ObjectState) -> float:
        return self.supports_of(obj)[0]

    def _lowest_z(self, obj: ObjectState) -> float:
        """The world z (mm) of obj's lowest corner (tilt included)."""
        h = obj.edge / 2
        corners = np.array([[sx, sy, sz] for sx in (-h, h) for sy in (-h, h) for sz in (-h, h)])
        return float(obj.position[2] + np.min(corners @ object_rotation(obj)[2]))

    def _simulate(self, act: Callable[[Physics, list[ObjectState]], None] | None = None) -> list[ObjectState]:
        """Run the physics of every free object (held ones excluded) from the present poses: act(physics, objects)
        first (e.g. a push), then until everything rests; write the poses back (armlab.sim.physics.rest), lowest
        first, and return the objects that moved."""
        free = self._free()
        before = [(o.position.copy(), float(o.yaw), o.tilt.copy()) for o in free]
        physics = Physics(free, arm=self._arm_parts(hand=True))
        if act is not None:
            act(physics, free)
        physics.run_to_rest()
        poses = [physics.pose(k) for k in range(len(free))]
        moved = []
        for k in sorted(range(len(free)), key=lambda k: poses[k][0][2]):
            if apply_rest_pose(free[k], *poses[k], before[k], self._support_top):
                moved.append(free[k])
        return moved

    def _arm_parts(self, hand: bool) -> list[ArmPart]:
        return [] if self.arm is None else self.arm(hand)

    # -- physics --------------------------------------------------------------------------------------------
    def settle(self, obj: ObjectState) -> list[ObjectState]:
        """Let obj fall from where it is onto whatever is below it and everything come to rest (MuJoCo); an object
        added far above its support (more than PLACE_DROP_MM, e.g. a scene's dropped block) is first set down on
        it, as a hand places it. Returns the objects that moved."""
        height = self.supports_of(obj)[0]
        low = self._lowest_z(obj)
        if low > height + PLACE_DROP_MM or low < height:
            obj.position[2] += height - low
        return self._simulate()

    def shove(self, obj: ObjectState, direction, distance: float) -> list[ObjectState]:
        """Push obj horizontally by distance mm along direction (2,) with a kinematic plate low on its trailing side
        (armlab.sim.physics.engine.Physics.push): what is stacked on it rides along by friction, what it runs into
        is pushed, and everything then comes to rest. Returns the objects that moved."""
        d = np.asarray(direction, dtype=float)[:2]
        if not np.isfinite(distance) or distance < 0 or not np.all(np.isfinite(d)) or np.linalg.norm(d) < 1e-12:
            raise ValueError(f"World.shove: need a horizontal direction and a distance >= 0 mm, got {d}, {distance}")
        if obj.id in self.held:
            raise ValueError(f"World.shove: {describe_object(obj)} is held by the gripper")

        def push(physics: Physics, objects: list[ObjectState]) -> None:
            physics.push(next(k for k, o in enumerate(objects) if o is obj), d, float(distance))

        return self._simulate(push)

    def grip(self, obj: ObjectState, T_tool, geometry: GripperGeometry, from_mm: float, width_mm: float,
             pressure: float) -> tuple[Grip, list[ObjectState]]:
        """Close the finger pads on obj at tool pose T_tool (4, 4) world mm and test the grip with a short lift
        (armlab.sim.physics.grasp.contact_grip: the pads from from_mm apart, the servo at `pressure`, its force taken
        at width_mm across). Returns the grip and the objects that rose with the pads (obj first, then what rode on
        it; none when the grip failed), which are left at their poses in the pads with the lift undone (their
        pose in the tool frame is the physics'); everything else is left where the pads and the lift left it, at
        rest."""
        free = self._free()
        k = next(j for j, o in enumerate(free) if o is obj)
        before = [(o.position.copy(), float(o.yaw), o.tilt.copy()) for o in free]
        grip = contact_grip(free, k, T_tool, geometry, from_mm, width_mm, pressure, arm=self._arm_parts(hand=False))
        rose = [j for j, (p, _) in enumerate(grip.poses)
                if grip.held and p[2] - before[j][0][2] >= LIFT_MM - SLIP_MM]
        group = sorted(rose, key=lambda j: (j != k, grip.poses[j][0][2]))
        down = np.asarray(T_tool, dtype=float) @ invert_transform(grip.T_tool)      # the lift undone
        for j in group:
            o = free[j]
            o.position = down[:3, :3] @ grip.poses[j][0] + down[:3, 3]
            roll, pitch, yaw = rpy_from_matrix(down[:3, :3] @ grip.poses[j][1])
            o.yaw, o.tilt = float(yaw), np.array([roll, pitch])
        self.held.update(free[j].id for j in group)
        rest = [j for j in range(len(free)) if j not in rose]
        for j in sorted(rest, key=lambda j: grip.poses[j][0][2]):
            apply_rest_pose(free[j], *grip.poses[j], before[j], self._support_top)
        if not grip.held:
            self._simulate()
        return grip, [free[j] for j in group]

    def would_move(self) -> list[tuple[ObjectState, float]]:
        """The free objects the physics moves further than STAY_MM (or turns) when left alone from the present
        poses, with how far (mm); the world itself is not changed."""
        copies = [dataclasses.replace(o, position=o.position.copy(), tilt=o.tilt.copy()) for o in self._free()]
        twin = World(copies)
        twin._simulate()
        out = []
        for o, c in zip(self._free(), copies, strict=True):
            shift = float(np.linalg.norm(c.position - o.position))
            if shift > STAY_MM or abs(c.yaw - o.yaw) > np.radians(2.0) or np.any(np.abs(c.tilt - o.tilt) > 0.035):
                out.append((o, shift))
        return out

    # -- validation -----------------------------------------------------------------------------------------
    def problems(self) -> list[str]:
        """Everything physically wrong with the world, in words (empty when valid): objects off the board,
        interpenetrating, floating, or where the physics would not leave them (tipping off, sliding). Held objects
        are exempt from resting."""
        lab = lab_config()
        out = []
        objs = self._objects
        for o in objs:
            pts = np.vstack(o.footprint_world())
            if not np.all(lab.on_board(pts)):
                out.append(f"{describe_object(o)} is not entirely on the board (x in {lab.board_x}, "
                           f"y in {lab.board_y})")
            if o.id in self.held or np.any(o.tilt):
                continue                           # a leaning object rests on its neighbours: the physics checks it
            height = self.supports_of(o)[0]
            if abs(o.bottom_z - height) > SETTLE_TOL_MM:
                out.append(f"{describe_object(o)} does not rest on its support: bottom at {o.bottom_z:.1f} mm, "
                           f"support top at {height:.1f} mm")
        for i, a in enumerate(objs):
            for b in objs[i + 1:]:
                if self.collide(a, b):
                    out.append(f"{describe_object(a)} overlaps {describe_object(b)}")
        ids = [o.id for o in objs]
        if len(set(ids)) != len(ids):
            out.append(f"object ids are not unique: {ids}")
        if not out:                                # the physics only runs on a world without the faults above
            out += [f"{describe_object(o)} would not stay where it is: the physics moves it {shift:.1f} mm (it tips "
                    f"off or slides)" for o, shift in self.would_move()]
        return out
