"""Exercise markers and the student release (armlab.exercises, tools/student-release).

The release must keep the kit usable while the exercises are blank: the simulator and the viewer run on the
manufacturer's model, never on a student's code, and each stub names its exercise.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from armlab.exercises import ExerciseMarkerError, find_regions, make_student_release, stub_regions

REPO = Path(__file__).resolve().parents[1]


def tracked(*suffixes: str) -> list[Path]:
    names = subprocess.run(["git", "-C", str(REPO), "ls-files"], capture_output=True, text=True, check=True).stdout
    return [REPO / n for n in names.split() if n.endswith(suffixes) and (REPO / n).is_file()]


def test_markers_pair_up_everywhere_and_check_cells_stay_outside():
    if not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    count = 0
    for path in tracked(".py"):
        count += len(find_regions(path.read_text(), str(path.relative_to(REPO))))
    for path in tracked(".ipynb"):
        for cell in json.loads(path.read_text())["cells"]:
            text = "".join(cell["source"])
            for region in find_regions(text, path.name):
                body = "\n".join(text.splitlines()[region.begin:region.end])
                assert "assert " not in body, f"{path.name}: a check sits inside an exercise region"
                count += 1
    assert count >= 20      # the DH, IK, calibration, detection and planning exercises at least


def test_bad_markers_are_named_with_file_and_line():
    begin, end = "# BEGIN SOLUTION", "# END SOLUTION"
    cases = {
        f"{begin}\nx = 1\n{begin}\n{end}\n": "f.py:3: BEGIN SOLUTION inside the region opened at line 1",
        f"x = 1\n{end}\n": "f.py:2: END SOLUTION without a BEGIN",
        f"def f():\n    {begin}\n    x = 1\n": "f.py:2: BEGIN SOLUTION never closed",
        f"def f():\n    {begin}\n    return 1\n{end}\n": "f.py:4: END SOLUTION indented differently",
        f"{begin}\n{end}\n": "f.py:2: empty solution region",
    }
    for text, message in cases.items():
        with pytest.raises(ExerciseMarkerError, match=message):
            find_regions(text, "f.py")


def test_a_stub_keeps_the_markers_and_raises_naming_the_exercise():
    text = "def area(r):\n    # BEGIN SOLUTION\n    a = 3.14159 * r * r\n    # END SOLUTION\n    return a\n"
    stub = stub_regions(text, "geometry.py")
    assert "3.14159" not in stub and stub.count("SOLUTION") == 2
    scope: dict = {}
    exec(compile(stub, "geometry.py", "exec"), scope)          # the stubbed module still imports
    with pytest.raises(NotImplementedError, match="exercise 1 of geometry.py"):
        scope["area"](1.0)


def test_the_student_release_runs_the_simulator_without_any_solution(tmp_path):
    if not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    out = tmp_path / "student"
    stubbed = make_student_release(REPO, out)
    assert "armlab/kinematics.py" in stubbed and any(n.endswith(".ipynb") for n in stubbed)
    with pytest.raises(FileExistsError):
        make_student_release(REPO, out)
    nb = json.loads((out / "notebooks/02_forward_kinematics.ipynb").read_text())
    assert all(c.get("outputs", []) == [] for c in nb["cells"])
    assert "NotImplementedError" in json.dumps(nb) and "BEGIN SOLUTION" in json.dumps(nb)
    code = """
import numpy as np
from armlab import kinematics, make_station
from armlab.viz.geometry import arm_part_poses
station = make_station("sim", seed=0, scene="swap")
station.arm.move_to(np.array([0.3, 0.1, 0.2, 0.4, 0.0]), moving_time=2.0)
frame = station.camera.capture()
assert frame.rgb.shape == (720, 1280, 3) and np.isfinite(frame.depth).mean() > 0.9
station.arm.open_gripper()
assert station.arm.close_gripper() in (True, False)
assert arm_part_poses(station.arm.joint_positions()) is not None
try:
    kinematics.fk(np.zeros(5))
except NotImplementedError as e:
    print("fk:", e)
"""
    env = {"PYTHONPATH": str(out), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-c", code], cwd=out, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "fk: exercise 1 of armlab/kinematics.py" in run.stdout
