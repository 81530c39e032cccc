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


# -- JupyterLab + Playwright (the control-station checks, tests/test_station_panel_browser.py) ---------------------
CHROMIUM_FLAGS = ("--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run")


def playwright_missing() -> str | None:
    """Why Playwright cannot drive a browser here, or None (the system Chromium is used; no browser download)."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (pip install playwright; no browser download is needed)"
    if find_chromium() is None:
        return "no chromium on PATH (tools/ensure-chromium installs it)"
    return None


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nobody listens on right now."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _children(pid: int) -> list[int]:
    """Pids of the live processes whose parent is pid."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(stat[1]) == pid and stat[0] not in ("Z", "X"):
                out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


class JupyterLab:
    """A JupyterLab server on 127.0.0.1 (a free port, a random token, a fresh runtime/settings/workspace folder
    under `home`) serving `root`. Use as a context manager: on exit its kernels are shut down, the server is
    terminated (killed after a timeout) and every process it started is checked gone (killed if not)."""

    def __init__(self, root, home, python: str, timeout_s: float = 120.0):
        import os
        import secrets

        self.root, self.home = Path(root), Path(home)
        self.port, self.token = free_port(), secrets.token_hex(16)
        self.url = f"http://127.0.0.1:{self.port}"
        self.timeout_s = timeout_s
        self.runtime_dir = self.home / "runtime"
        settings = self.home / "settings"
        for d in (self.runtime_dir, settings / "@jupyterlab" / "apputils-extension", self.home / "workspaces",
                  self.home / "config", self.home / "data"):
            d.mkdir(parents=True, exist_ok=True)
        (settings / "@jupyterlab" / "apputils-extension" / "notification.jupyterlab-settings").write_text(
            '{"fetchNews": "false", "checkForUpdates": false}')
        self.env = dict(os.environ, JUPYTER_RUNTIME_DIR=str(self.runtime_dir), JUPYTER_CONFIG_DIR=str(self.home /
                        "config"), JUPYTER_DATA_DIR=str(self.home / "data"), JUPYTERLAB_SETTINGS_DIR=str(settings),
                        JUPYTERLAB_WORKSPACES_DIR=str(self.home / "workspaces"))
        self.env.pop("MPLBACKEND", None)
        self.cmd = [python, "-m", "jupyter", "lab", "--no-browser", "--ip=127.0.0.1", f"--port={self.port}",
                    "--port-retries=0", f"--ServerApp.root_dir={self.root}", f"--IdentityProvider.token={self.token}",
                    "--allow-root", "--LabApp.expose_app_in_browser=True", "--ServerApp.shutdown_no_activity_timeout=0"]
        self.proc = None
        self.log = self.home / "jupyterlab.log"
        self.started: set[int] = set()

    def api(self, path: str, method: str = "GET", timeout_s: float = 10.0):
        import json
        import urllib.request

        request = urllib.request.Request(f"{self.url}{path}", method=method,
                                         headers={"Authorization": f"token {self.token}"})
        with urllib.request.urlopen(request, timeout=timeout_s) as response:
            body = response.read()
        return json.loads(body) if body else None

    def __enter__(self) -> JupyterLab:
        import time

        self._log_file = open(self.log, "wb")  # noqa: SIM115 (closed in __exit__)
        self.proc = subprocess.Popen(self.cmd, cwd=self.root, env=self.env, stdin=subprocess.DEVNULL,
                                     stdout=self._log_file, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + self.timeout_s
        while True:
            if self.proc.poll() is not None:
                self.__exit__(None, None, None)
                raise RuntimeError(f"jupyter lab exited ({self.proc.returncode}): {self.log.read_text()[-3000:]}")
            try:
                self.api("/api/status", timeout_s=2.0)
                return self
            except OSError:
                if time.monotonic() > deadline:
                    self.__exit__(None, None, None)
                    raise RuntimeError(f"jupyter lab did not answer within {self.timeout_s:g} s: "
                                       f"{self.log.read_text()[-3000:]}") from None
                time.sleep(0.25)

    def lab_url(self, path: str) -> str:
        return f"{self.url}/lab/tree/{path}?token={self.token}"

    def kernel_ids(self) -> list[str]:
        """The running kernels' ids; [] while the server cannot list them yet (jupyter_server 2.21 answers 500 to
        /api/kernels while a kernel is still starting: its last_activity is None then), so a poll tries again."""
        import urllib.error

        try:
            return [k["id"] for k in self.api("/api/kernels")]
        except urllib.error.HTTPError as e:
            if e.code == 500:
                return []
            raise

    def note_processes(self) -> None:
        """Remember the server's child processes (its kernels) so that __exit__ can check them gone."""
        if self.proc is not None:
            self.started.update(_children(self.proc.pid))

    def __exit__(self, *exc) -> None:
        import contextlib
        import os
        import signal
        import time

        if self.proc is None:
            return
        self.note_processes()
        with contextlib.suppress(Exception):
            for kernel_id in self.kernel_ids():
                self.api(f"/api/kernels/{kernel_id}", method="DELETE", timeout_s=30.0)
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(timeout=20)
        deadline = time.monotonic() + 20
        while any(_alive(p) for p in self.started) and time.monotonic() < deadline:
            time.sleep(0.1)
        for pid in self.started:                   # a kernel that did not go: kill it, and say so below
            if _alive(pid):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
        self._log_file.close()
        self.leftovers = [p for p in self.started if _alive(p)]


class Kernel:
    """A second client of a kernel that JupyterLab runs (its connection file in the server's runtime folder): the
    test's side channel to the simulator's ground truth. evaluate(expr) returns the JSON value of expr."""

    def __init__(self, lab: JupyterLab, kernel_id: str):
        from jupyter_client import BlockingKernelClient

        self.client = BlockingKernelClient(connection_file=str(lab.runtime_dir / f"kernel-{kernel_id}.json"))
        self.client.load_connection_file()
        self.client.start_channels()
        self.client.wait_for_ready(timeout=60)

    def run(self, code: str, timeout_s: float = 120.0) -> dict:
        reply = self.client.execute_interactive(code, timeout=timeout_s, store_history=False,
                                                output_hook=lambda msg: None)
        if reply["content"]["status"] != "ok":
            raise RuntimeError(f"kernel: {reply['content'].get('ename')}: {reply['content'].get('evalue')}")
        return reply["content"]

    def evaluate(self, expr: str, timeout_s: float = 120.0):
        import ast
        import json

        content = self.client.execute_interactive("import json as _json", timeout=timeout_s, store_history=False,
                                                  user_expressions={"v": f"_json.dumps({expr})"},
                                                  output_hook=lambda msg: None)["content"]
        value = content["user_expressions"]["v"]
        if value["status"] != "ok":
            raise RuntimeError(f"kernel: {expr}: {value.get('ename')}: {value.get('evalue')}")
        return json.loads(ast.literal_eval(value["data"]["text/plain"]))   # the repr of the JSON text

    def close(self) -> None:
        self.client.stop_channels()
