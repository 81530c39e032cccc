"""Exercises: the registry (ids, titles, points, where each lives), the solution markers, and the student release.

    python -m armlab exercises        # the list, in the order the notebooks teach them
    python tools/student-release OUT  # or: make student
"""

from .fallback import reference_fallback, require_written, with_reference
from .markers import ExerciseMarkerError, Region, find_answers, find_regions, stub_regions
from .registry import EXERCISES, Exercise, ExerciseNotWritten, exercise, notebook_of, of_notebook
from .release import RELEASE_EXCLUDES, make_student_release, released, student_notebook
from .rubric import exercises_json, exercises_table, rubric, solution_lines

__all__ = ["EXERCISES", "Exercise", "ExerciseMarkerError", "ExerciseNotWritten", "Region", "exercise", "find_answers",
           "find_regions", "notebook_of", "of_notebook", "rubric", "exercises_json", "solution_lines",
           "make_student_release", "released", "stub_regions", "student_notebook", "RELEASE_EXCLUDES",
           "exercises_table", "reference_fallback", "require_written", "with_reference"]

