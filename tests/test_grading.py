"""The grader, on submissions generated from the student release plus region edits: restored solutions score full
marks, the blank release 0, a wrong answer costs its own exercise only, the tricks of issue 11 score below full
marks (a library or kit call in place of the exercise by the static check), an infinite loop, a kernel death, a
memory hog, a huge output and a corrupt notebook are contained. One class is graded once (module fixture) on three
exercises of the two cheapest notebooks to keep the run short; the hidden checks of every exercise are tried on the
reference and on wrong answers in a few batched harness runs."""

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
GRADED = ["fk.dh_table", "fk.euler", "ik.candidates"]
CONTAINED = {   # region prefixes that break the run before the (correct) solution
    "kernel_exit": "    import os\n    os._exit(1)\n",
    "kernel_kill": "    import os\n    import signal\n    os.kill(os.getpid(), signal.SIGKILL)\n",
    "memory_hog": "    hog = bytearray(12 * 2**30)   # past the 8 GB cap, within the RAM: only the cap stops it\n",
    "huge_output": "    print('x' * (200 * 2**20))\n",
}
LIBRARY_EULER = ("    from armlab.transforms import euler_zyz_from_matrix\n"     # right values, the kit's work
                 "    return euler_zyz_from_matrix(np.asarray(T, dtype=float)[:3, :3])")
WRONG_DH = ("    return np.array([[np.pi / 2, h0, 0.0, np.pi / 2], [-(np.pi / 2 - beta), 0.0, L1, 0.0],\n"
            "                     [np.pi / 2 - beta, 0.0, L2, 0.0], [-np.pi / 2, 0.0, 0.0, -np.pi / 2],\n"
            "                     [0.0, Lt, 0.0, 0.0]])")      # alpha1's sign slipped: z1 points the other way


def _reference_bodies(exercise_id: str) -> list[str]:
    name = exercise_file(exercise(exercise_id))
    return regions_of(source_texts(ROOT / name), exercise_id, name)


def _wrong_euler() -> list[str]:
    # psi's sign slipped: the classic slip reading the third rotation off the bottom row
    body = _reference_bodies("fk.euler")[0]
    assert "-R[2, 0]" in body
    return [body.replace("-R[2, 0]", "R[2, 0]")]


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
    write_regions(student("wrong_dh"), "fk.dh_table", [WRONG_DH])
    wrong_euler = student("wrong_euler")
    write_regions(wrong_euler, "fk.euler", _wrong_euler())
    write_regions(wrong_euler, "fk.dh_table", _reference_bodies("fk.dh_table"))
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
    edited_only = subs / "edited_only"     # only the edited file, the rest not submitted
    (edited_only / "armlab").mkdir(parents=True)
    shutil.copy2(full / "armlab/kinematics.py", edited_only / "armlab")
    for name, prefix in CONTAINED.items():   # each then runs the reference: only the limits can make it score 0
        write_regions(student(name), "fk.euler", [prefix + _reference_bodies("fk.euler")[0]])   # called 300 times
        write_regions(subs / name, "fk.dh_table", _reference_bodies("fk.dh_table"))
    write_regions(student("library_call"), "fk.euler", [LIBRARY_EULER])
    kit = student("kit_call")            # the notebook's stand-in (the kit's table with the lengths put in)
    write_regions(kit, "fk.dh_table", ["    return kit_table(h0, L1, beta, L2, Lt)"])
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
    assert hidden and any("differs" in c.message for c in hidden if not c.passed)


def test_tricks_score_below_full_marks(graded):
    assert _score(graded, "tampered", "fk.dh_table") == 0        # edited asserts, verdicts, markers, conftest
    marker = graded[0]["marker"]["fk.dh_table"]
    assert marker.score == 0 and "NBVAL_RAISES_EXCEPTION" in marker.reason and not marker.checks


