"""A hub image built as docs/hub.md says, from the student release (dist/student) and its own binder/, holds no
solution and no hidden check (issue 34: an image built from the repository carried every solution).

repo2docker needs Docker to build, so the test does what its Dockerfile does (tests/test_binder.py reads that
Dockerfile: the repository copied in, `pip install -r binder/requirements.txt` there, then `binder/postBuild`) in a
fresh venv: the release is built (tools/student-release), binder/requirements.txt installed into the venv from the
release folder (with --no-compile: the search reads text files only, and compiling the environment's 6000-odd modules
cost 13 s of CPU), binder/postBuild run there with the venv first on PATH. Then every text file of the result (the
venv's site-packages and the release's files, the image's contents, each read once) is searched for the instructor's
solution lines (each line of a `# BEGIN SOLUTION` region body that the instructor's tree has nowhere else) and for the
hidden checks (armlab_course/grading/hidden: its files, and lines found only there). The same search over the
instructor's own tree finds both, so the search can fail. The environment's size is printed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from armlab_course.exercises.markers import ExerciseMarkerError, find_regions

REPO = Path(__file__).resolve().parent.parent
HIDDEN = "armlab_course/grading/hidden"
TEXT_SUFFIXES = {".py", ".ipynb", ".md", ".txt", ".json", ".cfg", ".toml", ".pth", ".sh", ".yaml", ".yml", ".html",
                 ".js", ".csv", ""}
SHORTEST = 16              # characters: shorter lines ("return T", "pass") are not evidence of anything


def _lines(path: Path) -> list[str]:
    """The stripped lines of a text file; a notebook's cell sources line by line (not its JSON)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (UnicodeDecodeError, OSError):
        return []
    if path.suffix == ".ipynb":
        try:
            cells = json.loads(text)["cells"]
            text = "\n".join("".join(c["source"]) if isinstance(c["source"], list) else c["source"] for c in cells)
        except (ValueError, KeyError, TypeError):
            pass
    return [line.strip() for line in text.splitlines()]


def _texts(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if p.is_file() and not p.is_symlink() and p.suffix in TEXT_SUFFIXES
            and ".git" not in p.relative_to(root).parts]


def _tracked(repo: Path) -> list[Path]:
    out = subprocess.run(["git", "ls-files", "-z"], cwd=repo, capture_output=True, text=True, check=True).stdout
    return [repo / n for n in out.split("\0") if n and (repo / n).is_file()]


def _region_lines(lines: list[str], where: str) -> set[int]:
    """Indices of the lines inside a solution region's body (none for a file without regions, or unreadable ones)."""
    if not any("BEGIN SOLUTION" in line for line in lines):
        return set()
    try:
        return {i for r in find_regions("\n".join(lines), where) for i in range(r.begin + 1, r.end)}
    except ExerciseMarkerError:       # a file that talks about markers (docs, tests): not an exercise file
        return set()


def secret_lines(repo: Path) -> tuple[set[str], set[str]]:
    """(solution lines, hidden-check lines) of the instructor's tree: stripped lines of at least SHORTEST characters
    found in a solution region's body of any tracked file (notebooks, their sources, the package; resp. under
    armlab_course/grading/hidden) and in no other part of the tree."""
    solution, hidden, public = set(), set(), set()
    for path in _tracked(repo):
        rel = path.relative_to(repo).as_posix()
        lines = _lines(path)
        if rel.startswith(HIDDEN + "/"):
            hidden |= {line for line in lines if len(line) >= SHORTEST}
            continue
        inside = _region_lines(lines, rel)
        solution |= {lines[i] for i in inside if len(lines[i]) >= SHORTEST}
        public |= {line for i, line in enumerate(lines) if i not in inside}
    return solution - public - hidden, hidden - public - solution


def secret_hits(root: Path, secrets: set[str]) -> dict[str, set[str]]:
    """Per text file under root (relative path), the secret lines it holds (each file read once)."""
    return {path.relative_to(root).as_posix(): secrets.intersection(_lines(path)) for path in _texts(root)}


