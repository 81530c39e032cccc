"""Exercises (armlab_course.exercises): the registry, the solution markers, and the student release
(tools/student-release).

The registry is the one place an exercise is declared; the markers in the package and the notebooks must agree with
it; the release must be a student's repository: stubs naming their exercise, student-facing files only, no solution
text anywhere, and a kit that still runs while the exercises are blank.
"""

from __future__ import annotations

import itertools
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from armlab_course.exercises import (
    EXERCISES,
    ExerciseMarkerError,
    ExerciseNotWritten,
    exercise,
    exercises_table,
    find_answers,
    find_regions,
    make_student_release,
    released,
    stub_regions,
)
from armlab_course.exercises.markers import stub_lines

REPO = Path(__file__).resolve().parents[2]
CHECK_TAG = re.compile(r"^# CHECK (?P<ids>.+)$", re.M)


def tracked(*suffixes: str) -> list[Path]:
    names = subprocess.run(["git", "-C", str(REPO), "ls-files"], capture_output=True, text=True, check=True).stdout
    return [REPO / n for n in names.split() if n.endswith(suffixes) and (REPO / n).is_file()]


def notebook_code_cells(stem: str) -> list[str]:
    nb = json.loads((REPO / "notebooks" / f"{stem}.ipynb").read_text())
    return ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]


@pytest.fixture(scope="module")
def git_checkout():
    if not (REPO / ".git").exists():
        pytest.skip("not a git checkout")


def test_every_region_names_a_registered_exercise_and_every_exercise_has_its_regions(git_checkout):
    seen: dict[str, set[str]] = {}
    for path in tracked(".py"):
        name = path.relative_to(REPO).as_posix()
        for region in find_regions(path.read_text(), name):
            seen.setdefault(region.exercise_id, set()).add(name)
    for e in EXERCISES:
        if e.kind == "written":                  # an answer cell, not a code region
            answers = find_answers(["".join(c["source"]) for c in json.loads(
                (REPO / "notebooks" / f"{e.notebook}.ipynb").read_text())["cells"] if c["cell_type"] == "markdown"])
            assert e.id in answers, f"{e.id}: notebooks/{e.notebook}.ipynb has no answer cell for it"
            assert e.id not in seen, f"{e.id}: a written answer has a code region"
            continue
        assert seen.get(e.id) == {e.where}, f"{e.id}: registered in {e.where}, regions found in {seen.get(e.id)}"
        if not e.in_package:           # the built notebook holds the same exercise
            cells = notebook_code_cells(e.notebook)
            assert any(r.exercise_id == e.id for c in cells for r in find_regions(c, e.notebook)), \
                f"{e.id}: notebooks/{e.notebook}.ipynb has no region for it (rebuild the notebook)"
    assert all(e.points > 0 for e in EXERCISES) and len({e.id for e in EXERCISES}) == len(EXERCISES)


def test_package_exercises_say_which_notebook_teaches_them():
    import importlib

    for e in (e for e in EXERCISES if e.in_package):
        module = importlib.import_module(e.where[:-3].replace("/", "."))
        for name in e.functions:
            obj = module
            for part in name.split("."):
                obj = getattr(obj, part)
            assert f"Exercise {e.id} (notebook {e.notebook_number}" in (obj.__doc__ or ""), \
                f"{e.where}: {name}'s docstring must say 'Exercise {e.id} (notebook {e.notebook_number}: ...)'"


def _asserting_helpers(cells: list[str]) -> set[str]:
    """The names of the notebook's own functions whose body asserts (a check cell may call one: notebook 07's
    full_marks_runs)."""
    import ast

    names = set()
    for cell in cells:
        try:
            tree = ast.parse(cell)
        except SyntaxError:                                   # IPython magics: not a helper's cell
            continue
        names |= {node.name for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)
                  and any(isinstance(inner, ast.Assert) for inner in ast.walk(node))}
    return names


def _calls(cell: str) -> set[str]:
    import ast

    try:
        tree = ast.parse(cell)
    except SyntaxError:
        return set()
    return {node.func.id for node in ast.walk(tree) if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)}


def test_every_exercise_is_graded_by_a_tagged_check_cell(git_checkout):
    tagged: dict[str, set[str]] = {}
    for path in sorted((REPO / "notebooks").glob("*.ipynb")):
        cells = notebook_code_cells(path.stem)
        helpers = _asserting_helpers(cells)
        for cell in cells:
            for m in CHECK_TAG.finditer(cell):
                for exercise_id in m["ids"].split():
                    exercise(exercise_id)                     # KeyError for an unregistered id
                    tagged.setdefault(exercise_id, set()).add(path.stem)
                asserts = "assert " in cell or bool(_calls(cell) & helpers)
                assert asserts and "BEGIN SOLUTION" not in cell, f"{path.name}: a CHECK tag on a cell that is " \
                                                                 f"not a check cell (no assert, no asserting helper)"
    for e in EXERCISES:
        if e.kind == "written":
            assert e.id not in tagged, f"{e.id}: a written answer is graded by hand, not by a check cell"
            continue
        assert e.notebook in tagged.get(e.id, set()), f"{e.id}: no '# CHECK {e.id}' cell in {e.notebook}"


def test_markers_pair_up_and_check_cells_stay_outside(git_checkout):
    for path in tracked(".ipynb"):
        for cell in notebook_code_cells(path.stem):
            for region in find_regions(cell, path.name):
                body = "\n".join(cell.splitlines()[region.begin:region.end])
                assert "assert " not in body, f"{path.name}: a check sits inside the region of {region.exercise_id}"


