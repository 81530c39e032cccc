"""The meshcat server process: start it, find it, stop it for sure.

One server per Viewer by default; under pytest/nbval the root conftest starts ONE server for the whole session and
hands its zmq URL to every Viewer (and to every notebook kernel, which inherits the environment) through the
environment variable ARMLAB_MESHCAT_ZMQ. Servers started here die with the process that started them, even when that
process is killed outright.
"""

from __future__ import annotations

import os
import re
import select
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import zmq

__all__ = ["ZMQ_ENV", "ServerProcess", "start_server", "server_pids", "probe"]

ZMQ_ENV = "ARMLAB_MESHCAT_ZMQ"
_ENTRY = "armlab.viz._serve"


@dataclass
class ServerProcess:
    """A meshcat server subprocess: its zmq URL (for clients) and web URL (for browsers)."""

    proc: subprocess.Popen = field(repr=False)
    zmq_url: str
    web_url: str

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        """True while the process runs."""
        return self.proc.poll() is None

    def stop(self, timeout_s: float = 10.0) -> None:
        """Kill the process and reap it (idempotent). meshcat's Visualizer has no working close()."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=timeout_s)
        if self.proc.stdout is not None:
            self.proc.stdout.close()


def start_server(timeout_s: float = 30.0) -> ServerProcess:
    """Start a meshcat server that exits when this process dies; returns once it listens (about 0.3 s).

    Ports start at 6000 (zmq) and 7000 (web) and move up when taken. Raises RuntimeError if it does not come up.
    """
    src = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ)
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    proc = subprocess.Popen([sys.executable, "-u", "-m", _ENTRY, str(os.getpid())], stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, start_new_session=True)
    urls: dict[str, str] = {}
    deadline = time.monotonic() + timeout_s
    while len(urls) < 2:
        remaining = deadline - time.monotonic()
        ready = select.select([proc.stdout], [], [], max(remaining, 0))[0] if remaining > 0 else []
        line = proc.stdout.readline().decode() if ready else ""
        match = re.match(r"^(zmq_url|web_url)=(\S+)$", line.strip())
        if match:
            urls[match.group(1)] = match.group(2)
        elif not ready or proc.poll() is not None:
            ServerProcess(proc, "", "").stop()
            why = f"exited with code {proc.returncode}" if not ready or line == "" else f"printed {line!r}"
            raise RuntimeError(f"the meshcat server did not start within {timeout_s:g} s ({why})")
    return ServerProcess(proc, urls["zmq_url"], urls["web_url"])


def probe(zmq_url: str, timeout_s: float = 5.0) -> str:
    """Ask the meshcat server at zmq_url for its web URL; ConnectionError naming the URL if nobody answers."""
    if not isinstance(zmq_url, str) or not re.match(r"^(tcp|ipc)://\S+$", zmq_url):
        raise ValueError(f"not a zmq URL: {zmq_url!r} (expected e.g. tcp://127.0.0.1:6000)")
    socket = zmq.Context.instance().socket(zmq.REQ)
    socket.setsockopt(zmq.LINGER, 0)
    socket.setsockopt(zmq.RCVTIMEO, int(timeout_s * 1000))
    try:
        socket.connect(zmq_url)
        socket.send(b"url")
        return socket.recv().decode()
    except zmq.Again:
        raise ConnectionError(f"no meshcat server answers at {zmq_url} within {timeout_s:g} s (is {ZMQ_ENV} "
                              f"stale? unset it to let the viewer start its own server)") from None
    finally:
        socket.close()


def server_pids(parent_pid: int | None = None) -> list[int]:
    """Pids of running (not zombie) meshcat servers started by start_server, optionally only those of one parent."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        args = [a.decode(errors="replace") for a in argv if a]
        if _ENTRY in args and state not in ("Z", "X"):
            if parent_pid is None or args[-1] == str(parent_pid):
                pids.append(int(entry.name))
    return sorted(pids)