def test_calling_the_kits_reference_function_fails_the_hidden_checks(graded):
    kit = graded[0]["kit_call"]["fk.dh_table"]
    hidden = [c for c in kit.checks if c.name.startswith("hidden")]
    assert hidden and not all(c.passed for c in hidden) and kit.score < exercise("fk.dh_table").points


def test_the_release_lacks_the_hidden_checks(tmp_path):
    make_student_release(ROOT, tmp_path / "s")
    assert (ROOT / "armlab/grading/hidden/__init__.py").is_file()
    assert not (tmp_path / "s/armlab/grading/hidden").exists()
    assert (tmp_path / "s/armlab/grading/harness.py").is_file()
    assert not list((tmp_path / "s/tests").glob("test_grading*.py"))


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
    """The kit's euler_zyz_from_matrix computes the right values (every public and hidden check passes); the static
    check fails naming the call."""
    result = graded[0]["library_call"]["fk.euler"]
    static = [c for c in result.checks if c.name.startswith("static")]
    assert all(c.passed for c in result.checks if not c.name.startswith("static"))
    assert len(static) == 1 and not static[0].passed and "euler_zyz_from_matrix" in static[0].message
    assert 0 < result.score < exercise("fk.euler").points
    kit = graded[0]["kit_call"]["fk.dh_table"]
    assert any("kit_table" in c.message for c in kit.checks if c.name.startswith("static"))


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
    from armlab.exercises.registry import EXERCISES

    assert rows[0]["student"] == "alice" and rows[0]["total"] == "0"
    assert float(rows[0]["max"]) == sum(e.points for e in EXERCISES if e.kind != "written")   # those by hand
    assert main(["grade", str(tmp_path / "missing"), "--out", str(tmp_path / "out")]) == 2   # one line, exit 2


def _replaced(exercise_id: str, old: str, new: str) -> list[str]:
    bodies = _reference_bodies(exercise_id)
    assert any(old in b for b in bodies), f"{old!r} not in the reference of {exercise_id}"
    return [b.replace(old, new) for b in bodies]