def test_bad_markers_are_named_with_file_and_line():
    begin, end = "# BEGIN SOLUTION fk.dh_table", "# END SOLUTION"
    cases = {
        f"{begin}\nx = 1\n{begin}\n{end}\n": "f.py:3: BEGIN SOLUTION inside the region opened at line 1",
        f"x = 1\n{end}\n": "f.py:2: END SOLUTION without a BEGIN",
        f"def f():\n    {begin}\n    x = 1\n": "f.py:2: BEGIN SOLUTION never closed",
        f"def f():\n    {begin}\n    return 1\n{end}\n": "f.py:4: END SOLUTION indented differently",
        f"{begin}\n{end}\n": "f.py:2: empty solution region",
        "# BEGIN SOLUTION\nx = 1\n# END SOLUTION\n": "f.py:1: BEGIN SOLUTION names no exercise",
        "# BEGIN SOLUTION fk.nope\nx = 1\n# END SOLUTION\n": "f.py:1: no exercise 'fk.nope'; registered: ",
    }
    for text, message in cases.items():
        with pytest.raises(ExerciseMarkerError, match=re.escape(message)):
            find_regions(text, "f.py")


def test_a_stub_keeps_the_markers_and_names_the_exercise_and_the_function():
    text = "def dh_table(theta, d, a, alpha):\n    # BEGIN SOLUTION fk.dh_table\n    T = 42\n" \
           "    # END SOLUTION\n    return T\n"
    stub = stub_regions(text, "nb.py")
    assert "42" not in stub and stub.count("SOLUTION") == 2
    scope: dict = {}
    exec(compile(stub, "nb.py", "exec"), scope)          # the stubbed code still runs up to the point of use
    with pytest.raises(NotImplementedError, match=r"^exercise fk\.dh_table \(notebook 02\): write dh_table$"):
        scope["dh_table"](0, 0, 0, 0)
    assert exercise("calib.depth_plane").message() == ("exercise calib.depth_plane (notebook 01): write "
                                                       "fit_depth_correction in armlab/calibration/depth.py")


def test_the_exercise_list_command():
    run = subprocess.run([sys.executable, "-m", "armlab", "exercises"], capture_output=True, text=True, cwd=REPO)
    assert run.returncode == 0 and run.stdout.strip() == exercises_table()
    assert run.stdout.strip().endswith(f"{len(EXERCISES)} exercises, {sum(e.points for e in EXERCISES)} points")
    listed = json.loads(subprocess.run([sys.executable, "-m", "armlab", "exercises", "--json"], capture_output=True,
                                       text=True, cwd=REPO, check=True).stdout)
    assert [x["id"] for x in listed] == [e.id for e in EXERCISES]
    for x in listed:
        e = exercise(x["id"])
        assert (x["title"], x["points"], x["notebook"], x["kind"]) == (e.title, e.points, e.notebook, e.kind)
        assert x["solution_lines"] >= 1, f"{e.id}: no solution lines found in {e.where}"
    # students design the robot's behaviour (issue 35): the station's machine, click-to-grab's sequence and a strategy
    # per event, graded by outcome; at least 60 points so, and over 400 lines of student code in the lab
    outcome = {x["id"]: x["points"] for x in listed if x["kind"] == "open"}
    assert {"station.machine", "grab.sequence", "events.sort_stack", "events.line_up", "events.sky"} <= set(outcome)
    assert sum(outcome.values()) >= 60, outcome
    assert sum(x["solution_lines"] for x in listed if x["kind"] != "written") > 400


@pytest.fixture(scope="module")
def release(git_checkout, tmp_path_factory):
    out = tmp_path_factory.mktemp("release") / "student"
    stubbed = make_student_release(REPO, out)
    return out, stubbed


def test_the_release_is_a_students_repository(release):
    out, stubbed = release
    assert "armlab/kinematics.py" in stubbed and "notebooks/02_forward_kinematics.ipynb" in stubbed
    with pytest.raises(FileExistsError):
        make_student_release(REPO, out)
    for gone in ("benchmarks", ".ci", "notebooks/src", "tools/student-release", "tools/student"):
        assert not (out / gone).exists(), f"{gone} is instructor-only"
    readme = (out / "README.md").read_text()
    assert readme == (REPO / "tools/student/README.md").read_text() and "## Submit" in readme
    assert "make bench" not in readme and (out / ".student-release").is_file()
    nb = json.loads((out / "notebooks/02_forward_kinematics.ipynb").read_text())
    assert all(c.get("outputs", []) == [] for c in nb["cells"])
    assert "raise ExerciseNotWritten('fk.dh_table')" in json.dumps(nb)
    assert all(released(p.relative_to(out).as_posix()) or p.name == "README.md"
               for p in out.rglob("*") if p.is_file())


def _solution_signatures() -> set[str]:
    """What would give a solution away (whitespace folded): every pair of consecutive code lines of every region of
    the instructor's sources, and a one-line solution's line itself (generic single lines such as
    `for _ in range(iterations):` are not a solution; two of a solution's lines in a row are)."""
    signatures = set()
    for path in tracked(".py"):
        text = path.read_text()
        for region in find_regions(text, path.name):
            body = [" ".join(line.split()) for line in text.splitlines()[region.begin + 1:region.end]]
            body = [line for line in body if line and not line.startswith("#")]
            if len(body) == 1 and len(body[0]) >= 24:
                signatures.add(body[0])
            signatures.update(f"{a} {b}" for a, b in itertools.pairwise(body) if len(a) + len(b) >= 30)
    return signatures


