"""Score a submission exercise by exercise, each with the reference in place for every other exercise.

Score of an exercise: 0 when blank (nothing runs) or when its regions cannot be read or spliced; otherwise
points x (passed checks / all checks), its checks being the notebook's code cells tagged `# CHECK <id>` (the public
checks, run by the instructor's copy of the notebook) and its hidden checks (armlab.grading.hidden), each counting
one; a region calling a forbidden library or kit function (armlab.grading.static) gets one more check, failed.
A region byte-identical to one already graded in this run (the reference's, or another student's) reuses that
result: the work tree is then identical, so is the outcome.
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
from .splice import RegionRejected, build_worktree, splice_into
from .static import static_check
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
        self._expected: dict[str, list[list[dict]]] = {}
        self._expected_lock = threading.Lock()
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
        static = static_check(exercise_id, bodies)
        return _score(exercise_id, checks + hidden + ([static] if static and not static.passed else []), run.problem)

    def hidden_checks(self, exercise_id: str, bodies: list[str]) -> list[CheckResult]:
        """Only the hidden checks of `bodies` spliced into the reference (no notebook run): for instructors trying a
        new HiddenSpec against wrong answers. RegionRejected for a body holding markers."""
        return self.hidden_checks_together({exercise_id: bodies})[exercise_id]

    def hidden_checks_together(self, bodies: dict[str, list[str]]) -> dict[str, list[CheckResult]]:
        """The hidden checks of several exercises' bodies spliced into one work tree, run in one harness subprocess
        (so one exercise's body is in place while another's is checked: for trying specs on exercises that do not
        call each other, not for grading). RegionRejected for a body holding markers."""
        with tempfile.TemporaryDirectory(prefix="armlab-grade-") as tmp:
            tree = build_worktree(self.reference, Path(tmp) / "work")
            for exercise_id, exercise_bodies in bodies.items():
                splice_into(tree, exercise_id, exercise_bodies)
            return self._hidden_of(tree, list(bodies))

    def _jobs(self, exercise_id: str, tree: Path) -> list[dict]:
        """The harness jobs of the exercise's hidden specs in `tree`: one per spec, every call of its checks."""
        from . import hidden

        ex = exercise(exercise_id)
        notebook = None if ex.in_package else str(tree / f"notebooks/{ex.notebook}.ipynb")
        return [{"notebook": notebook, "function": spec.function, "adapter": spec.adapter, "prelude": spec.prelude,
                 "cases": [args for check in checks for args in check]}
                for spec, checks in zip(hidden.specs_of(exercise_id), hidden.cases_of(exercise_id), strict=True)]

    def _expected_of(self, exercise_ids: list[str]) -> None:
        """Compute (once per Grader, all missing ones in one harness run on the reference tree) the expected results
        of the exercises' hidden checks; RuntimeError when the reference fails its own."""
        with self._expected_lock:
            missing = [e for e in exercise_ids if e not in self._expected]
            if not missing:
                return
            with tempfile.TemporaryDirectory(prefix="armlab-grade-ref-") as tmp:
                ref = build_worktree(self.reference, Path(tmp) / "work")
                jobs = {e: self._jobs(e, ref) for e in missing}
                expected, problem = run_harness(ref, [job for e in missing for job in jobs[e]], self.limits)
            if expected is None:
                raise RuntimeError(f"the reference's hidden checks of {', '.join(missing)} gave no results: {problem}")
            k = 0
            for e in missing:
                mine = expected[k:k + len(jobs[e])]
                k += len(jobs[e])
                errors = [r["error"] for job in mine for r in job if "error" in r]
                if errors:
                    raise RuntimeError(f"the reference fails its own hidden checks of {e}: {errors[0]}")
                self._expected[e] = mine

    def _hidden(self, exercise_id: str, tree: Path) -> list[CheckResult]:
        """The exercise's hidden checks (none without a spec, or in a student release, which lacks them): the
        student's results from `tree`, the expected ones from the reference tree (once per Grader)."""
        return self._hidden_of(tree, [exercise_id])[exercise_id]

    def _hidden_of(self, tree: Path, exercise_ids: list[str]) -> dict[str, list[CheckResult]]:
        """The hidden checks of the exercises in `tree`, all in one harness run; numbered across an exercise's
        specs."""
        try:
            from . import hidden
        except ImportError:
            return {e: [] for e in exercise_ids}
        out: dict[str, list[CheckResult]] = {e: [] for e in exercise_ids}
        with_specs = [e for e in exercise_ids if hidden.specs_of(e)]
        if not with_specs:
            return out
        self._expected_of(with_specs)
        jobs = [job for e in with_specs for job in self._jobs(e, tree)]
        got, problem = run_harness(tree, jobs, self.limits)
        k = 0
        for e in with_specs:
            first = 1
            for spec, checks, expected in zip(hidden.specs_of(e), hidden.cases_of(e), self._expected[e],
                                              strict=True):
                names = [f"hidden check {first + i}" for i in range(len(checks))]
                if got is None:
                    out[e] += [CheckResult(n, False, problem) for n in names]
                else:
                    verdicts = hidden.compare(spec, got[k], expected, [len(c) for c in checks], first)
                    out[e] += [CheckResult(n, ok, msg) for n, (ok, msg) in zip(names, verdicts, strict=True)]
                first += len(checks)
                k += 1
        return out

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
