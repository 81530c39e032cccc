"""Exercises: the registry (ids, titles, points, where each lives), the solution markers, and the student release.

    python -m armlab exercises        # the list, in the order the notebooks teach them
    python tools/student-release OUT  # or: make student
"""

from .fallback import reference_fallback, require_written, with_reference
from .markers import ExerciseMarkerError, Region, find_regions, stub_regions
from .registry import EXERCISES, Exercise, exercise, notebook_of
from .release import RELEASE_EXCLUDES, make_student_release, released, student_notebook

__all__ = ["EXERCISES", "Exercise", "ExerciseMarkerError", "Region", "exercise", "find_regions", "notebook_of",
           "make_student_release", "released", "stub_regions", "student_notebook", "RELEASE_EXCLUDES",
           "exercises_table", "reference_fallback", "require_written", "with_reference"]


def exercises_table() -> str:
    """The registry as a text table: id, points, notebook, where, what to write."""
    rows = [(e.id, str(e.points), e.notebook_number, e.where if e.in_package else "notebook", e.title)
            for e in EXERCISES]
    head = ("exercise", "points", "nb", "where", "what")
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(4)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(head, widths, strict=False)) + "  " + head[4]]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=False)) + "  " + r[4] for r in rows]
    lines.append(f"{len(EXERCISES)} exercises, {sum(e.points for e in EXERCISES)} points")
    return "\n".join(lines)
