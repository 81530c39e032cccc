"""Score submissions: every exercise in one pass, an exercise isolated only when one of its checks fails.

Score of an exercise: 0 when blank (nothing runs) or when its regions cannot be read or spliced; otherwise
points x (passed checks / all checks), its checks being the notebook's code cells tagged `# CHECK <id>` (the public
checks, run by the instructor's copy of the notebook) and its hidden checks (armlab_course.grading.hidden), each
counting
one; a region calling a forbidden library or kit function -- found in its text (armlab_course.grading.static) or seen
called while the hidden checks ran (armlab_course.grading.harness) -- gets one more check, failed.

One pass: the student's regions of every written exercise go into one copy of the student release (built once per
Grader by the release builder, armlab_course.exercises.release: every other region a stub the kit stands in for, no
reference, hidden spec or grader module in it), each notebook that checks a written exercise runs once, and the
hidden checks of every written exercise run in one harness process. An exercise whose checks all pass there is scored
from that run. An exercise with a failing check, when another written exercise failed too, is run again alone -- its
regions and those of the exercises that passed in the release, the failing ones blank -- and scored from that run,
so that one mistake costs one exercise. Results of identical regions are shared within one Grader (the work tree, so
the outcome, is the same). A submission's runs (each notebook, the hidden checks) are independent: with `parallel` > 1
they go side by side.

Everything of the grader is imported, the instructor's tree copied, the release built and every expected value
computed (the reference run once on the instructor's copy) when the Grader is made, before any student code runs;
student code runs only in the sandbox (armlab_course.grading.sandbox), each run in a fresh copy of the release with
its regions, and the grader's own sources are checked against the hashes taken at the start
before any report is written.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import re
import shutil
import tempfile
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

from armlab_course.exercises.registry import EXERCISES, exercise

from . import report as _report  # noqa: F401  (imported now: nothing of the grader is loaded after student code)
from . import similarity as _similarity
from .public import public_results, redacted, run_public
from .results import CheckResult, ExerciseResult, score_exercise
from .run import DEFAULT_LIMITS, Limits, NotebookRun, Runner, check_cells, code_cell_labels, with_cell_labels
from .sandbox import Sandbox, detect, owner_only, python_outside, refuse_shared_network
from .splice import RegionRejected, build_worktree, check_body, release_worktree, splice_into
from .static import STATIC_CHECK, static_check
from .submission import Submission, exercise_file, read_submission, regions_of, source_texts

try:
    from . import hidden as _hidden
except ImportError:                    # a student release: public checks only
    _hidden = None

__all__ = ["CheckResult", "ExerciseResult", "Grader", "GraderChanged", "grade_submission", "grade_class",
           "check_reference", "source_hashes", "TIME_BUDGET", "Deadline"]

# A submission's runs all end within TIME_BUDGET x --timeout (wall clock) of its first run's start, whatever its
# regions do: each run's own limit is cut to the time left, a run due after the deadline does not start (its checks
# fail, saying so), and an exercise that failed in the one pass is rerun alone only while time is left (else it is
# scored from the pass).
TIME_BUDGET = 8


class Deadline:
    """When a submission's time is up: `seconds` from now (time.monotonic)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = float(seconds)
        self.at = time.monotonic() + self.seconds

    def left(self) -> float:
        return self.at - time.monotonic()

    def spent(self) -> str:
        return (f"not run: the submission's time ({TIME_BUDGET} x the {self.seconds / TIME_BUDGET:g} s timeout) "
                f"was spent")

_OWN_SOURCES = (Path(__file__).parent, Path(__file__).parents[1] / "exercises")


# what reading a run's results of the wrong shape raises: the run's exercises fail, naming it; the class goes on
_MALFORMED = (KeyError, TypeError, ValueError, AttributeError, IndexError, RecursionError)


_RAISED = re.compile(r"(raised )([A-Za-z_][\w.]*)(?::.*)?$", re.DOTALL)
_TAIL = re.compile(r"^(the hidden checks gave no results \(.*?\)):.*$", re.DOTALL)


