"""Headless Chromium for tests: render a local HTML page (e.g. a meshcat snapshot) to an RGB image.

WebGL renders in software with SwiftShader (see reference/toolchain.md); `--use-gl=swiftshader` gives a blank page.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import cv2
import numpy as np

CANDIDATES = ("chromium", "chromium-browser", "google-chrome")


def find_chromium() -> str | None:
    """Path of a Chromium-like browser on PATH, or None."""
    for name in CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return None


def screenshot(html_path, png_path, size: tuple[int, int] = (1024, 768), budget_ms: int = 5000,
               timeout_s: float = 120.0) -> np.ndarray:
    """Render `html_path` headless at size (width, height) px, save the PNG to `png_path`, return it RGB uint8.

    `budget_ms` of virtual time lets the page's scripts and animation frames run before the shot.
    Raises RuntimeError with Chromium's output when no image comes out.
    """
    browser = find_chromium()
    if browser is None:
        raise RuntimeError("no chromium on PATH (run tools/ensure-chromium)")
    html_path, png_path = Path(html_path).resolve(), Path(png_path).resolve()
    with tempfile.TemporaryDirectory(prefix="armlab-chromium-") as profile:
        cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
               "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
               f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
               f"--virtual-time-budget={int(budget_ms)}", f"--screenshot={png_path}", html_path.as_uri()]
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    image = cv2.imread(str(png_path), cv2.IMREAD_COLOR)
    if image is None:
        raise RuntimeError(f"chromium wrote no screenshot (exit {run.returncode}): {run.stderr[-2000:]}")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
