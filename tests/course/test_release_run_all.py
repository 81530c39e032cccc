"""The student release as a student meets it (issue 34).

Run All goes on (in the blank release notebook 02 stopped at its third cell, 11 of its 14 code cells never ran, the
rubric cell included).

The release tags the cells that raise while an exercise is blank -- its exercise cells and its check cells --
"raises-exception" (armlab_course.exercises.release.RUN_ALL_TAG). Here a freshly built blank release's notebook 02
runs with nbclient *without* allow_errors (as JupyterLab's Run All: a raising cell without the tag ends the run) and
reaches its last cell, every error being a tagged cell's and each of the notebook's exercises showing its
not-written message; then the same notebook runs in JupyterLab
in headless Chromium (Playwright, Debian's chromium) through the "Restart Kernel and Run All Cells" command, and every
code cell shows an execution count. The grader's nbval runs ignore the tag (a raising check cell fails there):
tests/test_grading_cli.py's self-check of a wrong homography covers that.

The release is true about itself (its .student-release said to run `make check`, which did not exist; its Makefile
kept targets whose tools it does not ship; notebooks cited reference/lab.md and benchmarks/perception.py, which
neither the release nor the repository has): its Makefile has `make check` (the self-check) and none of the
instructor's targets; every `make X` its README, marker file and notebooks name is a target of it; every file a
recipe runs is in it; every repository path its README, notebooks and every markdown page it ships cite is in it
(the instructor's and maintainers' pages stay out, and a shipped page's instructor-only parts -- between
`<!-- BEGIN INSTRUCTOR ONLY -->` and `<!-- END INSTRUCTOR ONLY -->` -- go), and so is every path the package's
docstrings and comments cite.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from armlab_course.exercises import exercise, find_regions, make_student_release, of_notebook
from armlab_course.exercises.markers import CHECK_LINE
from armlab_course.exercises.release import RELEASE_MARKER, RUN_ALL_TAG
from armlab_course.grading.run import code_cell_labels

sys.path.insert(0, str(Path(__file__).parents[1]))     # tests/browser.py
import browser  # noqa: E402
from browser import poll  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
STEM = "02_forward_kinematics"


@pytest.fixture(scope="module")
def release(tmp_path_factory) -> Path:
    if not (ROOT / ".git").exists():
        pytest.skip("builds the release from the instructor's git checkout")
    out = tmp_path_factory.mktemp("run-all") / "student"
    make_student_release(ROOT, out)
    return out


def _tagged(cell) -> bool:
    return RUN_ALL_TAG in cell.get("metadata", {}).get("tags", [])


def test_exactly_the_exercise_and_check_cells_are_tagged(release):
    """In every released notebook the tagged cells are the code cells holding an exercise stub or a `# CHECK` line;
    the instructor's notebooks carry no such tag (their nbval runs expect every cell to pass)."""
    for path in sorted((release / "notebooks").glob("*.ipynb")):
        cells = json.loads(path.read_text())["cells"]
        for i, cell in enumerate(cells):
            source = "".join(cell["source"])
            raises = cell["cell_type"] == "code" and bool(find_regions(source, path.name) or CHECK_LINE.search(source))
            assert _tagged(cell) == raises, f"{path.name} cell {i}: tagged {_tagged(cell)}, raises when blank {raises}"
        mine = json.loads((ROOT / "notebooks" / path.name).read_text())["cells"]
        assert not any(_tagged(c) for c in mine), f"the instructor's {path.name} carries {RUN_ALL_TAG}"


def test_a_blank_notebook_runs_to_its_end_without_allow_errors(release):
    nb = nbformat.read(release / "notebooks" / f"{STEM}.ipynb", as_version=4)
    env = {**os.environ, "PYTHONPATH": str(release), "MPLBACKEND": "Agg"}
    NotebookClient(nb, timeout=600, allow_errors=False, kernel_name="python3",
                   resources={"metadata": {"path": str(release / "notebooks")}}).execute(env=env)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code), [c.execution_count for c in code]
    errors = {i: o for i, c in enumerate(code) for o in c.outputs if o.output_type == "error"}
    assert errors and all(_tagged(code[i]) for i in errors), sorted(errors)
    shown = {e.evalue for e in errors.values()}
    regions = {r.exercise_id for c in code for r in find_regions(c.source, STEM)}
    assert regions and all(exercise(x).message() in shown for x in regions), (sorted(regions), shown)
    last = "".join(o.get("text", "") for o in code[-1].outputs)
    assert f"{len(of_notebook(STEM))} exercises, " in last, last      # the last cell: rubric("02"), the student's table


WHY_NOT = browser.playwright_missing()
VIEWPORT = {"width": 1366, "height": 768}
PROMPTS = """() => [...document.querySelectorAll('.jp-Notebook .jp-CodeCell .jp-InputPrompt')]
                    .map(e => e.textContent)"""


