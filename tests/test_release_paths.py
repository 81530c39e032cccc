"""The student release is true about itself (issue 34: its .student-release said to run `make check`, which did not
exist; its Makefile kept targets whose tools it does not ship; notebooks cited reference/lab.md and
benchmarks/perception.py, which neither the release nor the repository has).

A freshly built release: its Makefile has `make check` (the self-check) and none of the instructor's targets; every
`make X` its README, marker file and notebooks name is a target of it; every file a recipe runs is in it; every
repository path its README, Makefile, notebooks and the docs they link to cite is in it.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

from armlab_course.exercises import make_student_release
from armlab_course.exercises.release import RELEASE_MARKER

ROOT = Path(__file__).resolve().parents[1]
INSTRUCTOR_TARGETS = {"notebooks", "bench", "exercise-docs", "student", "autograder"}
TOP = ("armlab", "armlab_course", "notebooks", "tests", "tools", "benchmarks", "docs", "reference", "binder")
CITED = re.compile(rf"(?<![\w/.-])((?:{'|'.join(TOP)})/[\w./-]*[\w/])")
LINK = re.compile(r"\]\(([^)#:\s]+)(?:#[^)]*)?\)")
MAKE = re.compile(r"`make ([a-z][\w-]*)`")


@pytest.fixture(scope="module")
def release(tmp_path_factory) -> Path:
    if not (ROOT / ".git").exists():
        pytest.skip("builds the release from the instructor's git checkout")
    out = tmp_path_factory.mktemp("paths") / "student"
    make_student_release(ROOT, out)
    return out


def targets(makefile: Path) -> set[str]:
    return set(re.findall(r"^([A-Za-z][\w.-]*):(?!=)", makefile.read_text(), re.MULTILINE))


def texts(release: Path) -> dict[str, str]:
    """What a student reads: the README, the marker file, the Makefile, every notebook's cells (markdown and code)
    and the docs the README or a notebook links to."""
    out = {name: (release / name).read_text() for name in ("README.md", RELEASE_MARKER, "Makefile")}
    for path in sorted((release / "notebooks").glob("*.ipynb")):
        out[f"notebooks/{path.name}"] = "\n".join("".join(c["source"]) for c in json.loads(path.read_text())["cells"])
    linked = {m for text in list(out.values()) for m in CITED.findall(text) if re.fullmatch(r"docs/[\w.-]+\.md", m)}
    for name in sorted(linked):
        if (release / name).is_file():
            out[name] = (release / name).read_text()
    return out


def test_the_release_makefile_has_check_and_no_instructor_targets(release):
    mine, theirs = targets(release / "Makefile"), targets(ROOT / "Makefile")
    assert INSTRUCTOR_TARGETS <= theirs, sorted(theirs)             # the instructor keeps them
    assert "check" in mine and not mine & INSTRUCTOR_TARGETS, sorted(mine)
    assert "INSTRUCTOR ONLY" not in (release / "Makefile").read_text()
    dry = subprocess.run(["make", "-n", "check"], cwd=release, capture_output=True, text=True, timeout=60)
    assert dry.returncode == 0 and "-m armlab check" in dry.stdout, dry.stdout + dry.stderr
    ran = set(re.findall(r"(?:tools|benchmarks)/[\w./-]+", (release / "Makefile").read_text()))
    assert ran and all((release / name).exists() for name in ran), sorted(n for n in ran if not (release / n).exists())


def test_every_make_target_the_release_names_is_there(release):
    mine = targets(release / "Makefile")
    named = {(name, m) for name, text in texts(release).items() for m in MAKE.findall(text)}
    assert {m for _, m in named} >= {"check", "test", "lab"}, sorted(named)
    assert not [(name, m) for name, m in named if m not in mine], sorted(named)


def test_every_path_the_release_cites_is_in_it(release):
    missing = []
    for name, text in texts(release).items():
        if name == "Makefile":          # what its recipes run: the test above (the rest are its outputs: docs/api)
            continue
        for cited in set(CITED.findall(text)):
            if not (release / cited.rstrip("/.")).exists():
                missing.append(f"{name} cites {cited}")
        if name.endswith(".md"):
            for link in set(LINK.findall(text)):
                if not link.startswith(("http", "mailto")) and not ((release / name).parent / link).exists():
                    missing.append(f"{name} links to {link}")
    assert not missing, "\n".join(sorted(missing))
