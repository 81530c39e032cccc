"""Pick and place over the whole board, on the simulated station: a grid of spots by region, and a trial
that picks a block put at one spot of a seeded scene and places it at another.

Regions (heading: the angle of the spot from world +y about the waist axis, positive towards -x; reach: mm from
the waist axis): in front close in (150-165 mm, heading up to 40 deg) and at full reach (400-420 mm, up to 60 deg),
beside the base (heading +-90 deg, 180-410 mm), behind the waist axis (heading 110-150 deg, y < 0, 170-400 mm), on a
stack (the top of two large blocks; a place onto a large block; 170-380 mm, in front, beside and behind), and
seeded random spots over the whole reachable board. Spots keep clear of the AprilTags and stay on the
board. Every spot serves once as a pick spot and once as a place spot (GRID paired with itself shifted by half).

A trial (run_trial): a fresh seeded station whose scene is the "random" preset with a large block put at the pick
spot (on a large block for a stack spot) and, for a stack place spot, a large block there to put it on (scattered
objects within 70 mm of either spot are left out); tasks.look, tasks.pick of the block seen at the pick spot,
tasks.place at the place spot with a seeded yaw. Each outcome is one of OUTCOMES; a refusal is "refused before"
when the guarded arm sent nothing for it, else "refused mid-plan" (a pre-check bug). The placement error is the
placed block's true bottom-face centre minus the target (world mm; ground truth, so simulation only). The pick's
error is the grasped block's true centre in the tool frame minus where the plan put it (tool frame mm: how well the
pads were centred on it), and its turn the angle between the block's true rotation in the tool frame and the one the
plan believes (held_in_tool): what the task layer believes it holds against the physics world's truth. Units: mm,
rad; world (board) frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab import tasks
from armlab.blocks import ObjectState, block_edge
from armlab.kinematics import Unreachable
from armlab.lab import lab_config
from armlab.sim.physics.rest import object_rotation
from armlab.station.contract import MotionRefused
from armlab.transforms import homogeneous

__all__ = ["GridSpot", "GRID", "REGIONS", "OUTCOMES", "Outcome", "random_spots", "grid_pairs", "run_trial"]

OUTCOMES = ("done", "refused before", "refused mid-plan", "not grasped")
_TAG_KEEP_OUT_MM = 70.0         # a spot's centre at least this far from every AprilTag centre
_SCENE_KEEP_OUT_MM = 70.0       # scattered objects within this of a trial's spots are left out of its scene


@dataclass(frozen=True)
class GridSpot:
    """A board spot: its region, centre (x, y) world mm, and whether it is on a stack (the block is picked from the
    top of two large blocks / placed onto a large block standing there)."""

    region: str
    x: float
    y: float
    stack: bool = False

    @property
    def reach(self) -> float:
        return float(np.hypot(self.x, self.y))

    def __str__(self) -> str:
        return f"({self.x:.0f}, {self.y:.0f}){' on a stack' if self.stack else ''}"


def _polar(region: str, reach: float, heading_deg: float, stack: bool = False) -> GridSpot:
    h = np.radians(heading_deg)
    return GridSpot(region, round(float(-reach * np.sin(h)), 1), round(float(reach * np.cos(h)), 1), stack)


# (region, [(reach mm, heading deg)], stack); each heading but 0 is used on both sides of the base
_LAYOUT = [
    ("in front, close in", [(150.0, 0.0), (165.0, 40.0)], False),
    ("in front, full reach", [(420.0, 0.0), (400.0, 25.0), (410.0, 60.0)], False),
    ("beside the base", [(180.0, 90.0), (330.0, 90.0), (410.0, 90.0)], False),
    ("behind the waist axis", [(175.0, 130.0), (300.0, 115.0), (170.0, 150.0), (400.0, 110.0)], False),
    ("on a stack", [(170.0, 30.0), (380.0, 0.0), (260.0, 75.0), (220.0, 130.0)], True),
]
REGIONS = tuple(name for name, _, _ in _LAYOUT) + ("random, whole board",)


def _grid() -> tuple[GridSpot, ...]:
    out = []
    for region, points, stack in _LAYOUT:
        for reach, heading in points:
            out += [_polar(region, reach, h, stack) for h in ((heading,) if heading == 0 else (heading, -heading))]
    return tuple(out)


GRID = _grid()


def _usable(x: float, y: float, edge: float = 38.0) -> bool:
    """True when a block of `edge` mm centred at (x, y) mm lies on the board (5 mm in) and clear of the tags."""
    lab = lab_config()
    h = edge / np.sqrt(2) + 5.0
    on = lab.board_x[0] + h <= x <= lab.board_x[1] - h and lab.board_y[0] + h <= y <= lab.board_y[1] - h
    tags = np.array(list(lab.tags.centres_mm.values()), float)
    return bool(on and np.min(np.hypot(tags[:, 0] - x, tags[:, 1] - y)) >= _TAG_KEEP_OUT_MM)


def random_spots(n: int, seed: int = 0, reach=(150.0, 420.0)) -> list[GridSpot]:
    """n seeded random spots of the region "random, whole board": reach uniform in `reach` (mm), any heading up to
    165 deg either side of +y, on the board and clear of the tags."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        spot = _polar(REGIONS[-1], rng.uniform(*reach), rng.uniform(-165.0, 165.0))
        if _usable(spot.x, spot.y):
            out.append(spot)
    return out


