"""The world's contact physics (armlab.sim.physics through armlab.sim.World and the public scene API): leaning towers
fall or stand as statics predicts, a pushed stack moves as a rigid one, and the same scene gives the same result."""

import numpy as np
import pytest

from armlab.blocks import ObjectState, block_edge
from armlab.sim import World
from armlab.sim.physics.mjcf import scene_mjcf
from armlab.sim.scenes import scene_to_dict, with_objects_at

E = block_edge("large")
BASE = np.array([-300.0, 250.0])    # a tower falling +x stays on the board


def leaning(n: int, step_mm: float) -> list[ObjectState]:
    """n large blocks, each listed to be dropped on the one before and shifted step_mm further out (+x)."""
    return [ObjectState("red", "large", E, np.array([BASE[0] + k * step_mm, BASE[1], 0.0]), 0.0, "cube", k)
            for k in range(n)]


def statics_stands(n: int, step_mm: float) -> bool:
    """Statics of a stack of equal cubes: it stands when, above every block, the centre of mass of everything above
    lies over that block's top face (within its half edge)."""
    x = np.arange(n) * step_mm
    return all(abs(x[j + 1:].mean() - x[j]) < E / 2 for j in range(n - 1))


@pytest.mark.parametrize("n, step_mm", [(10, 0.0), (10, 3.0), (10, 5.0), (4, 8.0), (5, 9.0), (10, 10.0)])
def test_leaning_towers_fall_or_stand_as_statics_predicts(n, step_mm):
    objects = with_objects_at([], leaning(n, step_mm))
    tops = sorted(o.top_z for o in objects)
    standing = np.allclose(tops, E * np.arange(1, n + 1), atol=0.5)
    assert standing == statics_stands(n, step_mm)
    # each block alone is over the one below it (|step| < e/2): the old block-by-block check let all of these stand
    assert all(step_mm < E / 2 for _ in objects)
    if not standing:
        assert max(tops) < E * n - E                          # it fell: the top is at least a level lower


def test_pushed_stack_moves_as_a_rigid_stack_and_pushes_what_it_meets():
    a = ObjectState("red", "large", E, np.array([0.0, 250.0, E / 2]), 0.0, "cube", 0)
    b = ObjectState("blue", "large", E, np.array([0.0, 250.0, 1.5 * E]), 0.0, "cube", 1)
    c = ObjectState("green", "small", 25.0, np.array([0.0, 250.0, 2 * E + 12.5]), 0.3, "cube", 2)
    d = ObjectState("yellow", "large", E, np.array([80.0, 250.0, E / 2]), 0.0, "cube", 3)
    world = World([a, b, c, d])
    world.shove(a, [1.0, 0.0], 60.0)
    assert a.position[0] == pytest.approx(60.0, abs=1.0) and abs(a.position[1] - 250.0) < 2.0
    for o, below in ((b, a), (c, b)):     # the stack rode along in place on its base (within 4 % of the 38 mm edge)
        assert np.linalg.norm(o.position[:2] - below.position[:2]) < 1.5
        assert o.bottom_z == pytest.approx(below.top_z, abs=0.5)
    assert c.yaw == pytest.approx(0.3, abs=np.radians(3.0))     # 2.5 deg turned with condim 3 (materials.py)
    assert d.position[0] >= a.position[0] + E - 0.1           # the block it ran into was pushed ahead
    assert world.problems() == []


def test_the_same_scene_settles_the_same_way():
    runs = [scene_to_dict(with_objects_at([], leaning(6, 9.0))) for _ in range(2)]
    assert runs[0] == runs[1]


def test_masses_come_from_the_wood_density():
    import mujoco

    model = mujoco.MjModel.from_xml_string(scene_mjcf([("cube", 38.0), ("cube", 25.0), ("cylinder", 38.0)]))
    masses = [model.body(f"object{k}").mass[0] for k in range(3)]
    assert masses[0] == pytest.approx(600.0 * 0.038 ** 3, rel=1e-6)
    assert masses[1] == pytest.approx(600.0 * 0.025 ** 3, rel=1e-6)
    assert masses[2] == pytest.approx(600.0 * np.pi * 0.019 ** 2 * 0.038, rel=0.02)   # a 24-sided prism


