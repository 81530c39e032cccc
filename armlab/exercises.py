"""Exercise regions and the student release.

The repository is the instructor's version. Code a student writes sits between a `# BEGIN SOLUTION` line and a
`# END SOLUTION` line (same indentation, never nested) in the package and in the notebooks. The student release is
a copy of the repository in which each region's body becomes a stub that still imports and runs up to the point of
use, where it raises NotImplementedError naming the exercise; notebooks lose their outputs.

    python tools/student-release OUT_DIR      # or: make student
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Region", "ExerciseMarkerError", "find_regions", "stub_regions", "student_notebook", "make_student_release"]

_BEGIN = re.compile(r"^(?P<indent>[ \t]*)# BEGIN SOLUTION\s*$")
_END = re.compile(r"^(?P<indent>[ \t]*)# END SOLUTION\s*$")


class ExerciseMarkerError(ValueError):
    """Exercise markers that do not pair up: names the file and line."""


@dataclass(frozen=True)
class Region:
    """One exercise: the lines (0-based, markers included) from begin to end, and the markers' indentation."""

    begin: int
    end: int
    indent: str


def find_regions(text: str, where: str = "<text>") -> list[Region]:
    """The exercise regions of a source text, in order; ExerciseMarkerError for nested, unclosed, unopened, empty or
    differently indented markers (`where` names the file in the message)."""
    regions, open_at, indent = [], None, ""
    for i, line in enumerate(text.splitlines()):
        begin, end = _BEGIN.match(line), _END.match(line)
        if begin:
            if open_at is not None:
                raise ExerciseMarkerError(f"{where}:{i + 1}: BEGIN SOLUTION inside the region opened at line "
                                          f"{open_at + 1}")
            open_at, indent = i, begin["indent"]
        elif end:
            if open_at is None:
                raise ExerciseMarkerError(f"{where}:{i + 1}: END SOLUTION without a BEGIN SOLUTION")
            if end["indent"] != indent:
                raise ExerciseMarkerError(f"{where}:{i + 1}: END SOLUTION indented differently from its BEGIN at "
                                          f"line {open_at + 1}")
            if i == open_at + 1:
                raise ExerciseMarkerError(f"{where}:{i + 1}: empty solution region")
            regions.append(Region(open_at, i, indent))
            open_at = None
    if open_at is not None:
        raise ExerciseMarkerError(f"{where}:{open_at + 1}: BEGIN SOLUTION never closed")
    return regions


def stub_regions(text: str, where: str = "<text>", first: int = 1) -> str:
    """The text with every region's body replaced by one line raising NotImplementedError("exercise N of <where>:
    ..."), numbering the regions from `first`."""
    lines = text.splitlines()
    out, last = [], 0
    for n, region in enumerate(find_regions(text, where), start=first):
        out += lines[last:region.begin + 1]
        out.append(f'{region.indent}raise NotImplementedError("exercise {n} of {where}: write this part")')
        last = region.end
    out += lines[last:]
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")


def student_notebook(nb: dict, where: str) -> dict:
    """A notebook (nbformat 4 JSON) with its exercise regions stubbed and every output and count cleared."""
    nb = json.loads(json.dumps(nb))
    count = 0                                                  # exercises are numbered across the notebook
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        text = "".join(cell["source"])
        n = len(find_regions(text, where))
        if n:
            cell["source"] = stub_regions(text, where, first=count + 1).splitlines(keepends=True)
            count += n
        cell["outputs"], cell["execution_count"] = [], None
    return nb


def make_student_release(repo: Path | str, out: Path | str) -> list[str]:
    """Write the student release of the git checkout `repo` (its tracked files) into the new folder `out`; returns
    the files that hold exercises. Refuses to write into an existing folder."""
    repo, out = Path(repo), Path(out)
    if out.exists():
        raise FileExistsError(f"{out} exists: the student release goes into a new folder")
    files = subprocess.run(["git", "-C", str(repo), "ls-files", "-z"], capture_output=True, check=True
                           ).stdout.decode().split("\0")
    stubbed = []
    for name in filter(None, files):
        src, dst = repo / name, out / name
        if not src.is_file():
            continue
        dst.parent.mkdir(parents=True, exist_ok=True)
        if name.endswith(".ipynb"):
            nb = json.loads(src.read_text())
            new = student_notebook(nb, name)
            dst.write_text(json.dumps(new, indent=1, ensure_ascii=False) + "\n")
            changed = any("BEGIN SOLUTION" in "".join(c["source"]) for c in nb["cells"])
        elif name.endswith(".py") or name.startswith("tools/"):
            text = src.read_text()
            new_text = stub_regions(text, name) if "# BEGIN SOLUTION" in text else text
            dst.write_text(new_text)
            changed = new_text != text
        else:
            shutil.copy2(src, dst)
            changed = False
        if src.stat().st_mode & 0o111:
            dst.chmod(src.stat().st_mode)
        if changed:
            stubbed.append(name)
    return stubbed