HIDDEN_WRONG = {   # per exercise: wrong answers its hidden checks must catch (a "hard-coded" one must fail them all)
    "calib.pinhole": {
        "no translation": _replaced("calib.pinhole", " + T_cam_world[:3, 3]", ""),
        "rotation not transposed": _replaced("calib.pinhole", "T_cam_world[:3, :3].T @", "T_cam_world[:3, :3] @"),
    },
    "calib.tag_homography": {
        "hard-coded": ["    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])"],
        "normalisation not undone": _replaced("calib.tag_homography", "np.linalg.solve(T_dst, H_normalised @ T_src)",
                                              "H_normalised"),
    },
    "calib.tag_extrinsics": {   # the refinement after the region would repair both: the adapter leaves it out
        "hard-coded": ["    R, t = np.diag([1.0, -1.0, -1.0]), np.array([0.0, 150.0, 1000.0])"],
        "pixels, not normalised points": _replaced("calib.tag_extrinsics", "dlt_homography(world[:, :2], normalised)",
                                                   "dlt_homography(world[:, :2], pixels)"),
    },
    "calib.depth_plane": {
        "one fit, no rejection": _replaced("calib.depth_plane", "range(iterations)", "range(1)"),
        "outliers kept": _replaced("calib.depth_plane", "< inlier_mm", "< 1e9"),
    },
    "fk.dh_table": {
        "alpha1's sign slipped": [WRONG_DH],
        "the L's tilt added, not taken off": _replaced("fk.dh_table", "[-(np.pi / 2 - beta), 0.0, L1, 0.0]",
                                                       "[-(np.pi / 2 + beta), 0.0, L1, 0.0]"),
    },
    "fk.euler": {
        "psi's sign slipped": _wrong_euler(),
        "no singular case": _replaced("fk.euler", "if sin_theta > 1e-12:", "if True:"),
    },
    "fk.dh_link_transform": {
        "d negated": _replaced("fk.dh_link_transform", "= sa, ca, d", "= sa, ca, -d"),
        "theta and alpha swapped in row 0": _replaced("fk.dh_link_transform", "-st * ca, st * sa", "-ct * sa, st * ca"),
    },
    "ik.candidates": {
        "hard-coded": ["    q1 = q2 = q3 = q4 = heading * 0.0\n    ok, d2 = heading == heading, heading * 0.0 + 1.0"],
        "elbow sign swapped": _replaced("ik.candidates", "* delta_sign", "* -delta_sign"),
    },
    "detect.segment": {
        "red's wrap ignored": _replaced("detect.segment", "if h0 <= h1:", "if True:"),
        "ranges tuned too tight": _replaced("detect.segment", "120, 60)", "250, 250)"),
    },
    "detect.face": {
        "yaw not wrapped": _replaced("detect.face", "yaw = (np.radians(angle) + np.pi / 4) % (np.pi / 2) - np.pi / 4",
                                     "yaw = np.radians(angle)"),
        "size from pixels, not mm": _replaced("detect.face", "edge_mm = np.sqrt(m[\"m00\"]) * mm_per_px",
                                              "edge_mm = np.sqrt(m[\"m00\"])"),
    },
    "detect.classify": {
        "per-class spreads ignored": _replaced(
            "detect.classify", "d = self.distances(rgb_means)",
            "d = np.linalg.norm(color_features(rgb_means)[:, None, :] - self.means[None], axis=-1)"),
        "margin to the farthest class": _replaced("detect.classify", "d[rows, order[:, 1]] - d[rows, order[:, 0]]",
                                                  "d[rows, order[:, -1]] - d[rows, order[:, 0]]"),
    },
    "grab.move_path": {
        "roll ignores the yaw": _replaced("grab.move_path",
                                          "roll = planning.tilted_roll(heading, float(pitch), float(yaw))",
                                          "roll = 0.0"),
        "release at the grasp height": _replaced("grab.move_path", "tool_z = target[2] + edge - depth",
                                                 "tool_z = target[2] - depth"),
    },
    "teach.replay": {
        "recorded before posing": _replaced("teach.replay", "arm.move_by_hand(q)\n            recorder.record(g)",
                                            "recorder.record(g)\n            arm.move_by_hand(q)"),
        "no velocity floor": _replaced("teach.replay", "np.maximum(np.maximum(lab_pace, velocity_floor), 0.4)",
                                       "np.maximum(lab_pace, 0.4)"),
    },
    "events.sort_stack": {
        "no unstacking": _replaced("events.sort_stack", "if standing_on_something:", "if False:"),
        "stack height not tracked": _replaced("events.sort_stack", "len(built[b.size]) * block_edge(b.size)", "0.0"),
    },
    "station.transition": {
        "no stop at the end of the work": _replaced("station.transition", "    if machine.stop_requested:\n",
                                                    "    if False:\n"),
        "errors always back to idle": _replaced("station.transition", "if not machine.stop_requested:\n", "if True:\n"),
    },
}
# exercises whose function calls another's region go into a second batch, apart from the one they call
SECOND_BATCH = {"calib.tag_extrinsics", "fk.dh_link_transform"}


def test_every_exercise_has_hidden_checks_and_wrong_answers():
    from armlab.exercises.registry import EXERCISES
    from armlab.grading import hidden

    graded_by_code = sorted(e.id for e in EXERCISES if e.kind != "written")
    assert sorted(hidden.SPECS) == graded_by_code == sorted(HIDDEN_WRONG)
    assert sorted(hidden.FORBIDDEN) == graded_by_code
    assert all(len(wrong) >= 2 for wrong in HIDDEN_WRONG.values()), "each exercise has two plausible wrong answers"


