"""The inline 3D view in Notebook 7, as a student on a hub gets it: `python -m notebook` (Notebook 7, the
one-document interface built from JupyterLab 4's components) under a JupyterHub-like base_url (/user/alice/, token,
fresh settings), and Debian's Chromium driven by Playwright (WebGL in software) inside a network namespace whose one
way out is the server's port (tests/browser.OnePort), as in tests/test_station_panel_browser.py for JupyterLab.

A small notebook the test writes (make_station("sim"), the viewer's widget as notebook 00 shows it, one cell that
moves the arm) runs through the Notebook 7 page: the cells above the move with the page's own "run all above"
command (window.jupyterapp, see browser.Notebook7), then the move cell with a real Ctrl+Enter. The pictures of the
view's canvas show a drawn scene (browser.blank_why, the JupyterLab test's rule) that holds still until the arm moves
and then changes; the meshcat server's port is proved unreachable from the browser, so the scene came over the
kernel's comm channel on the one port. One server, one page; everything is torn down and checked gone.
Screenshots go to $ARMLAB_BROWSER_SHOTS (default: a temporary folder, named in the test's output).
"""

from __future__ import annotations

import json
import os
import re
import sys
import time
from pathlib import Path

import cv2
import nbformat
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import browser  # noqa: E402
from browser import poll  # noqa: E402

WHY_NOT = browser.playwright_missing() or browser.OnePort.why_not()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=WHY_NOT or "")
VIEWPORT = {"width": 1366, "height": 768}          # a student's laptop
BASE_URL = "/user/alice/"                          # as a JupyterHub serves a student's server
NAME = "nb7_viewer.ipynb"
MOVE_TO = [1.2, -0.4, 0.3, 0.6, 0.0]               # joint angles (rad) of the move cell: the waist turns 1.2 rad
CELLS = [
    'from armlab import make_station\nfrom armlab.viz import Viewer\n\nstation = make_station("sim", seed=0)\n'
    'viewer = Viewer()\nprint("meshcat at", viewer.url)',
    "viewer.widget()",
    "viewer.show(station.arm.joint_positions(), gripper_opening_mm=station.arm.gripper_opening_mm)\n"
    "viewer.draw_objects(station.world.objects)\nprint(\"drawn:\", station.arm.joint_positions().round(2))",
    f"station.arm.move_to({MOVE_TO})\n"
    "viewer.show(station.arm.joint_positions(), gripper_opening_mm=station.arm.gripper_opening_mm)\n"
    "print(\"moved:\", station.arm.joint_positions().round(2))",
]
# every code cell of the page shows an execution count: "[n]:" in its input prompt
ALL_RUN = """(n) => { const p = [...document.querySelectorAll('.jp-Notebook .jp-CodeCell .jp-InputPrompt')]
                             .map(e => e.textContent);
                      return p.length === n && p.every(t => /\\[\\d+\\]/.test(t)); }"""
IDLE = """() => { const k = window.jupyterapp.shell.currentWidget?.sessionContext?.session?.kernel;
                  return k ? k.status : 'none'; }"""


def board_pixels(picture: np.ndarray) -> int:
    """How many pixels of an RGB picture have the board's colour (the viewer draws it 0xd9cfb8, a pale warm beige, lit:
    OpenCV hue 10-35, saturation 15-100, value 120 up). browser.blank_why alone passes meshcat's empty scene (its
    background is a vertical gradient of > 40 colours), so a drawn scene must show the board too."""
    hsv = cv2.cvtColor(np.ascontiguousarray(picture[..., ::-1]), cv2.COLOR_BGR2HSV)
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    return int(((h >= 10) & (h <= 35) & (s >= 15) & (s <= 100) & (v >= 120)).sum())


def write_notebook(path: Path) -> None:
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(src) for src in CELLS])
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}
    nbformat.write(nb, path)


