"""The grader, on submissions generated from the student release plus region edits: restored solutions score full
marks, the blank release 0, a wrong answer costs its own exercise only, the tricks of issue 11 score below full
marks, an infinite loop and a corrupt notebook are contained. One class is graded once (module fixture) on two
exercises of two notebooks to keep the run short."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from armlab.exercises import make_student_release
from armlab.exercises.registry import exercise
from armlab.grading import grade_class, read_submission
from armlab.grading.run import Limits
from armlab.grading.splice import write_regions
from armlab.grading.submission import exercise_file, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[1]
GRADED = ["fk.dh_transform", "fk.fk_from_table", "ik.planar_ik"]
WRONG = {"fk.dh_transform": "    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)\n"
                            "    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],\n"
                            "                     [0.0, sa, ca, -d], [0.0, 0.0, 0.0, 1.0]])",
         "ik.planar_ik": None}


def _reference_bodies(exercise_id: str) -> list[str]:
    name = exercise_file(exercise(exercise_id))
    return regions_of(source_texts(ROOT / name), exercise_id, name)


def _wrong_ik() -> list[str]:
    # the elbow branches swapped: the classic sign slip of notebook 03
    return [_reference_bodies("ik.planar_ik")[0].replace("(-1 if elbow_up else 1)", "(1 if elbow_up else -1)")]


def _tamper_checks(student: Path) -> None:
    """Comment out every assert of notebook 02's check cells and print the instructor's verdict line instead."""
    path = student / "notebooks/02_forward_kinematics.ipynb"
    nb = json.loads(path.read_text())
    ref = json.loads((ROOT / "notebooks/02_forward_kinematics.ipynb").read_text())
    for cell, ref_cell in zip(nb["cells"], ref["cells"], strict=True):
        text = "".join(cell["source"])
        if "# CHECK" in text:
            verdicts = [o.get("text", "") for o in ref_cell.get("outputs", []) if o.get("name") == "stdout"]
            lines = ["# NBVAL_RAISES_EXCEPTION"] + [("# " + ln if "assert" in ln else ln) for ln in text.splitlines()]
            lines += [f"print({''.join(v)!r}, end='')" for v in verdicts]
            cell["source"] = "\n".join(lines).splitlines(keepends=True)
    path.write_text(json.dumps(nb, indent=1))


@pytest.fixture(scope="module")
def graded(tmp_path_factory) -> tuple[dict, Path]:
    base = tmp_path_factory.mktemp("grading")
    subs = base / "submissions"
    release = base / "release"
    make_student_release(ROOT, release)
    import shutil

    def student(name: str) -> Path:
        shutil.copytree(release, subs / name)
        return subs / name

    full = student("full")
    for exercise_id in GRADED:
        write_regions(full, exercise_id, _reference_bodies(exercise_id))
    student("blank")
    write_regions(student("wrong_dh"), "fk.dh_transform", [WRONG["fk.dh_transform"]])
    wrong_ik = student("wrong_ik")
    write_regions(wrong_ik, "ik.planar_ik", _wrong_ik())
    write_regions(wrong_ik, "fk.dh_transform", _reference_bodies("fk.dh_transform"))
    tampered = student("tampered")          # a wrong DH, every trick on the check cells, a conftest that passes all
    write_regions(tampered, "fk.dh_transform", [WRONG["fk.dh_transform"].replace("-d]", "-1.0 * d]")])
    _tamper_checks(tampered)
    (tampered / "conftest.py").write_text(
        "import pytest\n\n@pytest.hookimpl(hookwrapper=True)\ndef pytest_runtest_makereport(item, call):\n"
        "    outcome = yield\n    outcome.get_result().outcome = 'passed'\n")
    (tampered / "pytest.ini").write_text("[pytest]\naddopts = -p no:nbval\n")
    write_regions(student("marker"), "fk.dh_transform",
          ["    # NBVAL_RAISES_EXCEPTION\n" + WRONG["fk.dh_transform"].replace("-d]", "-2 * d]")])
    write_regions(student("loop"), "fk.dh_transform", ["    while True:\n        pass"])
    corrupt = student("corrupt")
    (corrupt / "notebooks/02_forward_kinematics.ipynb").write_text('{"cells": [ not json')
    edited_only = subs / "edited_only"     # only the edited file, the rest not submitted
    (edited_only / "notebooks").mkdir(parents=True)
    shutil.copy2(full / "notebooks/03_inverse_kinematics.ipynb", edited_only / "notebooks")
    kit = student("kit_call")            # the kit's reference function in place of the DH chain
    write_regions(kit, "fk.fk_from_table", ["    from armlab import kinematics\n"
                                    "    return kinematics.fk_pox(q, check_limits=False)"])
    out = base / "out"
    results = grade_class(subs, out, ROOT, jobs=2, limits=Limits(timeout_s=240, cpu_s=25), exercises=GRADED)
    return results, out


def _score(graded, student, exercise_id):
    return graded[0][student][exercise_id].score


def test_restored_solutions_score_full_marks(graded):
    for exercise_id in GRADED:
        assert _score(graded, "full", exercise_id) == exercise(exercise_id).points


def test_blank_release_scores_zero_without_running(graded):
    results = graded[0]["blank"]
    assert all(r.score == 0 and r.reason == "not written (blank region)" and not r.checks for r in results.values())


def test_wrong_answer_costs_its_own_exercise_only(graded):
    assert _score(graded, "wrong_dh", "fk.dh_transform") < exercise("fk.dh_transform").points
    assert _score(graded, "wrong_ik", "ik.planar_ik") < exercise("ik.planar_ik").points
    assert _score(graded, "wrong_ik", "fk.dh_transform") == exercise("fk.dh_transform").points
    ik = graded[0]["wrong_ik"]["ik.planar_ik"]
    assert ik.checks[0].passed          # the public check right after the exercise misses the swapped branches
    first = next(c for c in ik.checks if not c.passed)
    assert first.name.startswith("hidden check") and "differs" in first.message


def test_tricks_score_below_full_marks(graded):
    assert _score(graded, "tampered", "fk.dh_transform") == 0        # edited asserts, verdicts, markers, conftest
    marker = graded[0]["marker"]["fk.dh_transform"]
    assert marker.score == 0 and "NBVAL_RAISES_EXCEPTION" in marker.reason and not marker.checks


def test_calling_the_kits_reference_function_fails_the_hidden_checks(graded):
    kit = graded[0]["kit_call"]["fk.fk_from_table"]
    hidden = [c for c in kit.checks if c.name.startswith("hidden")]
    assert hidden and not any(c.passed for c in hidden) and kit.score < exercise("fk.fk_from_table").points


def test_the_release_lacks_the_hidden_checks(tmp_path):
    make_student_release(ROOT, tmp_path / "s")
    assert (ROOT / "armlab/grading/hidden.py").is_file() and not (tmp_path / "s/armlab/grading/hidden.py").exists()
    assert (tmp_path / "s/armlab/grading/harness.py").is_file()
    assert not list((tmp_path / "s/tests").glob("test_grading*.py"))


def test_infinite_loop_and_corrupt_notebook_are_contained(graded):
    loop = graded[0]["loop"]["fk.dh_transform"]
    assert loop.score == 0 and loop.checks and not any(c.passed for c in loop.checks)
    corrupt = graded[0]["corrupt"]["fk.dh_transform"]
    assert corrupt.score == 0 and "not a readable notebook" in corrupt.reason
    assert _score(graded, "corrupt", "ik.planar_ik") == 0            # blank in that release copy, not broken


def test_a_submission_of_the_edited_files_only(graded):
    assert _score(graded, "edited_only", "ik.planar_ik") == exercise("ik.planar_ik").points
    assert graded[0]["edited_only"]["fk.dh_transform"].reason == "not written (blank region)"


def test_reports(graded):
    results, out = graded
    rows = list(csv.DictReader((out / "grades.csv").open()))
    assert [r["student"] for r in rows] == sorted(results)
    assert list(rows[0]) == ["student", *GRADED, "total", "max"]
    full = next(r for r in rows if r["student"] == "full")
    assert float(full["total"]) == float(full["max"]) == sum(exercise(i).points for i in GRADED)
    gradescope = json.loads((out / "wrong_dh" / "results.json").read_text())
    assert set(gradescope) == {"score", "tests"} and len(gradescope["tests"]) == len(GRADED)
    assert {"name", "score", "max_score", "output", "visibility"} <= set(gradescope["tests"][0])
    assert gradescope["score"] == sum(t["score"] for t in gradescope["tests"])
    feedback = (out / "wrong_dh" / "feedback.md").read_text()
    assert "fk.dh_transform" in feedback and "FAILED" in feedback and "first failing check" in \
        gradescope["tests"][0]["output"]


def test_submission_reading_reports_damaged_markers(tmp_path):
    make_student_release(ROOT, tmp_path / "s")
    path = tmp_path / "s" / "armlab/kinematics.py"
    path.write_text(path.read_text().replace("# END SOLUTION", "# the end", 1))
    sub = read_submission(tmp_path / "s", ROOT)
    damaged = [i for i in sub.problems if exercise(i).where == "armlab/kinematics.py"]
    assert damaged and "markers" in sub.problems[damaged[0]]


def test_grade_command_on_a_blank_class(tmp_path):
    from armlab.__main__ import main

    make_student_release(ROOT, tmp_path / "subs" / "alice")
    assert main(["grade", str(tmp_path / "subs"), "--out", str(tmp_path / "out"), "--reference", str(ROOT)]) == 0
    rows = list(csv.DictReader((tmp_path / "out" / "grades.csv").open()))
    assert rows[0]["student"] == "alice" and rows[0]["total"] == "0" and rows[0]["max"] == "100"
    with pytest.raises(SystemExit, match="no such folder"):
        main(["grade", str(tmp_path / "missing"), "--out", str(tmp_path / "out")])


def test_run_autograder_in_a_gradescope_layout(tmp_path):
    """The bundle (make autograder) unpacked as Gradescope does, run_autograder on a blank release with one exercise
    written, two exercises graded (ARMLAB_GRADE_EXERCISES)."""
    import os
    import shutil
    import subprocess
    import sys
    import zipfile

    from armlab.grading.autograder import build_bundle

    zip_path = build_bundle(ROOT, tmp_path / "bundle")
    root = tmp_path / "autograder"
    with zipfile.ZipFile(zip_path) as z:
        z.extractall(root / "source")
    assert (root / "source/setup.sh").is_file() and (root / "source/armlab/grading/hidden.py").is_file()
    shutil.copy2(root / "source/run_autograder", root / "run_autograder")
    (root / "run_autograder").chmod(0o755)
    make_student_release(ROOT, root / "submission")
    write_regions(root / "submission", "fk.dh_transform", _reference_bodies("fk.dh_transform"))
    (root / "results").mkdir()
    env = dict(os.environ, ARMLAB_AUTOGRADER_ROOT=str(root), ARMLAB_PYTHON=sys.executable,
               ARMLAB_GRADE_EXERCISES="fk.dh_transform,ik.planar_ik", ARMLAB_GRADE_TIMEOUT="240")
    env.pop("PYTHONPATH", None)
    done = subprocess.run([str(root / "run_autograder")], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    results = json.loads((root / "results/results.json").read_text())
    scores = {t["name"].split(":")[0]: (t["score"], t["max_score"]) for t in results["tests"]}
    points = exercise("fk.dh_transform").points
    assert scores == {"fk.dh_transform": (points, points), "ik.planar_ik": (0, exercise("ik.planar_ik").points)}
    assert results["score"] == points
    env["ARMLAB_GRADE_EXERCISES"] = "fk.no_such_exercise"
    done = subprocess.run([str(root / "run_autograder")], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and "no exercise 'fk.no_such_exercise'" in done.stderr


def _replaced(exercise_id: str, old: str, new: str) -> list[str]:
    bodies = _reference_bodies(exercise_id)
    assert any(old in b for b in bodies), f"{old!r} not in the reference of {exercise_id}"
    return [b.replace(old, new) for b in bodies]


HIDDEN_WRONG = {   # per exercise: wrong answers the hidden checks must fail (hard-coded, a slip, the kit's reference)
    "calib.tag_homography": {
        "hard-coded": ["    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])"],
        "normalisation not undone": _replaced("calib.tag_homography", "np.linalg.solve(T_dst, H_normalised @ T_src)",
                                              "H_normalised"),
    },
    "ik.candidates": {
        "hard-coded": ["    q1 = q2 = q3 = q4 = heading * 0.0\n    ok, d2 = heading == heading, heading * 0.0 + 1.0"],
        "elbow sign swapped": _replaced("ik.candidates", "* delta_sign", "* -delta_sign"),
    },
    "grab.sag_line": {
        "hard-coded (the lab's rule)": ["    return 0.068, 3.0"],   # one wrong answer: each costs a notebook run
    },
}


@pytest.mark.parametrize("exercise_id", sorted(HIDDEN_WRONG))
def test_hidden_checks_pass_the_reference_and_fail_wrong_answers(exercise_id):
    from armlab.grading.grade import Grader

    grader = Grader(ROOT, Limits(timeout_s=240, cpu_s=120), [exercise_id])
    reference = grader.hidden_checks(exercise_id, _reference_bodies(exercise_id))
    assert len(reference) >= 4 and all(c.passed for c in reference), [c.message for c in reference]
    for wrong, bodies in HIDDEN_WRONG[exercise_id].items():
        checks = grader.hidden_checks(exercise_id, bodies)
        assert not any(c.passed for c in checks), f"{exercise_id}, {wrong}: {[c.message for c in checks]}"


def test_regrading_gives_the_same_scores(graded):
    """A fresh Grader (no shared cache) on the class's wrong and tampered submissions: the same scores and checks."""
    from armlab.grading.grade import Grader

    results, out = graded
    grader = Grader(ROOT, Limits(timeout_s=240, cpu_s=25), GRADED)
    for student in ("wrong_dh", "tampered"):
        again = grader.grade(read_submission(out.parent / "submissions" / student, ROOT))
        for exercise_id in GRADED:
            first, second = results[student][exercise_id], again[exercise_id]
            assert (second.score, [(c.name, c.passed) for c in second.checks]) == \
                (first.score, [(c.name, c.passed) for c in first.checks]), (student, exercise_id)
    assert grader.runs == 2


def test_a_hard_coded_answer_scores_below_full_marks():
    """sky_points as a lookup of the public check's values passes that check and fails the hidden ones."""
    from armlab.grading.grade import Grader

    lookup = ("    return {0: 0, 1: 30, 5: 150, 7: 210, 8: 240, 9: 290, 12: 440, 13: 490, 20: 840, 24: 1040}[n]")
    result = Grader(ROOT, Limits(timeout_s=240, cpu_s=60), ["events.sky_points"]).grade_exercise(
        "events.sky_points", [lookup])
    public = [c for c in result.checks if not c.name.startswith("hidden")]
    assert public and all(c.passed for c in public), [c.message for c in public]
    assert 0 < result.score < exercise("events.sky_points").points
    assert any("KeyError" in c.message for c in result.checks if not c.passed)
