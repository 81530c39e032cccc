"""The simulator does not amplify rounding: runs whose inputs differ by 1e-12 end within 1e-6 mm of each other, and a
run repeats exactly on the same machine.

Another CPU (AVX-512 or not, another BLAS kernel, Apple silicon) computes sin, cos and matrix products with
last-bit differences (~1e-16 relative). Where the simulated manipulation chain made a decision on an exact comparison
those differences grew into tenths of a millimetre (notebooks 05-07 printed other positions there). Each test below
perturbs the simulator's inputs by 1e-12 (rad for joint commands, mm for positions), four orders of magnitude more
than a last-bit difference, and checks that the ends agree to 1e-6 mm.
"""

from __future__ import annotations

import numpy as np
import pytest

from armlab import calibration, make_station, tasks
from armlab.sim.arm import ArmRealism, SimArm
from armlab.sim.world import World
from armlab.tasks import teach
from armlab.tasks.events import event_station, run_event

PERTURBATION = 1e-12   # rad for joint commands, mm for object positions
AGREEMENT_MM = 1e-6


@pytest.fixture
def perturbed_commands(monkeypatch):
    """Returns enable(): from then on every joint command the simulated arm receives (move_to, move_by_hand) is
    moved by a seeded random 1e-12 rad per joint."""
    rng = np.random.default_rng(7)
    move_to, move_by_hand = SimArm.move_to, SimArm.move_by_hand

    def nudge(q):
        return np.asarray(q, dtype=float) + PERTURBATION * rng.standard_normal(5)

    def enable():
        monkeypatch.setattr(SimArm, "move_to", lambda self, q, *a, **k: move_to(self, nudge(q), *a, **k))
        monkeypatch.setattr(SimArm, "move_by_hand", lambda self, q: move_by_hand(self, nudge(q)))

    return enable


def _object_states(world) -> np.ndarray:
    return np.array([np.r_[o.position, o.yaw * 100.0] for o in world.objects])   # yaw as mm at 100 mm


def _teach_and_repeat_swap() -> np.ndarray:
    """Notebook 06's run: teach the swap by hand, replay it through the sag-compensated arm; the blocks' ends."""
    station = make_station("sim", seed=0, scene="swap")
    poses, gripper = teach.swap_waypoints()
    recorder = teach.Recorder(station.arm, name="swap")
    for q, g in zip(poses, gripper, strict=True):
        station.arm.move_by_hand(q)
        recorder.record(g)
    program = recorder.finish()                 # torque back on
    result = tasks.repeat(tasks.start_session(station).arm, program)
    assert result.grasps == (True, True, True)
    return _object_states(station.world)


def test_teach_and_repeat_ends_within_1e_6_mm_when_every_command_is_off_by_1e_12(perturbed_commands):
    plain = _teach_and_repeat_swap()
    perturbed_commands()
    nudged = _teach_and_repeat_swap()
    assert np.abs(nudged - plain).max() < AGREEMENT_MM, \
        f"blocks end {np.abs(nudged - plain).max():.2e} mm apart: something amplifies rounding"


def _sort_stack(scene_nudge: float = 0.0) -> np.ndarray:
    station = event_station("sort_stack", 1, seed=0)
    rng = np.random.default_rng(3)
    for o in station.world.objects:
        o.position[:2] += scene_nudge * rng.standard_normal(2)
    result = run_event(tasks.start_session(station), "sort_stack", 1, record=False)
    assert result.score.full_marks
    return _object_states(station.world)


def test_an_event_ends_within_1e_6_mm_when_commands_and_the_scene_are_off_by_1e_12(perturbed_commands):
    """Calibration, detection, planning, grasps, pushes and releases, from a perturbed scene and perturbed
    commands (the whole notebook-07 chain)."""
    plain = _sort_stack()
    perturbed_commands()
    nudged = _sort_stack(PERTURBATION)
    assert np.abs(nudged - plain).max() < AGREEMENT_MM, \
        f"blocks end {np.abs(nudged - plain).max():.2e} mm apart: something amplifies rounding"


def test_backlash_moves_the_link_continuously_with_the_motor():
    """A joint that moves by 1e-12 rad moves its link by no more than that (the old model flipped the whole play,
    3 mrad, on the sign of the last motion, so a last-bit difference in a command moved the tool by ~1 mm)."""
    realism = ArmRealism(shoulder_compliance_rad_per_nm=0.0, elbow_compliance_rad_per_nm=0.0,
                         joint_offset_std_rad=0.0, encoder_noise_rad=0.0, encoder_ticks=0)
    arm = SimArm(World(), realism)
    q = np.array([0.3, -0.2, 0.1, 0.4, 0.2])
    arm.move_to(q)
    before = arm.q_true
    assert np.allclose(before, q - realism.backlash_rad / 2 * np.sign(q - arm.robot.sleep), atol=1e-12), \
        "after a long move each link trails its motor by half the play"
    for step in (1e-12, -1e-12):
        arm.move_to(arm.joint_positions() + step)      # ideal encoders: the reading is the motor position
        assert np.abs(arm.q_true - before).max() <= 1e-12 + 1e-15, "a 1e-12 rad command moved a link further"
    arm.move_to(q - 0.01)                    # reversal: the play is taken up, then the links trail the other way
    assert np.allclose(arm.q_true, q - 0.01 + realism.backlash_rad / 2, atol=1e-12)
    arm.move_to(q - 0.01 + 0.001)           # back by less than the play: the gears turn, the links stay
    assert np.allclose(arm.q_true, q - 0.01 + realism.backlash_rad / 2, atol=1e-12)
    arm.move_to(q - 0.01 + 0.004)           # back by more: the links follow once the play is taken up
    assert np.allclose(arm.q_true, q - 0.01 + 0.004 - realism.backlash_rad / 2, atol=1e-12)


def test_checkerboard_intrinsics_repeat_exactly():
    """cv2.calibrateCamera's threaded sums differed by ~4e-7 px from call to call on 2 cores."""
    from armlab._paths import data_path

    images, meta = calibration.load_checkerboard_set(data_path("checkerboard"))
    results = [calibration.calibrate_intrinsics(images, tuple(meta["pattern_size"]), float(meta["square_mm"]))
               for _ in range(3)]
    for r in results[1:]:
        assert np.array_equal(r.K, results[0].K) and np.array_equal(r.dist, results[0].dist), \
            "the same checkerboard views gave another K: the solver is not repeatable"
