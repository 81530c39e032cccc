"""The student's self-check (`python -m armlab check`): the public CHECK cells of every exercise, run in a copy of
the student's own checkout (their notebooks hold no stored outputs, so a check cell passes when its asserts do),
printed as the feedback's per-exercise table. No hidden checks."""

from __future__ import annotations

import tempfile
from pathlib import Path

from armlab.exercises.registry import EXERCISES

from .grade import CheckResult, ExerciseResult, _score
from .run import DEFAULT_LIMITS, Limits, check_cells, run_notebook
from .splice import build_worktree
from .submission import read_submission

__all__ = ["self_check"]


def self_check(checkout: Path | str = ".", limits: Limits = DEFAULT_LIMITS) -> dict[str, ExerciseResult]:
    """Run the notebooks of `checkout` that teach an exercise and score each exercise by its CHECK cells."""
    checkout = Path(checkout).resolve()
    sub = read_submission(checkout, checkout)
    results: dict[str, ExerciseResult] = {}
    notebooks = sorted({e.notebook for e in EXERCISES if e.id not in sub.blank and e.id not in sub.problems})
    runs = {}
    with tempfile.TemporaryDirectory(prefix="armlab-check-") as tmp:
        tree = build_worktree(checkout, Path(tmp) / "work")
        for name in notebooks:
            path = f"notebooks/{name}.ipynb"
            runs[name] = (check_cells(tree / path), run_notebook(tree, path, limits, lax=True))
    for ex in EXERCISES:
        if ex.id in sub.problems or ex.id in sub.blank:
            reason = sub.problems.get(ex.id, "not written (blank region)")
            results[ex.id] = ExerciseResult(ex.id, 0.0, ex.points, [], reason)
            continue
        tags, run = runs[ex.notebook]
        checks = [CheckResult(f"{ex.notebook} cell {i}", i in run.cells and run.cells[i].passed,
                              run.cells[i].message if i in run.cells else run.problem or "the cell did not run")
                  for i, ids in tags.items() if ex.id in ids]
        results[ex.id] = _score(ex.id, checks, run.problem)
    return results