class Page:
    """The open notebook page, and where its screenshots go."""

    def __init__(self, page, shots: Path):
        self.page, self.shots = page, shots
        self.measured: dict = {}

    def canvas(self):
        return self.page.locator(".armlab-viewer canvas")

    def picture(self, name: str) -> np.ndarray:
        """The view's canvas as RGB uint8 (also saved as name.png)."""
        data = self.canvas().screenshot(path=str(self.shots / f"{name}.png"))
        return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]

    def steady_picture(self, name: str, timeout_s: float = 60.0) -> np.ndarray:
        """The canvas once two pictures in a row differ in fewer than 20 pixels (the view has drawn what it got)."""
        last = [self.picture(name)]

        def steady():
            now = self.picture(name)
            same = browser.changed(now, last[0]).sum() < 20
            last[0] = now
            return same

        poll(f"the 3D view to hold still ({name})", steady, timeout_s, 0.3)
        return last[0]

    def outputs(self) -> str:
        return "\n".join(self.page.locator(".jp-OutputArea-output").all_inner_texts())

    def view(self, key: str) -> str | None:
        return self.page.locator(".armlab-viewer").get_attribute(f"data-{key}")


@pytest.fixture(scope="module")
def nb7(tmp_path_factory):
    from playwright.sync_api import sync_playwright

    root, home = tmp_path_factory.mktemp("nb7-root"), tmp_path_factory.mktemp("nb7-home")
    shots = Path(os.environ.get("ARMLAB_BROWSER_SHOTS") or tmp_path_factory.mktemp("shots"))
    shots.mkdir(parents=True, exist_ok=True)
    write_notebook(root / NAME)
    with browser.Notebook7(root, home, sys.executable, base_url=BASE_URL) as server, \
            browser.OnePort(server.port, tmp_path_factory.mktemp("one-port")) as gate:
        with sync_playwright() as pw:
            chromium = pw.chromium.launch(executable_path=str(gate.executable(browser.find_chromium())),
                                          headless=True, args=list(browser.CHROMIUM_FLAGS), timeout=120_000)
            try:
                page = chromium.new_page(viewport=VIEWPORT)
                page.set_default_timeout(120_000)
                start = time.monotonic()
                page.goto(server.document_url(NAME))
                page.wait_for_function("window.jupyterapp && document.querySelector('.jp-Notebook .jp-CodeCell')")
                poll("the notebook's kernel", server.kernel_ids, 300)
                server.note_processes()
                nb = Page(page, shots)
                nb.server, nb.gate = server, gate
                nb.measured["page_open_s"] = round(time.monotonic() - start, 1)
                yield nb
            finally:
                chromium.close()
        print(f"\nscreenshots in {shots}\nmeasured: {json.dumps(nb.measured)}")
    assert not server.leftovers, f"processes outlived the Notebook 7 server: {server.leftovers}"
    assert server.proc.returncode is not None


def test_the_page_is_notebook_7_under_the_base_url(nb7):
    page = nb7.page
    assert page.url.startswith(f"http://127.0.0.1:{nb7.server.port}{BASE_URL}notebooks/{NAME}")
    assert page.evaluate("window.jupyterapp.name") == "Jupyter Notebook"
    assert page.evaluate("window.jupyterapp.version").startswith("7.")
    assert page.locator(".jp-Notebook .jp-CodeCell").count() == len(CELLS)
    assert page.locator(".jp-LabShell").count() == 0          # not JupyterLab's shell
    nb7.page.screenshot(path=str(nb7.shots / "00-opened.png"))


