"""The written questions (issue 35): at least ten, each after a figure of its notebook, each with a model answer in the
instructor's source and a point rubric (armlab_course.grading.hidden._rubrics) that the grader exports for marking
(OUT/rubric.csv, OUT/hand_grading.md); in the student release nothing beside a question gives its answer away.

"Beside" is the question's section: from the figure before the question to the end of its answer cell, in the
released notebook (text and code) and in the instructor's stored outputs (what a student sees after running it).
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest

from armlab_course.exercises import EXERCISES, exercise
from armlab_course.exercises.markers import answer_prompt, find_answers
from armlab_course.exercises.release import make_student_release, released
from armlab_course.grading.hand import model_answers, write_hand_grading
from armlab_course.grading.hidden._rubrics import FIGURE_FACTS, GIVEAWAYS, RUBRICS, rubric_of
from armlab_course.grading.results import ExerciseResult

ROOT = Path(__file__).resolve().parents[2]
WRITTEN = [e for e in EXERCISES if e.kind == "written"]
PROMPT = re.compile(r"\*\*(Exercise|Question) `(?P<id>[\w.]+)`")


def cells(path: Path) -> list[dict]:
    return json.loads(path.read_text())["cells"]


def text_of(cell: dict) -> str:
    return "".join(cell["source"])


def question_span(nb: list[dict], exercise_id: str) -> tuple[int, int]:
    """(the question's cell, the answer's cell) indices in a notebook's cells: the question is the markdown cell
    that sets it (**Exercise `id`** or **Question `id`**), the answer the one with its answer markers."""
    ask = next(i for i, c in enumerate(nb) if c["cell_type"] == "markdown"
               and any(m["id"] == exercise_id for m in PROMPT.finditer(text_of(c))))
    answer = next(i for i, c in enumerate(nb) if c["cell_type"] == "markdown"
                  and f"BEGIN ANSWER {exercise_id}" in text_of(c))
    return ask, answer


def figure_before(nb: list[dict], ask: int) -> int | None:
    """The last code cell before cell `ask` whose stored outputs hold an image (the figure the question is about)."""
    for i in range(ask - 1, -1, -1):
        if nb[i]["cell_type"] == "code" and any("image/png" in o.get("data", {}) for o in nb[i].get("outputs", [])):
            return i
    return None


def test_there_are_at_least_ten_written_questions_each_with_a_rubric_that_adds_up():
    assert len(WRITTEN) >= 10
    assert set(RUBRICS) == {e.id for e in WRITTEN}
    for e in WRITTEN:
        criteria = rubric_of(e.id)
        assert len(criteria) >= 2, f"{e.id}: a rubric of one criterion is a grade, not a rubric"
        assert sum(c.points for c in criteria) == e.points, f"{e.id}: its criteria do not add up to {e.points}"
        assert all(c.points > 0 and len(c.text) > 20 for c in criteria), e.id
    with pytest.raises(KeyError, match="not a written question"):
        rubric_of("fk.euler")


@pytest.mark.parametrize("e", WRITTEN, ids=lambda e: e.id)
def test_each_question_follows_a_figure_and_has_a_model_answer(e):
    nb = cells(ROOT / "notebooks" / f"{e.notebook}.ipynb")
    ask, answer = question_span(nb, e.id)
    assert ask < answer, f"{e.id}: the answer cell comes before the question"
    assert figure_before(nb, ask) is not None, f"{e.id}: no figure before the question"
    model = model_answers(ROOT, [e.id])[e.id]
    assert len(model.split()) >= 40, f"{e.id}: the model answer in {e.where} is {len(model.split())} words"
    assert model == find_answers([text_of(nb[answer])])[e.id], f"{e.id}: the stored notebook is not the source's"


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = tmp_path_factory.mktemp("release") / "student"
    make_student_release(ROOT, out)
    return out


@pytest.mark.parametrize("e", WRITTEN, ids=lambda e: e.id)
def test_no_answer_beside_a_question_in_the_release(e, release):
    """In the released notebook the answer cell holds only its prompt, and neither the cells from the figure to the
    answer (text and code) nor the outputs a student sees there (the instructor's stored ones) hold any of the
    question's give-aways (phrases of its model answer that would answer it) or a sentence of its model answer."""
    stored = cells(ROOT / "notebooks" / f"{e.notebook}.ipynb")
    ask, answer = question_span(stored, e.id)
    first = figure_before(stored, ask)
    ours = cells(release / "notebooks" / f"{e.notebook}.ipynb")
    assert [text_of(c) for c in ours[:answer]] != [] and len(ours) == len(stored)
    assert find_answers([text_of(ours[answer])])[e.id] == answer_prompt(e.id)
    beside = [text_of(c) for c in ours[first:answer + 1]]
    beside += ["".join(o.get("text", "")) + json.dumps(o.get("data", {}).get("text/plain", ""))
               for c in stored[first:answer + 1] if c["cell_type"] == "code" for o in c.get("outputs", [])]
    folded = " ".join(" ".join(beside).lower().split())
    found = [g for g in GIVEAWAYS[e.id] if g.lower() in folded]
    assert not found, f"{e.id}: beside the question: {found}"
    model = model_answers(ROOT, [e.id])[e.id]
    sentences = [s for s in re.split(r"(?<=[.;:])\s+", " ".join(model.split())) if len(s) > 40]
    assert not [s for s in sentences if s.lower() in folded], f"{e.id}: a sentence of the model answer is beside it"


def test_the_public_notebooks_ship_no_output_of_the_instructors_run(release):
    """The release ships the notebooks the public checks run (armlab_course/grading/public_notebooks), which a
    student can read: they hold no output and no count of the instructor's run (a check cell is judged by its
    asserts, so none is needed), hence no give-away and no model answer of any written question; each of their CHECK
    cells carries the tag that keeps nbval from comparing its printout."""
    from armlab_course.exercises.markers import CHECK_LINE
    from armlab_course.exercises.release import CHECK_VERDICT_TAG, PUBLIC_NOTEBOOKS

    public = sorted((release / PUBLIC_NOTEBOOKS).glob("*.ipynb"))
    assert public, "the release ships no public notebooks"
    for path in public:
        code = [c for c in cells(path) if c["cell_type"] == "code"]
        assert not [c for c in code if c.get("outputs") or c.get("execution_count") is not None], path.name
        checks = [c for c in code if CHECK_LINE.search("".join(c["source"]))]
        assert checks and all(CHECK_VERDICT_TAG in c["metadata"].get("tags", []) for c in checks), path.name


def test_every_question_has_give_aways_to_look_for():
    assert set(GIVEAWAYS) == {e.id for e in WRITTEN}
    for i, phrases in GIVEAWAYS.items():
        model = " ".join(model_answers(ROOT, [i])[i].lower().split())
        assert phrases and all(p.lower() in model for p in phrases), \
            f"{i}: every give-away is a phrase of the model answer: {[p for p in phrases if p.lower() not in model]}"


@pytest.mark.parametrize("exercise_id", sorted(FIGURE_FACTS))
def test_model_answers_read_the_numbers_their_notebook_prints(exercise_id):
    """The numbers a model answer reads off its figure's cells are the ones the stored notebook printed."""
    e = exercise(exercise_id)
    printed = " ".join("".join(o.get("text", "")) for c in cells(ROOT / "notebooks" / f"{e.notebook}.ipynb")
                       if c["cell_type"] == "code" for o in c.get("outputs", []))
    printed = " ".join(printed.split())
    model = " ".join(model_answers(ROOT, [exercise_id])[exercise_id].split())
    assert [f for f in FIGURE_FACTS[exercise_id] if f not in model] == [], "not in the model answer"
    assert [f for f in FIGURE_FACTS[exercise_id] if f not in printed] == [], "not printed by the notebook"


def test_the_rubric_and_marking_sheet_are_exported_for_hand_grading(tmp_path):
    ids = [e.id for e in WRITTEN]
    graded = {student: {i: ExerciseResult(i, 0.0, exercise(i).points, [], "graded by hand",
                                          answer=f"{student} on {i}" if student == "ada" else None) for i in ids}
              for student in ("ada", "bob")}
    written = write_hand_grading(graded, tmp_path, ROOT)
    assert [p.name for p in written] == ["rubric.csv", "hand_grading.md"]
    rows = list(csv.DictReader((tmp_path / "rubric.csv").open()))
    for i in ids:
        mine = [r for r in rows if r["exercise"] == i]
        assert [r["criterion"] for r in mine] == [c.text for c in rubric_of(i)]
        assert sum(float(r["points"]) for r in mine) == exercise(i).points
    sheet = (tmp_path / "hand_grading.md").read_text()
    for i in ids:
        assert f"## {i}: " in sheet and f"ada on {i}" in sheet
        first_line = model_answers(ROOT, [i])[i].splitlines()[0]
        assert first_line in sheet, f"{i}: the model answer is not on the marking sheet"
    assert sheet.count("(not answered)") == len(ids)                  # bob answered none
    assert write_hand_grading({"ada": {"fk.euler": ExerciseResult("fk.euler", 5.0, 5, [], "")}}, tmp_path / "x",
                              ROOT) == []


def test_the_rubrics_stay_with_the_instructor():
    assert not released("armlab_course/grading/hidden/_rubrics.py")
    assert not released("tests/course/test_written_questions.py")
