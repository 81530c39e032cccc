"""The docs say what the exercise registry says: every generated block (counts, points, the table) is what
`tools/exercise-docs` renders from `python -m armlab exercises --json`, and no README, doc or notebook names an
exercise id, points, kind, notebook or count the registry contradicts (issue 34: docs/release.md said 20 exercises,
100 points and named ids that no longer existed)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from armlab_course.exercises import exercises_json
from armlab_course.exercises.registry import EXERCISES
from armlab_course.exercises.registry_docs import BLOCK, disagreements, doc_files, refresh, render

ROOT = Path(__file__).resolve().parents[2]
ROWS = exercises_json(ROOT)
DOCS = doc_files(ROOT)


@pytest.mark.parametrize("path", DOCS, ids=[p.relative_to(ROOT).as_posix() for p in DOCS])
def test_a_doc_agrees_with_the_registry(path):
    text = path.read_text(encoding="utf-8")
    assert refresh(text, ROWS) == text, f"{path.name}: a generated block is stale: run make exercise-docs"
    assert disagreements(text, ROWS) == [], path.name


def test_the_release_doc_carries_the_generated_table_and_summary():
    """docs/release.md holds a summary and a table block, rendered from the registry: one row per exercise, the
    counts and points the registry sums to."""
    text = (ROOT / "docs/release.md").read_text(encoding="utf-8")
    kinds = [m["kind"] for m in BLOCK.finditer(text)]
    assert sorted(kinds) == ["summary", "table"], kinds
    table = next(m["body"] for m in BLOCK.finditer(text) if m["kind"] == "table")
    assert [ln.split("`")[1] for ln in table.splitlines()[2:]] == [e.id for e in EXERCISES]
    summary = next(m["body"] for m in BLOCK.finditer(text) if m["kind"] == "summary")
    auto = sum(e.points for e in EXERCISES if e.kind != "written")
    assert f"{len(EXERCISES)} exercises, {sum(e.points for e in EXERCISES)} points" in summary
    assert f"{auto} graded automatically" in summary, summary


def test_stale_figures_and_unknown_ids_are_named():
    """What docs/release.md said before (20 exercises, 100 points, fk.dh_transform), a wrong point count, kind or
    notebook, and a generated block edited by hand are each caught."""
    text = ("The 20 exercises (100 points, 113 lines of solution) are listed.\n"
            "e.g. `exercise fk.dh_transform (notebook 02): write dh_transform`\n"
            "the Euler angles (`fk.euler`, 4) and\n"
            "| `fk.dh_table` | 8 | open | notebook 02 |\n"
            "**Exercise `fk.euler` (5 points, written).** and exercise fk.euler (notebook 03)\n"
            "<!-- BEGIN GENERATED summary (tools/exercise-docs) -->\n**26 exercises, 1 points**\n"
            "<!-- END GENERATED -->\n"
            "stdout: `[3] alice: 87 / 100 automatic (+17 by hand: the written answers)`\n")
    found = disagreements(text, ROWS)
    assert len(found) == 7, found
    for line, words in ((1, f"the registry has {len(EXERCISES)} exercises"), (2, "fk.dh_transform"),
                        (3, "points 4 (the registry: 5)"), (4, "kind open (the registry: code)"),
                        (5, "kind written (the registry: code)"), (5, "notebook 03 (the registry: 02)"),
                        (9, "automatic points")):
        assert any(s.startswith(f"line {line}:") and words in s for s in found), (line, words, found)
    assert refresh(text, ROWS) != text and render("summary", ROWS) in refresh(text, ROWS)


def test_exercise_docs_check_runs_from_the_command_line():
    """`tools/exercise-docs --check` reads `python -m armlab exercises --json` and finds every doc fresh."""
    done = subprocess.run([sys.executable, str(ROOT / "tools/exercise-docs"), "--check"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"{len(EXERCISES)} exercises" in done.stdout and "0 claim(s)" in done.stdout, done.stdout
