"""The similarity report (armlab_course.grading.similarity), pure Python: the reference pasted with renamed
variables, changed numbers and a reflowed layout scores high against it; two classmates with the same renamed code
score high against each other; honest solutions written independently score low; blank and too-short regions give no
row; the scores are the same in every process. (The report written by a graded class: test_grading.py.)"""

from __future__ import annotations

import csv
import io
import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from copies import EULER_BY_HAND, INDEPENDENT, disguised
from wrong_answers import HIDDEN_WRONG, reference_bodies

from armlab_course.exercises.markers import stub_lines
from armlab_course.exercises.registry import EXERCISES
from armlab_course.grading import similarity
from armlab_course.grading.similarity import FLAG_AT, REFERENCE, fingerprints, score, similarity_rows, tokens
from armlab_course.grading.submission import Submission

ROOT = Path(__file__).resolve().parents[2]
CODE = [e.id for e in EXERCISES if e.kind != "written"]
INDEPENDENT_BELOW = 0.4       # measured: at most 0.32 (fk.euler by hand: the same matrix entries, in other shapes)


def _score(a: list[str], b: list[str]) -> float:
    return score(fingerprints(a), fingerprints(b))


def _stub(exercise_id: str) -> str:
    return "\n".join("    " + line for line in stub_lines(exercise_id))


def test_tokens_forget_names_literals_comments_and_layout():
    written = "    total = scale * (x[0] + 2.5)   # the sum\n    print(f'{total:.2f} mm', 'done')\n"
    copied = "    s = (\n        k * (v[1] + 7)\n    )\n    print(\"x\", 'y',)\n"
    assert tokens(written) == tokens(copied) == ["N", "=", "N", "*", "N", "[", "0", "]", "+", "0",   # no grouping
                                                 "N", "(", "S", ",", "S", ")"]
    assert tokens("    if x:\n        return None\n") == ["if", "N", ":", "return", "None"]   # keywords stay
    assert tokens("    f(a, b)") != tokens("    f(a)(b)")                                 # calls stay calls


def test_an_unreadable_body_is_read_line_by_line():
    assert tokens("    x = f(a,\n  y = 2\n") == ["N", "=", "0"]       # the unclosed call is left out, the rest read


@pytest.mark.parametrize("exercise_id", CODE)
def test_the_reference_renamed_renumbered_and_reflowed_scores_high(exercise_id):
    reference = reference_bodies(exercise_id)
    copy = [disguised(b) for b in reference]
    assert copy != reference
    assert _score(copy, reference) >= 0.95 >= FLAG_AT


def test_a_copy_padded_with_code_of_ones_own_keeps_its_score():
    reference = reference_bodies("fk.euler")
    padded = [disguised(reference[0]).replace("    return", "    unused = [k * k for k in range(10)]\n"
                                                              "    print('checking', unused)\n    return")]
    assert _score(padded, reference) >= 0.95


def test_classmates_with_the_same_renamed_code_score_high_against_each_other():
    honest = {"alice": [EULER_BY_HAND], "bob": [disguised(EULER_BY_HAND, "b")],
              "carol": [disguised(EULER_BY_HAND, "c")]}
    rows = similarity_rows({name: {"fk.euler": bodies} for name, bodies in honest.items()},
                           {"fk.euler": reference_bodies("fk.euler")})
    scores = {(r[0], r[2]): r[3] for r in rows}
    assert len(rows) == 9                                     # each: the reference and two classmates
    for a, b in itertools.permutations(honest, 2):
        assert scores[a, b] == scores[b, a] >= 0.95
    for name in honest:
        assert scores[name, REFERENCE] < INDEPENDENT_BELOW    # written apart from the reference


@pytest.mark.parametrize("exercise_id", sorted(INDEPENDENT))
def test_honest_solutions_written_independently_score_low(exercise_id):
    reference = reference_bodies(exercise_id)
    first, second = INDEPENDENT[exercise_id]
    assert _score(first, reference) < INDEPENDENT_BELOW
    assert _score(second, reference) < INDEPENDENT_BELOW
    assert _score(first, second) < INDEPENDENT_BELOW


def test_references_of_different_exercises_score_low_against_each_other():
    """The instructor's own code for other tasks: the same author, the same libraries, no copying (measured: 0.18 at
    most)."""
    prints = {e: fingerprints(reference_bodies(e)) for e in CODE}
    worst = max((score(prints[a], prints[b]), a, b) for a, b in itertools.combinations(CODE, 2))
    assert worst[0] < INDEPENDENT_BELOW, worst


