"""Session-wide fixtures shared by the unit tests and the nbval notebook runs.

ONE meshcat server serves the whole pytest session: it starts before the first test or notebook that may draw, its
zmq URL goes into os.environ[ARMLAB_MESHCAT_ZMQ] (so every Viewer(), including those in notebook kernels, which
inherit the environment, connects to it instead of starting a server), and it is killed and reaped when the session
ends. If ARMLAB_MESHCAT_ZMQ is already set, that server is used and left alone.
"""

from __future__ import annotations

import os

import pytest

from armlab.viz.server import ZMQ_ENV, ServerProcess, start_server

_state: dict[str, ServerProcess | None] = {"server": None}


def _ensure_shared_server() -> str:
    """Start the session's meshcat server once (unless one is given) and export its zmq URL; returns the URL."""
    if _state["server"] is None and not os.environ.get(ZMQ_ENV):
        _state["server"] = start_server()
        os.environ[ZMQ_ENV] = _state["server"].zmq_url
    return os.environ[ZMQ_ENV]


def pytest_collection_finish(session: pytest.Session) -> None:
    # Notebook cells (nbval items) take no fixtures: start the server before their kernels start.
    if any(str(item.path).endswith(".ipynb") for item in session.items):
        _ensure_shared_server()


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    server, _state["server"] = _state["server"], None
    if server is not None:
        server.stop()
        if os.environ.get(ZMQ_ENV) == server.zmq_url:
            del os.environ[ZMQ_ENV]
        _state["stopped"] = server


def pytest_terminal_summary(terminalreporter) -> None:
    server = _state.get("stopped")
    if server is not None:
        state = "still running!" if server.alive() else "stopped"
        terminalreporter.write_line(f"meshcat: the session's shared server (pid {server.pid}) {state}")


@pytest.fixture(scope="session", autouse=True)
def meshcat_server() -> str:
    """The zmq URL of the session's shared meshcat server (every Viewer() in the session connects to it)."""
    return _ensure_shared_server()