def test_the_cells_run_and_the_view_draws_the_scene(nb7):
    page = nb7.page
    poll("the kernel to be idle", lambda: page.evaluate(IDLE) == "idle", 300, 0.25)
    start = time.monotonic()
    page.evaluate(f"""() => {{ const nb = window.jupyterapp.shell.currentWidget.content;
        nb.activeCellIndex = {len(CELLS) - 1}; nb.mode = 'command';
        return window.jupyterapp.commands.execute('notebook:run-all-above'); }}""")
    poll("the cells above the move to run", lambda: page.evaluate(
        """(n) => [...document.querySelectorAll('.jp-Notebook .jp-CodeCell .jp-InputPrompt')].slice(0, n)
                  .every(e => /\\[\\d+\\]/.test(e.textContent))""", len(CELLS) - 1) and
         page.evaluate(IDLE) == "idle", 300, 0.25)
    nb7.measured["run_above_s"] = round(time.monotonic() - start, 1)
    outputs = nb7.outputs()
    assert "drawn:" in outputs and "Traceback" not in outputs and "moved:" not in outputs, outputs[-3000:]
    assert page.locator("iframe").count() == 0 and nb7.canvas().count() == 1
    poll("the 3D view to get its scene", lambda: nb7.view("state") == "live", 120, 0.25)
    assert not page.locator(".armlab-viewer-status").is_visible(), page.locator(".armlab-viewer-status").inner_text()
    nb7.canvas().scroll_into_view_if_needed()
    picture = nb7.steady_picture("01-drawn")
    h, w = picture.shape[:2]
    assert w > 300 and h > 300, f"the canvas is {w} x {h} px"
    why = browser.blank_why(picture)
    assert why is None, f"the 3D view in Notebook 7 is blank: {why}"
    board = board_pixels(picture)
    assert board > 0.01 * w * h, f"the board is not drawn ({board} board-coloured pixels)"
    nb7.drawn = picture
    nb7.measured["canvas_px"] = [w, h]
    nb7.measured["colours_16_levels"] = len(np.unique((picture // 16).reshape(-1, 3), axis=0))
    nb7.measured["board_px"] = board


def test_the_browser_reaches_the_server_and_not_meshcat(nb7):
    """The kernel draws through a meshcat server, whose port the browser cannot reach: the picture above came over
    the kernel's comm channel on the server's one port."""
    meshcat_url = re.search(r"meshcat at (http://\S+)", nb7.outputs()).group(1)
    meshcat_port = int(re.search(r":(\d+)/", meshcat_url).group(1))
    assert nb7.gate.reaches(nb7.server.port) and not nb7.gate.reaches(meshcat_port)
    fetch = """async (url) => { try { await fetch(url, {mode: "no-cors"}); return "reached"; }
                                catch (e) { return "failed: " + e; } }"""
    assert nb7.page.evaluate(fetch, meshcat_url).startswith("failed"), f"the browser reached meshcat at {meshcat_url}"


def test_the_move_cell_moves_the_arm_in_the_view(nb7):
    page = nb7.page
    before = nb7.steady_picture("02-before-move")
    assert browser.changed(before, nb7.drawn).sum() < 20, "the view changed with nothing moving"
    messages = int(nb7.view("messages"))
    last = page.locator(".jp-Notebook .jp-CodeCell").nth(len(CELLS) - 1)
    last.locator(".jp-InputArea-editor").click()              # a student clicks into the cell ...
    page.keyboard.press("Control+Enter")                      # ... and runs it
    poll("the move cell to run", lambda: "moved:" in nb7.outputs() and page.evaluate(IDLE) == "idle", 120, 0.25)
    assert page.evaluate(ALL_RUN, len(CELLS)), "not every cell of the notebook ran"
    moved = re.search(r"moved: \[([^\]]+)\]", nb7.outputs()).group(1).split()
    np.testing.assert_allclose([float(v) for v in moved], MOVE_TO, atol=0.02)
    poll("the new pose to reach the view", lambda: int(nb7.view("messages")) > messages, 60, 0.1)
    nb7.canvas().scroll_into_view_if_needed()
    after = nb7.steady_picture("03-after-move")
    assert browser.blank_why(after) is None, browser.blank_why(after)
    changed = int(browser.changed(before, after).sum())
    nb7.measured["changed_px_after_move"] = changed
    assert changed > 500, f"only {changed} pixels of the view changed when the arm turned 1.2 rad"
    assert "Traceback" not in nb7.outputs()
