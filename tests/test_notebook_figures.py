"""Every figure a notebook shows says what it shows and can be read at 1366 x 768 (issue 35).

tools/build-notebook executes each notebook with tools/figure_recorder.py in its kernel, which stores with every
figure's PNG, in the output's metadata, the record armlab.viz.figures.figure_record made of the live figure: its
problems (labels without units, missing titles, titles over tick labels, overlapping tick labels, panels too small,
labels too small, a figure too wide). These tests read the stored notebooks, so no notebook runs again: each figure
must carry a record, the record must be empty of problems, and the PNG itself (its header, not the record) must be
as wide and as tall as the screen can show. The rules themselves are tested on figures made here.
"""

from __future__ import annotations

import base64
import json
import struct
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from armlab.viz.figures import MAX_WIDTH_PX, figure_record, labelling_problems, readable  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
MAX_HEIGHT_PX = 1000       # a figure taller than this cannot be seen whole in the output area of a 768-px screen
MIN_WIDTH_PX = 300


def figures(path: Path):
    """(code cell number, PNG size (w, h) px from its header, the stored record or None) per figure of a notebook."""
    code = 0
    for cell in json.loads(path.read_text())["cells"]:
        if cell["cell_type"] != "code":
            continue
        code += 1
        for out in cell.get("outputs", []):
            png = out.get("data", {}).get("image/png")
            if png is None:
                continue
            head = base64.b64decode(png[:64])
            assert head[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name}, code cell {code}: not a PNG"
            size = struct.unpack(">II", head[16:24])
            yield code, size, out.get("metadata", {}).get("image/png", {}).get("armlab_figure")


def test_the_notebooks_have_figures_to_check():
    assert sum(1 for nb in NOTEBOOKS for _ in figures(nb)) >= 25


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_stored_figure_is_labelled_and_readable(path):
    bad = []
    for cell, (w, h), record in figures(path):
        where = f"{path.name}, code cell {cell}"
        if record is None:
            bad.append(f"{where}: no figure record (rebuild it with tools/build-notebook)")
            continue
        bad += [f"{where}: {p}" for p in record["problems"]]
        if not MIN_WIDTH_PX <= w <= MAX_WIDTH_PX or h > MAX_HEIGHT_PX:
            bad.append(f"{where}: the image is {w} x {h} px (width {MIN_WIDTH_PX}-{MAX_WIDTH_PX}, height at most "
                       f"{MAX_HEIGHT_PX})")
    assert not bad, "\n".join(bad)


# -- the rules, on figures made here -------------------------------------------------------------------------------
@pytest.fixture
def fresh():
    """The lab's figure settings for one test, matplotlib's own restored after it."""
    with matplotlib.rc_context():
        readable()
        yield
        plt.close("all")


def test_a_figure_that_says_what_it_shows_has_no_problems(fresh):
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.4))
    a.plot([0, 1], [0, 2])
    a.set(xlabel="time (s)", ylabel="angle [rad]", title="the angle grows")
    im = b.imshow([[0, 1], [2, 3]])
    b.set(xlabel="u (px)", ylabel="v (px)", title="an image")
    fig.colorbar(im, ax=b, label="height (mm)")
    fig.tight_layout()
    assert labelling_problems(fig) == []
    assert figure_record(fig) == {"width_px": 900, "height_px": 340, "problems": []}


def test_unlabelled_unitless_and_hidden_axes_are_reported(fresh):
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(9, 3))
    a.plot([0, 1], [0, 1])
    a.set(xlabel="iteration", ylabel="")                       # no unit, no label, no title
    im = b.imshow([[0, 1], [2, 3]])
    b.set(xlabel="u (px)", ylabel="v (px)", title="image")
    fig.colorbar(im, ax=b, label="mm")                         # a unit, but not in brackets
    c.set_axis_off()
    problems = "\n".join(labelling_problems(fig))
    assert "no title" in problems
    assert "'iteration' names no unit" in problems and "the y label ''" in problems
    assert "colour bar without a unit" in problems
    assert "a panel without axes" in problems


def test_a_title_over_tick_labels_and_a_tiny_panel_are_reported(fresh):
    fig, axes = plt.subplots(2, 1, figsize=(4, 3.2))
    for ax in axes:
        ax.plot([0, 1], [0, 1])
        ax.set(xlabel="x (mm)", ylabel="y (mm)")
        ax.set_title("a title over the ticks", y=-0.2)         # down among its own x tick labels
    problems = "\n".join(labelling_problems(fig))
    assert "overlaps the tick label" in problems
    assert "px on screen (at least" in problems


def test_a_shared_axis_needs_its_label_once(fresh):
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.4), sharey=True)
    for ax in (a, b):
        ax.plot([0, 1], [0, 1])
        ax.set(xlabel="x (mm)", title="panel", xticks=(0, 0.5, 1))
    a.set_ylabel("z (mm)")
    fig.tight_layout()
    assert labelling_problems(fig) == []


def test_the_recorder_stores_a_record_with_the_inline_figure(fresh):
    """tools/figure_recorder.py in an IPython shell whose PNG formatter is the one the inline backend registers: a
    shown figure's PNG comes with its record in the metadata."""
    from IPython.core.interactiveshell import InteractiveShell
    from IPython.core.pylabtools import select_figure_formats

    shell = InteractiveShell.instance()
    try:
        select_figure_formats(shell, {"png"})
        exec(compile((ROOT / "tools" / "figure_recorder.py").read_text(), "figure_recorder.py", "exec"),
             {"__name__": "figure_recorder"})
        shell.events.trigger("pre_run_cell", None)
        fig, ax = plt.subplots(figsize=(5, 3))
        ax.plot([0, 1], [0, 1])
        data, metadata = shell.display_formatter.format(fig)
        record = metadata["image/png"]["armlab_figure"]
        assert "image/png" in data and record["width_px"] == 500
        assert any("no title" in p for p in record["problems"])
    finally:
        InteractiveShell.clear_instance()
