"""The student's self-check (`python -m armlab check`): the public CHECK cells of every written exercise, run in a
sandboxed copy of the student's own checkout (the same sandbox and runner as the grader; their notebooks hold no
stored outputs, so a check cell passes when its asserts do). No hidden checks: those are the instructor's.

Each exercise is scored by its own CHECK cells. A check cell of exercise B that fails while an exercise A it uses (B's
region or check cell names A's function) fails too is reported as "not checked: it needs A, which fails" instead
of being charged to B: the student's checkout has no reference to isolate B with, so the self-check says what it
cannot know."""

from __future__ import annotations

import json
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

from armlab_course.exercises.registry import EXERCISES, Exercise

from .results import CheckResult, ExerciseResult, score_exercise
from .run import DEFAULT_LIMITS, Limits, Runner, check_cells
from .sandbox import detect
from .splice import build_worktree
from .submission import read_submission

__all__ = ["SelfCheck", "self_check", "missing_tools", "is_blank_result"]


@dataclass
class SelfCheck:
    """results: per exercise; blocked: exercise id -> (the exercise it needs, "fails" or "is not written yet")."""

    results: dict[str, ExerciseResult]
    blocked: dict[str, tuple[str, str]]

    @property
    def ok(self) -> bool:
        """Every written exercise passes every check, or fails only because one it needs is not written yet (blank
        ones are counted, not failed; written answers are graded by hand)."""
        return all(r.score == r.max_score for e, r in self.results.items()
                   if not is_blank_result(r) and not r.by_hand and self.blocked.get(e, ("", ""))[1] != "is not written"
                   " yet")


def is_blank_result(result: ExerciseResult) -> bool:
    """The exercise was not written (its region is still the stub)."""
    return not result.checks and result.reason == "not written (blank region)"


def missing_tools() -> list[str]:
    """What the self-check needs and this Python lacks (pytest, nbval, ipykernel), by package name."""
    import importlib.util

    return [name for name in ("pytest", "nbval", "ipykernel") if importlib.util.find_spec(name) is None]


def _uses(ex: Exercise, text: str) -> bool:
    names = {f.rsplit(".", 1)[-1] for f in ex.functions}
    return any(re.search(rf"\b{re.escape(n)}\b", text) for n in names)


def self_check(checkout: Path | str = ".", limits: Limits = DEFAULT_LIMITS, unsafe: bool = False) -> SelfCheck:
    """Run the notebooks of `checkout` that teach a written exercise and score each exercise by its CHECK cells."""
    checkout = Path(checkout).resolve()
    sub = read_submission(checkout, checkout)
    results: dict[str, ExerciseResult] = {}
    written = [e for e in EXERCISES if e.id not in sub.blank and e.id not in sub.problems and e.kind != "written"]
    notebooks = sorted({e.notebook for e in written})
    runs, sources = {}, {}
    runner = Runner(detect(unsafe), limits)
    try:
        with tempfile.TemporaryDirectory(prefix="armlab-check-") as tmp:
            tree = build_worktree(checkout, Path(tmp) / "work")
            for name in notebooks:
                path = f"notebooks/{name}.ipynb"
                code = [c for c in json.loads((tree / path).read_text())["cells"] if c["cell_type"] == "code"]
                sources[name] = ["".join(c["source"]) for c in code]
                runs[name] = (check_cells(tree / path), runner.notebook(tree, path, lax=True))
    finally:
        runner.close()
    for ex in EXERCISES:
        if ex.kind == "written" and ex.id in sub.answers:
            results[ex.id] = ExerciseResult(ex.id, 0.0, ex.points, [], "graded by hand", sub.answers[ex.id])
            continue
        if ex.id in sub.problems or ex.id in sub.blank:
            reason = sub.problems.get(ex.id, "not written (blank region)")
            results[ex.id] = ExerciseResult(ex.id, 0.0, ex.points, [], reason)
            continue
        tags, run = runs[ex.notebook]
        checks = [CheckResult(f"{ex.notebook} cell {i}", i in run.cells and run.cells[i].passed,
                              run.cells[i].message if i in run.cells else run.problem or "the cell did not run")
                  for i, ids in tags.items() if ex.id in ids]
        results[ex.id] = score_exercise(ex.id, checks, run.problem)
    blocked: dict[str, tuple[str, str]] = {}
    failing = [e for e in written if results[e.id].score < results[e.id].max_score]
    for ex in failing:
        text = "\n".join(sub.bodies.get(ex.id, [])) + "\n".join(
            sources[ex.notebook][int(c.name.rsplit(" ", 1)[-1])] for c in results[ex.id].checks if not c.passed)
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
