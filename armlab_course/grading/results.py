"""What grading an exercise gives: its checks (passed or not, with the first failure's message) and its score."""

from __future__ import annotations

from dataclasses import dataclass, field

from armlab_course.exercises.registry import exercise

__all__ = ["CheckResult", "ExerciseResult", "score_exercise", "STATIC_CHECK"]

STATIC_CHECK = "static check: no forbidden call"      # its failure: the region called the kit's or a library's answer


@dataclass(frozen=True)
class CheckResult:
    name: str
    passed: bool
    message: str = ""


@dataclass
class ExerciseResult:
    """One exercise's grade: score out of max_score, its checks, and why it scored 0 without checks (reason). A
    written answer (answer not None) is graded by hand: its score stays 0 here and it counts in no automatic total."""

    exercise_id: str
    score: float
    max_score: int
    checks: list[CheckResult] = field(default_factory=list)
    reason: str = ""
    answer: str | None = None

    @property
    def by_hand(self) -> bool:
        """A written answer, graded by the instructor (or one not given: blank)."""
        from armlab_course.exercises.registry import exercise

        return exercise(self.exercise_id).kind == "written"


def score_exercise(exercise_id: str, checks: list[CheckResult], reason: str = "") -> ExerciseResult:
    """The grading rule: points x (passed checks / all checks), rounded to 0.01; 0 with `reason` (or "no check ran")
    when no check ran, and 0 when the region called a forbidden function (its static check failed, in the text or
    at run time): calling the kit's or a library's answer earns nothing, whatever the other checks say."""
    points = exercise(exercise_id).points
    if not checks:
        return ExerciseResult(exercise_id, 0.0, points, [], reason or "no check ran")
    if any(c.name == STATIC_CHECK and not c.passed for c in checks):
        return ExerciseResult(exercise_id, 0.0, points, checks, reason)
    passed = sum(c.passed for c in checks)
    return ExerciseResult(exercise_id, round(points * passed / len(checks), 2), points, checks, reason)
