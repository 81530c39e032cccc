"""Session-wide fixtures shared by the unit tests and the nbval notebook runs.

ONE meshcat server serves the whole pytest session: it starts before the first test or notebook that may draw, its
zmq URL goes into os.environ[ARMLAB_MESHCAT_ZMQ] (so every Viewer(), including those in notebook kernels, which
inherit the environment, connects to it instead of starting a server), and it is killed and reaped when the session
ends. If ARMLAB_MESHCAT_ZMQ is already set, that server is used and left alone.

The files that run for minutes start first (START_FIRST): make test hands whole files to its workers
(pytest-xdist's loadfile, with its own reordering off), so a long file handed out last would run alone at the end.

Tests that need an exercise carry `@pytest.mark.exercise("<id>", ...)`. In the instructor's repository they always
run; in a student release (RELEASE_MARKER present) a test whose exercise is still blank is skipped with a reason
naming it, and runs as soon as the student has written it.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from armlab.viz.server import ZMQ_ENV, ServerProcess, start_server
from armlab_course.exercises import exercise
from armlab_course.exercises.markers import is_blank
from armlab_course.exercises.release import RELEASE_MARKER

ROOT = Path(__file__).resolve().parent

# The kit reads a user's own data (armlab._paths.user_data_dir: a refitted colour model, ...) before the packaged
# files. The tests, and the notebook kernels they start (which inherit the environment), see an empty per-user folder
# instead of the machine's, so that their results depend on the repository only.
os.environ["XDG_DATA_HOME"] = tempfile.mkdtemp(prefix="armlab-test-user-data-")

_state: dict[str, ServerProcess | None] = {"server": None}

# The files that take minutes, longest first (test time per file in a make test of 2026-12-03: 395-590 s for the
# first four on a loaded 2-core machine, 130-280 s for the rest); every other file follows in collection order.
# Only the order depends on this list: a stale entry costs time, never a result.
START_FIRST = ("tests/course/test_grading.py", "tests/course/test_hidden_checks_open.py",
               "tests/course/test_grading_hints.py", "tests/course/test_blank_release_runs.py",
               "tests/course/test_grading_attacks.py",
               "tests/test_hub_image.py", "tests/course/test_lab_04_08.py", "tests/test_place_fuzz.py",
               "tests/course/test_grading_self_check.py", "tests/test_station_contract.py",
               "tests/course/test_hidden_checks.py", "tests/course/test_grading_redteam.py",
               "tests/course/test_grading_fuzz.py", "notebooks/07_autonomous_tasks.ipynb",
               "tests/test_station_panel_browser.py", "tests/course/test_release_run_all.py",
               "tests/course/test_grading_tripwire.py", "tests/course/test_written_questions.py")


def _ensure_shared_server() -> str:
    """Start the session's meshcat server once (unless one is given) and export its zmq URL; returns the URL."""
    if _state["server"] is None and not os.environ.get(ZMQ_ENV):
        _state["server"] = start_server()
        os.environ[ZMQ_ENV] = _state["server"].zmq_url
    return os.environ[ZMQ_ENV]


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "exercise(*ids): the test needs these exercises (armlab_course.exercises) written")


def _blank(exercise_id: str) -> bool:
    source = ROOT / exercise(exercise_id).where
    return not source.is_file() or is_blank(source.read_text(), exercise_id, exercise(exercise_id).where)


def _start_rank(item: pytest.Item) -> int:
    try:
        name = item.path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return len(START_FIRST)
    return START_FIRST.index(name) if name in START_FIRST else len(START_FIRST)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items.sort(key=_start_rank)          # stable: each file's tests, and the other files, keep their order
    if not (ROOT / RELEASE_MARKER).is_file():
        return
    for item in items:
        marker = item.get_closest_marker("exercise")
        blank = [i for i in (marker.args if marker else ()) if _blank(i)]
        if blank:
            item.add_marker(pytest.mark.skip(reason=f"needs exercise {', '.join(blank)}, still blank here"))


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
