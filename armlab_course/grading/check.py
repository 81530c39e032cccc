"""The student's self-check (`python -m armlab check [EXERCISE]`): the public CHECK cells of the written exercises,
run as the grader runs them (armlab_course.grading.public: one path): each notebook as the release holds it
(release.PUBLIC_NOTEBOOKS: each CHECK cell judged by its asserts, not by what it prints) with the checkout's regions
spliced in, cut to the cells its check cells need (armlab_course.grading.slicing), run under strict nbval by the
grader's own runner and sandbox (the same nbval plugin, kernel, sanitize file and limits), each message redacted
alike. So the verdict and message of each check cell are the grader's for the same regions; what the student
changed outside the regions of a notebook counts for neither. No hidden checks: those are the instructor's.

Each notebook runs once, for the exercises asked for: a check that builds what it checks (notebook 08's, notebook
02's) runs little besides itself; one that reads what a demonstration built runs that demonstration. Each exercise
is reported as soon as its notebook has run (progress(exercise id, result, status)), as "written" (every check
passes), "failing", "blank" or "by hand".

Each exercise is scored by its own CHECK cells. A check cell of exercise B that fails while an exercise A it uses (B's
region or check cell names A's function) fails too is reported as "not checked: it needs A, which fails" instead
of being charged to B: the student's checkout has no reference to isolate B with, so the self-check says what it
cannot know."""

from __future__ import annotations

import json
import re
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from armlab_course.exercises.registry import EXERCISES, Exercise, exercise
from armlab_course.exercises.release import PUBLIC_NOTEBOOKS, RELEASE_MARKER, public_notebook

from .public import public_results, run_public
from .results import ExerciseResult, score_exercise
from .run import DEFAULT_LIMITS, Limits, Runner
from .sandbox import detect
from .splice import RegionRejected, build_worktree, splice_into
from .submission import read_submission

__all__ = ["SelfCheck", "self_check", "missing_tools", "is_blank_result", "status_of"]


@dataclass
class SelfCheck:
    """results: per exercise; blocked: exercise id -> (the exercise it needs, "fails" or "is not written yet")."""

    results: dict[str, ExerciseResult]
    blocked: dict[str, tuple[str, str]]

    @property
    def ok(self) -> bool:
        """Every exercise checked is written and passes every check (a written answer: answered). A blank one, or
        one waiting for another, is not ok: `python -m armlab check` then exits 1."""
        return all(status_of(r, self.blocked) in ("written", "by hand") for r in self.results.values())


def is_blank_result(result: ExerciseResult) -> bool:
    """The exercise was not written (its region is still the stub)."""
    return not result.checks and result.reason == "not written (blank region)"


def status_of(result: ExerciseResult, blocked: dict[str, tuple[str, str]] | None = None) -> str:
    """"blank", "by hand" (a written answer given), "written" (full points) or "failing"."""
    if is_blank_result(result) or (result.by_hand and not result.answer):
        return "blank"
    if result.by_hand:
        return "by hand"
    if result.score == result.max_score and not (blocked or {}).get(result.exercise_id):
        return "written"
    return "failing"


def _public_copy(checkout: Path, name: str, dest: Path, bodies: dict[str, list[str]]) -> str:
    """Write into `dest` notebook `name` as the grader runs it for `checkout`: the release's public notebook
    (release.PUBLIC_NOTEBOOKS; in the instructor's tree, made from its own notebook by release.public_notebook)
    with the checkout's regions of every written exercise of that notebook spliced in (`bodies`). '' or what
    went wrong."""
    shipped = checkout / PUBLIC_NOTEBOOKS / f"{name}.ipynb"
    instructors = (checkout / "armlab_course/grading/hidden").is_dir() and not (checkout / RELEASE_MARKER).exists()
    if shipped.is_file():
        shutil.copy2(shipped, dest)
    elif instructors:                 # its notebooks hold the stored outputs the release's copies are made from
        own = checkout / f"notebooks/{name}.ipynb"
        nb = public_notebook(json.loads(own.read_text(encoding="utf-8")), f"notebooks/{name}.ipynb")
        dest.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    else:
        return (f"this release has no {PUBLIC_NOTEBOOKS}/{name}.ipynb (the notebook the public checks run, as "
                f"the release holds it): ask for a release made with this version of the kit")
    tree = dest.parents[1]
    for ex in EXERCISES:
        if not ex.in_package and ex.notebook == name and ex.id in bodies:
            try:
                splice_into(tree, ex.id, bodies[ex.id])
            except RegionRejected as e:
                return str(e)
    return ""


