"""The committed notebooks keep the promises nbval grading stands on (README, "Grading with nbval"):

- every check cell (a cell with a top-level `assert` outside an exercise region) prints a verdict line starting
  with "OK:", and none carries an nbval marker that would skip or excuse it;
- no stored output prints a computed number at the scale of rounding noise (1e-7 and below in scientific notation),
  which another CPU's last bits would change; such residuals are stated as bounds typed into the cell ("within 1e-9
  mm") instead.

The numbers themselves are checked on other numerics by tools/nbval-numerics (part of `make test`).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))
NOISE_SCALE = re.compile(r"\b\d(\.\d+)?e-(0?[7-9]|[1-9]\d)\b")
FORBIDDEN_ON_CHECKS = ("NBVAL_IGNORE_OUTPUT", "NBVAL_RAISES_EXCEPTION", "NBVAL_SKIP", "NBVAL_CHECK_OUTPUT")


def code_cells(path: Path):
    for cell in json.loads(path.read_text())["cells"]:
        if cell["cell_type"] == "code":
            yield "".join(cell["source"]), cell.get("outputs", [])


def stdout(outputs) -> str:
    return "".join("".join(o.get("text", "")) for o in outputs if o.get("name") == "stdout")


def is_check(source: str) -> bool:
    return "BEGIN SOLUTION" not in source and any(line.startswith("assert ") for line in source.splitlines())


def test_there_are_notebooks_with_checks():
    assert len(NOTEBOOKS) >= 8
    assert sum(is_check(src) for nb in NOTEBOOKS for src, _ in code_cells(nb)) >= 30


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_check_cell_prints_an_ok_verdict_and_is_compared(path):
    for i, (source, outputs) in enumerate(code_cells(path), 1):
        if not is_check(source):
            continue
        lines = stdout(outputs).strip().splitlines()
        assert lines and lines[-1].startswith("OK: "), \
            f"{path.name}, code cell {i}: a check cell must end by printing 'OK: ...', printed {lines[-1:]}"
        markers = [m for m in FORBIDDEN_ON_CHECKS if m in source]
        assert not markers, f"{path.name}, code cell {i}: a check cell carries {markers}: grading must compare it"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_no_stored_output_prints_rounding_noise(path):
    for i, (source, outputs) in enumerate(code_cells(path), 1):
        if "NBVAL_IGNORE_OUTPUT" in source:
            continue
        computed = [m.group(0) for m in NOISE_SCALE.finditer(stdout(outputs)) if m.group(0) not in source]
        assert not computed, f"{path.name}, code cell {i} prints {computed}: values at the scale of rounding " \
                             f"noise differ on another CPU; print a bound instead"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_assert_says_what_is_wrong(path):
    """A bare AssertionError tells a student nothing: every assert in a notebook carries a message."""
    import ast

    bare = []
    for source, _ in code_cells(path):
        try:
            tree = ast.parse(source)
        except SyntaxError:                 # IPython magics: not Python
            continue
        bare += [ast.unparse(n)[:90] for n in ast.walk(tree) if isinstance(n, ast.Assert) and n.msg is None]
    assert not bare, f"{path.name}: asserts without a message: {bare}"