def test_no_solution_text_anywhere_in_the_release(release):
    out, _ = release
    solutions = _solution_signatures()
    assert len(solutions) >= 60
    leaks = []
    for path in out.rglob("*"):
        if path.is_file() and path.suffix in (".py", ".ipynb", ".md", ".txt", ".cfg", ".toml", ".json", ""):
            text = path.read_text(errors="ignore")
            folded = " ".join(text.replace("\\n", "\n").replace('\\"', '"').split())
            leaks += [f"{path.relative_to(out)}: {s}" for s in solutions if s in folded]
    assert not leaks, "solution text in the release:\n" + "\n".join(leaks[:20])


def test_the_release_runs_the_simulator_without_any_solution(release):
    out, _ = release
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
assert np.allclose(kinematics.fk(np.zeros(5))[:3, 3], [0.0, 408.575, 304.57])     # the kit's truth: PoX
from armlab.robot import load_robot
with_table = load_robot(dh_csv=DH_CSV)                     # the instructor's table: the release has none
assert np.allclose(kinematics.fk_dh(np.zeros(5), with_table)[:3, 3], [0.0, 408.575, 304.57])   # stood in
try:
    kinematics.dh_link_transform.__wrapped__(0.0, 1.0, 2.0, 0.5)                     # the blank stub itself
except NotImplementedError as e:
    print("dh_link_transform:", e)