def student_side(message: str) -> str:
    """A hidden check's message as the student may see it: which check and call failed and how (the exception's
    type, 'the result differs', the property), never what the region put into its exception's text or printed
    while the hidden checks ran (it holds the hidden inputs it was called with, or whatever it read of the run)."""
    message = _RAISED.sub(lambda m: f"{m[1]}{m[2]} (its message is not shown: the hidden checks' inputs stay hidden)",
                          message)
    return _TAIL.sub(lambda m: f"{m[1]} (the run's output is not shown)", message)


_NAMES = re.compile(r"[A-Za-z_]\w*")
_BRACKETED = {"<module>", "<lambda>", "<listcomp>", "<genexpr>", "<dictcomp>", "<setcomp>"}


def _at(exercise_id: str, where, bodies: Iterable[str], labels: list[str] | None = None) -> str:
    """Where a hidden check's call raised in the student's own code, for the feedback: " (in your code: <place>,
    line <n>, in <function>; ...)", innermost last, or ''. Of the frames the student's process sent (judge.where_of
    kept only plain triples), only those in the exercise's own notebook (its cells) or package file, in a function
    whose name the student's regions hold (or the exercise's function, <module>, <lambda>...), are shown: nothing
    else of the run, so no grader path or source, and no text of the run's choosing beyond its own names and line
    numbers. A notebook cell is named by its label (`labels`, the notebook's code_cell_labels) where given."""
    ex = exercise(exercise_id)
    names = set(_NAMES.findall("\n".join(bodies))) | _BRACKETED
    names |= {spec.function.rsplit(".", 1)[-1] for spec in (_hidden.specs_of(exercise_id) if _hidden else ())}
    shown = []
    for place, line, function in where if isinstance(where, list) else []:
        own = (place == ex.where) if ex.in_package else re.fullmatch(rf"{re.escape(ex.notebook)} cell \d{{1,4}}",
                                                                     place)
        if own and function in names:
            shown.append(f"{place}, line {line}, in {function}")
    text = f" (in your code: {'; '.join(shown)})" if shown else ""
    return with_cell_labels(text, Path(ex.notebook), labels) if text and labels and not ex.in_package else text


class GraderChanged(RuntimeError):
    """The grader's own files changed while it ran: no report is written."""


