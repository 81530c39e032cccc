"""Read a submission's exercise regions (never executing anything): notebooks as .ipynb JSON, package exercises from
the submission's armlab/ sources. A missing file is a blank exercise; a corrupt one is a reason, not a crash."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from armlab_course.exercises.markers import ExerciseMarkerError, find_answers, find_regions, is_blank, is_blank_answer
from armlab_course.exercises.registry import EXERCISES, Exercise

__all__ = ["Submission", "read_submission", "strict_file", "MAX_FILE_BYTES", "exercise_file", "regions_of",
           "source_texts", "markdown_texts"]


@dataclass
class Submission:
    """name: the student (the submission folder's name); bodies: per exercise id, the body text of each of its
    regions in file order (markers excluded); answers: per written exercise (kind "written"), the student's answer;
    blank: exercise ids not written yet; problems: per exercise id, why its regions could not be read."""

    name: str
    bodies: dict[str, list[str]] = field(default_factory=dict)
    answers: dict[str, str] = field(default_factory=dict)
    blank: set[str] = field(default_factory=set)
    problems: dict[str, str] = field(default_factory=dict)


def exercise_file(ex: Exercise) -> str:
    """The repository-relative file a student edits for the exercise: the package source, or the notebook."""
    return ex.where if ex.in_package else f"notebooks/{ex.notebook}.ipynb"


def markdown_texts(path: Path) -> list[str]:
    """Each markdown cell's source of a notebook (ValueError naming the problem for one that is not nbformat-4
    JSON)."""
    try:
        cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
        return ["".join(c["source"]) if isinstance(c["source"], list) else c["source"]
                for c in cells if c.get("cell_type") == "markdown"]
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError) as e:
        raise ValueError(f"{path.name} is not a readable notebook ({type(e).__name__}: {e})") from None


def source_texts(path: Path) -> list[str]:
    """The texts holding regions: the file's text, or each code cell's source of a notebook (ValueError naming the
    problem for a notebook that is not nbformat-4 JSON)."""
    if path.suffix != ".ipynb":
        return [path.read_text(encoding="utf-8")]
    try:
        nb = json.loads(path.read_text(encoding="utf-8"))
        cells = nb["cells"]
        return ["".join(c["source"]) if isinstance(c["source"], list) else c["source"]
                for c in cells if c.get("cell_type") == "code"]
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError) as e:
        raise ValueError(f"{path.name} is not a readable notebook ({type(e).__name__}: {e})") from None


def regions_of(texts: list[str], exercise_id: str, where: str) -> list[str]:
    """The body (the lines between the markers, joined with newlines) of each region of `exercise_id` in `texts`."""
    bodies = []
    for text in texts:
        lines = text.splitlines()
        bodies += ["\n".join(lines[r.begin + 1:r.end]) for r in find_regions(text, where)
                   if r.exercise_id == exercise_id]
    return bodies


MAX_FILE_BYTES = 64 * 2**20     # a submitted file larger than this is refused unread


def strict_file(folder: Path, name: str) -> Path | None:
    """The submitted file `name` of `folder`, read strictly: None when it is absent; ValueError naming the problem
    when the folder, a folder on the way or the file is a symbolic link, or the file is not a regular file or is
    too large."""
    if folder.is_symlink():
        raise ValueError(f"the submission folder {folder.name} is a symbolic link: submit the folder itself")
    path = folder
    for part in Path(name).parts:
        path = path / part
        if path.is_symlink():
            raise ValueError(f"{path.relative_to(folder)} is a symbolic link: submit the file itself")
        if not path.exists():
            return None
    if not path.is_file():
        raise ValueError(f"{name} is not a regular file")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise ValueError(f"{name} is larger than {MAX_FILE_BYTES // 2**20} MB")
    return path


def _read_answer(sub: Submission, ex: Exercise, path: Path, name: str) -> None:
    """The student's answer to a written exercise (blank when missing or still the release's prompt)."""
    try:
        answer = find_answers(markdown_texts(path), name).get(ex.id, "")
    except (ExerciseMarkerError, ValueError) as e:
        sub.problems[ex.id] = f"the answer markers of {name} are damaged: {e}"
        return
    if is_blank_answer(ex.id, answer):
        sub.blank.add(ex.id)
    else:
        sub.answers[ex.id] = answer


def read_submission(folder: Path | str, reference: Path | str) -> Submission:
    """The regions of every registered exercise in the submission `folder`, checked against the number of regions
    of the instructor's checkout `reference`."""
    folder, reference = Path(folder), Path(reference)
    sub = Submission(folder.name)
    cache: dict[str, list[str] | str] = {}
    for ex in EXERCISES:
        name = exercise_file(ex)
        if name not in cache:
            try:
                path = strict_file(folder, name)
                cache[name] = source_texts(path) if path is not None else "missing"
            except (ValueError, OSError) as e:
                cache[name] = str(e)
        texts = cache[name]
        if texts == "missing":
            sub.blank.add(ex.id)
            continue
        if isinstance(texts, str):
            sub.problems[ex.id] = texts
            continue
        if ex.kind == "written":
            _read_answer(sub, ex, folder / name, name)
            continue
        try:
            bodies = regions_of(texts, ex.id, name)
        except ExerciseMarkerError as e:
            sub.problems[ex.id] = f"the exercise markers of {name} are damaged: {e}"
            continue
        expected = len(regions_of(source_texts(reference / name), ex.id, name))
        if len(bodies) != expected:
            sub.problems[ex.id] = (f"{name} holds {len(bodies)} region(s) of {ex.id}, the exercise has {expected}: "
                                   f"keep the '# BEGIN SOLUTION {ex.id}' and '# END SOLUTION' lines")
            continue
        if all(is_blank(f"# BEGIN SOLUTION {ex.id}\n{b}\n# END SOLUTION\n", ex.id) for b in bodies):
            sub.blank.add(ex.id)
        else:
            sub.bodies[ex.id] = bodies
    return sub
