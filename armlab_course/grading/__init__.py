"""The instructor's grader: the student's exercise regions, spliced into the student release, run under
`pytest --nbval` with the instructor's checks and configuration in a bounded, sandboxed subprocess, and the hidden
checks asked of it by a judge process of the grader's own; scores, Gradescope results.json, feedback.md and
grades.csv.

    python -m armlab grade SUBMISSIONS --out OUT [--jobs N] [--timeout S]

A student release holds only the self-check's part of this package (armlab_course.exercises.release), so the
grading names are imported when first used.
"""

from __future__ import annotations

__all__ = ["ExerciseResult", "Submission", "grade_class", "grade_submission", "read_submission"]

_FROM = {"ExerciseResult": "results", "grade_class": "grade", "grade_submission": "grade",
         "Submission": "submission", "read_submission": "submission"}


def __getattr__(name: str):
    if name not in _FROM:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module

    return getattr(import_module(f"{__name__}.{_FROM[name]}"), name)
