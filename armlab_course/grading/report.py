"""The grader's outputs, each written atomically (a temporary file in the same folder, then os.replace):
OUT/grades.csv (student, one column per exercise id, total, max), OUT/<student>/results.json in Gradescope's
autograder format (score; tests with name, score, max_score, output, visibility) and OUT/<student>/feedback.md."""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
from pathlib import Path

from armlab_course.exercises.registry import exercise

from .csv_cells import csv_text
from .results import ExerciseResult, total

__all__ = ["atomic_write", "results_json", "feedback_md", "grades_csv", "answers_csv", "table",
           "self_check_report", "write_reports", "student_folder"]


def atomic_write(path: Path, text: str) -> None:
    """Write `text` to `path` so that readers see the old file or the whole new one, never a part."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _summary(r: ExerciseResult) -> str:
    if r.by_hand:
        return f"graded by hand ({r.max_score} points); your answer: {r.answer}" if r.answer else r.reason
    if not r.checks:
        return r.reason
    passed = sum(c.passed for c in r.checks)
    first = next((c for c in r.checks if not c.passed), None)
    text = f"{passed} of {len(r.checks)} checks passed"
    return text + (f"; first failing check: {first.name}: {first.message}" if first else "")


def results_json(results: dict[str, ExerciseResult]) -> str:
    """Gradescope's results.json: one test per exercise; a written answer is a test of 0 points showing the answer
    (its points are given by hand, in Gradescope's own manual grading)."""
    tests = [{"name": f"{r.exercise_id}: {exercise(r.exercise_id).title}", "score": 0 if r.by_hand else r.score,
              "max_score": 0 if r.by_hand else r.max_score, "output": _summary(r), "visibility": "visible"}
             for r in results.values()]
    return json.dumps({"score": total(results).score, "tests": tests}, indent=1) + "\n"


def table(results: dict[str, ExerciseResult]) -> str:
    """The per-exercise table (the feedback's and `python -m armlab check`'s): points, checks passed; written answers
    say "by hand" and count in no total."""
    width = max(len(i) for i in results)
    lines = [f"{'exercise'.ljust(width)}  points  checks"]
    for r in results.values():
        if r.by_hand:
            lines.append(f"{r.exercise_id.ljust(width)}  {'-':>5}/{r.max_score:<2d} by hand"
                         + ("" if r.answer else " (not answered)"))
            continue
        checks = f"{sum(c.passed for c in r.checks)}/{len(r.checks)}" if r.checks else "-"
        lines.append(f"{r.exercise_id.ljust(width)}  {r.score:>5g}/{r.max_score:<2d} {checks}")
    lines.append(f"{'total'.ljust(width)}  {total(results)}")
    return "\n".join(lines)


def self_check_report(results: dict[str, ExerciseResult], blocked: dict[str, tuple[str, str]]) -> str:
    """`python -m armlab check`'s report: the table, then per written exercise that is not full its first failing
    check's message (or the exercise it needs, which fails), and a last line saying where the student stands."""
    blank = [r for r in results.values() if not r.checks and r.reason == "not written (blank region)"]
    lines = [table(results), ""]
    failing = 0
    for r in results.values():
        if r.score == r.max_score or r in blank or r.by_hand:
            continue
        if r.exercise_id in blocked:
            needed, why = blocked[r.exercise_id]
            failing += why == "fails"
            lines.append(f"- {r.exercise_id}: not checked on its own: it needs {needed}, which {why}")
            continue
        failing += 1
        first = next((c for c in r.checks if not c.passed), None)
        lines.append(f"- {r.exercise_id}: " + (f"{first.name}: {first.message}" if first else r.reason))
    if failing:
        lines.append(f"{failing} written exercise(s) not yet passing (public checks only: the grader also runs "
                     f"hidden ones)")
    else:
        lines.append("all checks of the written exercises passed (public checks only: the grader also runs hidden "
                     "ones)")
    if blank:
        lines.append(f"{len(blank)} exercise(s) not written yet: {', '.join(r.exercise_id for r in blank)}")
    return "\n".join(lines).rstrip() + "\n"


def feedback_md(student: str, results: dict[str, ExerciseResult]) -> str:
    out = [f"# Feedback for {student}", "", f"Total: {total(results)}", "", "```", table(results), "```", ""]
    for r in results.values():
        if r.by_hand:
            out += [f"## {r.exercise_id} ({exercise(r.exercise_id).title}): graded by hand, {r.max_score} points", ""]
            out += ([f"> {line}" for line in r.answer.splitlines()] if r.answer else [f"- {r.reason}"]) + [""]
            continue
        out += [f"## {r.exercise_id} ({exercise(r.exercise_id).title}): {r.score:g} / {r.max_score}", ""]
        out += [f"- {'passed' if c.passed else 'FAILED'}: {c.name}" + ("" if c.passed else f": {c.message}")
                for c in r.checks]
        if r.reason:
            out.append(f"- {r.reason}")
        out.append("")
    return "\n".join(out)


def grades_csv(graded: dict[str, dict[str, ExerciseResult]]) -> str:
    """One row per student: each automatic exercise's score, total and max of those (results.total), then one empty
    column per written answer for the instructor to fill in by hand (as nbgrader's manual grading), headed with its
    points."""
    first = next(iter(graded.values()))
    auto = [i for i, r in first.items() if not r.by_hand]
    by_hand = [i for i, r in first.items() if r.by_hand]
    header = ["student", *auto, "total", "max", *(f"{i} (by hand, /{first[i].max_score})" for i in by_hand)]
    return csv_text(header, ([student, *(float(results[i].score) for i in auto), float(total(results).score),
                              total(results).out_of, *("" for _ in by_hand)] for student, results in graded.items()))


def answers_csv(graded: dict[str, dict[str, ExerciseResult]]) -> str:
    """The written answers to grade by hand: one row per student, one column per written exercise."""
    first = next(iter(graded.values()))
    by_hand = [i for i, r in first.items() if r.by_hand]
    return csv_text(["student", *by_hand],
                    ([student, *(results[i].answer or "" for i in by_hand)] for student, results in graded.items()))


_RESERVED = ("grades.csv", "answers.csv", "rubric.csv", "hand_grading.md", "similarity.csv", "similarity.md")
_PLAIN = re.compile(r"[\w][\w .@+,-]{0,99}")


def student_folder(student: str) -> str:
    """The folder of OUT that holds a student's results.json and feedback.md: the student's name when it is a
    plain one (letters, digits, space, . @ + , - _; not starting with a dot or a dash; not one of the grader's own
    files in OUT: grades.csv, answers.csv, rubric.csv, hand_grading.md, similarity.*), else its plain characters
    followed by a short hash of the whole name (so two odd names never share a folder)."""
    if _PLAIN.fullmatch(student) and student.lower() not in _RESERVED and student.rstrip(" .") == student:
        return student
    plain = re.sub(r"[^\w.@+,-]+", "_", student).strip("._-")[:60] or "student"
    return f"{plain}-{hashlib.sha256(student.encode('utf-8', 'surrogatepass')).hexdigest()[:10]}"


def write_reports(graded: dict[str, dict[str, ExerciseResult]], out: Path) -> None:
    """OUT/<student folder>/results.json and feedback.md for each student (see student_folder), then
    OUT/grades.csv and, when the course has written answers, OUT/answers.csv."""
    taken: set[str] = set()
    for student, results in graded.items():
        name, k = student_folder(student), 1
        while name.lower() in taken:          # a plain name that reads like another's hashed one
            k += 1
            name = f"{student_folder(student)}-{k}"
        taken.add(name.lower())
        folder = out / name
        atomic_write(folder / "results.json", results_json(results))
        atomic_write(folder / "feedback.md", feedback_md(student, results))
    atomic_write(out / "grades.csv", grades_csv(graded))
    if any(r.by_hand for r in next(iter(graded.values())).values()):
        atomic_write(out / "answers.csv", answers_csv(graded))
