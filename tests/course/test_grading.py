"""The grader, on submissions generated from the student release plus region edits: restored solutions score full
marks, the blank release 0, a wrong answer costs its own exercise only, the tricks of issue 11 score below full
marks (a library or kit call in place of the exercise by the static check), an infinite loop, a kernel death, a
memory hog, a huge output and a corrupt notebook are contained. One class is graded once (module fixture) on three
exercises of the two cheapest notebooks to keep the run short. (The hidden checks of every exercise, on the reference
and on wrong answers: test_hidden_checks.py and test_hidden_checks_open.py.)"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from copies import disguised
from wrong_answers import DEPENDS, HIDDEN_WRONG, WRONG_DH, reference_bodies, wrong_euler

from armlab_course.exercises import make_student_release
from armlab_course.exercises.registry import exercise
from armlab_course.grading import grade_class, read_submission
from armlab_course.grading.run import Limits
from armlab_course.grading.splice import write_regions

ROOT = Path(__file__).resolve().parents[2]
GRADED = ["fk.dh_table", "fk.euler", "ik.candidates", "fk.dh_link_transform", "ik.numerical"]
CONTAINED = {   # region prefixes that break the run before the (correct) solution
    "kernel_exit": "    import os\n    os._exit(1)\n",
    "kernel_kill": "    import os\n    import signal\n    os.kill(os.getpid(), signal.SIGKILL)\n",
    "memory_hog": "    hog = bytearray(12 * 2**30)   # past the 8 GB cap, within the RAM: only the cap stops it\n",
    "huge_output": "    print('x' * (200 * 2**20))\n",
}
LIBRARY_EULER = ("    import warnings\n"                                  # right values, scipy's work (it warns
                 "    from scipy.spatial.transform import Rotation\n"     # at gimbal lock: the student hushes it)
                 "    with warnings.catch_warnings():\n"
                 "        warnings.simplefilter('ignore')\n"
                 "        return Rotation.from_matrix(np.asarray(T, dtype=float)[:3, :3]).as_euler('ZYZ')")



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
        write_regions(full, exercise_id, reference_bodies(exercise_id))
    student("blank")
    write_regions(student("wrong_dh"), "fk.dh_table", [WRONG_DH])
    slipped = student("wrong_euler")
    write_regions(slipped, "fk.euler", wrong_euler())
    write_regions(slipped, "fk.dh_table", reference_bodies("fk.dh_table"))
    wrong_link = student("wrong_link")       # the kit's link transform wrong: ik.numerical calls it (kinematics.fk)
    write_regions(wrong_link, "fk.dh_link_transform", list(HIDDEN_WRONG["fk.dh_link_transform"].values())[0])
    for exercise_id in ("ik.numerical", "ik.candidates"):
        write_regions(wrong_link, exercise_id, reference_bodies(exercise_id))
    tampered = student("tampered")          # a wrong DH, every trick on the check cells, a conftest that passes all
    write_regions(tampered, "fk.dh_table", [WRONG_DH.replace("0.0, np.pi / 2]", "0.0, 1.0 * np.pi / 2]")])
    _tamper_checks(tampered)
    (tampered / "conftest.py").write_text(
        "import pytest\n\n@pytest.hookimpl(hookwrapper=True)\ndef pytest_runtest_makereport(item, call):\n"
        "    outcome = yield\n    outcome.get_result().outcome = 'passed'\n")
    (tampered / "pytest.ini").write_text("[pytest]\naddopts = -p no:nbval\n")
    write_regions(student("marker"), "fk.dh_table",
                  ["    # NBVAL_RAISES_EXCEPTION\n" + WRONG_DH.replace("0.0, np.pi / 2]", "0.0, 2 * np.pi / 2]")])
    write_regions(student("loop"), "fk.dh_table", ["    while True:\n        pass"])
    corrupt = student("corrupt")
    (corrupt / "notebooks/02_forward_kinematics.ipynb").write_text('{"cells": [ not json')
    edited_only = subs / "edited_only"     # only the edited files, the rest not submitted: wrong_link's two (the
    for name in ("armlab/kinematics.py", "notebooks/03_inverse_kinematics.ipynb"):   # Grader shares their runs)
        (edited_only / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(wrong_link / name, edited_only / name)
    for name, prefix in CONTAINED.items():   # each then runs the reference: only the limits can make it score 0
        write_regions(student(name), "fk.euler", [prefix + reference_bodies("fk.euler")[0]])   # called 300 times
        write_regions(subs / name, "fk.dh_table", reference_bodies("fk.dh_table"))
    write_regions(student("library_call"), "fk.euler", [LIBRARY_EULER])
    write_regions(student("renamed_copy"), "fk.euler", [disguised(reference_bodies("fk.euler")[0], runnable=True)])
    kit = student("kit_call")            # the notebook's stand-in (the PoX model with the lengths put in)
    write_regions(kit, "fk.dh_table", ["    return pox_of_lengths(h0, L1, beta, L2, Lt)"])
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
    assert _score(graded, "wrong_dh", "fk.dh_table") < exercise("fk.dh_table").points
    assert _score(graded, "wrong_euler", "fk.euler") < exercise("fk.euler").points
    assert _score(graded, "wrong_euler", "fk.dh_table") == exercise("fk.dh_table").points
    euler = graded[0]["wrong_euler"]["fk.euler"]
    hidden = [c for c in euler.checks if c.name.startswith("hidden check")]
    # the miss names the property and its size, not the inputs (issue 34: "the Euler angles (cos psi): off by ...")
    assert hidden and any("the Euler angles" in c.message and "off by up to" in c.message
                          for c in hidden if not c.passed), hidden


def test_a_wrong_kit_function_does_not_cost_the_exercise_that_calls_it(graded):
    """fk.dh_link_transform wrong (d negated): kinematics.fk, which ik.numerical's solution calls, is the kit's PoX
    model and never chains the student's link transform, so ik.numerical keeps its full marks (no DEPENDS rerun)."""
    assert "ik.numerical" not in DEPENDS
    results = graded[0]["wrong_link"]
    assert results["fk.dh_link_transform"].score < exercise("fk.dh_link_transform").points
    assert results["ik.numerical"].score == exercise("ik.numerical").points, \
        [c.message for c in results["ik.numerical"].checks if not c.passed]
    assert results["ik.candidates"].score == exercise("ik.candidates").points