def test_hard_coded_answers_score_low_and_edits_of_the_reference_high():
    """tests/course/wrong_answers.py: a hard-coded value shares nothing with the reference; a slip made in a copy of the
    reference (one sign, one index) is still a copy."""
    for exercise_id, wrong in HIDDEN_WRONG.items():
        reference = reference_bodies(exercise_id)
        for why, bodies in wrong.items():
            if why == "hard-coded":
                assert _score(bodies, reference) < INDEPENDENT_BELOW, (exercise_id, why)
            else:
                assert _score(bodies, reference) >= FLAG_AT, (exercise_id, why)


def test_blank_and_too_short_regions_give_no_row():
    reference = {"fk.euler": reference_bodies("fk.euler"), "calib.pinhole": reference_bodies("calib.pinhole")}
    students = {"blank": {"fk.euler": [_stub("fk.euler")]},
                "empty": {"fk.euler": ["    \n    # nothing yet\n"]},
                "short": {"fk.euler": ["    return np.zeros(3)"]},
                "half": {"calib.pinhole": [_stub("calib.pinhole"), reference["calib.pinhole"][1]]},
                "full": {"fk.euler": reference["fk.euler"]}}
    rows = similarity_rows(students, reference)
    assert {r[0] for r in rows} == {"full", "half"}
    assert [r for r in rows if r[0] == "full"] == [("full", "fk.euler", REFERENCE, 1.0)]
    half = [r for r in rows if r[0] == "half"]                # its written region, not the stub, compared
    assert [r[:3] for r in half] == [("half", "calib.pinhole", REFERENCE)]
    assert 0 < half[0][3] == _score([reference["calib.pinhole"][1]], reference["calib.pinhole"])


def _class() -> dict[str, dict[str, list[str]]]:
    euler = reference_bodies("fk.euler")
    return {"zoe": {"fk.euler": [disguised(euler[0], "z")]}, "reference": {"fk.euler": [EULER_BY_HAND]},
            "=cmd|' /C calc'!A0": {"fk.euler": [disguised(euler[0], "q")]},
            "al\nice": {"fk.euler": euler, "fk.dh_link_transform": reference_bodies("fk.dh_link_transform")}}


def test_rows_are_sorted_and_the_same_in_every_process():
    rows = similarity_rows(_class(), {e: reference_bodies(e) for e in ("fk.euler", "fk.dh_link_transform")})
    assert rows == sorted(rows, key=lambda r: (r[0], r[1], r[2] != REFERENCE, r[2]))
    assert [r[2] for r in rows if r[0] == "zoe"] == [REFERENCE, "./reference", "=cmd|' /C calc'!A0", "al\nice"]
    script = ("import json, sys; sys.path.insert(0, 'tests/course'); from test_similarity import _class; "
              "from wrong_answers import reference_bodies; "
              "from armlab_course.grading.similarity import similarity_rows; "
              "print(json.dumps(similarity_rows(_class(), {e: reference_bodies(e) for e in "
              "('fk.euler', 'fk.dh_link_transform')})))")
    for seed in ("1", "2"):          # Python's own hash() differs per process: the fingerprints must not use it
        run = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120,
                             env={**os.environ, "PYTHONHASHSEED": seed})
        assert run.returncode == 0, run.stderr[-2000:]
        assert [tuple(r) for r in json.loads(run.stdout)] == rows


def test_the_report_files(tmp_path):
    students = _class()
    submissions = [Submission(name, bodies=bodies) for name, bodies in students.items()]
    written = similarity.write_similarity(submissions, ROOT, tmp_path, ["fk.euler", "calib.pinhole"])
    table = list(csv.reader(io.StringIO((tmp_path / "similarity.csv").read_text())))
    assert table[0] == ["student", "exercise", "matched", "score"]
    assert len(table) == 1 + len(written) == 1 + 4 * 4                # fk.dh_link_transform is not graded here
    assert {r[1] for r in table[1:]} == {"fk.euler"}
    assert all(0 <= float(r[3]) <= 1 for r in table[1:])
    assert ["'=cmd|' /C calc'!A0", "fk.euler", REFERENCE, "1"] in table   # a formula-like name neutralised
    notes = (tmp_path / "similarity.md").read_text()
    flagged = [line for line in notes.splitlines() if line.startswith("- ")]
    assert len(flagged) == sum(r[3] >= FLAG_AT for r in written) == 9    # the three copies: reference, each other
    assert "- fk.euler: 1.000 against the reference" in notes
    assert "## al\\nice" in notes and "al\nice" not in notes            # a name cannot forge a line
    assert "## reference" not in notes                                # the honest one is flagged nowhere
    assert "./reference" not in notes
