"""Read a submission's exercise regions (never executing anything): notebooks as .ipynb JSON, package exercises from
the submission's armlab/ sources. A missing file is a blank exercise; a corrupt one is a reason, not a crash."""

from __future__ import annotations

import ast
import json
import os
import re
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

from armlab_course.exercises.markers import ExerciseMarkerError, find_answers, find_regions, is_blank, is_blank_answer
from armlab_course.exercises.registry import EXERCISES, Exercise

__all__ = ["Submission", "read_submission", "strict_file", "MAX_FILE_BYTES", "exercise_file", "regions_of",
           "source_texts", "markdown_texts", "region_problem", "MAX_REGION_CHARS",
           "display_name"]


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


MAX_REGION_CHARS = 256 * 1024   # a region longer than this is refused (a region is a few dozen lines)
# characters no region holds: NUL and the other C0 controls but tab, newline, vertical tab, form feed and carriage
# return; DEL; lone surrogates (JSON may carry them; they cannot be written out as UTF-8)
_BINARY = re.compile(r"[\x00-\x08\x0e-\x1f\x7f\ud800-\udfff]")


def _cell_texts(path: Path, cell_type: str) -> list[str]:
    """The source of each cell of `cell_type` of the notebook at `path`, every shape checked; ValueError naming the
    problem for a notebook that is not nbformat-4 JSON of the right shapes (nested too deeply, not UTF-8, `cells`
    not a list, a cell not an object, a `source` neither a string nor a list of strings)."""
    try:
        nb = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as e:
        raise ValueError(f"{path.name} is not UTF-8 text (byte {e.start})") from None
    except RecursionError:
        raise ValueError(f"{path.name} is JSON nested too deeply to be a notebook") from None
    except json.JSONDecodeError as e:
        raise ValueError(f"{path.name} is not a readable notebook (not JSON: {e})") from None
    if not isinstance(nb, dict) or not isinstance(nb.get("cells"), list):
        raise ValueError(f"{path.name} is not a readable notebook (no list of cells)")
    texts = []
    for k, cell in enumerate(nb["cells"]):
        if not isinstance(cell, dict):
            raise ValueError(f"{path.name} is not a readable notebook (cell {k} is a {type(cell).__name__}, not "
                             f"an object)")
        if cell.get("cell_type") != cell_type:
            continue
        source = cell.get("source")
        if isinstance(source, list) and all(isinstance(line, str) for line in source):
            source = "".join(source)
        if not isinstance(source, str):
            raise ValueError(f"{path.name} is not a readable notebook (the source of cell {k} is a "
                             f"{type(source).__name__}, not text)")
        texts.append(source)
    return texts


def markdown_texts(path: Path) -> list[str]:
    """Each markdown cell's source of a notebook (ValueError naming the problem for one that is not nbformat-4
    JSON)."""
    return _cell_texts(path, "markdown")


def source_texts(path: Path) -> list[str]:
    """The texts holding regions: the file's text, or each code cell's source of a notebook (ValueError naming the
    problem for a file that is not UTF-8 or a notebook that is not nbformat-4 JSON)."""
    if path.suffix != ".ipynb":
        try:
            return [path.read_bytes().decode("utf-8")]
        except UnicodeDecodeError as e:
            raise ValueError(f"{path.name} is not UTF-8 text (byte {e.start})") from None
    return _cell_texts(path, "code")


def region_problem(body: str) -> str:
    """Why a region's body cannot be graded ('' when it can): too long, or binary characters."""
    if len(body) > MAX_REGION_CHARS:
        return f"a region is longer than {MAX_REGION_CHARS // 1024} KB of text"
    found = _BINARY.search(body)
    if found:
        return (f"a region holds the character {found.group()!r} (code {ord(found.group())}), which is not "
                f"program text")
    try:                       # Python's own parser: what a kernel cannot compile either need not run
        ast.parse(textwrap.dedent(body))
    except (RecursionError, MemoryError):
        return "a region is nested too deeply for Python's parser"
    except (SyntaxError, ValueError):
        pass                   # a syntax error is the student's to see, in the notebook's run
    return ""


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
    except (ExerciseMarkerError, ValueError, OSError) as e:
        sub.problems[ex.id] = f"the answer markers of {name} are damaged: {e}"
        return
    if is_blank_answer(ex.id, answer):
        sub.blank.add(ex.id)
    elif len(answer) > MAX_REGION_CHARS:
        sub.problems[ex.id] = f"the answer to {ex.id} is longer than {MAX_REGION_CHARS // 1024} KB of text"
    else:
        sub.answers[ex.id] = answer


def _read_regions(sub: Submission, ex: Exercise, texts: list[str], name: str, expected: int) -> None:
    """The student's regions of a code exercise into `sub` (bodies, blank, or the problem that stops them)."""
    try:
        bodies = regions_of(texts, ex.id, name)
    except ExerciseMarkerError as e:
        sub.problems[ex.id] = f"the exercise markers of {name} are damaged: {e}"
        return
    if len(bodies) != expected:
        sub.problems[ex.id] = (f"{name} holds {len(bodies)} region(s) of {ex.id}, the exercise has {expected}: "
                               f"keep the '# BEGIN SOLUTION {ex.id}' and '# END SOLUTION' lines")
        return
    problem = next((p for p in map(region_problem, bodies) if p), "")
    if problem:
        sub.problems[ex.id] = f"{name}: {problem}: the region is not graded"
    elif all(is_blank(f"# BEGIN SOLUTION {ex.id}\n{b}\n# END SOLUTION\n", ex.id) for b in bodies):
        sub.blank.add(ex.id)
    else:
        sub.bodies[ex.id] = bodies


def _file_texts(folder: Path, name: str) -> list[str] | str | None:
    """The texts of the submitted file `name` (see source_texts), None when it is absent, or why it cannot be
    read."""
    try:
        path = strict_file(folder, name)
        return source_texts(path) if path is not None else None
    except (ValueError, OSError) as e:
        return str(e)


def read_submission(folder: Path | str, reference: Path | str) -> Submission:
    """The regions of every registered exercise in the submission `folder`, checked against the number of regions
    of the instructor's checkout `reference`. Never raises for what the folder holds: each exercise whose file or
    regions cannot be read gets the reason in `problems`."""
    folder, reference = Path(folder), Path(reference)
    sub = Submission(display_name(folder.name))
    cache: dict[str, list[str] | str | None] = {}
    reference_texts: dict[str, list[str]] = {}
    for ex in EXERCISES:
        name = exercise_file(ex)
        if name not in cache:
            cache[name] = _file_texts(folder, name)
        texts = cache[name]
        try:
            if texts is None:
                sub.blank.add(ex.id)
            elif isinstance(texts, str):
                sub.problems[ex.id] = texts
            elif ex.kind == "written":
                _read_answer(sub, ex, folder / name, name)
            else:
                if name not in reference_texts:
                    reference_texts[name] = source_texts(reference / name)
                _read_regions(sub, ex, texts, name, len(regions_of(reference_texts[name], ex.id, name)))
        except (RecursionError, MemoryError) as e:
            sub.problems[ex.id] = f"{name} could not be read ({type(e).__name__}): the region is not graded"
    return sub


def display_name(name: str) -> str:
    """A folder name as text that prints and encodes: bytes that are not UTF-8 as \\xNN, control characters as
    \\xNN."""
    text = os.fsencode(name).decode("utf-8", errors="backslashreplace")
    return "".join(c if c.isprintable() else f"\\x{ord(c):02x}" if ord(c) < 256 else f"\\u{ord(c):04x}"
                   for c in text)