def source_hashes() -> dict[str, str]:
    """SHA-256 of every file of the grader's own packages (armlab_course.grading, armlab_course.exercises) as
    installed."""
    out = {}
    for folder in _OWN_SOURCES:
        for path in sorted(folder.rglob("*.py")):
            out[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def check_reference(reference: Path) -> Path:
    """The instructor's checkout `reference`, resolved; ValueError in one line when it is not one (missing, not a
    folder, no notebooks, no hidden checks)."""
    reference = Path(reference)
    if not reference.is_dir():
        raise ValueError(f"--reference {reference}: no such folder (the instructor's checkout)")
    if not (reference / "notebooks").is_dir() or not (reference / "armlab").is_dir():
        raise ValueError(f"--reference {reference}: not the kit's checkout (no notebooks/ or armlab/)")
    hidden = reference / "armlab_course" / "grading"
    if not (hidden / "hidden.py").is_file() and not (hidden / "hidden").is_dir():
        raise ValueError(f"--reference {reference}: it has no hidden checks (armlab_course/grading/hidden/): "
                         f"a student release cannot grade")
    return reference.resolve()


class Grader:
    """Grades submissions against the instructor's checkout `reference` in `sandbox` (default: detect(unsafe));
    results of identical regions are shared (thread-safe). close() removes its temporary trees."""

    def __init__(self, reference: Path | str, limits: Limits = DEFAULT_LIMITS, exercises: Iterable[str] | None = None,
                 unsafe: bool = False, sandbox: Sandbox | None = None, written: Iterable[str] | None = None,
                 parallel: int = 1, shared_network: bool = False, private: Iterable[Path] = ()):
        """exercises: those graded (default every one); written: those some submission to grade has written (default
        every graded one): only their expected values are computed, and grading another written one raises
        ValueError; parallel: how many runs of one submission (its notebooks, its hidden checks) go at once;
        shared_network: grade in the uid fallback although it cannot take the network away (see
        refuse_shared_network); private: folders besides the reference that the fallback's uids may not read (the
        submissions, the output), made owner-only until close()."""
        if parallel < 1:
            raise ValueError(f"parallel must be at least 1, got {parallel}")
        self.parallel = int(parallel)
        self.reference = check_reference(Path(reference))
        self.limits = limits
        self.exercise_ids = list(exercises) if exercises is not None else [e.id for e in EXERCISES]
        for exercise_id in self.exercise_ids:
            exercise(exercise_id)
        written = None if written is None else set(written)
        self._computed = [e for e in self.exercise_ids if written is None or e in written]
        self.sandbox = sandbox or detect(unsafe)
        refuse_shared_network(self.sandbox, shared_network)
        self._private = contextlib.ExitStack()
        if self.sandbox.kind == "user":         # every instructor path owner-only while student code runs
            python_outside([self.reference, *private])
            self._private.enter_context(owner_only(self.reference, *private))
        self._sources = source_hashes()
        self._tmp = tempfile.TemporaryDirectory(prefix="armlab-grade-")
        self._root = Path(self._tmp.name)
        # the instructor's files: read by the grader (the reference's bodies) and run once, before any student code,
        # for the expected values; never a student run's tree
        self._instructor = build_worktree(self.reference, self._root / "instructor")
        self._instructor.chmod(0o700)          # never entered by a run's user (the "user" sandbox)
        # what every student run's tree is made of: the student release (built once), the student's regions spliced
        self._pristine = release_worktree(self._instructor, self._root / "release")
        self._pristine.chmod(0o700)
        (self._root / "runs").mkdir(mode=0o711)
        self.runner = Runner(self.sandbox, limits)
        self._cache: dict[tuple, object] = {}
        self._locks: dict[tuple, threading.Lock] = {}
        self._guard = threading.Lock()
        self.runs = 0
        self._expected = self._compute_expected()

    def close(self) -> None:
        self.runner.close()
        self._tmp.cleanup()
        self._private.close()

    def __enter__(self) -> Grader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def verify_sources(self) -> None:
        """GraderChanged when a file of the grader's own packages differs from its hash at the start."""
        now = source_hashes()
        changed = sorted(p for p in set(now) | set(self._sources) if now.get(p) != self._sources.get(p))
        if changed:
            raise GraderChanged(f"the grader's own files changed while it ran: {', '.join(changed[:3])}: no grade "
                                f"is written")

    # -- trees and runs ---------------------------------------------------------------------------------------
    def _fresh(self, tree: Path) -> Path:
        """A new private copy of `tree` for one run."""
        dest = Path(tempfile.mkdtemp(dir=self._root / "runs")) / "work"
        shutil.copytree(tree, dest, symlinks=True)
        return dest

    def _spliced(self, bodies: dict[str, list[str]]) -> Path:
        """A copy of the student release with these exercises' regions replaced (bodies already checked); every
        other exercise stays blank (the kit's stand-in answers for it)."""
        tree = self._fresh(self._pristine)
        for exercise_id, exercise_bodies in bodies.items():
            splice_into(tree, exercise_id, exercise_bodies)
        return tree

    def _discard(self, tree: Path) -> None:
        shutil.rmtree(tree.parent, ignore_errors=True)

    def _bounded(self, deadline: Deadline | None, exercises: int = 1) -> Runner | None:
        """The runner for one run: the limits of `exercises` exercises' worth of runs, cut to the time the
        submission has left; None when none is left."""
        left = float("inf") if deadline is None else deadline.left()
        if left < 1:
            return None
        if deadline is None and exercises == 1:
            return self.runner
        runner = copy.copy(self.runner)        # shares the read-only folder; its own limits
        runner.limits = replace(self.limits, timeout_s=min(self.limits.timeout_s * exercises, left),
                                cpu_s=int(min(self.limits.cpu_s * exercises, left + 10)))
        return runner

    def _notebook(self, tree: Path, name: str, deadline: Deadline | None = None,
                  exercise_ids: Iterable[str] = ()) -> NotebookRun:
        """The notebook's run on a fresh copy of `tree` for the public checks of `exercise_ids` (only the cells they
        need: public.run_public, as the self-check runs them); a run that could not start, or whose results could
        not be read, is a NotebookRun with the reason (never an exception: one submission never stops the class)."""
        if self._bounded(deadline) is None:
            return NotebookRun({}, deadline.spent())
        run_tree = self._fresh(tree)
        try:
            runner = self._bounded(deadline)   # again: the copy took some of the time left
            if runner is None:
                return NotebookRun({}, deadline.spent())
            with self._guard:
                self.runs += 1
            return run_public(runner, run_tree, name, exercise_ids)
        except (OSError, ValueError, TypeError, KeyError, AttributeError, RecursionError, MemoryError) as e:
            return NotebookRun({}, f"the notebook run's results could not be read ({type(e).__name__})")
        finally:
            self._discard(run_tree)

    def _jobs(self, exercise_id: str, tree_inside: str, compared_only: bool = False) -> list[dict | None]:
        """The harness jobs of the exercise's hidden specs: one per spec, every call of its checks, with the
        exercise's forbidden names; with compared_only, None in place of an outcome spec's (nothing to compute)."""
        from .static import forbidden_of

        ex = exercise(exercise_id)
        notebook = None if ex.in_package else f"{tree_inside}/notebooks/{ex.notebook}.ipynb"
        forbidden = list(forbidden_of(exercise_id))
        return [None if compared_only and spec.outcome else
                {"notebook": notebook, "function": spec.function, "adapter": spec.adapter, "prelude": spec.prelude,
                 "cases": [args for check in checks for args in check], "forbidden": forbidden, "judge": spec.judge}
                for spec, checks in zip(_hidden.specs_of(exercise_id), _hidden.cases_of(exercise_id), strict=True)]

    def _with_specs(self, exercise_ids: Iterable[str]) -> list[str]:
        return [e for e in exercise_ids if _hidden is not None and _hidden.specs_of(e)]

    def _harness(self, tree: Path, exercise_ids: list[str], compared_only: bool = False,
                 deadline: Deadline | None = None) -> tuple[dict[str, list[dict | None]] | None, str]:
        """Per exercise, its jobs' outputs (None for a job not run: see _jobs) from one harness run on a fresh copy
        of `tree`; or None and why (never an exception for what the run gave back)."""
        if self._bounded(deadline, max(1, len(exercise_ids))) is None:
            return None, deadline.spent()
        run_tree = self._fresh(tree)
        try:
            inside = self.runner.sandbox.inside(run_tree)
            jobs = {e: self._jobs(e, inside, compared_only) for e in exercise_ids}
            wanted = [job for e in exercise_ids for job in jobs[e] if job is not None]
            runner = self._bounded(deadline, max(1, len(exercise_ids)))   # again: after the copy
            if runner is None:
                return None, deadline.spent()
            got, problem = runner.harness(run_tree, wanted, exercises=1) if wanted else ([], "")
        except (OSError, ValueError, TypeError, KeyError, AttributeError, RecursionError, MemoryError) as e:
            return None, f"the hidden checks' results could not be read ({type(e).__name__})"
        finally:
            self._discard(run_tree)
        if got is None:
            return None, problem
        if len(got) != len(wanted):
            return None, f"the hidden checks gave {len(got)} results for {len(wanted)} jobs"
        outputs = iter(got)
        return {e: [None if job is None else next(outputs) for job in jobs[e]] for e in exercise_ids}, ""

    def _compute_expected(self) -> dict[str, list[list[dict] | None]]:
        """Per exercise with hidden checks, per spec, the reference's results (None for an outcome spec: all ones),
        from one harness run before any student code runs; RuntimeError when the reference fails its own."""
        ids = self._with_specs(self._computed)
        if not ids:
            return {}
        got, problem = self._harness(self._instructor, ids, compared_only=True)
        if got is None:
            raise RuntimeError(f"the reference's hidden checks gave no results: {problem}")
        expected = {}
        for e in ids:
            errors = [r["error"] for job in got[e] if job is not None for r in job["results"] if "error" in r]
            if errors:
                raise RuntimeError(f"the reference fails its own hidden checks of {e}: {errors[0]}")
            expected[e] = [None if job is None else job["results"] for job in got[e]]
        return expected

    # -- checks -----------------------------------------------------------------------------------------------
    def _hidden_results(self, exercise_id: str, outputs: list[dict] | None, problem: str,
                        bodies: list[str] = ()) -> tuple[list[CheckResult], list[str]]:
        """The exercise's hidden checks from its jobs' outputs, and the forbidden calls seen; an error's message
        says where in the student's own code (`bodies`) it was raised (_at)."""
        if outputs is not None:
            outputs = [job if job is None else {**job, "results": [
                {**r, "at": _at(exercise_id, r.get("where"), bodies, self._labels(exercise_id))}
                if isinstance(r, dict) and "error" in r else r
                for r in job["results"]]} for job in outputs]
        checks: list[CheckResult] = []
        seen: list[str] = []
        first = 1
        for k, (spec, cases) in enumerate(zip(_hidden.specs_of(exercise_id), _hidden.cases_of(exercise_id),
                                              strict=True)):
            names = [f"hidden check {first + i}" for i in range(len(cases))]
            if outputs is None:
                checks += [CheckResult(n, False, student_side(problem)) for n in names]
            else:
                verdicts = _hidden.compare(spec, outputs[k]["results"], self._expected[exercise_id][k],
                                           [len(c) for c in cases], first)
                checks += [CheckResult(n, ok, student_side(msg)) for n, (ok, msg) in zip(names, verdicts,
                                                                                           strict=True)]
                seen += [name for name in outputs[k]["forbidden"] if isinstance(name, str)]
            first += len(cases)
        return checks, sorted(set(seen))

    def _checks(self, exercise_id: str, bodies: list[str], run: NotebookRun, tree: Path,
                hidden: tuple[dict | None, str]) -> list[CheckResult]:
        """Every check of the exercise: its public CHECK cells in `run`, its hidden checks, and a failed check for a
        forbidden call (in the region's text or seen at run time)."""
        checks = self._public(exercise_id, run, tree)
        seen: list[str] = []
        if exercise_id in self._expected:
            outputs, problem = hidden
            try:
                hidden_checks, seen = self._hidden_results(exercise_id, None if outputs is None else
                                                           outputs[exercise_id], problem, bodies)
            except _MALFORMED as e:             # the run's results were not of the shape a harness writes
                hidden_checks, seen = self._hidden_results(
                    exercise_id, None, f"the hidden checks' results could not be read ({type(e).__name__})")
            checks += [CheckResult(c.name, c.passed, self._redact(c.message)) for c in hidden_checks]
        static = static_check(exercise_id, bodies)
        if static is not None and not static.passed:
            checks.append(static)
        elif seen:
            checks.append(CheckResult(STATIC_CHECK, False, f"the region called {seen[0]} while the hidden checks "
                                                           f"ran: the exercise is to write it, not to call it"))
        return checks

    def _public(self, exercise_id: str, run: NotebookRun, tree: Path) -> list[CheckResult]:
        """The exercise's public CHECK cells in the notebook run `run` of `tree`."""
        return public_results(exercise_id, run, tree, self._paths())

    def _paths(self) -> dict[str, str]:
        """The grader's own paths, as a message shows them."""
        return {str(self._root): "<grader>", str(self.reference): "<reference>"}

    def _labels(self, exercise_id: str) -> list[str] | None:
        """The code-cell labels of the exercise's notebook in the student release (a region's body spliced in
        changes no cell's place), or None for a package exercise."""
        ex = exercise(exercise_id)
        if ex.in_package:
            return None
        return self._once(("labels", ex.notebook),
                          lambda: code_cell_labels(self._pristine / f"notebooks/{ex.notebook}.ipynb"))

    def _redact(self, message: str) -> str:
        """A message without the grader's own paths."""
        return redacted(message, self._paths())

    # -- grading ----------------------------------------------------------------------------------------------
    def _once(self, key: tuple, compute: Callable[[], object]) -> object:
        with self._guard:
            lock = self._locks.setdefault(key, threading.Lock())
        with lock:
            if key not in self._cache:
                self._cache[key] = compute()
            return self._cache[key]

    @staticmethod
    def _digest(bodies: dict[str, list[str]]) -> str:
        text = "\0\0".join(f"{e}\0" + "\0".join(b) for e, b in sorted(bodies.items()))
        return hashlib.sha256(text.encode()).hexdigest()

    def grade_exercise(self, exercise_id: str, bodies: list[str], deadline: Deadline | None = None,
                       beside: dict[str, list[str]] | None = None) -> ExerciseResult:
        """The exercise alone: `bodies` spliced into the student release (with the `beside` exercises' bodies, already
        checked, in place too; every other exercise blank), its notebook and its hidden checks run (within
        `deadline`, if given)."""
        beside = {e: b for e, b in (beside or {}).items() if e != exercise_id}
        return self._once(("alone", exercise_id, self._digest({exercise_id: bodies}), self._digest(beside)),
                          lambda: self._alone(exercise_id, bodies, deadline, beside))

    def public_checks(self, exercise_id: str, bodies: list[str]) -> list[CheckResult]:
        """Only the exercise's public CHECK cells as grading runs them (its notebook on the student release with
        `bodies` spliced in, every other exercise blank; no hidden checks, so no expected values are needed): what
        the self-check must agree with. RegionRejected for a body holding markers."""
        for body in bodies:
            check_body(body, exercise_id)
        tree = self._spliced({exercise_id: bodies})
        try:
            ex = exercise(exercise_id)
            return self._public(exercise_id, self._notebook(tree, ex.notebook, None, [exercise_id]), tree)
        finally:
            self._discard(tree)

    def _alone(self, exercise_id: str, bodies: list[str], deadline: Deadline | None = None,
               beside: dict[str, list[str]] | None = None) -> ExerciseResult:
        try:
            for body in bodies:
                check_body(body, exercise_id)
            tree = self._spliced({**(beside or {}), exercise_id: bodies})
        except RegionRejected as e:
            return score_exercise(exercise_id, [], str(e))
        try:
            ex = exercise(exercise_id)
            if not any(exercise_id in ids for ids in check_cells(tree / f"notebooks/{ex.notebook}.ipynb").values()):
                return score_exercise(exercise_id, [],
                                      f"notebooks/{ex.notebook}.ipynb has no '# CHECK {exercise_id}' cell")
            runs, hidden = self._run_all(tree, [ex.notebook], [exercise_id], deadline)
            run = runs[ex.notebook]
            return score_exercise(exercise_id, self._checks(exercise_id, bodies, run, tree, hidden), run.problem)
        finally:
            self._discard(tree)

    def _together(self, written: dict[str, list[str]], deadline: Deadline | None = None
                  ) -> dict[str, tuple[list[CheckResult], str]]:
        """Every written exercise's checks from one pass (each notebook once, the hidden checks in one run), with
        its notebook run's problem ('' when none)."""
        tree = self._spliced(written)
        try:
            runs, hidden = self._run_all(tree, sorted({exercise(e).notebook for e in written}), list(written),
                                         deadline)
            out = {}
            for e, b in written.items():
                run = runs[exercise(e).notebook]
                out[e] = (self._checks(e, b, run, tree, hidden), run.problem)
            return out
        finally:
            self._discard(tree)

    def _run_all(self, tree: Path, notebooks: list[str], exercise_ids: list[str], deadline: Deadline | None = None
                 ) -> tuple[dict[str, NotebookRun], tuple[dict | None, str]]:
        """The notebooks' runs and the exercises' hidden checks on `tree`, `parallel` runs at a time (the hidden
        checks, the longest, first), none past `deadline`."""
        with ThreadPoolExecutor(max_workers=self.parallel) as pool:
            hidden = pool.submit(self._harness, tree, self._with_specs(exercise_ids), False, deadline)
            runs = dict(zip(notebooks, pool.map(lambda name: self._notebook(
                tree, name, deadline, [e for e in exercise_ids if exercise(e).notebook == name]), notebooks),
                strict=True))
            return runs, hidden.result()

    def _reference_bodies(self, exercise_id: str) -> list[str]:
        """The reference's region bodies of the exercise (from the grader's private copy of the instructor's
        files)."""
        name = exercise_file(exercise(exercise_id))
        return self._once(("reference", exercise_id),
                          lambda: regions_of(source_texts(self._instructor / name), exercise_id, name))

    def grade(self, submission: Submission) -> dict[str, ExerciseResult]:
        """Every graded exercise's result for `submission`; its runs end within TIME_BUDGET x the timeout."""
        deadline = Deadline(TIME_BUDGET * self.limits.timeout_s)
        results: dict[str, ExerciseResult] = {}
        written: dict[str, list[str]] = {}
        for exercise_id in self.exercise_ids:
            points = exercise(exercise_id).points
            if exercise_id in submission.problems:
                results[exercise_id] = ExerciseResult(exercise_id, 0.0, points, [], submission.problems[exercise_id])
            elif exercise_id in submission.blank:
                results[exercise_id] = ExerciseResult(exercise_id, 0.0, points, [], "not written (blank region)")
            elif exercise_id in submission.answers:
                results[exercise_id] = ExerciseResult(exercise_id, 0.0, points, [], "graded by hand",
                                                      submission.answers[exercise_id])
            else:
                if exercise_id not in self._computed:
                    raise ValueError(f"{submission.name} wrote {exercise_id}, which this Grader was told no "
                                     f"submission writes (its expected values were not computed)")
                try:
                    for body in submission.bodies[exercise_id]:
                        check_body(body, exercise_id)
                    written[exercise_id] = submission.bodies[exercise_id]
                except RegionRejected as e:
                    results[exercise_id] = ExerciseResult(exercise_id, 0.0, points, [], str(e))
        if written:
            together = self._once(("together", self._digest(written)), lambda: self._together(written, deadline))
            failing = {e for e, (checks, _) in together.items() if not checks or not all(c.passed for c in checks)}
            passing = {e: b for e, b in written.items() if e not in failing}
            for exercise_id, (checks, problem) in together.items():
                if exercise_id not in failing or not failing - {exercise_id}:
                    # every check passed, or no other exercise failed: the tree of a run alone (the exercises that
                    # passed in place, the failing ones blank) would be the pass's own
                    results[exercise_id] = score_exercise(exercise_id, checks, problem)
                elif deadline.left() < 1:
                    results[exercise_id] = score_exercise(exercise_id, checks, problem or (
                        "scored from the pass with every exercise in place: the submission's time was spent before "
                        "it could run alone"))
                else:
                    results[exercise_id] = self.grade_exercise(exercise_id, written[exercise_id], deadline, passing)
        return {e: results[e] for e in self.exercise_ids}

    # -- for instructors trying hidden specs ----------------------------------------------------------------
    def hidden_checks(self, exercise_id: str, bodies: list[str]) -> list[CheckResult]:
        """Only the hidden checks of `bodies` spliced into the student release (no notebook run): for instructors
        trying a new HiddenSpec against wrong answers. RegionRejected for a body holding markers."""
        return self.hidden_checks_together({exercise_id: bodies})[exercise_id]

    def hidden_checks_together(self, bodies: dict[str, list[str]]) -> dict[str, list[CheckResult]]:
        """The hidden checks of several exercises' bodies spliced into one work tree, run in one harness process (so
        one exercise's body is in place while another's is checked: for trying specs on exercises that do not call
        each other, not for grading). RegionRejected for a body holding markers."""
        for exercise_id, exercise_bodies in bodies.items():
            for body in exercise_bodies:
                check_body(body, exercise_id)
        tree = self._spliced(bodies)
        try:
            ids = self._with_specs(bodies)
            outputs, problem = self._harness(tree, ids)
        finally:
            self._discard(tree)
        out: dict[str, list[CheckResult]] = {e: [] for e in bodies}
        for e in ids:
            checks, seen = self._hidden_results(e, None if outputs is None else outputs[e], problem, bodies[e])
            out[e] = checks + ([CheckResult(STATIC_CHECK, False, f"called {seen[0]} at run time")] if seen else [])
        return out


def grade_submission(folder: Path | str, reference: Path | str, limits: Limits = DEFAULT_LIMITS,
                     exercises: Iterable[str] | None = None, grader: Grader | None = None, unsafe: bool = False
                     ) -> dict[str, ExerciseResult]:
    """The results of one submission folder (a student release copy or only the edited files)."""
    if grader is not None:
        return grader.grade(read_submission(folder, grader.reference))
    submission = read_submission(folder, check_reference(Path(reference)))
    with Grader(reference, limits, exercises, unsafe=unsafe, written=submission.bodies) as own:
        return own.grade(submission)


def grade_class(submissions: Path | str, out: Path | str, reference: Path | str, jobs: int = 1,
                limits: Limits = DEFAULT_LIMITS, exercises: Iterable[str] | None = None, unsafe: bool = False,
                progress: Callable[[str, dict[str, ExerciseResult]], None] | None = None,
                shared_network: bool = False) -> dict[str, dict]:
    """Grade every student folder of `submissions` (in parallel on `jobs` threads, each run its own sandboxed
    process), calling progress(student, results) as each is done, and write OUT/grades.csv,
    OUT/<student folder>/results.json and feedback.md (report.student_folder), and the regions' similarity for the
    instructor: OUT/similarity.csv and OUT/similarity.md (armlab_course.grading.similarity). shared_network: see
    Grader. With written questions among the exercises: OUT/answers.csv, and OUT/rubric.csv and OUT/hand_grading.md
    (armlab_course.grading.hand) to mark them by."""
    from .hand import write_hand_grading
    from .report import write_reports

    submissions = Path(submissions)
    if not submissions.is_dir():
        raise NotADirectoryError(f"{submissions}: no such folder of submissions")
    if submissions.is_symlink():
        raise ValueError(f"{submissions} is a symbolic link: give the folder itself")
    students = sorted(p for p in submissions.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not students:
        raise ValueError(f"{submissions} holds no student folder")
    if jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {jobs}")
    reference = check_reference(Path(reference))
    read = {p: read_submission(p, reference) for p in students}       # read only: nothing runs yet
    names = _unique_names(read[p].name for p in students)
    written = {e for submission in read.values() for e in submission.bodies}
    # a class smaller than the jobs: the spare ones run a submission's notebooks and hidden checks side by side
    parallel = max(1, jobs // len(students))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with Grader(reference, limits, exercises, unsafe=unsafe, written=written, parallel=parallel,
                shared_network=shared_network, private=[submissions.resolve(), out.resolve()]) as grader:
        def one(path: Path, name: str) -> dict[str, ExerciseResult]:
            try:
                results = grader.grade(read[path])
            except Exception as e:         # noqa: BLE001 -- one submission never stops the class: it scores 0
                why = f"the grader could not grade this submission ({type(e).__name__}): tell your instructor"
                results = {i: ExerciseResult(i, 0.0, exercise(i).points, [], why) for i in grader.exercise_ids}
            if progress is not None:
                progress(name, results)
            return results

        with ThreadPoolExecutor(max_workers=jobs) as pool:
            graded = dict(zip(names, pool.map(one, students, names), strict=True))
        grader.verify_sources()
    write_reports(graded, out)
    write_hand_grading(graded, out, reference)     # rubric.csv and hand_grading.md for the written questions
    _similarity.write_similarity(read.values(), reference, out, next(iter(graded.values())))
    return graded


def _unique_names(names: Iterable[str]) -> list[str]:
    """The students' names, each once: a second name that reads like an earlier one gets " (2)" and so on."""
    out: list[str] = []
    for name in names:
        unique, k = name, 1
        while unique in out:
            k += 1
            unique = f"{name} ({k})"
        out.append(unique)
    return out
