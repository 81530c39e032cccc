"""`python -m armlab grade` and `python -m armlab check` as instructors and students meet them: every bad option or
path is one line and a non-zero exit; the self-check prints the first failing check's message, does not charge a
wrong homography to the camera pose that calls it, and exits non-zero when anything fails or cannot run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from armlab_course.exercises import make_student_release
from armlab_course.exercises.registry import exercise
from armlab_course.grading.splice import write_regions
from armlab_course.grading.submission import exercise_file, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[2]
HOMOGRAPHY, POSE = "calib.tag_homography", "calib.tag_extrinsics"   # the pose calls the homography


def _armlab(*args: str, cwd: Path = ROOT, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "armlab", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=900, env={**os.environ, **(env or {})})


def _reference(exercise_id: str) -> list[str]:
    name = exercise_file(exercise(exercise_id))
    return regions_of(source_texts(ROOT / name), exercise_id, name)


@pytest.mark.parametrize("args, words", [
    (["--reference", "/nonexistent"], "--reference /nonexistent: no such folder"),
    (["--timeout", "nan"], "--timeout: 'nan' must be a positive, finite number of seconds"),
    (["--timeout", "-3"], "--timeout: '-3' must be a positive, finite number of seconds"),
    (["--jobs", "0"], "--jobs: 0 is out of range: must be 1 or more"),
    (["--jobs", "two"], "--jobs: 'two' is not a whole number"),
])
def test_grade_refuses_bad_options_in_one_line(tmp_path, args, words):
    (tmp_path / "subs" / "alice").mkdir(parents=True)
    done = _armlab("grade", str(tmp_path / "subs"), "--out", str(tmp_path / "out"), *args)
    assert done.returncode == 2 and words in done.stderr.strip().splitlines()[-1], done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert not (tmp_path / "out").exists()


def test_grade_refuses_a_student_release_as_reference(tmp_path):
    make_student_release(ROOT, tmp_path / "release")
    (tmp_path / "subs" / "alice").mkdir(parents=True)
    done = _armlab("grade", str(tmp_path / "subs"), "--out", str(tmp_path / "out"), "--reference",
                   str(tmp_path / "release"))
    assert done.returncode == 2 and "no hidden checks" in done.stderr and "Traceback" not in done.stderr


def test_grade_has_a_version():
    done = _armlab("grade", "--version")
    assert done.returncode == 0 and done.stdout.startswith("armlab ")


@pytest.fixture(scope="module")
def student(tmp_path_factory) -> Path:
    """A release with a wrong homography (the normalisation not undone) and the reference pose (whose check no longer
    runs the student's homography, but shares a cell with the blank depth plane)."""
    folder = tmp_path_factory.mktemp("check") / "student"
    make_student_release(ROOT, folder)
    wrong = _reference(HOMOGRAPHY)[0].replace("np.linalg.solve(T_dst, H_normalised @ T_src)", "H_normalised")
    assert wrong != _reference(HOMOGRAPHY)[0]
    write_regions(folder, HOMOGRAPHY, [wrong])
    write_regions(folder, POSE, _reference(POSE))
    return folder


def test_check_names_the_first_failing_check_and_does_not_charge_the_caller(student):
    done = _armlab("check", cwd=student)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    homography = next(ln for ln in lines if ln.startswith(f"- {HOMOGRAPHY}:"))
    assert "01_camera_calibration cell" in homography and "Error: " in homography, done.stdout   # the cell's error
    assert f"after Run All: # CHECK {HOMOGRAPHY}" in homography, homography     # the cell as JupyterLab numbers it
    pose = next(ln for ln in lines if ln.startswith(f"- {POSE}:"))
    assert "it needs calib.depth_plane, which is not written yet" in pose, done.stdout    # waiting, not charged
    assert HOMOGRAPHY not in pose, pose                            # the wrong homography costs its own exercise only
    assert "1 written exercise(s) not yet passing" in done.stdout and "not written yet" in done.stdout


def test_check_exits_0_only_when_nothing_is_blank_or_failing(tmp_path):
    """The homography and the pose written as the reference pass every check of theirs, except the pose's check cell
    shared with the depth plane, which waits for it: with blank exercises left the whole self-check exits 1 and
    says what is not written, each exercise on a progress line; `check EXERCISE` on the homography alone exits 0,
    an unknown id exits 2 naming the known ones."""
    folder = tmp_path / "student"
    make_student_release(ROOT, folder)
    for exercise_id in (HOMOGRAPHY, POSE):
        write_regions(folder, exercise_id, _reference(exercise_id))
    done = _armlab("check", cwd=folder)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "1 written" not in done.stdout and "not written yet" in done.stdout, done.stdout
    lines = done.stdout.splitlines()
    assert any(ln.startswith("[") and f"] {HOMOGRAPHY}: written, 6 / 6" in ln for ln in lines), done.stdout
    assert any(ln.startswith("[") and "] fk.euler: blank, 0 / 5" in ln for ln in lines), done.stdout
    one = _armlab("check", HOMOGRAPHY, cwd=folder)
    assert one.returncode == 0 and f"{HOMOGRAPHY}: written" in one.stdout and "fk.euler" not in one.stdout, \
        one.stdout + one.stderr
    unknown = _armlab("check", "fk.nothing", cwd=folder)
    assert unknown.returncode == 2 and "fk.euler" in unknown.stderr and "Traceback" not in unknown.stderr


def test_check_says_what_is_missing_when_it_cannot_run(tmp_path):
    """Without nbval (a Python whose path hides it) the self-check exits 2 naming the missing package."""
    shadow = tmp_path / "shadow"
    shadow.mkdir()
    (shadow / "nbval.py").write_text("raise ImportError('hidden for the test')\n")
    (shadow / "sitecustomize.py").write_text(
        "import importlib.util, sys\n_real = importlib.util.find_spec\n"
        "importlib.util.find_spec = lambda name, *a: None if name == 'nbval' else _real(name, *a)\n")
    make_student_release(ROOT, tmp_path / "student")
    done = _armlab("check", cwd=tmp_path / "student", env={"PYTHONPATH": str(shadow)})
    assert done.returncode == 2 and "nbval not installed" in done.stderr, done.stderr


def _fake_pythons(folder: Path, minors: list[int]) -> dict[str, str]:
    folder.mkdir()
    for minor in minors:
        path = folder / f"python3.{minor}"
        path.write_text(f"#!/bin/sh\necho {minor}\n")
        path.chmod(0o755)
    return {"PATH": f"{folder}:/usr/bin:/bin"}


@pytest.mark.parametrize("minors, picked", [([10], None), ([10, 12], "python3.12"), ([11, 13, 10], "python3.13")])
def test_gradescope_setup_picks_a_python_the_pins_can_install_on(tmp_path, minors, picked):
    """tools/autograder/pick-python (setup.sh's choice): the newest python3.X >= 3.11 on PATH, else one line naming
    what to install or which base image to choose. The fake interpreters print only their minor version."""
    env = _fake_pythons(tmp_path / "bin", minors)
    env["PATH"] = env["PATH"].replace(":/usr/bin:/bin", ":/nonexistent")
    done = subprocess.run(["/bin/bash", str(ROOT / "tools/autograder/pick-python"), "3.11"], env=env,
                          capture_output=True, text=True)
    if picked is None:
        assert done.returncode == 1 and "Ubuntu 24.04" in done.stderr and "python3.11" in done.stderr
    else:
        assert done.returncode == 0 and done.stdout.strip() == str(tmp_path / "bin" / picked)


def test_written_answers_reach_the_feedback_and_the_instructors_csv(tmp_path):
    """A written answer (kind "written") is read from the student's markdown cell: feedback.md and results.json show
    it (0 points there: graded by hand), grades.csv has an empty column for it headed with its points, answers.csv
    holds the text, rubric.csv its point rubric and hand_grading.md the marking sheet; a blank answer says so. No
    notebook runs for it."""
    import csv
    import json

    from armlab_course.exercises.registry import EXERCISES
    from armlab_course.grading import grade_class

    written = next(e for e in EXERCISES if e.kind == "written")
    subs = tmp_path / "subs"
    make_student_release(ROOT, subs / "ada")
    make_student_release(ROOT, subs / "bob")
    path = subs / "ada" / f"notebooks/{written.notebook}.ipynb"
    nb = json.loads(path.read_text())
    answer = "The error grows with the distance from the tags, because the homography's errors scale with it."
    hits = 0
    for cell in nb["cells"]:
        text = "".join(cell["source"])
        if cell["cell_type"] == "markdown" and f"BEGIN ANSWER {written.id}" in text:
            head, rest = text.split("-->", 1)
            cell["source"] = head + "-->\n" + answer + "\n<!-- END ANSWER -->" + rest.split("<!-- END ANSWER -->", 1)[1]
            hits += 1
    assert hits == 1, f"no answer cell for {written.id} in {path.name}"
    path.write_text(json.dumps(nb, indent=1))
    graded = grade_class(subs, tmp_path / "out", ROOT, exercises=[written.id])
    assert graded["ada"][written.id].answer == answer and graded["bob"][written.id].answer is None
    feedback = (tmp_path / "out/ada/feedback.md").read_text()
    assert f"graded by hand, {written.points} points" in feedback and answer in feedback
    results = json.loads((tmp_path / "out/ada/results.json").read_text())
    assert results["score"] == 0 and answer in results["tests"][0]["output"] and results["tests"][0]["max_score"] == 0
    rows = list(csv.DictReader((tmp_path / "out/grades.csv").open()))
    assert rows[0][f"{written.id} (by hand, /{written.points})"] == ""
    answers = {r["student"]: r[written.id] for r in csv.DictReader((tmp_path / "out/answers.csv").open())}
    assert answers == {"ada": answer, "bob": ""}
    assert "not written" in (tmp_path / "out/bob/feedback.md").read_text()
    rubric = list(csv.DictReader((tmp_path / "out/rubric.csv").open()))     # the point rubric to mark by
    assert {r["exercise"] for r in rubric} == {written.id}
    assert sum(float(r["points"]) for r in rubric) == written.points
    sheet = (tmp_path / "out/hand_grading.md").read_text()
    assert f"## {written.id}: " in sheet and answer in sheet and "**Model answer**" in sheet


def test_csv_cells_that_read_as_formulas_are_neutralised():
    """A written answer or a folder name starting like a spreadsheet formula lands as text (a leading apostrophe);
    the grader's own numbers, negative ones included, stay numbers."""
    import csv
    import io

    from armlab_course.grading.csv_cells import csv_text

    text = csv_text(["student", "answer", "score"],
                    [["=HYPERLINK(\"http://x\")", "+1", -2.5], ["@SUM(A1)", "-x", 3], ["bob", "plain, text", 0.0]])
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[1] == ["'=HYPERLINK(\"http://x\")", "'+1", "-2.5"], rows
    assert rows[2] == ["'@SUM(A1)", "'-x", "3"] and rows[3] == ["bob", "plain, text", "0"], rows


def test_odd_student_names_get_folders_of_their_own(tmp_path):
    """A student folder named grades.csv, one whose name reads like another's hashed folder, and two names that
    differ in case each get their own results folder; grades.csv stays the class's file."""
    from armlab_course.grading.report import student_folder, write_reports
    from armlab_course.grading.results import ExerciseResult

    def result(score: float) -> dict:
        return {"fk.euler": ExerciseResult("fk.euler", score, exercise("fk.euler").points, [], "")}

    names = ["grades.csv", student_folder("grades.csv"), "Alice", "alice", "answers.csv"]
    write_reports({name: result(k) for k, name in enumerate(names)}, tmp_path)
    assert (tmp_path / "grades.csv").is_file()
    folders = [p for p in tmp_path.iterdir() if p.is_dir()]
    assert len(folders) == len(names)
    scores = sorted(json.loads((f / "results.json").read_text())["score"] for f in folders)
    assert scores == list(range(len(names)))


def test_one_total_on_stdout_in_grades_csv_and_in_the_feedback(tmp_path):
    """`armlab grade` on a class of two (ada wrote the homography, bob nothing): the stdout line, the progress line,
    grades.csv's total and max, feedback.md's total and results.json's score give one total per student, out of the
    registry's automatic points, and each names the written answers' points as graded by hand."""
    import csv
    import re

    from armlab_course.exercises.registry import EXERCISES

    subs = tmp_path / "subs"
    for name in ("ada", "bob"):
        make_student_release(ROOT, subs / name)
    write_regions(subs / "ada", HOMOGRAPHY, _reference(HOMOGRAPHY))
    done = _armlab("grade", str(subs), "--out", str(tmp_path / "out"), "--reference", str(ROOT))
    assert done.returncode == 0, done.stdout + done.stderr
    auto = sum(e.points for e in EXERCISES if e.kind != "written")
    by_hand = sum(e.points for e in EXERCISES if e.kind == "written")
    assert 0 < by_hand and auto + by_hand == sum(e.points for e in EXERCISES)
    rows = {r["student"]: r for r in csv.DictReader((tmp_path / "out/grades.csv").open())}
    for student, score in (("ada", exercise(HOMOGRAPHY).points), ("bob", 0)):
        said = f"{score:g} / {auto} automatic (+{by_hand} by hand: the written answers)"
        assert f"{student}: {said}" in done.stdout.splitlines(), done.stdout
        assert any(ln.startswith("[") and f"] {student}: {said} (" in ln for ln in done.stderr.splitlines()), \
            done.stderr
        assert float(rows[student]["total"]) == score and int(rows[student]["max"]) == auto, rows[student]
        feedback = (tmp_path / "out" / student / "feedback.md").read_text()
        assert f"Total: {said}" in feedback and re.search(rf"^total +{re.escape(said)}$", feedback, re.M), feedback
        assert json.loads((tmp_path / "out" / student / "results.json").read_text())["score"] == score


def test_a_check_cell_is_named_as_jupyterlab_numbers_it(tmp_path):
    """A check cell's name: its position among all the notebook's cells (markdown included, from 1), the count
    JupyterLab shows after Restart Kernel and Run All Cells (its place among the code cells, from 1) and its first
    line (issue 34: 'cell 9' was a 0-based count of code cells)."""
    import nbformat

    from armlab_course.grading.run import check_cells, code_cell_labels

    nb = nbformat.v4.new_notebook(cells=[
        nbformat.v4.new_markdown_cell("# Title"), nbformat.v4.new_code_cell("x = 1"),
        nbformat.v4.new_markdown_cell("text"), nbformat.v4.new_markdown_cell("more"),
        nbformat.v4.new_code_cell("\n# CHECK fk.euler\nassert x == 1, 'x must be 1 ' + 'and ' * 30")])
    path = tmp_path / "02_forward_kinematics.ipynb"
    nbformat.write(nb, path)
    assert check_cells(path) == {1: ("fk.euler",)}
    assert code_cell_labels(path) == ["02_forward_kinematics cell 2 ([1] after Run All: x = 1)",
                                      "02_forward_kinematics cell 5 ([2] after Run All: # CHECK fk.euler)"]
