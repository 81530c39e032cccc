"""Every bad option or path of every subcommand of `python -m armlab` prints one line on stderr and exits non-zero,
before any work: no traceback, nothing written. Each case runs the real command line in its own process (about 1 s
each: only `demo --event` imports the task layer, to read the registered events)."""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from armlab._command_line import output_folder

CASES = [
    ("demo", "--seed", "-1"), ("demo", "--seed", "abc"), ("demo", "--seed", "1.5"), ("demo", "--seed", "9" * 30),
    ("demo", "--out", "A_FILE"), ("demo", "--out", "/proc/x"), ("demo", "--out", ""), ("demo", "--out", " "),
    ("demo", "--out", "A_FILE/sub"), ("demo", "--level", "-1"), ("demo", "--level", "abc"),
    ("demo", "--event", "nope"), ("demo", "--bogus"), ("demo", "--seed"),
    ("colors",), ("colors", "fit", "--frames", "A_FILE"), ("colors", "fit", "--frames", "MISSING"),
    ("colors", "fit", "--frames", ""), ("colors", "fit", "--frames", "EMPTY_DIR"),
    ("colors", "fit", "--out", "EMPTY_DIR"), ("colors", "fit", "--out", "MISSING/model.json"),
    ("colors", "fit", "--out", ""), ("colors", "refit"),
    ("record",), ("record", "MISSING/x.bag"), ("record", "x.mp4"), ("record", "A_BAG"), ("record", ""),
    ("record", "x.bag", "--seconds", "nan"), ("record", "x.bag", "--seconds", "-1"),
    ("record", "x.bag", "--seconds", "inf"), ("record", "x.bag", "--seconds", "abc"),
    ("record", "x.bag", "--warmup-frames", "-1"), ("record", "x.bag", "--warmup-frames", "2.5"),
    ("grade", "MISSING", "--out", "o"), ("grade", "A_FILE", "--out", "o"), ("grade", "EMPTY_DIR"),
    ("grade", "EMPTY_DIR", "--out", "o", "--jobs", "0"), ("grade", "EMPTY_DIR", "--out", "o", "--jobs", "x"),
    ("grade", "EMPTY_DIR", "--out", "o", "--timeout", "nan"), ("grade", "EMPTY_DIR", "--out", "o", "--timeout", "-1"),
    ("exercises", "extra"), ("check", "--bogus"), (), ("nope",),
]


def _run(args: tuple[str, ...], folder: Path) -> subprocess.CompletedProcess:
    names = {"A_FILE": folder / "a_file.txt", "MISSING": folder / "missing", "EMPTY_DIR": folder / "empty",
             "A_BAG": folder / "old.bag"}
    argv = [str(names.get(a.split("/")[0], a)) + ("/" + a.split("/", 1)[1] if "/" in a and a.split("/")[0] in names
                                                 else "") if a.split("/")[0] in names else a for a in args]
    env = {**os.environ, "ARMLAB_DATA": str(folder / "data")}
    return subprocess.run([sys.executable, "-m", "armlab", *argv], cwd=folder, env=env, capture_output=True,
                          text=True, timeout=120)


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "a_file.txt").write_text("not a folder")
    (tmp_path / "old.bag").write_bytes(b"x")
    (tmp_path / "empty").mkdir()
    (tmp_path / "data").mkdir()
    return tmp_path


def test_every_bad_option_or_path_prints_one_line_and_exits_non_zero(folder):
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda a: _run(a, folder), CASES))
    wrong = []
    for args, run in zip(CASES, runs, strict=True):
        lines = run.stderr.strip().splitlines()
        if run.returncode == 0 or len(lines) != 1 or "Traceback" in run.stderr or "np.float64" in run.stderr \
                or not lines[0].startswith("armlab"):
            wrong.append(f"{' '.join(args) or '(no arguments)'}: exit {run.returncode}, stderr {run.stderr!r}")
    print(f"\n{len(CASES)} bad command lines: {len(CASES) - len(wrong)} refused in one line")
    assert not wrong, "\n".join(wrong)
    after = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    assert after == before, "a refused command wrote something"


def test_messages_say_what_is_wrong(folder):
    cases = {("demo", "--seed", "-1"): "--seed: -1 is out of range", ("demo", "--out", ""): "--out is empty",
             ("demo", "--out", "A_FILE"): "is a file, not a folder", ("demo", "--out", "/proc/x"): "cannot create",
             ("colors", "fit", "--frames", "A_FILE"): "is a file, not a folder",
             ("record", "MISSING/x.bag"): "does not exist", ("record", "A_BAG"): "--overwrite",
             ("record", "x.bag", "--seconds", "nan"): "positive, finite"}
    for args, words in cases.items():
        run = _run(args, folder)
        assert words in run.stderr and run.returncode == 2, (args, run.stderr)


def test_output_folder_refuses_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="empty"):
        output_folder("")
    (tmp_path / "f").write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        output_folder(str(tmp_path / "f"))
    assert output_folder(str(tmp_path / "new" / "deeper")).is_dir()


def test_version_prints_the_package_version(tmp_path):
    """`python -m armlab --version` prints the version the package and the CHANGELOG hold (issue 34: only
    `grade --version` did), exit 0, nothing on stderr."""
    import armlab

    run = _run(("--version",), tmp_path)
    assert (run.returncode, run.stdout.strip(), run.stderr) == (0, f"armlab {armlab.__version__}", ""), run
