"""Malformed submissions (issue 37): a few hundred notebooks and sources broken at every level -- not JSON, not UTF-8,
wrong shapes, JSON nested 100,000 deep, huge or binary regions, duplicate or unclosed regions, markers hidden behind
odd line breaks, code nested past Python's parser -- go through the submission-reading layer (no notebook runs): each
gives a reason for the exercises of the broken file, never an exception, and whatever it does let through can be
spliced and statically checked. Then `python -m armlab grade` on a class of malformed submissions with hostile folder
names beside one honest one: the honest one scores full, every folder gets its feedback and a row in grades.csv, and
no malformed one runs anything."""

from __future__ import annotations

import copy
import csv
import json
import os
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest

from armlab_course.exercises.markers import stub_regions
from armlab_course.exercises.registry import EXERCISES, exercise
from armlab_course.exercises.release import student_notebook
from armlab_course.grading.splice import RegionRejected, check_body, write_regions
from armlab_course.grading.static import static_check
from armlab_course.grading.submission import (
    MAX_REGION_CHARS,
    exercise_file,
    read_submission,
    region_problem,
    regions_of,
    source_texts,
)

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = "notebooks/02_forward_kinematics.ipynb"
EULER = "fk.euler"
PACKAGE = next(e for e in EXERCISES if e.in_package)
DEEP = 100_000
WEIRD = [0, -1, 1e308, float("nan"), "", "x", None, True, [], {}, [1, "a"], {"source": 3}, [[[]]], "\ud800"]


def _begin(exercise_id: str) -> str:
    return "# BEGIN " + "SOLUTION " + exercise_id      # built so that this file holds no marker line itself


END = "# END " + "SOLUTION"


def _notebook() -> dict:
    """Notebook 02 as the release hands it out (every region a stub: only what a case breaks is written)."""
    return student_notebook(json.loads((ROOT / NOTEBOOK).read_text(encoding="utf-8")), NOTEBOOK)


def _package() -> bytes:
    """The package source of PACKAGE as the release hands it out."""
    return stub_regions((ROOT / exercise_file(PACKAGE)).read_text(encoding="utf-8")).encode()


def _with_region(body: str) -> dict:
    """The instructor's notebook with the first region of EULER replaced by `body` (kept as one source string)."""
    nb = _notebook()
    for cell in nb["cells"]:
        text = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
        if _begin(EULER) in text:
            head, rest = text.split(_begin(EULER), 1)
            cell["source"] = head + _begin(EULER) + "\n" + body + "\n" + END + rest.split(END, 1)[1]
            return nb
    raise AssertionError("no region of fk.euler in notebook 02")


def _paths(value, path=()):
    """Every path into a JSON value (keys and indexes), the value's own first."""
    yield path
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _paths(v, (*path, k))
    elif isinstance(value, list):
        for k, v in enumerate(value[:40]):
            yield from _paths(v, (*path, k))


def _set(value, path, new):
    if not path:
        return new
    target = value
    for part in path[:-1]:
        target = target[part]
    target[path[-1]] = new
    return value


def _dumps(value) -> bytes:
    return json.dumps(value, ensure_ascii=True, allow_nan=True).encode()


