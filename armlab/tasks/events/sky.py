"""To the sky: large blocks handed over one at a time at a fixed spot, stacked into one tower as high as possible.
The robot's side (the strategy) is the kit's own where it is installed (the instructor's tree,
armlab.tasks.events.strategies.sky) and the generic search (armlab.tasks.events.search) in the student release, where
writing it is exercise events.sky; this module holds the hand-over and the reach the strategy builds on.

HandOver is the scene's side (the person handing the blocks over, acting on the simulated world): it puts one large
block at HANDOVER_XY (with a little jitter in position and turn, as a hand would) at the start and after every block
that ends on the tower. The kit's strategy is the robot's side: it picks the block at the hand-over spot and puts
it on the tower at TOWER_XY, the next level up, always aimed at the same (x, y) so placement errors do not add up
(the detected top face of a tall tower drifts by a few mm per 100 mm of height, more than the arm errs).
The tower stops when the next level is out of the arm's reach. What limits it is the height the tool point can reach
above the tower spot (highest_tool_z): top-down only about 260 mm (wrist_angle runs out), so every level above ~6
blocks is placed with a tilted approach; at any pitch about 510 mm, best at 150-180 mm from the waist axis (the
horizontal approach reaches highest). The block is carried SKY_CLEARANCE_MM over the tower top (not the default
50 mm) and the tool hovers that far above the new top before it comes down, so the next level can be placed while
top + edge + clearance is within that reach. TOWER_XY sits on the 45 deg diagonal at the radius where the reach is
highest. Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

import numpy as np

from armlab import kinematics
from armlab.blocks import COLORS, ObjectState, block_edge
from armlab.detection import DetectionSettings
from armlab.kinematics import Unreachable
from armlab.planning import inner_limits, steepest_pitch_inside
from armlab.sim.physics.rest import tipping_shift_mm

from ..handling import RELEASE_GAP_MM
from .registry import EventSpec
from .scoring import SKY_LEVELS, score_sky
from .search import kit_or_search

__all__ = ["HandOver", "HANDOVER_XY", "TOWER_XY", "SKY_CLEARANCE_MM", "SKY_SETTINGS", "TOWER_RADIUS_MM",
           "highest_tool_z", "landing_offset", "SKY_TOWER_BLOCKS", "SKY_TOWER_DEFAULT_CLEARANCE_BLOCKS", "EVENT"]

HANDOVER_XY = (-200.0, 150.0)
TOWER_XY = (120.0, 120.0)           # 170 mm from the waist axis: where the tool reaches highest (module notes)
NEAR_MM = 40.0
SKY_CLEARANCE_MM = 15.0             # held block over the tower top; the empty finger tips (8 mm below the tool point)
                                    # end 7 mm above the new top after the release
SKY_SETTINGS = DetectionSettings(max_height=500.0, max_levels=13)   # the tower rises above the default 260 mm, 6 levels
TOWER_RADIUS_MM = 27.0              # the tower as an obstacle for the plans: a column this wide at TOWER_XY
# How tall a tower the kit's strategy builds on the physics world (2026-12-07, with grasps by contact and the arm's
# bodies in the physics; the public check of notebook 07 and the hidden checks of events.sky ask for these): carried
# SKY_CLEARANCE_MM over the top and aimed by landing_offset, 12 blocks (440 points) on seeds 0-7, every centre within
# 6.3-11.3 mm of the tower's axis (the levels let go tilted land against the open finger on their low side; seed 0's
# physics inputs are the same under the other numerics of tools/nbval-numerics); then the next level is out of reach.
# With the kit's default 50 mm clearance, 8 on seeds 0-3 (the 9th falls off). (Before the arm's bodies were in the
# physics: 9 and 8; the geometric world, which laid every released block flat: 12 and 11.)
SKY_TOWER_BLOCKS = 12
SKY_TOWER_DEFAULT_CLEARANCE_BLOCKS = 8


def highest_tool_z(xy, top_down: bool = False, tol_mm: float = 0.5) -> float:
    """The highest tool point (world mm) the arm reaches over the board point xy (2,) mm with every joint
    planning.LIMIT_MARGIN_RAD inside its limits: straight down (top_down) or at any pitch in [0, pi/2]."""
    robot = inner_limits()

    def ok(z: float) -> bool:
        p = np.array([xy[0], xy[1], z], float)
        if top_down:
            return bool(kinematics.ik_batch(p[None], np.pi / 2, robot=robot).success[0])
        try:
            kinematics.steepest_pitch(p, robot=robot)
            return True
        except Unreachable:
            return False

    good, bad = 0.0, 800.0
    if not ok(good):
        raise Unreachable(f"({xy[0]:.0f}, {xy[1]:.0f}) mm: the tool cannot reach the board there")
    while bad - good > tol_mm:
        mid = 0.5 * (good + bad)
        good, bad = (mid, bad) if ok(mid) else (good, mid)
    return good


def landing_offset(level: int, xy=TOWER_XY) -> np.ndarray:
    """Where (x, y) mm a large block put on a tower of `level` blocks at xy lands from where its centre is let go,
    when it was picked top-down and is placed at the steepest pitch the arm has a block's height above the release
    (planning.steepest_pitch_inside; the arm comes straight down from above at one pitch). It is carried turned by
    the pitch's tilt t from vertical about the pads' closing axis, falls onto its lowest edge and tips flat
    (armlab.sim.physics.rest.tipping_shift_mm), outward from the waist axis. Zero while the release is top-down (up
    to ~6 levels at TOWER_XY); aiming the block's centre at xy minus this offset lands it over xy.

    Beyond t = 45 deg (the tenth level at TOWER_XY) it lands on its other face, tips inward by 16-18 mm and slides:
    whether it then stays is decided by fractions of a mm, so no aim is given (zero). Aimed by half the predicted
    offset, the tenth level stood or fell with the last bits of the kit's numerics (to the sky seed 0: 12 levels
    natively, 10 without AVX-512 or 9 without AVX2, so no stored output could hold it); unaimed it falls off.

    Measured 2026-12-07 at TOWER_XY (to the sky, seed 0): levels 7-10 were let go at 9.8, 23.9, 36.8 and 50.8 deg
    (this gives 11.5, 24.8, 38.2, 53.0) and, unaimed, landed 1.2, 7.7, 16.4 and 17.8 mm off; aimed, levels 7-9 land
    within 5 mm of the tower's axis."""
    e = block_edge("large")
    p = np.array([xy[0], xy[1], level * e + RELEASE_GAP_MM + e / 2 + e], float)
    try:
        pitch, _ = steepest_pitch_inside(p)
    except Unreachable:
        return np.zeros(2)
    t = np.pi / 2 - float(pitch)
    if t > np.pi / 4:
        return np.zeros(2)
    return np.array(xy, float) / np.linalg.norm(xy) * tipping_shift_mm(e, t)