def test_hidden_checks_pass_the_reference_and_fail_wrong_answers():
    """All exercises' hidden checks: the reference (in one harness run after the one computing the expected values)
    passes every one; each wrong answer (one batch per round of wrong answers and per group of exercises that do not
    call each other) fails at least one, a hard-coded answer every one."""
    from armlab.grading.grade import Grader

    ids = sorted(HIDDEN_WRONG)
    grader = Grader(ROOT, Limits(timeout_s=300, cpu_s=200), ids)
    reference = grader.hidden_checks_together({e: _reference_bodies(e) for e in ids})
    for exercise_id in ids:
        checks = reference[exercise_id]
        assert len(checks) >= 3 and all(c.passed for c in checks), (exercise_id, [c.message for c in checks])
    rounds = max(len(w) for w in HIDDEN_WRONG.values())
    for r in range(rounds):
        for group in ([e for e in ids if e not in SECOND_BATCH], sorted(SECOND_BATCH)):
            wrong = {e: list(HIDDEN_WRONG[e].items())[r] for e in group if len(HIDDEN_WRONG[e]) > r}
            got = grader.hidden_checks_together({e: bodies for e, (_, bodies) in wrong.items()})
            for exercise_id, (label, _) in wrong.items():
                passed = [c.passed for c in got[exercise_id]]
                assert not all(passed), f"{exercise_id}, {label}: every hidden check passed"
                assert not (label == "hard-coded" and any(passed)), f"{exercise_id}, {label}: {passed}"


def test_static_check_names_the_forbidden_call():
    """Every reference region passes; each exercise's forbidden names and the kit's reference module, called,
    imported, aliased or named in a string, fail the check with the name; the region's own names do not count."""
    from armlab.exercises.registry import EXERCISES
    from armlab.grading.hidden import FORBIDDEN
    from armlab.grading.static import forbidden_uses, static_check

    for ex in (e for e in EXERCISES if e.kind != "written"):
        assert static_check(ex.id, _reference_bodies(ex.id)).passed, ex.id
        for name in FORBIDDEN[ex.id]:
            module, _, last = name.rpartition(".")
            module = module or "lib"
            uses = [f"    x = {module}.{last}(1)", f"    from {module} import {last}\n    x = {last}(2)",
                    f"    f = getattr({module}, {last!r})"]
            for body in uses:
                result = static_check(ex.id, [body])
                assert not result.passed and name in result.message, (ex.id, body, result)
    ref = static_check("teach.replay", ["    from armlab.exercises import references\n"
                                             "    return references.scaled_durations_by_search(program, speed)"])
    assert not ref.passed and "armlab.exercises.references" in ref.message
    assert forbidden_uses("    fk = 1.0\n    return fk * 2", ("kinematics.fk",)) == []      # its own variable
    assert forbidden_uses("    return sky_points(n - 1) + 30", ("scoring.sky_points",), ("sky_points",)) == []
    assert forbidden_uses("    if x:\n        pass\n    H = cv2.findHomography(a, b)",
                          ("cv2.findHomography",)) == [("cv2.findHomography", 3)]


def test_regrading_gives_the_same_scores(graded):
    """A fresh Grader (no shared cache) on the class's tampered submission: the same scores and checks."""
    from armlab.grading.grade import Grader

    results, out = graded
    grader = Grader(ROOT, Limits(timeout_s=240, cpu_s=25), GRADED)
    for student in ("tampered",):
        again = grader.grade(read_submission(out.parent / "submissions" / student, ROOT))
        for exercise_id in GRADED:
            first, second = results[student][exercise_id], again[exercise_id]
            assert (second.score, [(c.name, c.passed) for c in second.checks]) == \
                (first.score, [(c.name, c.passed) for c in first.checks]), (student, exercise_id)
    assert grader.runs == 1


def test_a_hard_coded_answer_fails_the_hidden_checks():
    """fk.euler as the public check's one singular case, hard-coded: the hidden checks' other poses fail it."""
    from armlab.grading.grade import Grader

    lookup = "    return np.array([0.7, 0.0, 0.0])"
    with Grader(ROOT, Limits(timeout_s=240, cpu_s=60), ["fk.euler"]) as grader:
        checks = grader.hidden_checks("fk.euler", [lookup])
    assert checks and not any(c.passed for c in checks)
    assert all("differs from the expected value" in c.message for c in checks)
