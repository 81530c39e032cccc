"""The API reference (`make docs`: tools/api-docs, pdoc over every public module) builds, documents every public
module found in the source tree, and carries the docstrings it is built from."""

from __future__ import annotations

import html
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tools import load_tool

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "api-docs"

pytest.importorskip("pdoc")


def api_docs_tool():
    return load_tool("api-docs")


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("api")
    run = subprocess.run([sys.executable, str(TOOL), str(out)], capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    return out


def test_the_module_list_is_every_public_module():
    modules = api_docs_tool().public_modules()
    assert {"armlab", "armlab.kinematics", "armlab.station.contract", "armlab.tasks.events.registry"} <= set(modules)
    assert not [m for m in modules if any(p.startswith("_") for p in m.split("."))]
    assert "armlab_course.grading.kernel_startup" not in modules          # a startup script: importing it runs it
    assert not [m for m in modules if m.startswith("armlab_course.grading.hidden")]    # the instructor's hidden checks
    assert len(modules) >= 100


def test_the_reference_builds_a_page_per_module_with_its_docstrings(reference):
    modules = api_docs_tool().public_modules()
    missing = [m for m in modules if not (reference / (m.replace(".", "/") + ".html")).is_file()]
    assert not missing, f"no page for {missing}"
    raw = (reference / "armlab" / "kinematics.html").read_text()
    page = " ".join(html.unescape(re.sub(r"<[^>]+>", "", raw)).split())
    from armlab import kinematics

    assert 'id="ik"' in raw, "no entry for kinematics.ik"
    first_line = kinematics.ik.__doc__.splitlines()[0].replace("`", "")      # rendered: `x` becomes <code>x</code>
    assert first_line in page, "the page lacks ik's docstring"
    assert (reference / "index.html").is_file() and (reference / "search.js").is_file()


def test_the_reference_shows_no_source_so_no_solution(reference):
    """Built from the instructor's checkout (which holds every solution), the pages carry docstrings only: no
    exercise region's text, no marker, no hidden check."""
    pages = {p: p.read_text() for p in reference.rglob("*.html")}
    assert not [p for p, text in pages.items() if re.search(r"BEGIN SOLUTION [a-z]+\.[a-z_]+", text)]
    page = pages[reference / "armlab" / "kinematics.html"]
    kinematics = " ".join(html.unescape(re.sub(r"<[^>]+>", "", page)).split())
    assert "ct, st, ca, sa = np.cos(theta)" not in kinematics     # fk.dh_link_transform's solution
    assert not (reference / "armlab" / "grading" / "hidden.html").exists()