def flagged(hits: dict[str, set[str]]) -> dict[str, list[str]]:
    """Of secret_hits(), the files holding a secret line, and every path under a hidden-checks folder."""
    found: dict[str, list[str]] = {}
    for rel, lines in hits.items():
        listed = sorted(lines)
        if "grading/hidden/" in rel:
            listed.insert(0, "(a hidden-checks file)")
        if listed:
            found[rel] = listed
    return found


def leaks(root: Path, solution: set[str], hidden: set[str]) -> dict[str, list[str]]:
    """Per file under root (relative path) the secret lines it holds, and every path under a hidden-checks folder."""
    return flagged(secret_hits(root, solution | hidden))


def _ours(rel: str) -> bool:
    """Whether a site-packages path belongs to the kit's own installation (the package, or its editable finder)."""
    return rel.split("/")[0] in ("armlab", "armlab_course") or rel.startswith(("__editable__", "armlab-"))


def generic_lines(hits: dict[str, set[str]]) -> set[str]:
    """Of secret_hits() over a site-packages folder, the secret lines a third-party package there also holds
    ("except (ValueError, TypeError):" is in matplotlib too: finding it proves nothing)."""
    return set().union(*(lines for rel, lines in hits.items() if not _ours(rel)))


def _size_mb(root: Path) -> float:
    return sum(p.stat().st_size for p in root.rglob("*") if p.is_file() and not p.is_symlink()) / 2**20


@pytest.fixture(scope="module")
def secrets():
    solution, hidden = secret_lines(REPO)
    assert len(solution) > 20 and len(hidden) > 20, (len(solution), len(hidden))
    return solution, hidden


def test_the_search_finds_the_secrets_in_the_instructors_tree(secrets, tmp_path):
    """The detector can fail: the instructor's tree holds solution lines in its exercise files and hidden checks."""
    found = leaks(REPO / "armlab_course", *secrets) | leaks(REPO / "notebooks", *secrets)
    assert any(rel.startswith("grading/hidden/") for rel in found)
    assert any(rel.endswith(".ipynb") for rel in found)


def test_a_hub_environment_from_the_student_release_holds_no_solution(secrets, tmp_path):
    release, env = tmp_path / "student", tmp_path / "venv"
    built = subprocess.run([sys.executable, str(REPO / "tools/student-release"), str(release)], capture_output=True,
                           text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-3000:]
    venv.EnvBuilder(with_pip=True).create(env)
    path = f"{env / 'bin'}{os.pathsep}{os.environ['PATH']}"
    clean = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    for step in (["python", "-m", "pip", "install", "--quiet", "--no-compile", "-r", "binder/requirements.txt"],
                 ["bash", "binder/postBuild"]):
        done = subprocess.run(step, cwd=release, env=dict(clean, PATH=path, VIRTUAL_ENV=str(env)),
                              capture_output=True, text=True, timeout=1800)
        assert done.returncode == 0, (step, done.stdout[-2000:], done.stderr[-3000:])
    site = next((env / "lib").glob("python3*/site-packages"))
    every = secrets[0] | secrets[1]
    hits = secret_hits(site, every)                   # each file of the environment read once
    generic = generic_lines(hits)
    image = {f"(image) {k}": v for k, v in secret_hits(release, every).items()}
    found = flagged({rel: lines - generic for rel, lines in (hits | image).items()})
    assert found == {}, f"the hub environment holds secrets: {dict(list(found.items())[:5])}"
    assert not (release / HIDDEN).exists()
    print(f"\nhub environment: site-packages {_size_mb(site):.0f} MB, venv {_size_mb(env):.0f} MB, the image's "
          f"files (the release) {_size_mb(release):.1f} MB; searched {len(secrets[0])} solution lines and "
          f"{len(secrets[1])} hidden-check lines ({len(generic)} of them also in third-party packages: not evidence), "
          f"none found")