def test_a_block_dropped_over_the_edge_topples_and_a_settled_world_stays():
    world = World([ObjectState("red", "large", E, np.array([0.0, 250.0, E / 2]), 0.0, "cube", 0)])
    top = world.add(ObjectState("green", "large", E, np.array([22.0, 250.0, 200.0]), 0.0, "cube", 1))
    assert top.top_z < 2 * E - 5.0                          # centre 3 mm beyond the edge: it does not stay up there
    assert world.would_move() == []


def test_pads_squeeze_and_lift_a_block_by_friction_and_an_off_centre_grip_turns_it_more():
    from armlab.gripper_geometry import GRIPPER
    from armlab.sim.physics.grasp import LIFT_MM, contact_grip

    R = np.column_stack([[0, 0, -1], [1, 0, 0], [0, -1, 0]]).astype(float)     # top-down, closing along +x
    turns = []
    for off in (0.0, 10.0):
        block = ObjectState("red", "large", E, np.array([0.0, 250.0, E / 2]), 0.0, "cube", 0)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, [0.0, 250.0, E / 2] + off * R[:, 2]
        grip = contact_grip([block], 0, T, GRIPPER, GRIPPER.max_opening_mm, E)
        assert grip.held and grip.rise_mm == pytest.approx(LIFT_MM, abs=0.1)
        assert grip.force_n == pytest.approx(13.0, abs=0.1)                 # the servo at the default pressure
        np.testing.assert_allclose(grip.T_tool_block[:3, 3], [0.0, 0.0, -off], atol=0.1)   # where the pads hold it
        assert grip.gap_mm == pytest.approx(E, abs=0.2)                     # the pads sink in a little
        turns.append(grip.turn_rad)
    assert turns[0] < np.radians(0.01) < turns[1]          # gravity turns a block gripped off its centre


def test_the_servo_force_follows_the_pressure():
    from armlab.gripper_geometry import GRIPPER
    from armlab.sim.physics import gripper_servo

    forces = [gripper_servo.pad_force_n(p, E / 2 + GRIPPER.pad_thickness_mm) for p in (0.0, 0.5, 1.0)]
    assert forces == pytest.approx([7.8, 13.0, 18.2], abs=0.1)              # (150 + 200 p) / 885 of the stall torque
    small = gripper_servo.pad_force_n(0.5, 12.5 + GRIPPER.pad_thickness_mm)
    assert small == pytest.approx(16.0, abs=0.1)                            # the crank's lever is shorter there
    with pytest.raises(ValueError, match="pressure"):
        gripper_servo.duty(1.5)
    with pytest.raises(ValueError, match="crank's travel"):
        gripper_servo.pad_force_n(0.5, 40.0)


def test_the_arm_is_a_body_a_block_dropped_on_its_gripper_rests_there_and_a_part_inside_a_block_is_left_out():
    from armlab.gripper_geometry import GRIPPER
    from armlab.robot import rx200
    from armlab.sim.physics import Physics
    from armlab.sim.physics.arm_bodies import BAR_HALF_MM, arm_parts

    robot = rx200()
    home = arm_parts(np.zeros(5), robot, GRIPPER, GRIPPER.max_opening_mm)       # the arm straight out at 304.57 mm
    assert [p.name for p in home] == ["upper arm", "forearm", "wrist", "gripper bar", "left finger", "right finger"]
    bar = home[3]
    block = ObjectState("red", "large", E, bar.pose[:3, 3] + [0.0, 0.0, 60.0], 0.0, "cube", 0)
    physics = Physics([block], arm=home)
    physics.run_to_rest()
    position, _ = physics.pose(0)
    assert position[2] == pytest.approx(304.57 + BAR_HALF_MM[1] + E / 2, abs=0.5)   # on the bar's top, not the board
    # the arm reaching down into a block (a link swept through it): that part is left out, the block stays put
    from armlab import kinematics

    low = kinematics.ik([0.0, 250.0, 19.0], np.pi / 2, 0.0)[0]                  # top-down at a block's centre height
    fingers = arm_parts(low, robot, GRIPPER, GRIPPER.max_opening_mm)
    tip = fingers[4].pose[:3, 3]
    inside = ObjectState("blue", "large", E, np.array([tip[0], tip[1], E / 2]), 0.0, "cube", 0)
    physics = Physics([inside], arm=fingers)
    assert "left finger" in physics.arm_left_out
    physics.run_to_rest()
    np.testing.assert_allclose(physics.pose(0)[0], inside.position, atol=0.1)
