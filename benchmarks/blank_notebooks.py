"""Run time of each notebook with every exercise blank (the student release) against solved (the instructor's).

    .venv/bin/python benchmarks/blank_notebooks.py [NN ...]        # default: every notebook

Builds a student release in a temporary folder; then, one notebook at a time, executes the instructor's notebook
(the solutions, PYTHONPATH = this checkout) and the release's (every exercise blank, PYTHONPATH = the release) in a
fresh kernel each, errors allowed (a blank exercise's own cells raise), and prints seconds and the ratio blank /
solved. Issue 32 asks for at most 1.5 with every exercise blank: the kit's stand-ins must not slow the lab.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from armlab_course.exercises import make_student_release  # noqa: E402


def run_seconds(path: Path, pythonpath: Path) -> float:
    """Seconds to execute the notebook at `path` top to bottom (errors allowed) with `pythonpath` first."""
    nb = nbformat.read(path, as_version=4)
    env = {**os.environ, "PYTHONPATH": str(pythonpath), "MPLBACKEND": "Agg"}
    start = time.perf_counter()
    NotebookClient(nb, timeout=1800, allow_errors=True, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute(env=env)
    return time.perf_counter() - start


def main(numbers: list[str]) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        release = Path(tmp) / "student"
        make_student_release(REPO, release)
        stems = sorted(p.stem for p in (REPO / "notebooks").glob("*.ipynb")
                       if not numbers or p.stem[:2] in numbers)
        print(f"{'notebook':28} {'solved s':>9} {'blank s':>9} {'blank/solved':>13}", flush=True)
        for stem in stems:
            solved = run_seconds(REPO / "notebooks" / f"{stem}.ipynb", REPO)
            blank = run_seconds(release / "notebooks" / f"{stem}.ipynb", release)
            print(f"{stem:28} {solved:9.1f} {blank:9.1f} {blank / solved:13.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
