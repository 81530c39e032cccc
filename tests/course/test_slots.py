"""The engine's slots (armlab.slots) and its truth: a plausible wrong answer in any package slot changes nothing the kit
believes, only that slot's own demonstrations.

For every package exercise and each of its two wrong answers (tests/course/wrong_answers.py HIDDEN_WRONG), a copy of the
engine with that wrong region computes, in a fresh process, the kit's truths: forward kinematics and the Jacobian
(the manufacturer's PoX model), the kit's own IK (ik_pox), every stand-in (the kit's reference for each slot), the
course's references for the notebooks' exercises, the motion safety verdicts (board intrusion of fixed moves, the
whole-plan check of fixed plans, placements) and the simulator (a move, the world, a camera frame). Each must equal
the instructor's to the last bit. The demonstrations a slot may change, as its notebook says (fk_dh chains the DH
slot in notebook 02, the planners use the student's IK from notebook 03 on, ...), are not among them; the test shows
it can fail: the DH chain itself is probed too and must change under each wrong dh_link_transform.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from wrong_answers import HIDDEN_WRONG

from armlab import slots
from armlab_course.exercises import EXERCISES, find_regions

ROOT = Path(__file__).resolve().parents[2]
PACKAGE_SLOTS = [e for e in EXERCISES if e.in_package]

PROBE = r'''
import json, sys
import numpy as np

from armlab import kinematics, motion_safety
from armlab.calibration import depth, extrinsics, homography
from armlab.camera import Camera
from armlab.detection.color import ColorModel, default_color_model
from armlab.robot import rx200
from armlab_course.exercises import references

out = {}
rng = np.random.default_rng(7)
robot = rx200()
Q = rng.uniform(robot.lower, robot.upper, (16, 5))
out["fk"] = kinematics.fk(Q)
out["link_frames"] = kinematics.link_frames(Q)
out["joint_positions"] = kinematics.joint_positions(Q)
out["jacobian"] = kinematics.jacobian(Q[:4])
out["ik_pox"] = kinematics.ik_pox([150.0, 220.0, 40.0], np.pi / 2, 0.3)
out["dh_chain (demonstration)"] = kinematics.fk_dh(Q, check_limits=False)      # the DH slot's own: may change
# the stand-ins: the kit's own method for each slot
P = np.array([[150.0, 220.0, 40.0], [-120.0, 260.0, 90.0]])
c = kinematics._numerical_candidates(P, np.array([np.pi / 2, 1.0]), np.array([0.0, 0.2]), robot)
out["ik stand-in"] = np.nan_to_num(c.q, nan=-99.0)
out["dh stand-in"] = kinematics._dh_by_elementary_motions(Q[:, 1], 10.0, 200.0, 0.4)
K = np.array([[900.0, 0.0, 640.0], [0.0, 900.0, 360.0], [0.0, 0.0, 1.0]])
T = extrinsics.hand_measured_extrinsic()
world = np.column_stack([rng.uniform(-400, 400, 12), rng.uniform(-150, 450, 12), np.zeros(12)])
cam = world @ T[:3, :3].T + T[:3, 3]
uv = cam @ K.T
pixels = uv[:, :2] / uv[:, 2:] + rng.normal(0, 0.3, (12, 2))
out["pose stand-in"] = extrinsics._opencv_pose(world, pixels, K, np.zeros(5))
out["homography stand-in"] = homography.opencv_homography(world[:, :2], pixels)
camera = Camera(K, np.zeros(5), T)
board, on_board = depth.board_depth(camera)
vv, uu = np.mgrid[0:720, 0:1280]
tilted = np.where(on_board, board + 0.01 * uu - 0.005 * vv + 3.0, np.nan)
tilted[300:340, 600:660] -= 38.0                                                  # a block
out["depth stand-in"] = [depth._robust_plane(tilted, camera).a, depth._robust_plane(tilted, camera).c]
model = default_color_model()
rgb = rng.uniform(20, 235, (40, 3))
out["classify stand-in"] = ColorModel._nearest_mean(model, rgb)[1]
out["course: ik_by_least_squares"] = references.ik_by_least_squares(kinematics.fk(Q[0]), Q[1])[0]
out["course: pose_error_by_log"] = references.pose_error_by_log(kinematics.fk(Q[2]), kinematics.fk(Q[3]))
out["course: segment_by_colour_model"] = references.segment_by_colour_model(
    rng.integers(0, 255, (24, 32, 3)).astype(np.uint8))
# safety verdicts: straight joint moves against the board, placements
verdicts = []
for q0, q1 in zip(Q[:8], Q[8:]):
    verdicts.append(motion_safety.board_intrusion(q0, q1, motion_safety.REAL_CLEARANCE, robot) or "clear")
out["board verdicts"] = verdicts
out["placements"] = [motion_safety.placement_problem(p, 38.0) or "ok" for p in ([0.0, 250.0, 0.0], [450.0, 0.0, 0.0],
                                                                              [0.0, 30.0, 0.0])]
# the kit's own inputs: the swap's waypoints (teach.replay's), a detection case with the arm over the board
from armlab.sim.detection_eval import sim_case
from armlab.tasks.teach import swap_waypoints
out["teach: swap waypoints"] = swap_waypoints()[0]
case = sim_case("stacks", 5, arm_over_board=True)
out["detection case: arm"] = case.arm_q
# the simulator
from armlab import make_station
station = make_station("sim", seed=3, scene="swap")
station.arm.move_to(np.array([0.3, 0.1, 0.2, 0.4, 0.0]), moving_time=2.0)
frame = station.camera.capture()
out["sim arm"] = station.arm.joint_positions()
out["sim world"] = [list(o.position) for o in station.world.objects]
out["sim frame"] = [float(frame.rgb.astype(float).mean()), float(np.nanmean(frame.depth))]


def plain(x):
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return plain(x.tolist())
    if isinstance(x, (np.floating, float)):
        return repr(float(x))
    return x


import armlab
out["engine"] = armlab.__file__
json.dump(plain(out), sys.stdout)
'''


def wrong_tree(tmp: Path, exercise_id: str, bodies: list[str]) -> Path:
    """A copy of the engine (armlab/) whose regions of `exercise_id` hold `bodies`."""
    e = next(x for x in EXERCISES if x.id == exercise_id)
    shutil.copytree(ROOT / "armlab", tmp / "armlab", ignore=shutil.ignore_patterns("__pycache__"))
    path = tmp / e.where
    text = path.read_text()
    lines, out, last = text.splitlines(), [], 0
    regions = [r for r in find_regions(text, e.where) if r.exercise_id == exercise_id]
    assert len(regions) == len(bodies), exercise_id
    for r, body in zip(regions, bodies, strict=True):
        out += lines[last:r.begin + 1] + body.splitlines()
        last = r.end
    path.write_text("\n".join(out + lines[last:]) + "\n")
    return tmp


def truths(tree: Path | None) -> dict:
    path = f"{tree}:{ROOT}" if tree else str(ROOT)
    run = subprocess.run([sys.executable, "-c", PROBE], cwd=tree or ROOT, capture_output=True, text=True, timeout=900,
                         env={"PYTHONPATH": path, "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg",
                              "HOME": str(Path.home())})
    assert run.returncode == 0, run.stderr[-3000:]
    found = json.loads(run.stdout)
    assert found.pop("engine") == str((tree or ROOT) / "armlab" / "__init__.py")      # the copy, not the checkout
    return found


def test_every_package_slot_has_two_wrong_answers():
    assert len(PACKAGE_SLOTS) == 7
    for e in PACKAGE_SLOTS:
        assert len(HIDDEN_WRONG[e.id]) >= 2, e.id


def test_a_wrong_answer_in_any_package_slot_changes_none_of_the_kits_truths(tmp_path):
    cases = [(e.id, name, bodies) for e in PACKAGE_SLOTS for name, bodies in HIDDEN_WRONG[e.id].items()]
    trees = [wrong_tree(tmp_path / f"t{k}", x, bodies) for k, (x, _, bodies) in enumerate(cases)]
    with ThreadPoolExecutor(max_workers=2) as pool:
        reference = pool.submit(truths, None)
        results = list(pool.map(truths, trees))
        reference = reference.result()
    changed = []
    for (exercise_id, name, _), got in zip(cases, results, strict=True):
        moved = sorted(k for k in reference if got[k] != reference[k])
        if exercise_id == "fk.dh_link_transform":        # the test can fail: the DH chain itself does change
            assert moved == ["dh_chain (demonstration)"], (name, moved)
            continue
        changed += [f"{exercise_id} ({name}): {k}" for k in moved if "demonstration" not in k]
    assert not changed, "a wrong slot changed the kit's truth:\n" + "\n".join(changed)


def test_slot_not_written_crosses_processes_and_names_its_slot():
    import pickle

    e = slots.SlotNotWritten("fk.dh_link_transform", "write it", "exercise fk.dh_link_transform (notebook 02)")
    back = pickle.loads(pickle.dumps(e))
    assert (type(back), back.slot_id, str(back), back.label) == (slots.SlotNotWritten, e.slot_id, "write it", e.label)
    assert isinstance(back, NotImplementedError)
    with pytest.raises(TypeError):
        slots.SlotNotWritten("")
    with pytest.raises(TypeError):
        slots.standin(None, print, "")


def test_kit_or_standin_takes_the_kits_where_installed_and_the_standin_otherwise(tmp_path, monkeypatch):
    """The instructor's tree finds the kit's code that answers an exercise; without its module (the student release)
    the stand-in answers; an import error inside an installed module is not taken for a missing module."""
    from armlab.tasks import buttons

    assert slots.kit_or_standin("armlab.tasks.buttons", "refuse_out_of_turn", print) is buttons.refuse_out_of_turn
    assert slots.kit_or_standin("armlab.tasks.no_such_kit_module", "anything", print) is print
    (tmp_path / "kit_breaks_inside.py").write_text("import no_such_dependency_of_the_kit\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ModuleNotFoundError, match="no_such_dependency_of_the_kit"):
        slots.kit_or_standin("kit_breaks_inside", "anything", print)
