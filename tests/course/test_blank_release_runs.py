"""The student release as handed out: every notebook runs top to bottom ("Run All") with every exercise blank, and
the only cells that raise are an exercise's own cell and the check cells that test it, each with the exercise's
message (its id, the notebook that teaches it, what to write). Everything else -- the simulator, the viewer, the
demonstrations that need a blank exercise -- works on the kit's reference paths, which say so in one line.

The instructor's notebooks (the solutions restored) pass every cell under nbval in the same `make test`.
"""

from __future__ import annotations

import multiprocessing
import os
import re
import subprocess
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from armlab_course.exercises import EXERCISES, exercise, find_regions, make_student_release
from armlab_course.exercises.release import RUN_ALL_TAG

REPO = Path(__file__).resolve().parents[2]
CHECK_TAG = re.compile(r"^# CHECK (?P<ids>.+)$", re.M)
STUB_ERROR = re.compile(r"^exercise (?P<id>\S+) \(notebook \d\d\): write ")


def _run_notebook(path: str, release: str) -> str:
    """Execute one notebook (errors allowed) in a kernel whose path starts with the release; the executed JSON."""
    nb = nbformat.read(path, as_version=4)
    env = {**os.environ, "PYTHONPATH": release, "MPLBACKEND": "Agg"}
    NotebookClient(nb, timeout=900, allow_errors=True, kernel_name="python3",
                   resources={"metadata": {"path": str(Path(path).parent)}}).execute(env=env)
    return nbformat.writes(nb)


@pytest.fixture(scope="module")
def blank_run(tmp_path_factory):
    """Every notebook of a fresh student release, executed with errors allowed (two at a time, each in its own
    process and kernel), with the release's armlab first on the kernels' path: {stem: executed notebook}, and the
    release folder."""
    if not (REPO / ".git").exists():
        pytest.skip("builds the release from the instructor's git checkout")
    out = tmp_path_factory.mktemp("blank") / "student"
    make_student_release(REPO, out)
    paths = sorted((out / "notebooks").glob("*.ipynb"))
    with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as pool:
        executed = list(pool.map(_run_notebook, [str(p) for p in paths], [str(out)] * len(paths)))
    return {p.stem: nbformat.reads(text, as_version=4) for p, text in zip(paths, executed, strict=True)}, out


def _errors(cell) -> list[dict]:
    return [o for o in cell.get("outputs", []) if o.get("output_type") == "error"]


def _stderr(cell) -> str:
    return "".join(o.get("text", "") for o in cell.get("outputs", [])
                   if o.get("output_type") == "stream" and o.get("name") == "stderr")


def test_the_release_imports_the_release_not_the_instructors_package(blank_run):
    notebooks, out = blank_run
    code = "import armlab, sys; print(armlab.__file__)"
    run = subprocess.run([os.sys.executable, "-c", code], cwd=out, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(out)}, check=True)
    assert run.stdout.strip().startswith(str(out)), run.stdout


def test_only_exercise_and_check_cells_raise_and_each_names_its_exercise(blank_run):
    notebooks, _ = blank_run
    assert len(notebooks) >= 9
    wrong = []
    for stem, nb in notebooks.items():
        for i, cell in enumerate(nb.cells):
            if cell.cell_type != "code" or not _errors(cell):
                continue
            error = _errors(cell)[0]
            regions = {r.exercise_id for r in find_regions(cell.source, stem)}
            tags = set(CHECK_TAG.findall(cell.source)[0].split()) if CHECK_TAG.search(cell.source) else set()
            named = STUB_ERROR.match(error["evalue"])
            if error["ename"] not in ("ExerciseNotWritten", "SlotNotWritten") or not named:
                wrong.append(f"{stem} cell {i}: {error['ename']}: {error['evalue'][:200]}")
            elif named["id"] not in regions | tags:
                wrong.append(f"{stem} cell {i} (exercises {sorted(regions | tags)}) raised for {named['id']}")
    assert not wrong, "cells that should run in the blank release:\n" + "\n".join(wrong)


def test_every_cell_that_raises_is_tagged_so_run_all_goes_on(blank_run):
    """Every cell that raised carries the release's RUN_ALL_TAG ("raises-exception"): JupyterLab's Run All, and
    nbclient, go on past it to the notebook's end (issue 34: notebook 02 stopped at its third cell)."""
    notebooks, _ = blank_run
    untagged = [f"{stem} cell {i}: {cell.source.splitlines()[0]}" for stem, nb in notebooks.items()
                for i, cell in enumerate(nb.cells) if cell.cell_type == "code" and _errors(cell)
                and RUN_ALL_TAG not in cell.metadata.get("tags", [])]
    assert not untagged, "cells that raise in the blank release and would stop Run All:\n" + "\n".join(untagged)


def test_every_check_cell_fails_while_its_exercise_is_blank(blank_run):
    """No check passes on the kit's reference path: a blank exercise scores nothing in the student's own run."""
    notebooks, _ = blank_run
    passing = []
    for stem, nb in notebooks.items():
        for i, cell in enumerate(nb.cells):
            if cell.cell_type == "code" and CHECK_TAG.search(cell.source) and not _errors(cell):
                passing.append(f"{stem} cell {i}: {cell.source.splitlines()[0]}")
    assert not passing, "check cells that pass with their exercise blank:\n" + "\n".join(passing)
    checked = {x for nb in notebooks.values() for c in nb.cells if c.cell_type == "code"
               for m in CHECK_TAG.findall(c.source) for x in m.split()}
    every = {e.id for e in EXERCISES if e.kind != "written"}     # written answers are graded by hand
    assert checked == every, f"exercises without a check cell: {sorted(every - checked)}"


def test_the_reference_paths_say_so_in_one_line_each(blank_run):
    """Every note names an exercise that is blank, once per notebook's kernel."""
    notebooks, _ = blank_run
    notes = [line for nb in notebooks.values() for c in nb.cells if c.cell_type == "code"
             for line in _stderr(c).splitlines() if line.startswith("note: exercise ")]
    ids = [line.split()[2] for line in notes]
    for x in ids:
        exercise(x)
    per_notebook = [[line.split()[2] for c in nb.cells if c.cell_type == "code"
                     for line in _stderr(c).splitlines() if line.startswith("note: exercise ")]
                    for nb in notebooks.values()]
    assert all(len(n) == len(set(n)) for n in per_notebook), "a reference path announced itself twice"
    # not fk.dh_link_transform: nothing but notebook 02's DH chain calls it, and that chains the student's table
    assert {"calib.tag_extrinsics", "calib.depth_plane", "ik.candidates", "fk.dh_table", "detect.classify",
            "grab.move_path", "teach.replay", "events.sort_stack"} <= set(ids), sorted(set(ids))
