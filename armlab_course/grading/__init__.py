"""The instructor's grader: the student's exercise regions, spliced one exercise at a time into the instructor's
reference checkout, run under `pytest --nbval` with the instructor's checks and configuration in a bounded
subprocess; scores, Gradescope results.json, feedback.md and grades.csv.

    python -m armlab grade SUBMISSIONS --out OUT [--jobs N] [--timeout S]
"""

from .grade import ExerciseResult, grade_class, grade_submission
from .submission import Submission, read_submission

__all__ = ["ExerciseResult", "Submission", "grade_class", "grade_submission", "read_submission"]
