"""Find a submission's release files wherever they are in a Gradescope upload.

Students upload what they have: the files dragged in flat, one folder holding them, or the whole student release.
The grader reads the release's layout (notebooks/NN_name.ipynb, armlab/...py), so each file the release names is
looked for by its name anywhere in the upload: the file whose path ends with most of the release's path wins (so
armlab/kinematics.py beats benchmarks/kinematics.py in a whole-release upload, and a flat kinematics.py is found
too); two equally good files of one name are refused, naming both. The files found are staged in the release's
layout for armlab_course.grading.submission.read_submission, which reads them strictly (a symbolic link stays a
symbolic link there, and is refused there with its reason).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from armlab_course.exercises.registry import EXERCISES

from .submission import exercise_file

__all__ = ["Found", "release_names", "find_release_files", "stage", "refusal", "SKIPPED_FOLDERS"]

SKIPPED_FOLDERS = frozenset({"__MACOSX", ".ipynb_checkpoints", ".git", "__pycache__"})   # never a student's copy


@dataclass
class Found:
    """files: per release name (e.g. "notebooks/02_forward_kinematics.ipynb") the upload-relative path that holds
    it; links: upload-relative symbolic links to folders standing where a release folder should be (staged as they
    are, so the reader refuses them); ambiguous: per release name, the equally good upload-relative paths."""

    files: dict[str, PurePosixPath] = field(default_factory=dict)
    links: set[PurePosixPath] = field(default_factory=set)
    ambiguous: dict[str, list[PurePosixPath]] = field(default_factory=dict)


def release_names() -> list[str]:
    """The release-relative files a student edits (every exercise's notebook or package source), sorted."""
    return sorted({exercise_file(ex) for ex in EXERCISES})


def _upload_files(upload: Path) -> list[PurePosixPath]:
    """Every file (and symbolic link to a file) under `upload`, upload-relative; symbolically linked folders are not
    entered, SKIPPED_FOLDERS are skipped."""
    found = []
    for here, folders, files in os.walk(upload, followlinks=False):
        folders[:] = sorted(f for f in folders if f not in SKIPPED_FOLDERS)
        rel = PurePosixPath(Path(here).relative_to(upload).as_posix())
        found += [rel / f for f in sorted(files)]
    return found


def _shared_tail(path: PurePosixPath, name: PurePosixPath) -> int:
    """How many trailing parts of `path` equal those of `name` (0: not even the file name)."""
    n = 0
    for a, b in zip(reversed(path.parts), reversed(name.parts)):
        if a != b:
            break
        n += 1
    return n


def _linked_folder(upload: Path, name: PurePosixPath) -> PurePosixPath | None:
    """The folder on `name`'s release path in the upload that is a symbolic link, if one is."""
    path = upload
    for part in name.parts[:-1]:
        path = path / part
        if path.is_symlink():
            return PurePosixPath(path.relative_to(upload).as_posix())
        if not path.is_dir():
            return None
    return None


def find_release_files(upload: Path | str, names: list[str] | None = None) -> Found:
    """Where each of `names` (default: release_names()) is in the folder `upload` (read only)."""
    upload = Path(upload)
    files = _upload_files(upload)
    found = Found()
    for text in names if names is not None else release_names():
        name = PurePosixPath(text)
        link = _linked_folder(upload, name)
        if link is not None:                        # the release's own place, through a link: the reader says no
            found.links.add(link)
            found.files[text] = name
            continue
        scored = [(_shared_tail(f, name), f) for f in files if f.name == name.name]
        best = max((s for s, _ in scored), default=0)
        winners = [f for s, f in scored if s == best and best > 0]
        if len(winners) == 1:
            found.files[text] = winners[0]
        elif winners:
            found.ambiguous[text] = winners
    return found


def refusal(found: Found, names: list[str] | None = None) -> str | None:
    """Why the upload cannot be graded (None when it can): two equally good files of one name, or no release file
    at all (the message says what to upload)."""
    if found.ambiguous:
        clashes = "; ".join(f"{PurePosixPath(n).name} at " + " and ".join(str(p) for p in paths)
                            for n, paths in sorted(found.ambiguous.items()))
        return (f"refused: the upload holds more than one file of one name ({clashes}); the grader cannot tell "
                f"which is your work: upload one copy of each file")
    if not found.files:
        wanted = [PurePosixPath(n).name for n in (names if names is not None else release_names())]
        return ("no release files found: upload your notebooks and the package files you edited, flat or in their "
                f"folders, by their release names ({', '.join(wanted)})")
    return None


def stage(upload: Path | str, found: Found, into: Path | str) -> Path:
    """Put the files found into the new folder `into` in the release's layout (hard links where the file system
    allows, else copies; symbolic links stay links); returns `into`."""
    upload, into = Path(upload), Path(into)
    into.mkdir()
    for link in sorted(found.links):
        (into / link).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(os.readlink(upload / link), into / link)
    for name, rel in sorted(found.files.items()):
        src, dst = upload / rel, into / name
        if any(PurePosixPath(name).is_relative_to(link) for link in found.links):
            continue
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_symlink():
            os.symlink(os.readlink(src), dst)
            continue
        try:
            os.link(src, dst)
        except OSError:
            shutil.copyfile(src, dst)
    return into
