"""Headless Chromium for tests: render a local HTML page (e.g. a meshcat snapshot) to an RGB image.

WebGL renders in software with SwiftShader (see reference/toolchain.md); `--use-gl=swiftshader` gives a blank page.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

CANDIDATES = ("chromium", "chromium-browser", "google-chrome")


def poll(what, condition, timeout_s=60.0, period_s=0.1):
    """Call condition() until it returns something truthy; AssertionError naming `what` after timeout_s."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")
        time.sleep(period_s)


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


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mask (H, W) of the pixels where RGB pictures a and b (same shape, uint8) differ by more than 40 in a channel:
    what the browser tests count as a visible change of a 3D view."""
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 40


def blank_why(picture: np.ndarray) -> str | None:
    """Why an RGB picture (H, W, 3) uint8 of a 3D view is blank, or None when it shows a scene: quantised to 16
    levels a channel, one colour must cover under 60 % of it, more than 40 colours must occur, and the standard
    deviation of its values must exceed 15 (a grey box, an empty canvas or a lone grid fails)."""
    quantised = (picture // 16).reshape(-1, 3)
    _, counts = np.unique(quantised, axis=0, return_counts=True)
    if counts.max() / counts.sum() >= 0.6:
        return f"one colour covers {counts.max() / counts.sum():.0%} of the picture (a blank or covered scene)"
    if len(counts) <= 40 or picture.std() <= 15:
        return f"the picture is nearly uniform ({len(counts)} colours, standard deviation {picture.std():.1f})"
    return None


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
    under `home`) serving `root` under `base_url` (a JupyterHub's /user/NAME/). Use as a context manager: on exit
    its kernels are shut down, the server is terminated (killed after a timeout) and every process it started is
    checked gone (killed if not). The page exposes the application as `window.jupyterapp`."""

    APP = ("jupyter", "lab")          # python -m APP starts the server
    APP_CLASS = "LabApp"              # whose expose_app_in_browser puts the application in window.jupyterapp
    DOCUMENTS = "lab/tree"            # the page of a document: {base_url}DOCUMENTS/{path}

    def __init__(self, root, home, python: str, timeout_s: float = 120.0, base_url: str = "/"):
        import os
        import secrets

        if not (base_url.startswith("/") and base_url.endswith("/")):
            raise ValueError(f"base_url must start and end with '/', got {base_url!r}")
        self.root, self.home = Path(root), Path(home)
        self.port, self.token = free_port(), secrets.token_hex(16)
        self.base_url = base_url
        self.url = f"http://127.0.0.1:{self.port}{base_url.rstrip('/')}"
        self.timeout_s = timeout_s
        self.runtime_dir = self.home / "runtime"
        settings = self.home / "settings"
        for d in (self.runtime_dir, settings / "@jupyterlab" / "apputils-extension", self.home / "workspaces",
                  self.home / "config", self.home / "data"):
            d.mkdir(parents=True, exist_ok=True)
        (settings / "@jupyterlab" / "apputils-extension" / "notification.jupyterlab-settings").write_text(
            '{"fetchNews": "false", "checkForUpdates": false}')
        # every cell in the page (JupyterLab 4 otherwise leaves out cells scrolled far away: a test reads them all)
        (settings / "@jupyterlab" / "notebook-extension").mkdir(parents=True, exist_ok=True)
        (settings / "@jupyterlab" / "notebook-extension" / "tracker.jupyterlab-settings").write_text(
            '{"windowingMode": "none"}')
        self.env = dict(os.environ, JUPYTER_RUNTIME_DIR=str(self.runtime_dir), JUPYTER_CONFIG_DIR=str(self.home /
                        "config"), JUPYTER_DATA_DIR=str(self.home / "data"), JUPYTERLAB_SETTINGS_DIR=str(settings),
                        JUPYTERLAB_WORKSPACES_DIR=str(self.home / "workspaces"))
        self.env.pop("MPLBACKEND", None)
        self.cmd = [python, "-m", *self.APP, "--no-browser", "--ip=127.0.0.1", f"--port={self.port}",
                    "--port-retries=0", f"--ServerApp.root_dir={self.root}", f"--IdentityProvider.token={self.token}",
                    "--allow-root", f"--{self.APP_CLASS}.expose_app_in_browser=True",
                    "--ServerApp.shutdown_no_activity_timeout=0", f"--ServerApp.base_url={base_url}"]
        self.proc = None
        self.log = self.home / f"{self.APP[-1]}.log"
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
                raise RuntimeError(f"{' '.join(self.APP)} exited ({self.proc.returncode}): "
                                   f"{self.log.read_text()[-3000:]}")
            try:
                self.api("/api/status", timeout_s=2.0)
                return self
            except OSError:
                if time.monotonic() > deadline:
                    self.__exit__(None, None, None)
                    raise RuntimeError(f"{' '.join(self.APP)} did not answer within {self.timeout_s:g} s: "
                                       f"{self.log.read_text()[-3000:]}") from None
                time.sleep(0.25)

    def document_url(self, path: str) -> str:
        """The page that opens the document `path` (relative to root), with the token."""
        return f"{self.url}/{self.DOCUMENTS}/{path}?token={self.token}"

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


