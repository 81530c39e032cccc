"""The suite's own scheduling (conftest.py): every file START_FIRST names exists (in a student release: every one the
release carries), so that a renamed long file is not silently handed out last again, and collection puts those files
first, in that order."""

from __future__ import annotations

import subprocess
import sys

from armlab_course.exercises.release import RELEASE_MARKER, released
from conftest import ROOT, START_FIRST


def test_every_file_started_first_exists():
    in_release = (ROOT / RELEASE_MARKER).is_file()
    expected = [name for name in START_FIRST if released(name)] if in_release else list(START_FIRST)
    missing = [name for name in expected if not (ROOT / name).is_file()]
    assert not missing, f"conftest.START_FIRST names files that do not exist: {missing}"


def test_collection_starts_with_the_long_files():
    listed = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "tests", "notebooks", "--nbval"],
                            cwd=ROOT, capture_output=True, text=True, timeout=600).stdout.splitlines()
    files = list(dict.fromkeys(line.split("::")[0] for line in listed if "::" in line))
    collected = [name for name in START_FIRST if name in files]       # (a release skips some whole files)
    assert collected and files[:len(collected)] == collected, files[:len(collected) + 2]