def _named_cases() -> list[tuple[str, str, bytes]]:
    """The cases the issue names, and their neighbours: (label, file, bytes)."""
    nb = _notebook()
    region = "\n".join(regions_of(source_texts(ROOT / NOTEBOOK), EULER, NOTEBOOK)[0].splitlines())
    cases = [
        ("cells is a string", NOTEBOOK, _dumps({**nb, "cells": "print(1)"})),
        ("cells holds an integer", NOTEBOOK, _dumps({**nb, "cells": [*nb["cells"][:3], 7]})),
        ("a source is an integer", NOTEBOOK, _dumps({**nb, "cells": [{"cell_type": "code", "source": 5}]})),
        ("a source is a list of integers", NOTEBOOK, _dumps({**nb, "cells": [{"cell_type": "code", "source": [1]}]})),
        ("JSON nested 100,000 deep", NOTEBOOK, b"[" * DEEP + b"]" * DEEP),
        ("objects nested 100,000 deep", NOTEBOOK, b'{"cells": ' + b'{"a": ' * DEEP + b"1" + b"}" * (DEEP + 1)),
        ("not JSON", NOTEBOOK, b"print('hello')\n"),
        ("empty file", NOTEBOOK, b""),
        ("not UTF-8", NOTEBOOK, b'{"cells": [], "x": "\xff\xfe"}'),
        ("a JSON list", NOTEBOOK, b"[1, 2, 3]"),
        ("a JSON string", NOTEBOOK, b'"cells"'),
        ("binary", NOTEBOOK, bytes(range(256)) * 64),
        ("a NUL in the region", NOTEBOOK, _dumps(_with_region("    x = 1\x00\n    return x"))),
        ("a lone surrogate in the region", NOTEBOOK, _dumps(_with_region("    return '\ud800'"))),
        ("a huge region", NOTEBOOK, _dumps(_with_region("    x = 1\n" * (MAX_REGION_CHARS // 8)))),
        ("a region nested past the parser", NOTEBOOK, _dumps(_with_region("    return " + "-" * DEEP + "1"))),
        ("attribute chain past the parser", NOTEBOOK, _dumps(_with_region("    return a" + ".b" * DEEP))),
        ("a region opened twice", NOTEBOOK,
         _dumps(_with_region(f"    {_begin(EULER)}\n{region}"))),
        ("a region never closed", NOTEBOOK,
         _dumps({**nb, "cells": [{"cell_type": "code", "source": f"{_begin(EULER)}\n    return 1\n"}]})),
        ("an END without a BEGIN", NOTEBOOK, _dumps({**nb, "cells": [{"cell_type": "code", "source": f"{END}\n"}]})),
        ("two regions where one is", NOTEBOOK,
         _dumps({**nb, "cells": [*nb["cells"], *[c for c in nb["cells"] if _begin(EULER) in "".join(c["source"])]]})),
        ("a package source not UTF-8", exercise_file(PACKAGE), b"def f():\n    return '\xe9'\n"),
        ("a package source with a NUL", exercise_file(PACKAGE),
         re.sub(rb"(# BEGIN SOLUTION [^\n]*\n)", lambda m: m[1] + b"    x = 1\x00\n", _package())),
        ("a package region never closed", exercise_file(PACKAGE), _package().replace(END.encode(), b"# nothing", 1)),
    ]
    for sep in ("\x0c", "\r", "\x1c", "\u2028", "\x85", "\x0b"):
        cases.append((f"a CHECK tag behind {sep!r}", NOTEBOOK,
                      _dumps(_with_region(f"    x = 1{sep}# CHECK {EULER}\n    return x"))))
    return cases


def _random_cases(n: int, seed: int = 37) -> list[tuple[str, str, bytes]]:
    """n notebooks broken at random: a value anywhere in the JSON replaced by an odd one, the bytes cut or flipped,
    or a random character put into a region."""
    rng = random.Random(seed)
    nb = _notebook()
    paths = list(_paths(nb))
    raw = (ROOT / NOTEBOOK).read_bytes()
    cases = []
    for k in range(n):
        kind = k % 4
        if kind == 0:
            path = rng.choice(paths)
            new = rng.choice(WEIRD)
            cases.append((f"{path} = {new!r}", NOTEBOOK, _dumps(_set(copy.deepcopy(nb), path, new))))
        elif kind == 1:
            cut = rng.randrange(len(raw))
            cases.append((f"cut at byte {cut}", NOTEBOOK, raw[:cut]))
        elif kind == 2:
            data = bytearray(raw)
            for _ in range(rng.randint(1, 8)):
                data[rng.randrange(len(data))] = rng.randrange(256)
            cases.append(("bytes flipped", NOTEBOOK, bytes(data)))
        else:
            char = chr(rng.choice([*range(0, 32), 127, 0x85, 0x2028, 0x2029, 0xD800, 0xDFFF, 0xFEFF]))
            body = f"    x = 1{char}# NBVAL_SKIP{char}{_begin(EULER)}\n    return x" if rng.random() < 0.5 else \
                f"    x = {char!r}{char}\n    return x"
            cases.append((f"region with {char!r}", NOTEBOOK, _dumps(_with_region(body))))
    return cases


CASES = _named_cases() + _random_cases(320)


def _check_read(folder: Path, label: str, name: str) -> dict:
    """read_submission on the folder: never raises; the broken file's exercises are each a problem (a reason), blank
    or regions that can be spliced and statically checked."""
    sub = read_submission(folder, ROOT)
    of_file = [e.id for e in EXERCISES if exercise_file(e) == name]
    for exercise_id in of_file:
        kinds = [exercise_id in sub.problems, exercise_id in sub.blank, exercise_id in sub.bodies,
                 exercise_id in sub.answers]
        assert sum(kinds) == 1, (label, exercise_id, kinds)
        if exercise_id in sub.problems:
            assert isinstance(sub.problems[exercise_id], str) and sub.problems[exercise_id].strip(), label
        for body in sub.bodies.get(exercise_id, []):
            assert region_problem(body) == "", label
            body.encode("utf-8")
            try:
                check_body(body, exercise_id)
            except RegionRejected:
                pass
        if exercise_id in sub.bodies:
            static_check(exercise_id, sub.bodies[exercise_id])
    return {"problems": sub.problems, "bodies": sub.bodies}


def test_a_few_hundred_malformed_submissions_each_get_a_reason(tmp_path):
    assert len(CASES) >= 300
    reasons = 0
    for k, (label, name, data) in enumerate(CASES):
        folder = tmp_path / f"s{k}"
        (folder / name).parent.mkdir(parents=True)
        (folder / name).write_bytes(data)
        got = _check_read(folder, label, name)
        reasons += bool(got["problems"])
    assert reasons > len(CASES) // 2          # most are broken past reading: a reason each


@pytest.mark.parametrize("label, name, data", _named_cases(), ids=[c[0] for c in _named_cases()])
def test_each_case_the_issue_names_is_a_reason_or_a_rejected_region(tmp_path, label, name, data):
    (tmp_path / name).parent.mkdir(parents=True)
    (tmp_path / name).write_bytes(data)
    got = _check_read(tmp_path, label, name)
    of_file = [e.id for e in EXERCISES if exercise_file(e) == name and e.kind != "written"]
    if label.startswith("a CHECK tag behind") and EULER in got["bodies"]:
        with pytest.raises(RegionRejected, match="CHECK"):
            for body in got["bodies"][EULER]:
                check_body(body, EULER)
        return
    broken = [e for e in of_file if e in got["problems"]]
    assert EULER in broken or PACKAGE.id in broken, (label, got["problems"])


def test_files_that_are_no_files_are_reasons(tmp_path):
    """A directory, a FIFO or a symbolic link where the notebook should be: a reason, nothing read or run."""
    for k, make in enumerate((lambda p: p.mkdir(), lambda p: os.mkfifo(p),
                              lambda p: p.symlink_to(ROOT / NOTEBOOK))):
        folder = tmp_path / f"s{k}"
        (folder / "notebooks").mkdir(parents=True)
        make(folder / NOTEBOOK)
        assert EULER in read_submission(folder, ROOT).problems


HOSTILE_NAMES = ["grades.csv", "answers.csv", os.fsdecode(b"odd-\xff\xfe-name"), "-rf", "=HYPERLINK(\"x\")",
                 "line\nbreak", "tab\there", "\x1b[31mred", "a" * 200, "üñí", " spaced ", "dots..."]


def test_a_class_of_malformed_submissions_beside_an_honest_one(tmp_path):
    """`python -m armlab grade --jobs 2`: two dozen malformed submissions (the issue's cases, under hostile folder
    names) and one honest one. The honest one scores full on its exercise, every folder has a row in grades.csv
    and its own feedback naming its problem, and no malformed one ran a check."""
    subs = tmp_path / "subs"
    cases = _named_cases()
    names = HOSTILE_NAMES + [f"malformed-{k:02d}" for k in range(len(cases) - len(HOSTILE_NAMES))]
    for name, (_label, file, data) in zip(names, cases, strict=True):
        folder = subs / name
        (folder / file).parent.mkdir(parents=True)
        (folder / file).write_bytes(data)
    honest = subs / "honest"
    (honest / "notebooks").mkdir(parents=True)
    (honest / NOTEBOOK).write_text(json.dumps(_notebook()))
    write_regions(honest, EULER, regions_of(source_texts(ROOT / NOTEBOOK), EULER, NOTEBOOK))
    done = subprocess.run([sys.executable, "-m", "armlab", "grade", str(subs), "--out", str(tmp_path / "out"),
                           "--jobs", "2", "--timeout", "120"], capture_output=True, text=True, timeout=1500)
    assert done.returncode == 0, done.stderr[-3000:]
    with open(tmp_path / "out" / "grades.csv", newline="", encoding="utf-8") as f:
        rows = {row["student"]: row for row in csv.DictReader(f)}
    assert len(rows) == len(cases) + 1
    assert float(rows["honest"][EULER]) == exercise(EULER).points
    folders = [p for p in (tmp_path / "out").iterdir() if p.is_dir()]
    assert len(folders) == len(cases) + 1
    for folder in folders:
        feedback = (folder / "feedback.md").read_text(encoding="utf-8")
        results = json.loads((folder / "results.json").read_text(encoding="utf-8"))
        if folder.name == "honest":
            continue
        assert results["score"] == 0, (folder.name, results["score"])
        assert "checks passed" not in feedback, folder.name            # nothing of it ran
        assert any(t["output"] not in ("", "not written (blank region)") for t in results["tests"]), folder.name