def test_tricks_score_below_full_marks(graded):
    assert _score(graded, "tampered", "fk.dh_table") == 0        # edited asserts, verdicts, markers, conftest
    marker = graded[0]["marker"]["fk.dh_table"]
    assert marker.score == 0 and "NBVAL_RAISES_EXCEPTION" in marker.reason and not marker.checks


def test_calling_the_kits_reference_function_fails_the_hidden_checks(graded):
    kit = graded[0]["kit_call"]["fk.dh_table"]
    hidden = [c for c in kit.checks if c.name.startswith("hidden")]
    assert hidden and not all(c.passed for c in hidden) and kit.score < exercise("fk.dh_table").points


GRADER_SIDE = ("grade.py", "judge.py", "harness.py", "wire.py", "adapters.py", "similarity.py", "upload.py",
               "autograder.py")


def test_the_release_lacks_the_hidden_checks_and_the_graders_side(tmp_path):
    """The release keeps what the self-check runs (it imports there, and `grade` says it is the instructor's) and
    none of the grader's side; the instructor's tree has every file left out."""
    make_student_release(ROOT, tmp_path / "s")
    grading = tmp_path / "s/armlab_course/grading"
    assert (ROOT / "armlab_course/grading/hidden/__init__.py").is_file()
    assert not (grading / "hidden").exists()
    assert all((ROOT / "armlab_course/grading" / name).is_file() for name in GRADER_SIDE)
    assert [name for name in GRADER_SIDE if (grading / name).exists()] == []
    assert not list((tmp_path / "s/tests").rglob("test_grading*.py"))
    probe = ("import armlab_course.grading as g, armlab_course.grading.check, armlab_course.grading.cli\n"
             "from armlab_course.grading import read_submission\nprint(g.__file__)")
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "s")}
    done = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path / "s", env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == str(grading / "__init__.py"), done.stderr
    done = subprocess.run([sys.executable, "-m", "armlab", "grade", "x", "--out", "y"], cwd=tmp_path / "s", env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "no grader" in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_infinite_loop_and_corrupt_notebook_are_contained(graded):
    loop = graded[0]["loop"]["fk.dh_table"]
    assert loop.score == 0 and loop.checks and not any(c.passed for c in loop.checks)
    corrupt = graded[0]["corrupt"]["fk.dh_table"]
    assert corrupt.score == 0 and "not a readable notebook" in corrupt.reason
    assert _score(graded, "corrupt", "ik.candidates") == 0            # blank in that release copy, not broken


@pytest.mark.parametrize("student, why", [("kernel_exit", "the kernel died"), ("kernel_kill", "the kernel died"),
                                          ("memory_hog", "MemoryError"), ("huge_output", "")])
def test_kernel_death_memory_hog_and_huge_output_are_contained(graded, student, why):
    """Each scores 0 on its exercise with the reason in feedback.md, its other exercise keeps its points, the rest
    of the class is graded (the grader survived). The memory hog's 12 GB fit this machine's RAM: only the address-space
    cap on the kernel (and on the hidden checks' process) turns it into a MemoryError."""
    results, out = graded
    broken = results[student]["fk.euler"]
    assert broken.score == 0 and broken.checks and not any(c.passed for c in broken.checks)
    assert _score(graded, student, "fk.dh_table") == exercise("fk.dh_table").points
    feedback = (out / student / "feedback.md").read_text()
    assert why in feedback and "FAILED" in feedback
    assert len(feedback) < 50_000 and (out / student / "results.json").stat().st_size < 50_000
    assert _score(graded, "full", "fk.euler") == exercise("fk.euler").points


def test_a_library_call_in_place_of_the_exercise_scores_below_full_marks(graded):
    """scipy's Rotation.as_euler('ZYZ') computes the right values (every public and hidden check passes); the static
    check fails naming the call, and the exercise scores 0: calling the answer earns nothing (issue 32)."""
    result = graded[0]["library_call"]["fk.euler"]
    static = [c for c in result.checks if c.name.startswith("static")]
    assert all(c.passed for c in result.checks if not c.name.startswith("static"))
    assert len(static) == 1 and not static[0].passed and "scipy.spatial.transform.Rotation" in static[0].message
    assert result.score == 0
    kit = graded[0]["kit_call"]["fk.dh_table"]
    assert any("pox_of_lengths" in c.message for c in kit.checks if c.name.startswith("static"))


def test_a_submission_of_the_edited_files_only(graded):
    assert _score(graded, "edited_only", "ik.candidates") == exercise("ik.candidates").points
    assert graded[0]["edited_only"]["fk.dh_table"].reason == "not written (blank region)"


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
    assert "fk.dh_table" in feedback and "FAILED" in feedback and "first failing check" in \
        gradescope["tests"][0]["output"]


def test_similarity_report(graded):
    """OUT/similarity.csv scores every written region against the reference's and the classmates'; the reference
    pasted with renamed variables and a reflowed layout scores full marks and is flagged in OUT/similarity.md, which
    no student's folder holds."""
    from armlab_course.grading.similarity import FLAG_AT

    results, out = graded
    rows = list(csv.reader((out / "similarity.csv").open()))
    assert rows[0] == ["student", "exercise", "matched", "score"] and rows[1:] == sorted(
        rows[1:], key=lambda r: (r[0], r[1], r[2] != "reference", r[2]))
    score = {(s, e, m): float(v) for s, e, m, v in rows[1:]}
    assert _score(graded, "renamed_copy", "fk.euler") == exercise("fk.euler").points
    assert score["renamed_copy", "fk.euler", "reference"] >= FLAG_AT
    assert score["renamed_copy", "fk.euler", "full"] == score["full", "fk.euler", "renamed_copy"] >= FLAG_AT
    assert score["full", "fk.euler", "reference"] == 1.0
    assert score["full", "ik.candidates", "edited_only"] == 1.0           # the same file, handed in twice
    assert not any(s == "blank" or m == "blank" for s, _, m in score)      # blank regions: never compared
    assert {s for s, _, _ in score} < set(results)
    notes = (out / "similarity.md").read_text()
    section = notes.split("## renamed_copy\n", 1)[1].split("##", 1)[0]
    assert f"- fk.euler: {score['renamed_copy', 'fk.euler', 'reference']:.3f} against the reference" in section
    for student in results:                  # what students receive says nothing of it
        for name in ("feedback.md", "results.json"):
            assert "similarity" not in (out / student / name).read_text().lower(), (student, name)
        assert sorted(p.name for p in (out / student).iterdir()) == ["feedback.md", "results.json"]


def test_submission_reading_reports_damaged_markers(tmp_path):
    make_student_release(ROOT, tmp_path / "s")
    path = tmp_path / "s" / "armlab/kinematics.py"
    path.write_text(path.read_text().replace("# END SOLUTION", "# the end", 1))
    sub = read_submission(tmp_path / "s", ROOT)
    damaged = [i for i in sub.problems if exercise(i).where == "armlab/kinematics.py"]
    assert damaged and "markers" in sub.problems[damaged[0]]


def test_grade_command_on_a_blank_class(tmp_path, monkeypatch):
    """Nothing runs for a class that wrote nothing: not even the reference's expected values (none is needed)."""
    from armlab.__main__ import main
    from armlab_course.grading.run import Runner

    def ran(*args, **kwargs):
        raise AssertionError("a blank class ran something")

    monkeypatch.setattr(Runner, "harness", ran)
    monkeypatch.setattr(Runner, "notebook", ran)
    make_student_release(ROOT, tmp_path / "subs" / "alice")
    assert main(["grade", str(tmp_path / "subs"), "--out", str(tmp_path / "out"), "--reference", str(ROOT)]) == 0
    rows = list(csv.DictReader((tmp_path / "out" / "grades.csv").open()))
    from armlab_course.exercises.registry import EXERCISES

    assert rows[0]["student"] == "alice" and rows[0]["total"] == "0"
    assert float(rows[0]["max"]) == sum(e.points for e in EXERCISES if e.kind != "written")   # those by hand
    assert main(["grade", str(tmp_path / "missing"), "--out", str(tmp_path / "out")]) == 2   # one line, exit 2


@pytest.fixture(scope="module")
def fresh_grader():
    """A Grader of the class's exercises and limits, apart from the one grade_class made (no shared cache): made
    once for the two tests below (each made its own: the instructor's tree copied, the release built and the expected
    values computed twice)."""
    from armlab_course.grading.grade import Grader

    with Grader(ROOT, Limits(timeout_s=240, cpu_s=25), GRADED) as made:
        yield made


def test_regrading_gives_the_same_scores(graded, fresh_grader):
    """A fresh Grader (no shared cache) on the class's tampered submission: the same scores and checks."""
    results, out = graded
    grader = fresh_grader
    for student in ("tampered",):
        again = grader.grade(read_submission(out.parent / "submissions" / student, ROOT))
        for exercise_id in GRADED:
            first, second = results[student][exercise_id], again[exercise_id]
            assert (second.score, [(c.name, c.passed) for c in second.checks]) == \
                (first.score, [(c.name, c.passed) for c in first.checks]), (student, exercise_id)
    assert grader.runs == 1


def test_a_hard_coded_answer_fails_the_hidden_checks(fresh_grader):
    """fk.euler as the public check's one singular case, hard-coded: the hidden checks' other poses fail it."""
    lookup = "    return np.array([0.7, 0.0, 0.0])"
    checks = fresh_grader.hidden_checks("fk.euler", [lookup])
    assert checks and not any(c.passed for c in checks)
    assert all("the Euler angles (" in c.message and "): off by up to " in c.message
               for c in checks), [c.message for c in checks]


def test_a_grader_told_an_exercise_is_not_written_refuses_to_grade_it_unprepared():
    """Expected values are computed only for exercises some submission writes (grade_class reads every submission
    first); a submission writing another one is refused, never graded against values computed after it ran."""
    from armlab_course.grading.grade import Grader
    from armlab_course.grading.submission import Submission

    with Grader(ROOT, exercises=["fk.euler"], written=[]) as grader:
        with pytest.raises(ValueError, match="bob wrote fk.euler, which this Grader was told no submission writes"):
            grader.grade(Submission("bob", bodies={"fk.euler": wrong_euler()}))


def test_a_grader_needs_at_least_one_run_at_a_time():
    from armlab_course.grading.grade import Grader

    with pytest.raises(ValueError, match="parallel must be at least 1, got 0"):
        Grader(ROOT, exercises=["fk.euler"], written=[], parallel=0)
