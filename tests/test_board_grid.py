"""Pick and place over the whole board: on a cheap subset of the benchmark grid (benchmarks/scenarios/board_grid.py,
the full grid in benchmarks/manipulation.py grid), every pick and place across the regions is done, none is refused
mid-plan (that would be a pre-check bug), and the placed blocks land within the issue's 3 mm; the scene helper that
puts a block at a chosen spot of a seeded scene."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from armlab.blocks import ObjectState
from armlab.sim.scenes import SceneError, scene_objects, with_objects_at
from armlab.sim.world import World

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
if not (BENCHMARKS / "scenarios" / "board_grid.py").is_file():
    pytest.skip("no benchmarks here (a student release)", allow_module_level=True)
sys.path.insert(0, str(BENCHMARKS))
from scenarios import board_grid  # noqa: E402


def _spot(region: str, x: float, y: float) -> board_grid.GridSpot:
    (spot,) = [s for s in board_grid.GRID if s.region == region and abs(s.x - x) < 1 and abs(s.y - y) < 1]
    return spot


# six trials, twelve spots: each region picked from and placed at, at both ends of its reach or on both sides
SUBSET = [
    (_spot("in front, close in", 0, 150), _spot("behind the waist axis", -85, -147)),
    (_spot("in front, full reach", 0, 420), _spot("on a stack", 85, 147)),
    (_spot("beside the base", -330, 0), _spot("in front, full reach", -169, 362)),
    (_spot("behind the waist axis", 272, -127), _spot("in front, close in", 106, 126)),
    (_spot("on a stack", -168, -141), _spot("beside the base", 410, 0)),
    (_spot("in front, full reach", 355, 205), _spot("behind the waist axis", -376, -137)),
]


@pytest.fixture(scope="module")
def outcomes():
    out = []
    for i, (pick, place) in enumerate(SUBSET):
        picked, placed = board_grid.run_trial(pick, place, 600 + i)
        out += [picked, placed]
    return out


def test_the_subset_covers_every_region_as_pick_and_as_place():
    for k in (0, 1):
        assert {pair[k].region for pair in SUBSET} >= set(board_grid.REGIONS[:-1])


def test_no_pick_or_place_on_the_grid_subset_is_refused_mid_plan(outcomes):
    mid = [f"{o.action} at {o.spot}: {o.message}" for o in outcomes
           if o is not None and o.outcome == "refused mid-plan"]
    assert not mid, mid


def test_every_pick_and_place_on_the_grid_subset_is_done_within_3_mm(outcomes):
    failed = [f"{o.action} at {o.spot} ({o.spot.region}): {o.outcome} {o.message}" for o in outcomes
              if o is not None and o.outcome != "done"]
    assert not failed and None not in outcomes, failed
    errors = np.abs([o.error for o in outcomes if o.action == "place"])
    assert errors.max() < 3.0, errors.round(2)
    assert np.all(errors.mean(axis=0) < 1.0), errors.mean(axis=0)
    grasp = np.abs([o.error for o in outcomes if o.action == "pick"])
    assert grasp.max() < 3.0, grasp.round(2)                    # the pads close on the block where planned


def test_the_task_layers_held_block_is_the_physics_worlds_after_every_grasp(outcomes):
    """After each pick, what the task layer believes it holds (session.held_in_tool: the block's pose in the tool
    frame as planned) against the physics world's truth (the held block's pose in the true tool frame). Measured
    2026-12-07 with grasps by contact: within 0.7 mm and 0.1 deg on the four top-down picks; the two at full reach,
    whose pitched tools meet the block 8 deg off square with the closing axis 5 deg off horizontal, hold it 1.8 and
    1.5 mm and 3.9 and 2.5 deg from the belief (the pads seat it where contact leaves it). Their places still land
    within 3 mm (test_placed_blocks_land_within_3_mm)."""
    picks = [o for o in outcomes if o is not None and o.action == "pick" and o.outcome == "done"]
    assert len(picks) == len(SUBSET)
    off = [f"{o.spot}: {np.round(o.error, 2)} mm, {np.degrees(o.turn_rad):.2f} deg" for o in picks
           if np.linalg.norm(o.error) >= 2.5 or o.turn_rad >= np.radians(5.0)]
    assert not off, off


def test_grid_spots_are_on_the_board_in_their_regions_and_pairs_use_each_once():
    from armlab.lab import lab_config

    lab = lab_config()
    for s in board_grid.GRID:
        assert lab.on_board(np.array([s.x, s.y])), s
        if s.region == "behind the waist axis":
            assert s.y < 0
    spots = [*board_grid.GRID, *board_grid.random_spots(5, seed=3)]
    assert board_grid.random_spots(5, seed=3) == spots[-5:]               # seeded
    pairs = board_grid.grid_pairs(spots)
    assert sorted(map(str, (p for p, _ in pairs))) == sorted(map(str, spots))
    assert sorted(map(str, (q for _, q in pairs))) == sorted(map(str, spots))
    assert all(p != q for p, q in pairs)


def test_with_objects_at_puts_blocks_at_chosen_spots_of_a_seeded_scene():
    base = scene_objects("random", 5, n=6)
    near = base[0].position[:2]
    cube = ObjectState("red", "large", 38.0, np.array([near[0], near[1], 0.0]), 0.3)
    top = ObjectState("blue", "small", 25.0, np.array([near[0], near[1], 0.0]), 0.3)
    objects = with_objects_at(base, [cube, top])
    kept = [o for o in base if np.hypot(*(o.position[:2] - near)) > 70.0]
    assert 0 < len(kept) < len(base) and len(objects) == len(kept) + 2     # the scattered ones there left out
    assert not World(objects).problems()
    bottom, upper = objects[-2:]
    assert bottom.position[2] == pytest.approx(19.0) and upper.position[2] == pytest.approx(38.0 + 12.5)
    assert len({o.id for o in objects}) == len(objects)
    assert base[0].position[2] == pytest.approx(base[0].edge / 2)                    # the input is untouched
    with pytest.raises(SceneError, match="not entirely on the board"):
        with_objects_at(base, [ObjectState("red", "large", 38.0, np.array([499.0, 0.0, 0.0]))])
    with pytest.raises(SceneError, match="keep_out_mm"):
        with_objects_at(base, [cube], keep_out_mm=float("nan"))
