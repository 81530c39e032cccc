"""What the instructor grades by hand, written next to grades.csv by `grade_class`:

- OUT/rubric.csv: one row per criterion of every written question graded (exercise, notebook, figure, points,
  criterion), the point rubric to mark against;
- OUT/hand_grading.md: per question, the figure it follows, its rubric with a box per criterion, the model answer
  (from the instructor's notebook source, between the answer markers) and every student's answer.

The rubrics are instructor only (armlab_course.grading.hidden._rubrics); the students' answers are quoted as text.
"""

from __future__ import annotations

from pathlib import Path

from armlab_course.exercises.markers import find_answers
from armlab_course.exercises.registry import exercise

from .csv_cells import csv_text
from .results import ExerciseResult

__all__ = ["HAND_FILES", "model_answers", "rubric_csv", "hand_grading_md", "write_hand_grading"]

HAND_FILES = ("rubric.csv", "hand_grading.md")


def model_answers(reference: Path, ids) -> dict[str, str]:
    """The model answer of each written question in `ids`, read from the instructor checkout's notebook source (its
    '# ' comment prefixes removed); '' when the source holds none."""
    out = {}
    for i in ids:
        where = exercise(i).where
        path = Path(reference) / where
        text = path.read_text(encoding="utf-8") if path.is_file() else ""
        body = find_answers([text], where).get(i, "")
        out[i] = "\n".join(line[2:] if line.startswith("# ") else line.lstrip("#") for line in body.splitlines())
    return out


def rubric_csv(ids) -> str:
    """The rubric of the written questions `ids`: one row per criterion."""
    from .hidden._rubrics import rubric_of

    rows = [[i, exercise(i).notebook, " and ".join(exercise(i).functions), c.points, c.text]
            for i in ids for c in rubric_of(i)]
    return csv_text(["exercise", "notebook", "figure", "points", "criterion"], rows)


def _quote(text: str) -> list[str]:
    return [f"> {line}" if line.strip() else ">" for line in text.splitlines()]


def hand_grading_md(graded: dict[str, dict[str, ExerciseResult]], models: dict[str, str]) -> str:
    """The marking sheet: per written question its rubric, model answer and each student's answer."""
    from .hidden._rubrics import rubric_of

    ids = [i for i, r in next(iter(graded.values())).items() if r.by_hand]
    out = ["# Written questions: marking sheet", "",
           "Mark each answer against its question's criteria (points per criterion); enter the sum in grades.csv's "
           "'(by hand)' column.", ""]
    for i in ids:
        e = exercise(i)
        out += [f"## {i}: {e.title} ({e.points} points)", "",
                f"Notebook {e.notebook}, after {' and '.join(e.functions)}.", "",
                "| points | criterion |", "|---:|---|"]
        out += [f"| {c.points:g} | {c.text} |" for c in rubric_of(i)]
        out += ["", "**Model answer**", ""] + (_quote(models.get(i, "")) or ["(none in the source)"]) + [""]
        for student, results in graded.items():
            answer = results[i].answer
            out += [f"### {student}: __ / {e.points}", ""]
            out += (_quote(answer) if answer else ["(not answered)"]) + [""]
            out += [f"- [ ] {c.points:g}: {c.text[:80]}" for c in rubric_of(i)] + [""]
    return "\n".join(out)


def write_hand_grading(graded: dict[str, dict[str, ExerciseResult]], out: Path, reference: Path) -> list[Path]:
    """OUT/rubric.csv and OUT/hand_grading.md when the graded exercises include written questions; the files
    written."""
    from .report import atomic_write

    if not graded:
        return []
    ids = [i for i, r in next(iter(graded.values())).items() if r.by_hand]
    if not ids:
        return []
    out = Path(out)
    atomic_write(out / HAND_FILES[0], rubric_csv(ids))
    atomic_write(out / HAND_FILES[1], hand_grading_md(graded, model_answers(reference, ids)))
    return [out / name for name in HAND_FILES]