def grid_pairs(spots) -> list[tuple[GridSpot, GridSpot]]:
    """(pick spot, place spot) pairs: each spot picked from once and placed at once, the place spot half the list
    further on (so mostly in another region)."""
    spots = list(spots)
    n = len(spots)
    return [(spots[i], spots[(i + n // 2) % n]) for i in range(n)]


@dataclass(frozen=True)
class Outcome:
    """One pick or place: its spot, action ("pick" or "place"), outcome (one of OUTCOMES), error (3,) mm or None
    (module notes) and the refusal's message ("" when done)."""

    spot: GridSpot
    action: str
    outcome: str
    error: np.ndarray | None = None
    message: str = ""
    tilt_rad: float = 0.0          # a place: how tilted the block was when the gripper let it go (SimArm.last_release)
    turn_rad: float = 0.0          # a pick: the angle between the held block's true and believed rotation in the tool


def _cube(color: str, x: float, y: float, yaw: float) -> ObjectState:
    e = block_edge("large")
    return ObjectState(color, "large", e, np.array([x, y, e / 2]), float(yaw))


def trial_scene(pick: GridSpot, place: GridSpot, seed: int) -> tuple[list[ObjectState], float]:
    """The objects of a trial's scene (module notes) and the place yaw (rad), both seeded."""
    # the simulator: imported when a trial runs
    from armlab.sim.scenes import scene_objects, with_objects_at

    rng = np.random.default_rng([seed, 14])
    yaws = rng.uniform(-np.pi / 4, np.pi / 4, 3)
    added = [_cube("green", pick.x, pick.y, yaws[0])] if pick.stack else []
    added.append(_cube("red", pick.x, pick.y, yaws[0] if pick.stack else yaws[1]))
    if place.stack:
        added.append(_cube("blue", place.x, place.y, yaws[2]))
    scattered = [o for o in scene_objects("random", seed, n=4)
                 if np.hypot(o.position[0] - place.x, o.position[1] - place.y) > _SCENE_KEEP_OUT_MM]
    return with_objects_at(scattered, added, _SCENE_KEEP_OUT_MM), float(yaws[1])


def _refusal(sent_before: int, arm) -> str:
    return "refused mid-plan" if len(arm.sent) != sent_before else "refused before"


def run_trial(pick: GridSpot, place: GridSpot, seed: int) -> tuple[Outcome, Outcome | None]:
    """Pick the block put at `pick` and place it at `place` on a fresh seeded station (module notes); the place's
    Outcome is None when the pick did not end with the block held."""
    from armlab import make_station
    from armlab.sim.scenes import scene_to_dict

    objects, yaw = trial_scene(pick, place, seed)
    st = make_station("sim", seed=seed, scene=scene_to_dict(objects))
    session = tasks.start_session(st)
    truth = max((o for o in st.world.blocks if np.hypot(o.position[0] - pick.x, o.position[1] - pick.y) < 1.0),
                key=lambda o: o.position[2])
    seen = [b for b in tasks.look(session).blocks if np.hypot(b.position[0] - pick.x, b.position[1] - pick.y) < 25.0]
    if not seen:
        return Outcome(pick, "pick", "not grasped", message="the block at the pick spot is not seen"), None
    block = max(seen, key=lambda b: b.position[2])
    sent = len(session.arm.sent)
    try:
        held = tasks.pick(session, block)
    except (MotionRefused, Unreachable) as e:
        return Outcome(pick, "pick", _refusal(sent, session.arm), message=str(e)), None
    if not held or truth not in st.arm.holding:
        return Outcome(pick, "pick", "not grasped", message=str(getattr(st.arm, "last_grasp", ""))), None
    T_tool_block = np.linalg.inv(st.arm.tool_pose_true()) @ homogeneous(object_rotation(truth), truth.position)
    grasp_error = T_tool_block[:3, 3] - session.held_in_tool[:3, 3]
    turn = np.clip((np.trace(session.held_in_tool[:3, :3].T @ T_tool_block[:3, :3]) - 1.0) / 2.0, -1.0, 1.0)
    picked = Outcome(pick, "pick", "done", grasp_error, turn_rad=float(np.arccos(turn)))
    target = np.array([place.x, place.y, block_edge("large") if place.stack else 0.0])
    sent = len(session.arm.sent)
    try:
        tasks.place(session, target, yaw)
    except (MotionRefused, Unreachable) as e:
        return picked, Outcome(place, "place", _refusal(sent, session.arm), message=str(e))
    bottom = truth.position - [0.0, 0.0, truth.edge / 2]
    return picked, Outcome(place, "place", "done", bottom - target)
