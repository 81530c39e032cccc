"""The public checks as the grader and the self-check both run them (one path, so one verdict): an exercise's
notebook as the release holds it (its regions stubs, its CHECK cells with the instructor's stored outputs:
public_notebook), the student's region bodies spliced in, cut to the cells its CHECK cells need
(armlab_course.grading.slicing), run under strict nbval by the grader's Runner; each CHECK cell's result labelled
as JupyterLab shows it, with no path of the machine that ran it."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from armlab_course.exercises.registry import exercise

from .results import CheckResult
from .run import NotebookRun, Runner, check_cells, code_cell_labels, with_cell_labels
from .sandbox import WORK
from .slicing import slice_notebook

__all__ = ["run_public", "public_results", "redacted"]


def run_public(runner: Runner, run_tree: Path, name: str, exercise_ids: Iterable[str]) -> NotebookRun:
    """Run notebook `name` of `run_tree` (a run's own copy: its notebook is rewritten) for the public checks of
    `exercise_ids`: only the cells their CHECK cells need (slicing.slice_notebook), under the runner's nbval."""
    path = f"notebooks/{name}.ipynb"
    slice_notebook(run_tree / path, exercise_ids)
    return runner.notebook(run_tree, path)


def redacted(message: str, paths: dict[str, str]) -> str:
    """`message` with each of `paths` (a path -> the name shown instead) and the sandbox's work folder (WORK ->
    '<work>') replaced."""
    for path, shown in [*paths.items(), (WORK, "<work>")]:
        message = message.replace(path, shown)
    return message


def public_results(exercise_id: str, run: NotebookRun, tree: Path, paths: dict[str, str]) -> list[CheckResult]:
    """The exercise's public CHECK cells in the run `run` of its notebook in `tree` (the tree it was copied from,
    before slicing: the labels are the whole notebook's), their messages redacted(paths)."""
    notebook = tree / f"notebooks/{exercise(exercise_id).notebook}.ipynb"
    tags = [i for i, ids in check_cells(notebook).items() if exercise_id in ids]
    labels = code_cell_labels(notebook)
    return [CheckResult(labels[i], i in run.cells and run.cells[i].passed,
                        redacted(with_cell_labels(run.cells[i].message, notebook, labels) if i in run.cells
                                 else run.problem or "the cell did not run", paths), i) for i in tags]
