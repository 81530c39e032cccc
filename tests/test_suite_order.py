"""The suite's own scheduling (conftest.py): every file START_FIRST names exists, so that a renamed long file is not
silently handed out last again, and collection puts those files first, in that order."""

from __future__ import annotations

import subprocess
import sys

from conftest import ROOT, START_FIRST


def test_every_file_started_first_exists():
    missing = [name for name in START_FIRST if not (ROOT / name).is_file()]
    assert not missing, f"conftest.START_FIRST names files that do not exist: {missing}"


def test_collection_starts_with_the_long_files():
    listed = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "tests", "notebooks", "--nbval"],
                            cwd=ROOT, capture_output=True, text=True, timeout=600).stdout.splitlines()
    files = list(dict.fromkeys(line.split("::")[0] for line in listed if "::" in line))
    assert files[:len(START_FIRST)] == list(START_FIRST), files[:len(START_FIRST) + 2]
