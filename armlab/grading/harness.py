"""Child side of the hidden checks: `python -m armlab.grading.harness REQUEST.json OUT.json`, run by the grader in a
bounded subprocess of a grading work tree. A request is one job or a list of jobs (several exercises' hidden checks
in one subprocess); each job finds the exercise's function -- in a notebook, by running the code cells in an IPython
shell up to the cell that defines it (prelude "cells"), or only their imports, definitions and literal constants
(prelude "definitions": no simulator run); in the package, by importing it -- calls it (through the spec's adapter,
armlab.grading.hidden.<adapter>, when the exercise is a method or needs built objects) on each case's arguments and
writes the results as JSON (numbers and nested lists, NaN allowed; never pickle). It decides nothing: the grader's
own process compares the results with the values of the reference."""

from __future__ import annotations

import ast
import importlib
import json
import re
import sys
from pathlib import Path

import numpy as np


def _definitions(source: str) -> str:
    """The cell's top-level imports, function and class definitions and assignments of literal constants."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return source                                  # let the shell report it
    keep = []
    for node in tree.body:
        if isinstance(node, (ast.Import, ast.ImportFrom, ast.FunctionDef, ast.ClassDef)):
            keep.append(node)
        elif isinstance(node, ast.Assign):
            try:
                ast.literal_eval(node.value)
                keep.append(node)
            except ValueError:
                pass
    return ast.unparse(ast.Module(body=keep, type_ignores=[]))


def _notebook_function(notebook: Path, name: str, prelude: str = "cells"):
    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance()
    shell.reset(new_session=False)                     # a fresh namespace per job
    shell.enable_gui = lambda gui=None: None      # '%matplotlib inline' outside a kernel: no event loop to start
    defines = re.compile(rf"^(def|class) {re.escape(name)}\b", re.MULTILINE)
    earlier = None
    for cell in json.loads(notebook.read_text(encoding="utf-8"))["cells"]:
        if cell["cell_type"] != "code":
            continue
        source = "".join(cell["source"])
        result = shell.run_cell(_definitions(source) if prelude == "definitions" else source, silent=True)
        if not result.success and earlier is None:
            earlier = result.error_before_exec or result.error_in_exec
        if defines.search(source):
            if not result.success:
                raise RuntimeError(f"the cell defining {name} raised {result.error_in_exec!r} (first error: "
                                   f"{earlier!r})")
            return shell.user_ns[name]
    raise LookupError(f"{notebook.name} defines no function {name}")


def _package_object(dotted: str):
    """The object named by a dotted path: the longest importable module prefix, then attributes."""
    parts = dotted.split(".")
    for k in range(len(parts) - 1, 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for attribute in parts[k:]:
            obj = getattr(obj, attribute)
        return obj
    raise LookupError(f"no module in {dotted!r}")


def _plain(value):
    """A JSON-able copy of a result: arrays and tuples become (nested) lists of floats."""
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return np.asarray(value, dtype=float).tolist()


def run_job(job: dict) -> list[dict]:
    """The results of one job's calls (an error per call, or for every call when the function cannot be found). A
    plain function gets its list arguments as arrays; an adapter gets the JSON arguments as they are."""
    try:
        if job.get("notebook"):
            function = _notebook_function(Path(job["notebook"]), job["function"], job.get("prelude", "cells"))
        else:
            function = _package_object(job["function"])
        adapter = getattr(importlib.import_module("armlab.grading.hidden"), job["adapter"]) if job.get("adapter") \
            else None
    except Exception as e:                                       # the student's cells, reported for every call
        return [{"error": f"{type(e).__name__}: {e}"[:300]} for _ in job["cases"]]
    results = []
    for args in job["cases"]:
        try:
            if adapter is None:
                value = function(*[np.asarray(a) if isinstance(a, list) else a for a in args])
            else:
                value = adapter(function, *args)
            results.append({"value": _plain(value)})
        except Exception as e:                                   # the student's error, reported per case
            results.append({"error": f"{type(e).__name__}: {e}"[:300]})
    return results


def main(request_path: str, out_path: str) -> int:
    request = json.loads(Path(request_path).read_text())
    if isinstance(request, list):
        results = [run_job(job) for job in request]
    else:
        results = run_job(request)
    Path(out_path).write_text(json.dumps(results))
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