"""
    code = code.replace("DH_CSV", repr(str(REPO / "armlab/data/rx200_dh.csv")))
    env = {"PYTHONPATH": str(out), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-c", code], cwd=out, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "dh_link_transform: exercise fk.dh_link_transform (notebook 02): write dh_link_transform in " \
        "armlab/kinematics.py" in run.stdout
    assert "note: exercise fk.dh_link_transform (notebook 02) is not written yet" in run.stderr


def test_a_reference_path_stands_in_only_for_its_own_blank_stub(caplog):
    """The kit's function runs the student's code when written; the reference only for that exercise's blank stub
    (the course's ExerciseNotWritten in a notebook, the engine's SlotNotWritten a package file's stub raises), with
    one warning of the armlab.slots logger (once per exercise and process)."""
    from armlab import slots
    from armlab_course.exercises import ExerciseNotWritten, registry
    from armlab_course.exercises import exercise as registered
    from armlab_course.exercises.fallback import reference_fallback
    from armlab_course.exercises.markers import stub_lines

    blank = registered("fk.dh_link_transform").message()

    @reference_fallback(registry.DH_LINK, lambda x, error=None: ("reference", x), "the reference is used")
    def kit(x, error=None):
        if error:
            raise error
        return ("student", x)

    scope: dict = {}
    package_stub = "def stub():\n" + "".join(f"    {line}\n" for line in stub_lines("fk.dh_link_transform",
                                                                                   "armlab/kinematics.py"))
    exec(compile(package_stub, "armlab/kinematics.py", "exec"), scope)
    try:
        scope["stub"]()
    except NotImplementedError as e:
        released_stub = e
    assert type(released_stub) is slots.SlotNotWritten and str(released_stub) == blank

    slots._announced.discard("fk.dh_link_transform")          # as in a fresh process
    assert kit(1) == ("student", 1)                                   # written: the reference never runs
    with caplog.at_level("WARNING", logger="armlab.slots"):
        assert kit(2, ExerciseNotWritten("fk.dh_link_transform")) == ("reference", 2)
        assert kit(3, released_stub) == ("reference", 3)
    notes = [r for r in caplog.records if r.name == "armlab.slots"]
    assert [r.getMessage() for r in notes] == ["note: exercise fk.dh_link_transform (notebook 02) is not written "
                                               "yet: the reference is used"]            # one line, once
    # another exercise's stub, a student's own NotImplementedError (even with the message's text), anything else
    for other in (ExerciseNotWritten("ik.candidates"), slots.SlotNotWritten("ik.candidates", blank),
                  NotImplementedError(blank), NotImplementedError("todo"), ValueError(blank)):
        with pytest.raises(type(other)):                             # anything else propagates
            kit(4, other)


def test_the_reference_ik_finds_the_closed_forms_branches():
    import numpy as np

    from armlab import kinematics
    from armlab.robot import rx200

    robot = rx200()
    Q = np.random.default_rng(5).uniform(robot.lower, robot.upper, (1500, 5))
    T = kinematics.fk(Q)
    P, approach = T[:, :3, 3], T[:, :3, 0]
    radial = P[:, :2] / np.linalg.norm(P[:, :2], axis=1, keepdims=True)
    pitch = np.arctan2(-approach[:, 2], np.sum(approach[:, :2] * radial, axis=1))
    closed = kinematics._ik_candidates(P, pitch, Q[:, 4], robot)
    reference = kinematics._numerical_candidates(P, pitch, Q[:, 4], robot)
    both = closed.valid & reference.valid
    assert not (reference.valid & ~closed.valid).any(), "the reference IK found a branch the closed form does not have"
    assert both.sum() >= 0.97 * closed.valid.sum(), f"the reference IK found {both.sum()} of {closed.valid.sum()}"
    assert np.abs(kinematics._wrap(closed.q[both] - reference.q[both])).max() < 1e-6


def test_the_blank_release_picks_and_places_through_the_kits_reference_paths(release):
    out, _ = release
    code = """
import numpy as np
from armlab import kinematics, make_station, tasks
station = make_station("sim", seed=0, scene="swap")
session = tasks.start_session(station)
red = next(b for b in tasks.look(session).blocks if b.color == "red")
assert tasks.pick(session, red) and tasks.place(session, (0.0, 300.0, 0.0))
truth = next(o for o in station.world.blocks if o.color == "red")
print("error", float(np.abs(truth.position[:2] - [0.0, 300.0]).max()))
"""
    env = {"PYTHONPATH": str(out), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-c", code], cwd=out, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: exercise ")]
    # the DH chain is not among them: the kit's truth (fk, safety, the simulator) is the PoX model
    assert {n.split()[2] for n in notes} == {"ik.candidates", "calib.tag_extrinsics", "calib.depth_plane",
                                             "detect.classify"}, run.stderr
    assert float(run.stdout.split("error")[-1]) < 3.0, run.stdout


def test_in_the_release_a_test_of_a_blank_exercise_skips_until_it_is_written(release, tmp_path):
    """The release's own `make test` tests what the student can rely on: a test marked with an exercise skips,
    naming it, while the exercise is blank, and runs once the student has written it."""
    out, _ = release
    (out / "tests" / "test_probe.py").write_text(
        "import pytest\n\n\n@pytest.mark.exercise('calib.depth_plane')\ndef test_probe():\n    assert True\n")
    try:
        def run():
            return subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "tests/test_probe.py",
                                   "-p", "no:cacheprovider"], cwd=out, capture_output=True, text=True, timeout=300,
                                  env={"PYTHONPATH": str(out), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"})
        blank = run()
        assert "1 skipped" in blank.stdout and "needs exercise calib.depth_plane, still blank here" in blank.stdout
        source = out / "armlab/calibration/depth.py"
        text = source.read_text()
        stub = "\n".join("    " + line for line in stub_lines("calib.depth_plane", "armlab/calibration/depth.py"))
        assert "raise SlotNotWritten('calib.depth_plane'," in stub and stub in text
        source.write_text(text.replace(stub, "coef = np.zeros(3)"))          # a student's (poor) answer
        written = run()
        assert "1 passed" in written.stdout, written.stdout
        source.write_text(text)
    finally:
        (out / "tests" / "test_probe.py").unlink()


def test_the_student_readme_names_every_exercise_with_its_points():
    readme = (REPO / "tools/student/README.md").read_text()
    for e in EXERCISES:
        assert f"(`{e.id}`, {e.points}" in readme, f"the student README does not list {e.id} with {e.points} points"
        row = next(line for line in readme.splitlines() if line.startswith(f"| `{e.notebook}`"))
        assert e.id in row, f"{e.id} is listed in another notebook's row than {e.notebook}'s"


def test_a_package_exercises_check_cells_refuse_to_pass_on_its_reference_path(git_checkout):
    """Its check cells call require_written first: otherwise they would pass on the kit's reference path while the
    exercise is blank."""
    for e in EXERCISES:
        if not e.in_package:
            continue
        for stem in {x.notebook for x in EXERCISES}:
            for cell in notebook_code_cells(stem):
                tags = CHECK_TAG.findall(cell)
                if tags and e.id in tags[0].split():
                    assert f'require_written("{e.id}")' in cell, \
                        f"a check cell of {e.id} in {stem} does not call require_written({e.id!r}):\n{cell[:300]}"


def test_require_written_names_the_blank_exercise(monkeypatch):
    from armlab_course.exercises import require_written

    require_written("fk.dh_link_transform")                # written in the instructor's checkout: no error
    from armlab import slots

    monkeypatch.setattr(slots, "_standing_in", {"teach.replay"})
    with pytest.raises(NotImplementedError, match=r"exercise teach\.replay \(notebook 06\): write "
                                                  r"teach_program, scaled_durations and scaled_plan"):
        require_written("teach.replay")


def _with_regions_of(text: str, source: str, where: str) -> str:
    """`text` with each exercise region's body replaced by the same region's body in `source`."""
    lines, theirs = text.splitlines(), source.splitlines()
    bodies = {(r.exercise_id, k): theirs[r.begin + 1:r.end]
              for k, r in enumerate(find_regions(source, where))}
    out, last = [], 0
    for k, r in enumerate(find_regions(text, where)):
        out += lines[last:r.begin + 1] + bodies[(r.exercise_id, k)]
        last = r.end
    return "\n".join(out + lines[last:]) + ("\n" if text.endswith("\n") else "")


def test_restoring_the_solutions_gives_back_the_instructors_files(release):
    """Release = instructor's files with the regions stubbed: putting the solutions back into the regions restores
    every package file byte for byte and every notebook's code, so the restored release passes what the
    instructor's checkout passes (its notebooks under nbval, its tests)."""
    out, stubbed = release
    for name in stubbed:
        mine, theirs = (out / name).read_text(), (REPO / name).read_text()
        if name.endswith(".py"):
            assert _with_regions_of(mine, theirs, name) == theirs, f"{name} does not restore"
            continue
        cells = [("".join(c["source"]) if isinstance(c["source"], list) else c["source"])
                 for c in json.loads(mine)["cells"] if c["cell_type"] == "code"]
        originals = [("".join(c["source"]) if isinstance(c["source"], list) else c["source"])
                     for c in json.loads(theirs)["cells"] if c["cell_type"] == "code"]
        assert len(cells) == len(originals), f"{name}: the release has other cells"
        for cell, original in zip(cells, originals, strict=True):
            assert _with_regions_of(cell, original, name) == original, f"{name}: a cell does not restore"


def test_a_blank_stub_raises_the_typed_exception_carrying_its_id():
    text = "def f():\n    # BEGIN SOLUTION fk.euler\n    return 1\n    # END SOLUTION\n"
    scope: dict = {}
    exec(compile(stub_regions(text, "nb.py"), "nb.py", "exec"), scope)
    with pytest.raises(ExerciseNotWritten) as raised:
        scope["f"]()
    assert raised.value.exercise_id == "fk.euler" and isinstance(raised.value, NotImplementedError)
    assert str(raised.value) == exercise("fk.euler").message()
    import pickle

    assert pickle.loads(pickle.dumps(raised.value)).exercise_id == "fk.euler"      # crosses process boundaries
    with pytest.raises(KeyError, match="no exercise 'fk.nope'"):
        ExerciseNotWritten("fk.nope")


def test_the_librarys_slots_are_the_course_package_exercises():
    """The engine names its slots by plain ids (it imports nothing of the course, tests/test_import_graph.py): every
    slot a kit function stands in for is a registered package exercise whose region is in that function's file, and
    every package exercise with a stand-in is one."""
    import importlib
    import inspect

    from armlab import slots

    found = {}
    for path in tracked(".py"):
        name = path.relative_to(REPO).as_posix()
        if not name.startswith("armlab/") or "standin(" not in path.read_text():
            continue
        module = importlib.import_module(name[:-3].replace("/", "."))
        for _, obj in inspect.getmembers(module):
            for f in [obj] + [v for v in vars(obj).values() if callable(v)] if inspect.isclass(obj) else [obj]:
                if callable(f) and slots.is_standin_for(f):
                    found[slots.is_standin_for(f)] = name
    assert found, "no stand-in found"
    for slot_id, where in found.items():
        e = exercise(slot_id)
        assert e.in_package and e.where == where, f"{where} stands in for {slot_id}, whose region is in {e.where}"


def test_written_answers_are_found_blanked_and_refused_when_damaged():
    from armlab_course.exercises.markers import answer_prompt, blank_answers, is_blank_answer

    cell = "Question.\n\n<!-- BEGIN ANSWER fk.q_frames -->\nFrame 4 turns z.\n<!-- END ANSWER -->\nAfter."
    assert find_answers(["no answer here", cell]) == {"fk.q_frames": "Frame 4 turns z."}
    blank = blank_answers(cell)
    assert "Frame 4" not in blank and answer_prompt("fk.q_frames") in blank and blank.endswith("After.")
    assert find_answers([blank]) == {"fk.q_frames": answer_prompt("fk.q_frames")}
    assert is_blank_answer("fk.q_frames", find_answers([blank])["fk.q_frames"])
    assert not is_blank_answer("fk.q_frames", "Frame 4 turns z.")
    for bad, message in [(cell.replace("<!-- END ANSWER -->", ""), "do not pair up"),
                         (cell.replace("fk.q_frames", "fk.nope"), "no exercise 'fk.nope'"),
                         (cell.replace("fk.q_frames", "fk.euler"), "not a written exercise")]:
        with pytest.raises(ExerciseMarkerError, match=message):
            find_answers([bad], "nb.ipynb")
    with pytest.raises(ExerciseMarkerError, match="two answers to fk.q_frames"):
        find_answers([cell, cell])


def test_the_release_blanks_every_written_answer(release):
    out, stubbed = release
    from armlab_course.exercises.markers import is_blank_answer

    written = [e for e in EXERCISES if e.kind == "written"]
    assert written
    for e in written:
        nb = json.loads((out / "notebooks" / f"{e.notebook}.ipynb").read_text())
        answers = find_answers(["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown"])
        assert is_blank_answer(e.id, answers[e.id]), f"{e.id}: the release keeps the instructor's answer"
        assert f"notebooks/{e.notebook}.ipynb" in stubbed


def test_the_rubric_is_the_students_own_table(release, capsys):
    from armlab_course.exercises import rubric
    from armlab_course.exercises.rubric import exercise_state, solution_lines

    out, _ = release
    for e in EXERCISES:
        assert exercise_state(e, REPO) == "written" and exercise_state(e, out) == "blank", e.id
        assert solution_lines(e, REPO) >= 1 and solution_lines(e, out) == 0, e.id
    rubric("02", out)
    table = capsys.readouterr().out
    for e in (e for e in EXERCISES if e.notebook_number == "02"):
        assert re.search(rf"^{re.escape(e.id)}\s+{e.points}\s+{e.kind}\s.*blank$", table, re.M), table
    assert "0 points' worth written" in table


# -- no twin in the release ----------------------------------------------------------------------------------------
# Per exercise, the instructor's code and data that compute its answer: none of it may exist in the student release.
# ("file", path): a file; ("attr", module, dotted name): a module-level name or a class's attribute, looked up by
# importing the release's module (absent when the module is); ("text", path, snippet): source text in a released file
# (a notebook's code cells).
TWINS = {
    "fk.dh_table": [("file", "armlab/data/rx200_dh.csv"),
                    ("text", "notebooks/02_forward_kinematics.ipynb", "def kit_table"),
                    ("text", "notebooks/02_forward_kinematics.ipynb", "robot.dh")],
    "detect.classify": [("attr", "armlab.detection.color", "ColorModel.distances")],
    "ik.numerical": [("text", "armlab_course/exercises/references.py", "np.linalg.norm(e[:3]), np.linalg.norm(e[3:])"),
                     ("text", "armlab_course/exercises/references.py",
                      "T, T_target = np.asarray(T, dtype=float), np.asarray(T_target, dtype=float)")],
    "detect.stacks": [("text", "armlab_course/exercises/references.py", "large, small = max(edges_mm), min(edges_mm)")],
    "events.sort_stack": [("text", "notebooks/07_autonomous_tasks.ipynb", "SortStack("),   # no move while blank
                          ("text", "notebooks/07_autonomous_tasks.ipynb", "STACK_XY, SortStack"),
                          ("file", "armlab/tasks/events/strategies/sort_stack.py"),
                          ("attr", "armlab.tasks.events.sort_stack", "SortStack")],
    "events.line_up": [("file", "armlab/tasks/events/strategies/line_up.py"),
                       ("attr", "armlab.tasks.events.line_up", "LineUp"),
                       ("attr", "armlab.tasks.events.line_up", "line_slots"),
                       ("text", "notebooks/07_autonomous_tasks.ipynb", "line_up\", 3)\n")],  # the kit's run
    "events.sky": [("file", "armlab/tasks/events/strategies/sky.py"), ("attr", "armlab.tasks.events.sky", "Sky"),
                   ("text", "notebooks/07_autonomous_tasks.ipynb", "run_event(start_session(station), \"sky\")")],
    "station.transition": [("file", "armlab/tasks/transition.py"),
                           ("attr", "armlab.tasks.machine", "command_transition")],
    # the kit's refusal of a teaching button out of turn (the release's machine stops the station instead); the
    # machine's estop / reset stay: the engine's stop and restart (the port's halt / restart), which a stop must go
    # through, never student code; the engine's reset restarts from any state, the exercise's refuses outside estop
    "station.machine": [("file", "armlab/tasks/buttons.py"), ("attr", "armlab.tasks.buttons", "refuse_out_of_turn"),
                        ("text", "armlab/tasks/machine.py", "raise MachineBusy(")],
    # the kit's click rule (the release grabs only at a block's centre pixel, and refuses a drop on the held block's
    # old place); the student's sequence runs through tasks.click_with
    "grab.sequence": [("file", "armlab/tasks/click_rule.py"), ("attr", "armlab.tasks.click_rule", "grab_target"),
                      ("attr", "armlab.tasks.click_rule", "drop_point"),
                      ("text", "armlab/tasks/click.py", "held.position[2] - block_edge(held.size)"),
                      ("text", "armlab/tasks/click.py", "b.position[:2] - point[:2]")],
    # the kit's planners with move_path's arguments, which stood in for a blank move_path in notebooks 05 and 06 (the
    # release's notebooks plan with the lab report's fixed-height plan, move_path.report_move_path)
    # and the kit's own descent (a straight line at the steepest pitch the whole line allows), through which
    # planning.plan_pick / plan_place / choose_grasp answered it in the instructor's tree: the release's planners come
    # down on a joint chord instead (planning.descent), which the exercise's judge does not accept as straight
    "grab.move_path": [("file", "armlab/tasks/kit_move_path.py"),
                       ("attr", "armlab.tasks.kit_move_path", "kit_move_path"),
                       ("attr", "armlab.tasks.move_path", "kit_move_path"),
                       ("file", "armlab/planning/straight_descent.py"),
                       ("attr", "armlab.planning.straight_descent", "descend"),
                       ("attr", "armlab.planning.straight_descent", "approach_reachable")],
}

_LOOKUP = """
import importlib, json, sys
found = []
for module, name in json.loads(sys.argv[1]):
    try:
        obj = importlib.import_module(module)
    except ModuleNotFoundError as e:      # the module itself left out (an error inside it would be a broken release)
        if e.name != module:
            raise
        obj = None
    for part in name.split("."):
        obj = getattr(obj, part, None)
    found.append(obj is not None)
print(json.dumps(found))
"""


def _present(out: Path, twins: list[tuple]) -> list[bool]:
    """Whether each declared twin exists in the release at `out`."""
    attrs = [t[1:] for t in twins if t[0] == "attr"]
    found_attrs = iter(json.loads(subprocess.run(
        [sys.executable, "-c", _LOOKUP, json.dumps(attrs)], cwd=out, capture_output=True, text=True, check=True,
        env={"PYTHONPATH": str(out), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}).stdout) if attrs else [])
    present = []
    for kind, where, *what in twins:
        if kind == "file":
            present.append((out / where).exists())
        elif kind == "attr":
            present.append(next(found_attrs))
        else:
            text = (out / where).read_text() if (out / where).is_file() else ""
            if where.endswith(".ipynb") and text:
                text = "\n".join("".join(c["source"]) for c in json.loads(text)["cells"] if c["cell_type"] == "code")
            present.append(what[0] in text)
    return present


@pytest.mark.parametrize("exercise_id", sorted(TWINS))
def test_the_release_holds_no_twin_of_the_exercise(release, exercise_id):
    out, _ = release
    twins = TWINS[exercise_id]
    found = [t for t, here in zip(twins, _present(out, twins), strict=True) if here]
    assert not found, f"twins of {exercise_id} in the release: {found}"
    # ... and the declaration names real things: each is in the instructor's checkout, or was moved out of it
    in_checkout = _present(REPO, [t for t in twins if t[0] == "file"])
    assert all(in_checkout), f"{exercise_id}: a declared twin file is not in the instructor's checkout"


def test_the_released_engine_runs_without_the_instructors_twins(release):
    """The kit's own code in the release needs none of the left-out twins: the robot model loads without its DH table,
    the kit's IK and detection's colour check run, the DH chain says how to chain the student's table, the machine,
    click-to-grab and the notebooks' move_path run their stand-ins, and the kit's pick and place plans come down on a
    joint chord, another method than the straight descent grab.move_path asks for."""
    out, _ = release
    code = """
import numpy as np
from dataclasses import replace
from armlab import kinematics
from armlab.detection.color import default_color_model
from armlab.robot import rx200
robot = rx200()
assert robot.dh is None
print("ik", kinematics.ik([0.0, 250.0, 19.0], np.pi / 2)[0].round(6).tolist())
print("pox", kinematics.ik_pox([0.0, 250.0, 19.0], np.pi / 2)[0].round(6).tolist())
print("colours", default_color_model().common_distances(np.array([[200.0, 40.0, 40.0]])).shape)
try:
    kinematics.fk_dh(robot.home)
except ValueError as e:
    print("dh:", e)
from armlab.tasks import click, machine, move_path
print("stand-ins", click.click_rule() == (click.centre_click_block, click.standin_drop_point),
      machine.default_refusal() is machine.latching_refusal, move_path.default_path()[0] is move_path.report_move_path)
from armlab import planning
bows = []
for r in (170.0, 260.0, 340.0):
    for top in (25.0, 38.0, 114.0):
        plan = planning.plan_pick(planning.CAMERA_CLEAR_POSE, [r * 0.6, r * 0.8, top], 0.3, 25.0)
        bows.append(planning.approach_deviation(plan, "close"))
print("planners", planning.descent.straight(), type(plan.steps[-1].trajectory).__name__, min(bows))
"""
    env = {"PYTHONPATH": str(out), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-c", code], cwd=out, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    lines = dict(line.split(" ", 1) for line in run.stdout.splitlines())
    assert lines["ik"] == lines["pox"] and lines["colours"] == "(1, 6)"
    assert "no DH table" in lines["dh:"]
    assert lines["stand-ins"] == "True True True", "the release's machine, click rule or move_path is not its stand-in"
    # grab.move_path: the release's planners come down on a joint chord, which the exercise's judge refuses as not
    # straight (the instructor's come straight down: test_planning)
    straight, kind, least_bow = lines["planners"].split()
    assert (straight, kind) == ("False", "JointChord")
    from armlab import planning
    assert float(least_bow) > planning.STRAIGHT_TOLERANCE_MM, f"a release descent bows only {least_bow} mm"


def test_the_release_machine_and_click_rule_are_another_methods():
    """station.machine and grab.sequence: the release's stand-ins (machine.latching_refusal, click.centre_click_block /
    standin_drop_point) agree with the kit's (instructor only) where the lab's rule is plain and differ where the
    exercise's rule decides: a teaching button out of turn stops the station instead of being refused; a click off a
    face's centre is refused instead of grabbing; a drop on the held block's old place is refused instead of landing
    on what it stood on."""
    import numpy as np

    from armlab import make_station, tasks
    from armlab.detection.types import Block
    from armlab.station.contract import EmergencyStopped
    from armlab.tasks import buttons, click, click_rule, machine

    assert machine.default_refusal() is buttons.refuse_out_of_turn         # the instructor's tree runs the kit's
    station = make_station("sim", seed=0, scene={"objects": []})
    outcomes = {}
    for name, refusal in (("kit", buttons.refuse_out_of_turn), ("stand-in", machine.latching_refusal)):
        m = tasks.TaskMachine(tasks.Session(station, tasks.GuardedArm(station.arm)))
        m.refuse = refusal
        try:
            m.teach_record("open")
            raised = None
        except (tasks.MachineBusy, EmergencyStopped) as e:
            raised = type(e).__name__
        outcomes[name] = (raised, m.state, m.stop_requested)
        m.reset()
    assert outcomes == {"kit": ("MachineBusy", "idle", False), "stand-in": ("EmergencyStopped", "estop", True)}

    block = Block("red", "large", np.array([0.0, 250.0, 38.0]), 0.3, (640.0, 400.0), 38.0)
    assert click.click_rule() == (click_rule.grab_target, click_rule.drop_point)
    centre = block.position.copy()
    for rule in (click_rule.grab_target, click.centre_click_block):          # a click on the centre: both grab
        assert rule([block], centre, np.array([641.0, 399.0])) is block
    off = block.position + [0.3 * 38.0, 0.2 * 38.0, 0.0]                   # on the face, off its centre
    assert click_rule.grab_target([block], off, np.array([652.0, 392.0])) is block
    with pytest.raises(click.ClickRefused, match="centre"):
        click.centre_click_block([block], off, np.array([652.0, 392.0]))
    where_it_stood = block.position + [2.0, -1.0, 0.0]                      # the frame still shows the held block
    np.testing.assert_allclose(click_rule.drop_point(block, where_it_stood), [2.0, 249.0, 0.0])
    with pytest.raises(click.ClickRefused, match="held red block"):
        click.standin_drop_point(block, where_it_stood)
    free = np.array([-200.0, 80.0, 0.0])
    np.testing.assert_array_equal(click_rule.drop_point(block, free), click.standin_drop_point(block, free))


def test_the_release_move_path_is_another_methods():
    """grab.move_path: the release's stand-in (move_path.report_move_path, the lab report's plan) and the kit's
    (kit_move_path, instructor only) reach the same grasp point of a block square to the board, but the stand-in comes
    down by a joint move (its tool bows off the vertical), meets a turned block square to the board, not to the block,
    and refuses what the report's heights and top-down pitch cannot do, where the kit's plans."""
    import numpy as np

    from armlab import kinematics, planning
    from armlab.kinematics import Unreachable
    from armlab.tasks import move_path
    from armlab.tasks.kit_move_path import kit_move_path

    assert move_path.default_path()[0] is kit_move_path                     # the instructor's tree runs the kit's

    def descent(plan):
        """The tool points (n, 3) mm along the move just before the plan's close, and the joints at its end."""
        i = next(k for k, s in enumerate(plan.steps) if isinstance(s, planning.GripperStep) and s.action == "close")
        move = plan.steps[i - 1].trajectory
        q, _ = move.sample(np.linspace(0.0, move.duration, 41))
        return kinematics.fk(q)[:, :3, 3], q[-1]

    q0 = planning.CAMERA_CLEAR_POSE
    square = {f.__name__: descent(f(q0, [-150.0, 200.0, 38.0], 0.0, 38.0, "grasp"))
              for f in (kit_move_path, move_path.report_move_path)}
    (kit_tool, kit_end), (report_tool, report_end) = square["kit_move_path"], square["report_move_path"]
    np.testing.assert_allclose(report_end, kit_end, atol=1e-9)                # the same grasp of a square block
    off_vertical = [np.hypot(*(p[:, :2] - p[-1, :2]).T).max() for p in (kit_tool, report_tool)]
    assert off_vertical[0] < 0.5 < 5.0 < off_vertical[1], off_vertical       # straight down; a joint move's bow
    turned = [descent(f(q0, [-150.0, 200.0, 38.0], 0.4, 38.0, "grasp"))[1][4] for f in (kit_move_path,
                                                                                     move_path.report_move_path)]
    assert abs(turned[0] - kit_end[4] + 0.4) < 1e-9 and turned[1] == report_end[4], turned   # the wrist: yaw or not
    for target, why in (([0.0, 420.0, 38.0], "top-down only"), ([0.0, 250.0, 152.0], "a stack that tall")):
        assert kit_move_path(q0, target, 0.2, 38.0, "grasp").steps
        with pytest.raises(Unreachable, match=why):
            move_path.report_move_path(q0, target, 0.2, 38.0, "grasp")


def test_the_stand_ins_give_another_methods_result():
    """Each package slot's stand-in answers by another method than the exercise asks: close to the instructor's
    answer, never bit for bit the same."""
    import numpy as np

    from armlab import kinematics
    from armlab.calibration import depth, extrinsics, homography
    from armlab.camera import Camera
    from armlab.detection.color import default_color_model
    from armlab.robot import rx200

    rng = np.random.default_rng(11)
    robot = rx200()
    pairs = {}
    theta, alpha = rng.uniform(-3, 3, 50), rng.uniform(-3, 3, 50)
    pairs["fk.dh_link_transform"] = (kinematics._dh_by_elementary_motions(theta, 10.0, 200.0, alpha),
                                     kinematics.dh_link_transform(theta, 10.0, 200.0, alpha), 1e-9)
    Q = rng.uniform(robot.lower, robot.upper, (50, 5))
    T = kinematics.fk(Q)
    pitch = np.arctan2(-T[:, 2, 0], np.hypot(T[:, 0, 0], T[:, 1, 0]))
    pairs["ik.candidates"] = (np.nan_to_num(kinematics._numerical_candidates(T[:, :3, 3], pitch, Q[:, 4], robot).q),
                              np.nan_to_num(kinematics._ik_candidates(T[:, :3, 3], pitch, Q[:, 4], robot).q), 1e-9)
    K = np.array([[900.0, 0.0, 640.0], [0.0, 900.0, 360.0], [0.0, 0.0, 1.0]])
    T_cam = extrinsics.hand_measured_extrinsic()
    world = np.column_stack([rng.uniform(-400, 400, 12), rng.uniform(-150, 450, 12), np.zeros(12)])
    uv = (world @ T_cam[:3, :3].T + T_cam[:3, 3]) @ K.T
    pixels = uv[:, :2] / uv[:, 2:] + rng.normal(0, 0.3, (12, 2))
    pairs["calib.tag_homography"] = (homography.opencv_homography(world[:, :2], pixels),
                                     homography.dlt_homography(world[:, :2], pixels), 1e-2)
    pairs["calib.tag_extrinsics"] = (extrinsics._opencv_pose(world, pixels, K, np.zeros(5), refine=False),
                                     extrinsics.pose_from_corners(world, pixels, K, np.zeros(5), refine=False), 5.0)
    camera = Camera(K, np.zeros(5), T_cam)
    board, on_board = depth.board_depth(camera)
    vv, uu = np.mgrid[0:720, 0:1280]
    tilted = np.where(on_board, board + 0.01 * uu - 0.005 * vv + 3.0 + rng.normal(0, 1.0, board.shape), np.nan)
    tilted[300:340, 600:660] -= 38.0
    fit, kit = depth.fit_depth_correction(tilted, camera), depth._robust_plane(tilted, camera)
    pairs["calib.depth_plane"] = (np.array([kit.a, kit.b, kit.c]), np.array([fit.a, fit.b, fit.c]), 0.5)
    model = default_color_model()
    rgb = rng.uniform(20, 235, (40, 3))
    pairs["detect.classify"] = (model._nearest_mean(rgb)[1], model.classify(rgb)[1], np.inf)
    # every package slot but grab.move_path, whose stand-in (the kit's planners) is a declared twin still
    assert set(pairs) == {e.id for e in EXERCISES if e.in_package} - {"grab.move_path"}
    for exercise_id, (stand_in, answer, close) in pairs.items():
        assert not np.array_equal(stand_in, answer), f"{exercise_id}: the stand-in gives the exercise's own result"
        assert np.abs(stand_in - answer).max() < close, f"{exercise_id}: the stand-in is far from the answer"
