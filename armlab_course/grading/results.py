"""What grading an exercise gives: its checks (passed or not, with the first failure's message) and its score; and
a submission's one total (total), which every output of the grader shows."""

from __future__ import annotations

from dataclasses import dataclass, field

from armlab_course.exercises.registry import exercise

__all__ = ["CheckResult", "ExerciseResult", "Total", "score_exercise", "total", "STATIC_CHECK"]

STATIC_CHECK = "static check: no forbidden call"      # its failure: the region called the kit's or a library's answer


@dataclass(frozen=True)
class CheckResult:
    """One check: its name as the student reads it (a public check: its cell as JupyterLab shows it,
    run.code_cell_labels), passed or not, the failure's message, and for a public check the code-cell index (nbval's
    'Cell N') of its cell."""

    name: str
    passed: bool
    message: str = ""
    cell: int | None = None


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


@dataclass(frozen=True)
class Total:
    """A submission's total, the one every output gives (the grader's stdout and progress lines, grades.csv's total
    and max, feedback.md, results.json, the self-check's table): `score` points of `out_of`, the points of the
    automatically graded exercises (code and open); `by_hand` more points are the written answers, which the
    instructor grades by hand and which count in no automatic total. Points come from the exercise registry."""

    score: float
    out_of: int
    by_hand: int

    def __str__(self) -> str:
        """'17 / 141 automatic (+17 by hand: the written answers)', or '17 / 141 automatic' without written
        answers."""
        text = f"{self.score:g} / {self.out_of} automatic"
        return text + (f" (+{self.by_hand} by hand: the written answers)" if self.by_hand else "")


def total(results: dict[str, ExerciseResult]) -> Total:
    """The total of one submission's results (exercise id -> result): the automatic exercises' scores, their points
    and the written answers' points, each exercise's points read from the registry (not from the results)."""
    exercises = [exercise(i) for i in results]
    auto = [e for e in exercises if e.kind != "written"]
    return Total(round(sum(results[e.id].score for e in auto), 2), sum(e.points for e in auto),
                 sum(e.points for e in exercises if e.kind == "written"))