class Notebook7(JupyterLab):
    """The same server as Notebook 7 (`python -m notebook`: one document a page, built from JupyterLab 4's
    components). notebook 7.6.5's JupyterNotebookApp has its own expose_app_in_browser (notebook/app.py), and its page
    bundle sets `window.jupyterapp` to the NotebookApp when the page config's exposeAppInBrowser is "true"
    (notebook/static/2343.*.js); a notebook opens at {base_url}notebooks/{path}."""

    APP = ("notebook",)
    APP_CLASS = "JupyterNotebookApp"
    DOCUMENTS = "notebooks"


def wait_for_kernel_info(client, dead, timeout_s: float, name: str = "the kernel") -> None:
    """Wait until `client` (channels started without the heartbeat) gets a kernel_info reply: however long the kernel
    takes to start on a loaded machine. Every 5 s without a reply, dead() (the kernel's owner: its server or its
    process) says whether the kernel died; RuntimeError naming why, or after timeout_s."""
    import time

    deadline = time.monotonic() + timeout_s
    while True:
        msg_id = client.kernel_info()
        try:
            reply = client.get_shell_msg(timeout=5.0)
        except Exception:                 # queue.Empty: no reply yet; a slow kernel, or a dead one (asked below)
            reply = None
        if reply is not None and reply["parent_header"].get("msg_id") == msg_id:
            return
        why = dead()
        if why:
            raise RuntimeError(f"{name} died before replying to kernel_info: {why}")
        if time.monotonic() > deadline:
            raise RuntimeError(f"{name} is alive but sent no kernel_info reply in {timeout_s:g} s")


class Kernel:
    """A second client of a kernel that JupyterLab runs (its connection file in the server's runtime folder): the
    test's side channel to the simulator's ground truth. evaluate(expr) returns the JSON value of expr.

    Whether the kernel is alive is asked of its server (the kernel's process), not of zmq heartbeats: jupyter_client's
    heartbeat gives a kernel 1 s to answer a ping, and the server lists a kernel as soon as it has launched its
    process: a client that connects then, to a kernel still starting (2-3 s here, far longer on a loaded machine),
    gets no answer within 1 s and wait_for_ready() raised "Kernel died before replying to kernel_info" for a live
    kernel (issue 26; tests/test_browser_harness.py). Without the heartbeat channel the client waits for the
    kernel_info reply itself; a kernel that really died is reported by the server's /api/kernels (execution_state
    "dead") or its process being gone."""

    def __init__(self, lab: JupyterLab, kernel_id: str, timeout_s: float = 300.0):
        from jupyter_client import BlockingKernelClient

        self.lab, self.kernel_id = lab, kernel_id
        self.client = BlockingKernelClient(connection_file=str(lab.runtime_dir / f"kernel-{kernel_id}.json"))
        self.client.load_connection_file()
        self.client.start_channels(hb=False)
        wait_for_kernel_info(self.client, self.dead, timeout_s, f"kernel {kernel_id}")

    def dead(self) -> str:
        """Why the server says the kernel is dead, or '' while it lives."""
        import urllib.error

        try:
            state = self.lab.api(f"/api/kernels/{self.kernel_id}").get("execution_state")
        except urllib.error.HTTPError as e:
            return f"the server no longer knows it (HTTP {e.code})" if e.code == 404 else ""
        except OSError:
            return ""                     # the server is slow to answer: not a verdict on the kernel
        return "the server reports it dead" if state == "dead" else ""

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


