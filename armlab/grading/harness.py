"""Child side of the hidden checks: `python -m armlab.grading.harness REQUEST.json OUT.json`, run by the grader in a
bounded subprocess of a grading work tree. It finds the exercise's function -- in a notebook, by running the code
cells in an IPython shell up to the cell that defines it; in the package, by importing it -- calls it on each case's
arguments and writes the results as JSON (numbers and nested lists, NaN allowed; never pickle). It decides nothing:
the grader's own process compares the results with the values of the reference."""

from __future__ import annotations

import importlib
import json
import re
import sys
from pathlib import Path

import numpy as np


def _notebook_function(notebook: Path, name: str):
    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance()
    shell.enable_gui = lambda gui=None: None      # '%matplotlib inline' outside a kernel: no event loop to start
    defines = re.compile(rf"^def {re.escape(name)}\(", re.MULTILINE)
    earlier = None
    for cell in json.loads(notebook.read_text(encoding="utf-8"))["cells"]:
        if cell["cell_type"] != "code":
            continue
        source = "".join(cell["source"])
        result = shell.run_cell(source, silent=True)
        if not result.success and earlier is None:
            earlier = result.error_before_exec or result.error_in_exec
        if defines.search(source):
            if not result.success:
                raise RuntimeError(f"the cell defining {name} raised {result.error_in_exec!r} (first error: "
                                   f"{earlier!r})")
            return shell.user_ns[name]
    raise LookupError(f"{notebook.name} defines no function {name}")


def _plain(value):
    """A JSON-able copy of a result: arrays and tuples become (nested) lists of floats."""
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return np.asarray(value, dtype=float).tolist()


def main(request_path: str, out_path: str) -> int:
    request = json.loads(Path(request_path).read_text())
    if request.get("notebook"):
        function = _notebook_function(Path(request["notebook"]), request["function"])
    else:
        module, _, attribute = request["function"].rpartition(".")
        function = getattr(importlib.import_module(module), attribute)
    results = []
    for args in request["cases"]:
        call = [np.asarray(a) if isinstance(a, list) else a for a in args]
        try:
            results.append({"value": _plain(function(*call))})
        except Exception as e:                                   # the student's error, reported per case
            results.append({"error": f"{type(e).__name__}: {e}"[:300]})
    Path(out_path).write_text(json.dumps(results))
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