class HandOver:
    """Hands large blocks over at HANDOVER_XY in the simulated world (ROYGBV in turn), up to `supply` blocks."""

    def __init__(self, world, seed: int = 0, supply: int = 24, jitter_mm: float = 4.0,
                 jitter_rad: float = float(np.radians(10.0))):
        self.world, self.supply = world, int(supply)
        self.jitter_mm, self.jitter_rad = float(jitter_mm), float(jitter_rad)
        self.rng = np.random.default_rng(seed)
        self.handed: list[ObjectState] = []

    def waiting(self) -> bool:
        """True while a handed block still stands at the hand-over spot."""
        return any(np.linalg.norm(o.position[:2] - np.asarray(HANDOVER_XY)) < NEAR_MM and o.id not in self.world.held
                   for o in self.world.objects)

    def hand_over(self) -> ObjectState | None:
        """Put the next block at the spot (when the spot is free and blocks are left); returns it."""
        if len(self.handed) >= self.supply or self.waiting():
            return None
        e = block_edge("large")
        xy = np.asarray(HANDOVER_XY) + self.rng.uniform(-self.jitter_mm, self.jitter_mm, 2)
        yaw = float(self.rng.uniform(-self.jitter_rad, self.jitter_rad))
        next_id = max((o.id for o in self.world.objects), default=-1) + 1
        obj = ObjectState(COLORS[len(self.handed) % 6], "large", e, np.array([xy[0], xy[1], e / 2]), yaw, "cube",
                          next_id)
        self.world.add(obj)
        self.handed.append(obj)
        return obj

    def score_options(self) -> dict:
        """score_sky's options: how many blocks could be handed over, and where."""
        return {"n_handed": self.supply, "handover_xy": HANDOVER_XY}


EVENT = EventSpec("sky", "to the sky", SKY_LEVELS, 600.0, kit_or_search("sky", "Sky"), score_sky,
                  scene=lambda level: "empty",
                  detection=SKY_SETTINGS, supply=HandOver)