@pytest.mark.skipif(WHY_NOT is not None, reason=WHY_NOT or "")
def test_restart_kernel_and_run_all_runs_every_cell_in_jupyterlab(release, tmp_path):
    """JupyterLab's "Restart Kernel and Run All Cells…" on the blank notebook 02 (the dialog confirmed as a student
    would): every code cell gets an execution count and the not-written messages show."""
    from playwright.sync_api import sync_playwright

    code = [c for c in json.loads((release / "notebooks" / f"{STEM}.ipynb").read_text())["cells"]
            if c["cell_type"] == "code"]
    lab = browser.JupyterLab(release, tmp_path / "home", sys.executable)
    lab.env["PYTHONPATH"] = str(release)      # the kernels import the release's armlab, as from a student's install
    with lab:
        with sync_playwright() as pw:
            chromium = pw.chromium.launch(executable_path=browser.find_chromium(), headless=True,
                                          args=list(browser.CHROMIUM_FLAGS), timeout=120_000)
            try:
                page = chromium.new_page(viewport=VIEWPORT)
                page.set_default_timeout(120_000)
                page.goto(lab.document_url(f"notebooks/{STEM}.ipynb"))
                page.wait_for_function("window.jupyterapp && document.querySelector('.jp-Notebook .jp-CodeCell')")
                poll("the notebook's kernel", lab.kernel_ids, 300)
                lab.note_processes()
                # not awaited: the command's promise settles only once its dialog is answered
                page.evaluate("() => { window.jupyterapp.commands.execute('notebook:restart-run-all'); }")
                page.locator(".jp-Dialog button.jp-mod-accept").click()        # "Restart" in the dialog
                seen: list = []

                def all_ran():
                    seen[:] = page.evaluate(PROMPTS)
                    return list(seen) if len(seen) == len(code) and all(t.strip("[]: ").isdigit() for t in seen) \
                        else None

                try:
                    prompts = poll("every code cell to run", all_ran, timeout_s=600)
                except AssertionError as e:
                    raise AssertionError(f"{e}; the prompts: {seen}") from None
                lab.note_processes()
                outputs = "\n".join(page.locator(".jp-OutputArea-output").all_inner_texts())
            finally:
                chromium.close()
    print(f"\nprompts after Restart Kernel and Run All Cells: {prompts}")
    # the grader names a check cell by the count JupyterLab shows here (armlab_course.grading.run.code_cell_labels)
    shown = [f"[{p.strip('[]: ')}]" for p in prompts]
    named = [label.split("(", 1)[1].split(" after Run All")[0]
             for label in code_cell_labels(release / "notebooks" / f"{STEM}.ipynb")]
    assert shown == named, (shown, named)
    assert outputs.count("ExerciseNotWritten") >= 2 and "exercise fk.dh_table (notebook 02): write" in outputs, \
        outputs[-3000:]
    assert f"{len(of_notebook(STEM))} exercises, " in outputs, outputs[-2000:]      # the last cell: rubric("02")
    assert not lab.leftovers, f"processes outlived JupyterLab: {lab.leftovers}"


# -- the release true about itself ------------------------------------------------------------------------------
INSTRUCTOR_TARGETS = {"notebooks", "bench", "exercise-docs", "student", "autograder"}
TOP = ("armlab", "armlab_course", "notebooks", "tests", "tools", "benchmarks", "docs", "reference", "binder")
CITED = re.compile(rf"(?<![\w/.-])((?:{'|'.join(TOP)})/[\w./-]*[\w/])")
LINK = re.compile(r"\]\(([^)#:\s]+)(?:#[^)]*)?\)")
MAKE = re.compile(r"`make ([a-z][\w-]*)`")
MADE = {"docs/api", "docs/api/index.html"}      # written by the release's `make docs` (docs/api.md says so)


def targets(makefile: Path) -> set[str]:
    return set(re.findall(r"^([A-Za-z][\w.-]*):(?!=)", makefile.read_text(), re.MULTILINE))


def texts(release: Path) -> dict[str, str]:
    """What a student reads: the README, the marker file, the Makefile, every notebook's cells (markdown and code),
    every markdown page the release ships, and the package's Python sources (docstrings and comments cite files)."""
    out = {name: (release / name).read_text() for name in ("README.md", RELEASE_MARKER, "Makefile")}
    for path in sorted((release / "notebooks").glob("*.ipynb")):
        out[f"notebooks/{path.name}"] = "\n".join("".join(c["source"]) for c in json.loads(path.read_text())["cells"])
    for path in sorted(release.rglob("*.md")):
        out.setdefault(str(path.relative_to(release)), path.read_text())
    for path in sorted((release / "armlab").rglob("*.py")):
        out[str(path.relative_to(release))] = path.read_text()
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
            if not (release / cited.rstrip("/.")).exists() and cited.rstrip("/.") not in MADE:
                missing.append(f"{name} cites {cited}")
        if name.endswith(".md"):
            for link in set(LINK.findall(text)):
                if not link.startswith(("http", "mailto")) and not ((release / name).parent / link).exists():
                    missing.append(f"{name} links to {link}")
    assert not missing, "\n".join(sorted(missing))
