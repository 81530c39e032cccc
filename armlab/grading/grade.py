"""Score a submission exercise by exercise, each with the reference in place for every other exercise.

Score of an exercise: 0 when blank (nothing runs) or when its regions cannot be read or spliced; otherwise
points x (passed checks / all checks), its checks being the notebook's code cells tagged `# CHECK <id>` (the public
checks, run by the instructor's copy of the notebook) and its hidden checks (armlab.grading.hidden), each public
cell and each hidden check counting one. A region byte-identical to one already graded in this run
(the reference's, or another student's) reuses that result: the work tree is then identical, so is the outcome.
"""

from __future__ import annotations

import hashlib
import tempfile
import threading
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from armlab.exercises.registry import EXERCISES, exercise

from .results import CheckResult, ExerciseResult
from .run import DEFAULT_LIMITS, Limits, check_cells, run_harness, run_notebook
from .splice import RegionRejected, build_worktree
from .submission import Submission, read_submission

__all__ = ["CheckResult", "ExerciseResult", "Grader", "grade_submission", "grade_class"]


def _score(exercise_id: str, checks: list[CheckResult], reason: str = "") -> ExerciseResult:
    points = exercise(exercise_id).points
    if not checks:
        return ExerciseResult(exercise_id, 0.0, points, [], reason or "no check ran")
    passed = sum(c.passed for c in checks)
    return ExerciseResult(exercise_id, round(points * passed / len(checks), 2), points, checks, reason)


