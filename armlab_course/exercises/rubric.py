"""The rubric as students and instructors read it: each exercise's points, kind and state (written or blank), from
the files on disk (what the grader would receive), and the registry as a table or JSON.

    rubric("02_forward_kinematics")    # a notebook's last cell: the student's own table for that notebook
    python -m armlab exercises [--json]
"""

from __future__ import annotations

import json
from pathlib import Path

from .markers import find_answers, find_regions, is_blank, is_blank_answer
from .registry import EXERCISES, Exercise, exercise, of_notebook

__all__ = ["rubric", "rubric_rows", "exercise_state", "solution_lines", "exercises_json", "exercises_table"]

ROOT = Path(__file__).resolve().parents[2]
_HOW = {"code": "hidden inputs", "open": "outcome on hidden seeds", "written": "by hand"}


def _notebook_texts(e: Exercise, root: Path, kind: str) -> list[str] | None:
    """The code (kind "code") or markdown cells of the exercise's notebook, None when it is not there."""
    path = root / "notebooks" / f"{e.notebook}.ipynb"
    if not path.is_file():
        return None
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    return ["".join(c["source"]) for c in cells if c["cell_type"] == kind]


def _texts(e: Exercise, root: Path, kind: str) -> list[str]:
    """Where the exercise lives: its package file, or the notebook's percent-format source in the instructor's
    checkout, else (a student release: no sources) the saved notebook a student edits."""
    source = root / e.where
    if source.is_file():
        return [source.read_text(encoding="utf-8")]
    return _notebook_texts(e, root, kind) or []


def _region_bodies(e: Exercise, root: Path) -> list[list[str]]:
    """The bodies (lines) of the exercise's regions."""
    bodies = []
    for text in _texts(e, root, "code"):
        lines = text.splitlines()
        bodies += [lines[r.begin + 1:r.end] for r in find_regions(text, e.where) if r.exercise_id == e.id]
    return bodies


def _answer(e: Exercise, root: Path) -> str | None:
    answers = find_answers(_texts(e, root, "markdown"), e.where)
    answer = answers.get(e.id)
    if answer is None:
        return None
    return "\n".join(line[2:] if line.startswith("# ") else line.lstrip("#") for line in answer.splitlines())


def solution_lines(e: Exercise | str, root: Path | str = ROOT) -> int:
    """Non-blank, non-comment lines of the exercise's regions (for a written answer: non-blank lines of it); 0 while
    it is blank."""
    e, root = exercise(e) if isinstance(e, str) else e, Path(root)
    if exercise_state(e, root) != "written":
        return 0
    if e.kind == "written":
        answer = _answer(e, root) or ""
        return sum(1 for line in answer.splitlines() if line.strip())
    return sum(1 for body in _region_bodies(e, root) for line in body
               if line.strip() and not line.strip().startswith("#"))


def exercise_state(e: Exercise | str, root: Path | str = ROOT) -> str:
    """"written" or "blank" (or "missing" when its region or answer cell is not in the files)."""
    e, root = exercise(e) if isinstance(e, str) else e, Path(root)
    if e.kind == "written":
        answer = _answer(e, root)
        return "missing" if answer is None else "blank" if is_blank_answer(e.id, answer) else "written"
    bodies = _region_bodies(e, root)
    if not bodies:
        return "missing"
    text = "\n".join(f"# BEGIN SOLUTION {e.id}\n" + "\n".join(b) + "\n# END SOLUTION" for b in bodies)
    return "blank" if is_blank(text, e.id) else "written"


def rubric_rows(notebook: str, root: Path | str = ROOT) -> list[tuple[str, int, str, str, str]]:
    """Per exercise of the notebook (file stem or number): id, points, kind, how it is graded, state."""
    return [(e.id, e.points, e.kind, _HOW[e.kind], exercise_state(e, root)) for e in of_notebook(notebook)]


def _table(head: tuple[str, ...], rows: list[tuple]) -> list[str]:
    cells = [tuple(str(c) for c in r) for r in rows]
    widths = [max(len(r[i]) for r in [head, *cells]) for i in range(len(head))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in [head, *cells]]


def rubric(notebook: str, root: Path | str = ROOT) -> None:
    """Print the notebook's exercises as the student's own table: points, kind, how graded, written or blank (from
    the saved files: save the notebook first). `python -m armlab check` runs the checks themselves."""
    rows = rubric_rows(notebook, root)
    if not rows:
        print(f"notebook {notebook}: no exercises")
        return
    lines = _table(("exercise", "points", "kind", "graded on", "state"), rows)
    done = sum(p for _, p, _, _, s in rows if s == "written")
    lines.append(f"{len(rows)} exercises, {sum(r[1] for r in rows)} points; {done} points' worth written "
                 f"(the grader decides the score)")
    print("\n".join(lines))


def exercises_json(root: Path | str = ROOT) -> list[dict]:
    """Every exercise: id, title, points, notebook, kind, where, functions, hidden, solution_lines."""
    return [{"id": e.id, "title": e.title, "points": e.points, "notebook": e.notebook, "kind": e.kind,
             "where": e.where, "functions": list(e.functions), "hidden": e.hidden,
             "solution_lines": solution_lines(e, root)} for e in EXERCISES]


def exercises_table() -> str:
    """The registry as a text table: id, points, kind, notebook, where, what to write."""
    rows = [(e.id, e.points, e.kind, e.notebook_number, e.where if e.in_package else "notebook", e.title)
            for e in EXERCISES]
    lines = _table(("exercise", "points", "kind", "nb", "where", "what"), rows)
    lines.append(f"{len(EXERCISES)} exercises, {sum(e.points for e in EXERCISES)} points")
    return "\n".join(lines)