def missing_tools() -> list[str]:
    """What the self-check needs and this Python lacks (pytest, nbval, ipykernel), by package name."""
    import importlib.util

    return [name for name in ("pytest", "nbval", "ipykernel") if importlib.util.find_spec(name) is None]


def _uses(ex: Exercise, text: str) -> bool:
    names = {f.rsplit(".", 1)[-1] for f in ex.functions}
    return any(re.search(rf"\b{re.escape(n)}\b", text) for n in names)


def self_check(checkout: Path | str = ".", limits: Limits = DEFAULT_LIMITS, unsafe: bool = False,
               only: str | None = None,
               progress: Callable[[str, ExerciseResult, str], None] | None = None) -> SelfCheck:
    """Run the notebooks of `checkout` that check a written exercise, each up to the last CHECK cell of the exercises
    asked for (`only`: that one exercise id; default every one), and score each exercise by its CHECK cells, calling
    progress(exercise id, result, status) as each is known. KeyError for an unknown id."""
    checkout = Path(checkout).resolve()
    asked = [exercise(only)] if only else list(EXERCISES)
    sub = read_submission(checkout, checkout)
    results: dict[str, ExerciseResult] = {}

    def tell(ex: Exercise, result: ExerciseResult) -> None:
        results[ex.id] = result
        if progress is not None:
            progress(ex.id, result, status_of(result))

    written = [e for e in asked if e.id not in sub.blank and e.id not in sub.problems and e.kind != "written"]
    for ex in asked:
        if ex.kind == "written":
            tell(ex, ExerciseResult(ex.id, 0.0, ex.points, [], "graded by hand" if ex.id in sub.answers else
                                    "not written (blank region)", sub.answers.get(ex.id)))
        elif ex.id in sub.problems or ex.id in sub.blank:
            tell(ex, ExerciseResult(ex.id, 0.0, ex.points, [], sub.problems.get(ex.id, "not written (blank region)")))
    sources: dict[str, list[str]] = {}
    if not written:
        return SelfCheck({e.id: results[e.id] for e in asked}, {})
    runner = Runner(detect(unsafe), limits)
    try:
        with tempfile.TemporaryDirectory(prefix="armlab-check-") as tmp:
            tree = build_worktree(checkout, Path(tmp) / "work")
            whole = Path(tmp) / "whole"           # each notebook before slicing: the labels are the whole one's
            (whole / "notebooks").mkdir(parents=True)
            for name in sorted({e.notebook for e in written}):
                mine = [e for e in written if e.notebook == name]
                notebook = whole / f"notebooks/{name}.ipynb"
                problem = _public_copy(checkout, name, notebook, sub.bodies)
                if problem:
                    for ex in mine:
                        tell(ex, score_exercise(ex.id, [], problem))
                    continue
                shutil.copy2(notebook, tree / f"notebooks/{name}.ipynb")
                sources[name] = ["".join(c["source"]) for c in json.loads(notebook.read_text(encoding="utf-8"))[
                    "cells"] if c["cell_type"] == "code"]
                run = run_public(runner, tree, name, [e.id for e in mine])
                for ex in mine:
                    tell(ex, score_exercise(ex.id, public_results(ex.id, run, whole, {tmp: "<grader>"}),
                                            run.problem))
    finally:
        runner.close()
    results = {e.id: results[e.id] for e in asked}
    blocked: dict[str, tuple[str, str]] = {}
    failing = [e for e in written if results[e.id].score < results[e.id].max_score]
    for ex in failing:
        text = "\n".join(sub.bodies.get(ex.id, [])) + "\n".join(
            sources.get(ex.notebook, [])[c.cell] for c in results[ex.id].checks
            if not c.passed and c.cell is not None and c.cell < len(sources.get(ex.notebook, [])))
        earlier = [a for a in failing if EXERCISES.index(a) < EXERCISES.index(ex)]   # what ex may build on
        needed = next((a for a in earlier if _uses(a, text)), None)
        if needed is not None:
            blocked[ex.id] = (needed.id, "fails")
            continue
        messages = " ".join(c.message for c in results[ex.id].checks if not c.passed)
        missing = next((b for b in sorted(sub.blank) if f"exercise {b} (" in messages), None)
        if missing is not None:
            blocked[ex.id] = (missing, "is not written yet")
    return SelfCheck(results, blocked)