class Grader:
    """Grades submissions against the instructor's checkout `reference`; results of identical regions are shared
    within one Grader (thread-safe)."""

    def __init__(self, reference: Path | str, limits: Limits = DEFAULT_LIMITS, exercises: Iterable[str] | None = None):
        self.reference = Path(reference).resolve()
        self.limits = limits
        self.exercise_ids = list(exercises) if exercises is not None else [e.id for e in EXERCISES]
        for exercise_id in self.exercise_ids:
            exercise(exercise_id)
        self._cache: dict[tuple[str, str], ExerciseResult] = {}
        self._locks: dict[tuple[str, str], threading.Lock] = {}
        self._guard = threading.Lock()
        self._expected: dict[str, list[dict]] = {}
        self.runs = 0

    def grade_exercise(self, exercise_id: str, bodies: list[str]) -> ExerciseResult:
        """Splice `bodies` into the reference, run the exercise's notebook, score its CHECK cells."""
        key = (exercise_id, hashlib.sha256("\0".join(bodies).encode()).hexdigest())
        with self._guard:
            lock = self._locks.setdefault(key, threading.Lock())
        with lock:
            if key not in self._cache:
                self._cache[key] = self._run(exercise_id, bodies)
            return self._cache[key]

    def _run(self, exercise_id: str, bodies: list[str]) -> ExerciseResult:
        ex = exercise(exercise_id)
        notebook = f"notebooks/{ex.notebook}.ipynb"
        with tempfile.TemporaryDirectory(prefix="armlab-grade-") as tmp:
            try:
                tree = build_worktree(self.reference, Path(tmp) / "work", exercise_id, bodies)
            except RegionRejected as e:
                return _score(exercise_id, [], str(e))
            tags = [i for i, ids in check_cells(tree / notebook).items() if exercise_id in ids]
            if not tags:
                return _score(exercise_id, [], f"{notebook} has no '# CHECK {exercise_id}' cell")
            self.runs += 1
            run = run_notebook(tree, notebook, self.limits)
            hidden = self._hidden(exercise_id, tree)
        checks = [CheckResult(f"{ex.notebook} cell {i}", run.cells.get(i, None) is not None and run.cells[i].passed,
                              run.cells[i].message if i in run.cells else run.problem or "the cell did not run")
                  for i in tags]
        return _score(exercise_id, checks + hidden, run.problem)

    def hidden_checks(self, exercise_id: str, bodies: list[str]) -> list[CheckResult]:
        """Only the hidden checks of `bodies` spliced into the reference (no notebook run): for instructors trying a
        new HiddenSpec against wrong answers. RegionRejected for a body holding markers."""
        with tempfile.TemporaryDirectory(prefix="armlab-grade-") as tmp:
            return self._hidden(exercise_id, build_worktree(self.reference, Path(tmp) / "work", exercise_id, bodies))

    def _request(self, exercise_id: str, tree: Path, spec_function: str, cases: list) -> dict:
        ex = exercise(exercise_id)
        notebook = None if ex.in_package else str(tree / f"notebooks/{ex.notebook}.ipynb")
        return {"notebook": notebook, "function": spec_function, "cases": [args for case in cases for args in case]}

    def _hidden(self, exercise_id: str, tree: Path) -> list[CheckResult]:
        """The exercise's hidden checks (none without a spec, or in a student release, which lacks them): the
        student's results from `tree`, the expected ones from the reference tree (once per Grader)."""
        try:
            from . import hidden
        except ImportError:
            return []
        cases = hidden.cases_of(exercise_id)
        if cases is None:
            return []
        function = hidden.SPECS[exercise_id].function
        with self._guard:
            lock = self._locks.setdefault(("expected", exercise_id), threading.Lock())
        with lock:
            if exercise_id not in self._expected:
                with tempfile.TemporaryDirectory(prefix="armlab-grade-ref-") as tmp:
                    ref = build_worktree(self.reference, Path(tmp) / "work")
                    expected, problem = run_harness(ref, self._request(exercise_id, ref, function, cases), self.limits)
                if expected is None or any("error" in e for e in expected):
                    raise RuntimeError(f"the reference fails its own hidden checks of {exercise_id}: "
                                       f"{problem or expected}")
                self._expected[exercise_id] = expected
        got, problem = run_harness(tree, self._request(exercise_id, tree, function, cases), self.limits)
        names = [f"hidden check {i + 1}" for i in range(len(cases))]
        if got is None:
            return [CheckResult(n, False, problem) for n in names]
        verdicts = hidden.compare(exercise_id, got, self._expected[exercise_id], [len(c) for c in cases])
        return [CheckResult(n, ok, message) for n, (ok, message) in zip(names, verdicts, strict=True)]

    def grade(self, submission: Submission) -> dict[str, ExerciseResult]:
        results = {}
        for exercise_id in self.exercise_ids:
            points = exercise(exercise_id).points
            if exercise_id in submission.problems:
                results[exercise_id] = ExerciseResult(exercise_id, 0.0, points, [], submission.problems[exercise_id])
            elif exercise_id in submission.blank:
                results[exercise_id] = ExerciseResult(exercise_id, 0.0, points, [], "not written (blank region)")
            else:
                results[exercise_id] = self.grade_exercise(exercise_id, submission.bodies[exercise_id])
        return results


def grade_submission(folder: Path | str, reference: Path | str, limits: Limits = DEFAULT_LIMITS,
                     exercises: Iterable[str] | None = None, grader: Grader | None = None
                     ) -> dict[str, ExerciseResult]:
    """The results of one submission folder (a student release copy or only the edited files)."""
    grader = grader or Grader(reference, limits, exercises)
    return grader.grade(read_submission(folder, grader.reference))


def grade_class(submissions: Path | str, out: Path | str, reference: Path | str, jobs: int = 1,
                limits: Limits = DEFAULT_LIMITS, exercises: Iterable[str] | None = None) -> dict[str, dict]:
    """Grade every student folder of `submissions` (in parallel on `jobs` threads, each run its own bounded
    subprocess) and write OUT/grades.csv, OUT/<student>/results.json and OUT/<student>/feedback.md."""
    from .report import write_reports

    submissions = Path(submissions)
    if not submissions.is_dir():
        raise NotADirectoryError(f"{submissions}: no such folder of submissions")
    students = sorted(p for p in submissions.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not students:
        raise ValueError(f"{submissions} holds no student folder")
    if jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {jobs}")
    grader = Grader(reference, limits, exercises)
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        graded = dict(zip((p.name for p in students),
                          pool.map(lambda p: grade_submission(p, reference, grader=grader), students), strict=True))
    write_reports(graded, Path(out))
    return graded
