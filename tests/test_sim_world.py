"""The block world: statics (dropping, stacking, tipping, pushing), scene presets and the event rules, JSON files."""

import json

import numpy as np
import pytest

from armlab.blocks import COLORS, ObjectState, block_edge
from armlab.lab import lab_config
from armlab.sim import PRESETS, SceneError, World, load_scene, save_scene, scene_objects
from armlab.sim.scenes import REACH_MM, SWAP_SPOTS_MM, scene_to_dict


def cube(color="red", size="large", xy=(0.0, 250.0), z=None, yaw=0.0, id=0):
    e = block_edge(size)
    return ObjectState(color, size, e, np.array([xy[0], xy[1], e / 2 if z is None else z]), yaw, "cube", id)


def stack_heights(objects) -> list[int]:
    """Number of objects in each stack (objects resting on the board start a stack)."""
    world = World(objects)
    return [1 + len(world.stack_above(o)) for o in objects if o.bottom_z < 1e-6]


# -- statics -----------------------------------------------------------------------------------------------------

def test_dropped_block_lands_on_the_highest_support_under_it():
    world = World([cube("red", id=0), cube("blue", "small", xy=(200.0, 250.0), id=1)])
    falling = world.add(cube("green", "small", xy=(5.0, 250.0), z=300.0, id=2))
    assert falling.position[2] == pytest.approx(38.0 + 12.5)
    assert world.problems() == []


def test_block_hanging_over_the_edge_tips_off_beside_its_support():
    world = World([cube("red", id=0)])
    falling = world.add(cube("green", xy=(21.0, 250.0), z=200.0, id=1))   # centre beyond the 19 mm half edge
    assert falling.position[2] == pytest.approx(19.0)
    assert falling.position[0] >= 38.0
    assert world.problems() == []


def test_block_bridging_two_blocks_is_supported_by_both():
    world = World([cube("red", xy=(-22.0, 250.0), id=0), cube("blue", xy=(22.0, 250.0), id=1)])
    top = world.add(cube("green", xy=(0.0, 250.0), z=200.0, id=2))        # centre over the gap, not over either
    assert top.position[2] == pytest.approx(38.0 + 19.0)
    assert world.problems() == []


def test_shove_carries_the_stack_and_pushes_what_it_runs_into():
    a, b, c = cube("red", id=0), cube("blue", "small", z=38.0 + 12.5, id=1), cube("green", xy=(50.0, 250.0), id=2)
    world = World([a, b, c])
    world.shove(a, [1.0, 0.0], 20.0)
    assert a.position[0] == pytest.approx(20.0, abs=1.0)              # a pushed block slides on a little (physics)
    assert b.position[0] == pytest.approx(a.position[0], abs=1.0)     # b rode along on a, by friction
    assert c.position[0] >= a.position[0] + 38.0 - 0.1                # c was pushed clear
    assert world.problems() == []


def test_problems_name_overlaps_floating_and_off_board_objects():
    world = World([cube("red", id=0), cube("blue", xy=(10.0, 250.0), id=1), cube("green", xy=(200.0, 250.0), z=60.0,
                                                                              id=2),
                   cube("yellow", xy=(495.0, 0.0), id=3)])
    text = " | ".join(world.problems())
    assert "object 0 (large red block" in text and "overlaps object 1" in text
    assert "object 2" in text and "does not rest on its support" in text
    assert "object 3" in text and "not entirely on the board" in text


def test_clock_advances_in_small_steps_and_rejects_bad_steps():
    world, seen = World(), []
    world.add_listener(seen.append)
    world.advance(0.1)
    assert len(seen) == 5 and seen[-1] == pytest.approx(0.1) and world.time_s == pytest.approx(0.1)
    with pytest.raises(ValueError, match="dt must be"):
        world.advance(-1.0)


# -- presets -----------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_is_valid_reachable_and_seeded(name):
    objects = scene_objects(name, seed=7)
    assert World(objects).problems() == []
    lab = lab_config()
    tags = np.array(list(lab.tags.centres_mm.values()))
    for o in objects:
        r = np.hypot(*o.position[:2])
        assert REACH_MM[0] - 1 <= r <= REACH_MM[1] + 1 or name == "swap"
        assert np.min(np.linalg.norm(tags - o.position[:2], axis=1)) > 30.0     # AprilTags stay visible
    again = scene_objects(name, seed=7)
    assert scene_to_dict(objects) == scene_to_dict(again)
    if name not in ("empty", "swap"):
        assert scene_to_dict(objects) != scene_to_dict(scene_objects(name, seed=8))


