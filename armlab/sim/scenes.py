"""Scenes for the simulated board: named presets (the lab's exercises and competition events) and JSON files.

A scene is a list of armlab.blocks.ObjectState in the world (board) frame, mm and rad, physically valid: on the
board, no two objects interpenetrating, each resting flat on the board or on the object below it. Random scenes are
seeded and scatter objects on the part of the board the arm reaches with a top-down grasp, clear of the AprilTags,
with room between objects for the fingers.

JSON format (`save_scene` / `load_scene`):
    {"format": "armlab-scene", "version": 1,
     "objects": [{"color": "red", "size": "large", "shape": "cube", "edge_mm": 38.0,
                  "position_mm": [x, y, z], "yaw_rad": 0.0, "id": 0}, ...]}
"shape" (default "cube"), "edge_mm" (default: the size's edge), "yaw_rad" (default 0) and "id" (default: the index)
are optional; "position_mm" may be [x, y], in which case the object is dropped onto what lies below it (objects are
placed in file order).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from armlab.blocks import COLORS, SHAPES, SIZES, ObjectState, block_edge
from armlab.files import read_json, write_json_atomic
from armlab.lab import lab_config
from armlab.schemas import integer, number, strict_object, validate, vector
from armlab.sim.geometry import polygons_overlap
from armlab.sim.world import World

__all__ = ["PRESETS", "scene_objects", "load_scene", "save_scene", "scene_to_dict", "objects_from_dict",
           "with_objects_at", "SceneError", "REACH_MM", "SWAP_SPOTS_MM"]

REACH_MM = (150.0, 350.0)       # radii (from the waist axis) where scattered objects go: top-down grasps work there
TAG_CLEARANCE_MM = 35.0         # no object footprint within this distance of an AprilTag centre
GAP_MM = 22.0                   # free space between scattered objects, so a finger pad fits between them
# The lab report's teach-and-repeat exercise: swap blocks A and B through an intermediate spot (world mm).
SWAP_SPOTS_MM = {"A": (-100.0, 225.0), "B": (100.0, 225.0), "intermediate": (250.0, 75.0)}
DISTRACTOR_SHAPES = tuple(s for s in SHAPES if s != "cube")
_FORMAT = "armlab-scene"


class SceneError(ValueError):
    """A scene (preset options, dict or JSON file) is invalid; the message names the source and the problem."""


# ---------------------------------------------------------------------------------------------------------------
# Random placement
# ---------------------------------------------------------------------------------------------------------------

def _square(xy, edge, yaw, grow=0.0) -> np.ndarray:
    h = edge / 2 + grow
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[-h, -h], [h, -h], [h, h], [-h, h]]) @ np.array([[c, -s], [s, c]]).T + np.asarray(xy)


class _Scatter:
    """Seeded rejection sampling of non-overlapping footprints in the reachable part of the board."""

    def __init__(self, rng: np.random.Generator, y_min: float | None = None, max_tries: int = 20000):
        self.rng, self.y_min, self.max_tries = rng, y_min, max_tries
        self.taken: list[np.ndarray] = []
        lab = lab_config()
        self.tags = np.array(list(lab.tags.centres_mm.values()), float)
        self.board_x, self.board_y = lab.board_x, lab.board_y

    def _fits(self, sq: np.ndarray) -> bool:
        r = np.hypot(sq[:, 0], sq[:, 1])
        if r.min() < REACH_MM[0] or r.max() > REACH_MM[1]:
            return False
        if self.y_min is not None and sq[:, 1].min() < self.y_min:
            return False
        if (sq[:, 0].min() < self.board_x[0] + 5 or sq[:, 0].max() > self.board_x[1] - 5
                or sq[:, 1].min() < self.board_y[0] + 5 or sq[:, 1].max() > self.board_y[1] - 5):
            return False
        centre = sq.mean(axis=0)
        if np.min(np.linalg.norm(self.tags - centre, axis=1)) < TAG_CLEARANCE_MM + np.abs(sq - centre).max() * 1.5:
            return False
        return not any(polygons_overlap(sq, t, -GAP_MM) for t in self.taken)

    def place(self, edge: float) -> tuple[float, float, float]:
        """A free spot (x, y, yaw) for a footprint of the given edge (mm), yaw in [-pi/4, pi/4)."""
        for _ in range(self.max_tries):
            r = np.sqrt(self.rng.uniform(REACH_MM[0] ** 2, REACH_MM[1] ** 2))
            a = self.rng.uniform(0, 2 * np.pi)
            xy = np.array([r * np.cos(a), r * np.sin(a)])
            yaw = float(self.rng.uniform(-np.pi / 4, np.pi / 4))
            sq = _square(xy, edge, yaw)
            if self._fits(sq):
                self.taken.append(sq)
                return float(xy[0]), float(xy[1]), yaw
        raise SceneError(f"could not find a free spot for a {edge:.0f} mm object after {self.max_tries} tries: "
                         f"ask for fewer objects")


def _stack(scatter: _Scatter, items: list[tuple[str, str]], next_id: int) -> list[ObjectState]:
    """Place (color, size) items as one stack (listed bottom first) at a free spot; larger blocks go below."""
    items = sorted(items, key=lambda cs: -block_edge(cs[1]))
    x, y, yaw = scatter.place(max(block_edge(s) for _, s in items))
    out, z = [], 0.0
    for k, (color, size) in enumerate(items):
        e = block_edge(size)
        out.append(ObjectState(color, size, e, np.array([x, y, z + e / 2]), yaw, "cube", next_id + k))
        z += e
    return out


def _distractors(scatter: _Scatter, rng: np.random.Generator, n: int, next_id: int) -> list[ObjectState]:
    out = []
    for k in range(n):
        size = str(rng.choice(SIZES))
        e = block_edge(size)
        x, y, yaw = scatter.place(e)
        out.append(ObjectState(str(rng.choice(COLORS)), size, e, np.array([x, y, e / 2]), yaw,
                               str(rng.choice(DISTRACTOR_SHAPES)), next_id + k))
    return out


def _scattered(rng, items, y_min=None, stacks=(), n_distractors=0) -> list[ObjectState]:
    """Blocks `items` [(color, size)] scattered singly, plus stacks (lists of items), plus distractors."""
    scatter = _Scatter(rng, y_min)
    out: list[ObjectState] = []
    for group in stacks:                           # the big footprints first
        out += _stack(scatter, list(group), len(out))
    for color, size in items:
        out += _stack(scatter, [(color, size)], len(out))
    out += _distractors(scatter, rng, n_distractors, len(out))
    return out


def _int_option(name: str, value, low: int, high: int) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not low <= value <= high:
        raise SceneError(f"scene option {name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


# ---------------------------------------------------------------------------------------------------------------
# Presets
# ---------------------------------------------------------------------------------------------------------------

def _empty(rng) -> list[ObjectState]:
    return []


def _swap(rng) -> list[ObjectState]:
    e = block_edge("large")
    (ax, ay), (bx, by) = SWAP_SPOTS_MM["A"], SWAP_SPOTS_MM["B"]
    return [ObjectState("red", "large", e, np.array([ax, ay, e / 2]), 0.0, "cube", 0),
            ObjectState("blue", "large", e, np.array([bx, by, e / 2]), 0.0, "cube", 1)]


def _random(rng, n: int = 6) -> list[ObjectState]:
    n = _int_option("n", n, 0, 16)
    return _scattered(rng, [(str(rng.choice(COLORS)), str(rng.choice(SIZES))) for _ in range(n)])


def _stacks(rng, n_stacks: int = 3, max_height: int = 3) -> list[ObjectState]:
    n_stacks = _int_option("n_stacks", n_stacks, 1, 6)
    max_height = _int_option("max_height", max_height, 2, 4)
    groups = [[(str(rng.choice(COLORS)), str(rng.choice(SIZES))) for _ in range(rng.integers(2, max_height + 1))]
              for _ in range(n_stacks)]
    return _scattered(rng, [], stacks=groups)


def _colours(rng, k: int) -> list[str]:
    return [str(c) for c in rng.choice(COLORS, size=k, replace=False)]


def _sort_stack(level: int) -> Callable:
    """Sort 'n stack: blocks start at y > 0. Level 1: 3 large red/green/blue; level 2: 3 large + 3 small of random
    colours; level 3: as level 2 with stacks two high, plus distractors."""

    def build(rng) -> list[ObjectState]:
        if level == 1:
            return _scattered(rng, [(c, "large") for c in ("red", "green", "blue")], y_min=0.0)
        items = [(c, "large") for c in _colours(rng, 3)] + [(c, "small") for c in _colours(rng, 3)]
        if level == 2:
            return _scattered(rng, items, y_min=0.0)
        order = rng.permutation(len(items))
        n_pairs = int(rng.integers(1, 3))
        pairs = [[items[order[2 * k]], items[order[2 * k + 1]]] for k in range(n_pairs)]
        singles = [items[i] for i in order[2 * n_pairs:]]
        return _scattered(rng, singles, y_min=0.0, stacks=pairs, n_distractors=2)

    build.__doc__ = f"Sort 'n stack level {level}."
    return build


def _line_up(level: int) -> Callable:
    """Line 'em up. Level 1: the six large blocks; level 2: six large and six small; level 3: as level 2 with stacks
    two or three high, plus distractors."""

    def build(rng) -> list[ObjectState]:
        large = [(c, "large") for c in COLORS]
        if level == 1:
            return _scattered(rng, [large[i] for i in rng.permutation(6)])
        items = large + [(c, "small") for c in COLORS]
        order = [items[i] for i in rng.permutation(len(items))]
        if level == 2:
            return _scattered(rng, order)
        stacks = [order[0:3], order[3:5]]
        return _scattered(rng, order[5:], stacks=stacks, n_distractors=3)

    build.__doc__ = f"Line 'em up level {level}."
    return build


def _sky(rng, n: int = 8) -> list[ObjectState]:
    """To the sky: large blocks only (the supply the event hands over one at a time)."""
    n = _int_option("n", n, 1, 12)
    return _scattered(rng, [(COLORS[i % 6], "large") for i in range(n)])


PRESETS: dict[str, Callable] = {
    "empty": _empty,
    "swap": _swap,
    "random": _random,
    "stacks": _stacks,
    **{f"sort_stack_{k}": _sort_stack(k) for k in (1, 2, 3)},
    **{f"line_up_{k}": _line_up(k) for k in (1, 2, 3)},
    "sky": _sky,
}


def scene_objects(scene: str | os.PathLike | dict = "random", seed: int = 0, **options) -> list[ObjectState]:
    """The objects of a scene: a preset name (PRESETS; random ones seeded by `seed`, options such as n=...), the
    path of a JSON scene file, or a scene dict. Raises SceneError naming the problem."""
    if isinstance(scene, dict):
        if options:
            raise SceneError(f"scene options {sorted(options)} only apply to presets, not to a scene dict")
        return objects_from_dict(scene, "scene dict")
    if isinstance(scene, str) and scene in PRESETS:
        rng = np.random.default_rng(seed)
        try:
            objects = PRESETS[scene](rng, **options)
        except TypeError as e:
            raise SceneError(f"scene {scene!r} does not take options {sorted(options)} ({e})") from None
        problems = World(objects).problems()
        if problems:
            raise AssertionError(f"preset {scene!r} built an invalid scene: {problems}")
        return objects
    if isinstance(scene, (str, os.PathLike)) and str(scene).endswith(".json"):
        if options:
            raise SceneError(f"scene options {sorted(options)} only apply to presets, not to a scene file")
        return load_scene(scene)
    raise SceneError(f"unknown scene {scene!r}: expected one of {sorted(PRESETS)}, a .json file or a dict")


def with_objects_at(objects, added, keep_out_mm: float = 70.0) -> list[ObjectState]:
    """A scene made of `added` objects (ObjectState, world mm: each dropped onto what lies below it, in order, so a
    stack is listed bottom first) and those of `objects` (a scene) whose centres lie more than keep_out_mm from every
    added one (horizontally): e.g. a block put at a chosen spot of a seeded random scene. Ids are renumbered after
    the kept objects. Raises SceneError when the result is not physically valid (off the board, overlapping)."""
    added = list(added)
    if not np.isfinite(keep_out_mm) or keep_out_mm < 0:
        raise SceneError(f"keep_out_mm must be a finite length >= 0 in mm, got {keep_out_mm}")
    centres = np.array([a.position[:2] for a in added], float).reshape(-1, 2)
    kept = [dataclasses.replace(o, position=np.array(o.position, float)) for o in objects
            if not len(centres) or np.min(np.linalg.norm(centres - o.position[:2], axis=1)) > keep_out_mm]
    world = World(kept)
    first_id = max((o.id for o in kept), default=-1) + 1
    for k, a in enumerate(added):
        obj = dataclasses.replace(a, position=np.array([a.position[0], a.position[1], 1e6]), id=first_id + k)
        world.add(obj, settle=True)
    problems = world.problems()
    if problems:
        raise SceneError("the scene with the added objects is not valid: " + "; ".join(problems))
    return world.objects



# ---------------------------------------------------------------------------------------------------------------
# JSON
# ---------------------------------------------------------------------------------------------------------------

def scene_to_dict(objects) -> dict:
    """The JSON-ready dict of a scene (a list of ObjectState or a World)."""
    objects = objects.objects if isinstance(objects, World) else objects
    return {"format": _FORMAT, "version": 1, "objects": [
        {"id": int(o.id), "color": o.color, "size": o.size, "shape": o.shape, "edge_mm": float(o.edge),
         "position_mm": [float(v) for v in o.position], "yaw_rad": float(o.yaw)} for o in objects]}


_KEYS = {"id", "color", "size", "shape", "edge_mm", "position_mm", "yaw_rad"}


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise SceneError(f"{where} must be a finite number, got {value!r}")
    return float(value)


_SCENE_MM = number(minimum=-1e5, maximum=1e5)
SCHEMA = strict_object({
    "format": {"type": "string"}, "version": {"type": "integer"},
    "objects": vector(strict_object({"id": integer(-2**31, 2**31 - 1), "color": {"type": "string"},
                                     "size": {"type": "string"}, "shape": {"type": "string"},
                                     "edge_mm": number(exclusive_minimum=0.0, maximum=1e4),
                                     "position_mm": vector(_SCENE_MM, (2, 3)), "yaw_rad": number(-1e6, 1e6)},
                                    required=("color", "size", "position_mm"), allow_comments=False),
                      max_items=10_000)},
    required=("objects",))
"""The declared schema of a scene file (armlab.schemas): types, finite numbers and ranges of each object; the
names (colour, size, shape) and the physics (objects_from_dict, World.problems) are checked after it."""


def objects_from_dict(data, source: str = "scene") -> list[ObjectState]:
    """Validate a scene dict (format of this module) and build its objects; SceneError names source and object."""
    if not isinstance(data, dict):
        raise SceneError(f"{source}: a scene must be a JSON object with an 'objects' list, got {type(data).__name__}")
    if data.get("format", _FORMAT) != _FORMAT or data.get("version", 1) != 1:
        raise SceneError(f"{source}: format {data.get('format')!r} version {data.get('version')!r} is not "
                         f"{_FORMAT!r} version 1")
    validate(data, SCHEMA, source, SceneError)
    extra = set(data) - {"format", "version", "objects", "_comment"}
    if extra:
        raise SceneError(f"{source}: unknown keys {sorted(extra)}")
    items = data.get("objects")
    if not isinstance(items, list):
        raise SceneError(f"{source}: 'objects' must be a list, got {type(items).__name__}")
    world = World()
    for i, item in enumerate(items):
        where = f"{source}: object {i}"
        if not isinstance(item, dict):
            raise SceneError(f"{where}: must be a JSON object, got {type(item).__name__}")
        unknown = set(item) - _KEYS
        if unknown:
            raise SceneError(f"{where}: unknown keys {sorted(unknown)} (allowed: {sorted(_KEYS)})")
        for key in ("color", "size", "position_mm"):
            if key not in item:
                raise SceneError(f"{where}: missing key {key!r}")
        color, size, shape = item["color"], item["size"], item.get("shape", "cube")
        if color not in COLORS:
            raise SceneError(f"{where}: colour {color!r} is not one of {COLORS}")
        if size not in SIZES:
            raise SceneError(f"{where}: size {size!r} is not one of {SIZES}")
        if shape not in SHAPES:
            raise SceneError(f"{where}: shape {shape!r} is not one of {SHAPES}")
        edge = _number(item.get("edge_mm", block_edge(size)), f"{where}: edge_mm")
        if edge <= 0:
            raise SceneError(f"{where}: edge_mm must be positive, got {edge}")
        pos = item["position_mm"]
        if not isinstance(pos, list) or len(pos) not in (2, 3):
            raise SceneError(f"{where}: position_mm must be [x, y] or [x, y, z] in mm, got {pos!r}")
        pos = [_number(v, f"{where}: position_mm[{k}]") for k, v in enumerate(pos)]
        yaw = _number(item.get("yaw_rad", 0.0), f"{where}: yaw_rad")
        oid = item.get("id", i)
        if isinstance(oid, bool) or not isinstance(oid, int):
            raise SceneError(f"{where}: id must be an integer, got {oid!r}")
        if any(o.id == oid for o in world.objects):
            raise SceneError(f"{where}: id {oid} is used twice")
        dropped = len(pos) == 2
        z = 1e6 if dropped else pos[2]
        world.add(ObjectState(color, size, edge, np.array([pos[0], pos[1], z]), yaw, shape, oid), settle=dropped)
    problems = world.problems()
    if problems:
        raise SceneError(f"{source}: " + "; ".join(problems))
    return world.objects


def load_scene(path: str | os.PathLike) -> list[ObjectState]:
    """Read and validate a JSON scene file; SceneError names the file and the problem."""
    return objects_from_dict(read_json(path, "scene", SceneError), str(path))


def save_scene(objects, path: str | os.PathLike) -> Path:
    """Write a scene (list of ObjectState or a World) as JSON, atomically (temporary file, then replace).

    The scene is validated first (SceneError and nothing written when it is not physically valid)."""
    path = Path(path)
    data = scene_to_dict(objects)
    objects_from_dict(data, f"scene to save as {path}")
    return write_json_atomic(path, data)
