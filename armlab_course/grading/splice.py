"""Build a grading work tree: the instructor's tracked files with exactly one exercise's regions replaced by the
student's region bodies (every other region stays the reference). Only region bodies are taken from a submission,
never a cell, a check, a conftest or a configuration file, and a body may not carry cell or exercise markers."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

from armlab_course.exercises.markers import find_regions
from armlab_course.exercises.registry import exercise

from .submission import exercise_file

__all__ = ["RegionRejected", "tracked_files", "check_body", "splice_text", "write_regions", "build_worktree",
           "splice_into", "GRADER_ONLY", "release_worktree"]

# nbval's comment markers, the kit's check tags and exercise markers: a student body may hold none of them. A line
# is a marker the way nbval reads one (nbval.plugin.find_comment_markers: the stripped line starts with '#', and
# lstrip('#').strip() is the marker), so any number of '#' counts.
_FORBIDDEN = re.compile(r"^\s*#+\s*(NBVAL_\w*|CHECK\b|BEGIN SOLUTION|END SOLUTION|PYTEST_VALIDATE_IGNORE_OUTPUT)")
# the grader's own files: never copied into a work tree that student code sees
GRADER_ONLY = ("armlab_course/grading/hidden.py", "armlab_course/grading/hidden/")


class RegionRejected(ValueError):
    """A student region that may not be spliced (it carries a marker that would change how cells are checked)."""


def tracked_files(reference: Path) -> list[str]:
    """The instructor checkout's tracked files (`git ls-files`), or every file under it outside .git/.venv."""
    try:
        out = subprocess.run(["git", "-C", str(reference), "ls-files", "-z"], capture_output=True, check=True)
        names = [n for n in out.stdout.decode().split("\0") if n]
        if names:
            return names
    except (OSError, subprocess.CalledProcessError):
        pass
    skip = {".git", ".venv", "__pycache__"}
    return [p.relative_to(reference).as_posix() for p in reference.rglob("*")
            if p.is_file() and not skip & set(p.relative_to(reference).parts)]


def check_body(body: str, exercise_id: str) -> None:
    """RegionRejected naming the line when a student body holds an nbval marker, a CHECK tag or an exercise
    marker."""
    # line by line as str.splitlines() splits them (what splicing and nbval do): a form feed, a lone carriage return
    # or U+2028 starts a line there too, so a marker cannot hide behind one
    for line in body.splitlines():
        if _FORBIDDEN.match(line):
            raise RegionRejected(f"the region of {exercise_id} holds the marker line {line.strip()!r}: markers and "
                                 f"tags are not allowed inside an exercise region")


def splice_text(text: str, exercise_id: str, bodies: list[str], start: int, where: str) -> tuple[str, int]:
    """`text` with its regions of `exercise_id` (the start-th onwards, in order) replaced by `bodies`; returns the
    new text and how many bodies were used."""
    lines = text.splitlines()
    out, last, used = [], 0, 0
    for region in find_regions(text, where):
        if region.exercise_id != exercise_id:
            continue
        out += lines[last:region.begin + 1]
        out += bodies[start + used].splitlines()
        last, used = region.end, used + 1
    out += lines[last:]
    return "\n".join(out) + ("\n" if text.endswith("\n") else ""), used


def write_regions(folder: Path, exercise_id: str, bodies: list[str]) -> None:
    """Put `bodies` into the regions of an exercise in a submission folder's copy of its file (a notebook's code
    cells or a package source), as a student edits their release copy (tests and benchmarks build classes so)."""
    name = exercise_file(exercise(exercise_id))
    path = Path(folder) / name
    if name.endswith(".ipynb"):
        nb = json.loads(path.read_text())
        used = 0
        for cell in nb["cells"]:
            if cell["cell_type"] == "code":
                new, n = splice_text("".join(cell["source"]), exercise_id, bodies, used, name)
                cell["source"], used = new.splitlines(keepends=True), used + n
        path.write_text(json.dumps(nb, indent=1))
    else:
        path.write_text(splice_text(path.read_text(), exercise_id, bodies, 0, name)[0])


def build_worktree(reference: Path, dest: Path, exercise_id: str | None = None,
                   bodies: list[str] | None = None) -> Path:
    """Copy the instructor's tracked files into the new folder `dest` and splice `bodies` into the regions of
    `exercise_id` (None: the reference as it is). RegionRejected for a body with markers."""
    for body in bodies or []:
        check_body(body, exercise_id or "?")
    for name in tracked_files(reference):
        src = reference / name
        if not src.is_file() or src.is_symlink() or name.startswith(GRADER_ONLY):
            continue
        target = dest / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, target)
    if exercise_id is not None:
        splice_into(dest, exercise_id, bodies or [])
    return dest


def release_worktree(instructor: Path, dest: Path) -> Path:
    """The student release of `instructor` (a private copy of the instructor's tracked files, as build_worktree makes
    it; a git index is made in it when it has none) written into the new folder `dest` by the release builder
    (armlab_course.exercises.release: every region a stub, no instructor-only file), its notebooks those the public
    checks run (release.public_notebook: the CHECK cells as the instructor ran them, each judged by its asserts,
    not by what it prints), which the release also ships for the self-check (PUBLIC_NOTEBOOKS)."""
    from armlab_course.exercises.release import PUBLIC_NOTEBOOKS, make_student_release

    if not (instructor / ".git").exists():
        for cmd in (["init", "-q"], ["add", "-A"]):
            subprocess.run(["git", "-C", str(instructor), *cmd], capture_output=True, check=True)
    make_student_release(instructor, dest)
    for public in sorted((dest / PUBLIC_NOTEBOOKS).glob("*.ipynb")):
        shutil.copy2(public, dest / "notebooks" / public.name)
    return dest


def splice_into(tree: Path, exercise_id: str, bodies: list[str]) -> None:
    """Replace the regions of `exercise_id` in the work tree `tree` by `bodies` (RegionRejected for a body with
    markers, or a count of bodies other than the reference's regions)."""
    for body in bodies:
        check_body(body, exercise_id)
    name = exercise_file(exercise(exercise_id))
    path = tree / name
    if name.endswith(".ipynb"):
        nb = json.loads(path.read_text(encoding="utf-8"))
        used = 0
        for cell in nb["cells"]:
            if cell["cell_type"] != "code":
                continue
            text = "".join(cell["source"])
            new, n = splice_text(text, exercise_id, bodies, used, name)
            if n:
                cell["source"] = new.splitlines(keepends=True)
                used += n
        path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    else:
        new, used = splice_text(path.read_text(encoding="utf-8"), exercise_id, bodies, 0, name)
        path.write_text(new, encoding="utf-8")
    if used != len(bodies):
        raise RegionRejected(f"{exercise_id}: {len(bodies)} region(s) submitted, {used} in the reference")