# -- one port: the browser of a student on a hub -------------------------------------------------------------------
def _splice(a, b) -> None:
    """Copy bytes both ways between sockets a and b until either side closes (two daemon threads)."""
    import socket
    import threading

    def pump(src, dst):
        try:
            while True:
                data = src.recv(65536)
                if not data:
                    break
                dst.sendall(data)
        except OSError:
            pass
        finally:
            for s, how in ((dst, socket.SHUT_WR), (src, socket.SHUT_RD)):
                try:
                    s.shutdown(how)
                except OSError:
                    pass

    for src, dst in ((a, b), (b, a)):
        threading.Thread(target=pump, args=(src, dst), daemon=True).start()


def _serve(listener, connect) -> None:
    """Accept on listener forever; splice each connection with a new connect()."""
    import threading

    def loop():
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            try:
                other = connect()
            except OSError:
                conn.close()
                continue
            _splice(conn, other)

    threading.Thread(target=loop, daemon=True).start()


def relay_inside(port: int, gate: str) -> None:
    """Run inside the namespace: TCP 127.0.0.1:port -> the unix socket `gate` (outside's end). Prints 'ready'."""
    import socket
    import time

    listener = socket.socket()
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", port))
    listener.listen(64)

    def connect():
        s = socket.socket(socket.AF_UNIX)
        s.connect(gate)
        return s

    _serve(listener, connect)
    print("ready", flush=True)
    while True:
        time.sleep(3600)


class OnePort:
    """A network namespace (`unshare -n`, root only) whose one way out is TCP 127.0.0.1:port, forwarded to the same
    port of this machine through a unix socket (which crosses namespaces by path). Whatever runs inside (Chromium,
    through `executable(...)`) reaches JupyterLab's port and nothing else: no meshcat port, no other service.
    why_not() says why it cannot be made here (not root, no unshare/nsenter)."""

    def __init__(self, port: int, workdir):
        self.port, self.workdir = int(port), Path(workdir)
        self.gate = str(self.workdir / "gate.sock")
        self.inner = None
        self.listener = None

    @staticmethod
    def why_not() -> str | None:
        import os

        if os.geteuid() != 0:
            return "a network namespace needs root (unshare -n)"
        for tool in ("unshare", "nsenter", "ip"):
            if shutil.which(tool) is None:
                return f"{tool} is missing (util-linux / iproute2)"
        return None

    def __enter__(self) -> OnePort:
        import socket
        import sys

        self.workdir.mkdir(parents=True, exist_ok=True)
        self.listener = socket.socket(socket.AF_UNIX)
        self.listener.bind(self.gate)
        self.listener.listen(64)
        _serve(self.listener, lambda: socket.create_connection(("127.0.0.1", self.port)))
        code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); import browser; "
                f"browser.relay_inside({self.port}, {self.gate!r})")
        self.inner = subprocess.Popen(["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$0" -c "$1"',
                                       sys.executable, code], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      stdin=subprocess.DEVNULL, text=True)
        line = self.inner.stdout.readline()
        if line.strip() != "ready":
            self.__exit__()
            raise RuntimeError(f"the one-port namespace did not start: {line!r} {self.inner.stderr.read()[-2000:]}")
        return self

    def executable(self, browser_path: str) -> Path:
        """A script that runs `browser_path` with its arguments inside the namespace (for Playwright's
        executable_path: the pipes it talks through are inherited)."""
        script = self.workdir / "chromium-one-port"
        script.write_text(f'#!/bin/sh\nexec nsenter --net=/proc/{self.inner.pid}/ns/net -- {browser_path} "$@"\n')
        script.chmod(0o755)
        return script

    def reaches(self, port: int, timeout_s: float = 5.0) -> bool:
        """True when a TCP connection to 127.0.0.1:port succeeds from inside the namespace."""
        import sys

        probe = (f"import socket; socket.create_connection(('127.0.0.1', {int(port)}), timeout={timeout_s})")
        run = subprocess.run(["nsenter", f"--net=/proc/{self.inner.pid}/ns/net", "--", sys.executable, "-c", probe],
                             capture_output=True, timeout=timeout_s + 30)
        return run.returncode == 0

    def __exit__(self, *exc) -> None:
        if self.inner is not None and self.inner.poll() is None:
            self.inner.kill()
            self.inner.wait(timeout=20)
        for stream in (self.inner.stdout, self.inner.stderr) if self.inner is not None else ():
            stream.close()
        if self.listener is not None:
            self.listener.close()