def test_swap_scene_matches_the_lab_report():
    blocks = scene_objects("swap")
    assert [tuple(b.position[:2]) for b in blocks] == [SWAP_SPOTS_MM["A"], SWAP_SPOTS_MM["B"]]
    assert all(b.position[2] == b.edge / 2 for b in blocks)
    assert SWAP_SPOTS_MM["intermediate"] == (250.0, 75.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sort_n_stack_levels_follow_the_event_rules(seed):
    one, two, three = (scene_objects(f"sort_stack_{k}", seed=seed) for k in (1, 2, 3))
    for objects in (one, two, three):
        assert all(np.vstack(o.footprint_world())[:, 1].min() > 0 for o in objects)   # every block starts at y > 0
    assert sorted(b.color for b in one) == ["blue", "green", "red"] and {b.size for b in one} == {"large"}
    for objects in (two, three):
        blocks = [o for o in objects if o.is_block]
        assert len(blocks) == 6 and sorted(b.size for b in blocks) == ["large"] * 3 + ["small"] * 3
        for size in ("large", "small"):
            assert len({b.color for b in blocks if b.size == size}) == 3
    assert max(stack_heights(two)) == 1 and all(o.is_block for o in two)
    assert max(stack_heights(three)) == 2 and any(not o.is_block for o in three)


@pytest.mark.parametrize("seed", [0, 1])
def test_line_em_up_levels_follow_the_event_rules(seed):
    one, two, three = (scene_objects(f"line_up_{k}", seed=seed) for k in (1, 2, 3))
    assert sorted(b.color for b in one) == sorted(COLORS) and {b.size for b in one} == {"large"}
    for objects in (two, three):
        blocks = [o for o in objects if o.is_block]
        assert sorted((b.size, b.color) for b in blocks) == sorted((s, c) for s in ("large", "small") for c in COLORS)
    assert max(stack_heights(one)) == 1 and max(stack_heights(two)) == 1
    assert max(stack_heights(three)) == 3 and any(not o.is_block for o in three)


def test_sky_random_and_stacks_options():
    assert {b.size for b in scene_objects("sky", n=5)} == {"large"} and len(scene_objects("sky", n=5)) == 5
    assert len(scene_objects("random", seed=3, n=10)) == 10
    assert all(2 <= h <= 3 for h in stack_heights(scene_objects("stacks", seed=3, n_stacks=4)))
    with pytest.raises(SceneError, match="option n must be an integer"):
        scene_objects("random", n=-1)
    with pytest.raises(SceneError, match="does not take options"):
        scene_objects("swap", n=3)
    with pytest.raises(SceneError, match="unknown scene 'chess'"):
        scene_objects("chess")


# -- JSON --------------------------------------------------------------------------------------------------------

def test_json_round_trip_is_exact_and_atomic(tmp_path):
    objects = scene_objects("line_up_3", seed=4)
    path = save_scene(objects, tmp_path / "scene.json")
    assert [p.name for p in tmp_path.iterdir()] == ["scene.json"]              # no temporary file left behind
    assert scene_to_dict(load_scene(path)) == scene_to_dict(objects)
    assert scene_to_dict(scene_objects(str(path))) == scene_to_dict(objects)


def test_json_positions_without_z_are_dropped_in_file_order(tmp_path):
    path = tmp_path / "drop.json"
    path.write_text(json.dumps({"objects": [
        {"color": "red", "size": "large", "position_mm": [0, 250]},
        {"color": "blue", "size": "small", "position_mm": [3, 250], "yaw_rad": 0.2}]}))
    low, high = load_scene(path)
    assert low.position[2] == 19.0 and high.position[2] == pytest.approx(38.0 + 12.5)


@pytest.mark.parametrize("content, message", [
    ("{not json", "not valid JSON"),
    ('{"objects": {}}', "objects: must be of type array"),
    ('{"objects": [{"color": "red", "size": "large"}]}', r"objects\[0\]\.position_mm: missing"),
    ('{"objects": [{"color": "pink", "size": "large", "position_mm": [0, 250]}]}', "object 0: colour 'pink'"),
    ('{"objects": [{"color": "red", "size": "huge", "position_mm": [0, 250]}]}', "object 0: size 'huge'"),
    ('{"objects": [{"color": "red", "size": "large", "position_mm": [0, 250, 19], "mass": 3}]}',
     r"objects\[0\]: unknown key.*'mass'"),
    ('{"objects": [{"color": "red", "size": "large", "position_mm": [0, "a"]}]}',
     r"objects\[0\]\.position_mm\[1\]: must be of type number"),
    ('{"objects": [{"color": "red", "size": "large", "position_mm": [0, 250, 19]},'
     ' {"color": "blue", "size": "large", "position_mm": [10, 250, 19]}]}', "overlaps"),
    ('{"objects": [{"color": "red", "size": "large", "position_mm": [0, 250, 50]}]}', "does not rest"),
    ('{"objects": [{"color": "red", "size": "large", "position_mm": [0, 900, 19]}]}', "not entirely on the board"),
    ('{"format": "other", "objects": []}', "is not 'armlab-scene'"),
])
def test_bad_json_is_refused_naming_the_problem(tmp_path, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(SceneError, match=message):
        load_scene(path)


def test_saving_an_invalid_scene_writes_nothing(tmp_path):
    path = tmp_path / "scene.json"
    save_scene(scene_objects("swap"), path)
    before = path.read_text()
    with pytest.raises(SceneError, match="overlaps"):
        save_scene([cube("red", id=0), cube("blue", xy=(5.0, 250.0), id=1)], path)
    assert path.read_text() == before and [p.name for p in tmp_path.iterdir()] == ["scene.json"]
