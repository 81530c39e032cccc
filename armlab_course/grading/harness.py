"""Child side of the hidden checks: `python -m armlab_grader.harness`, run by the grader in the sandbox with the
grading work tree (run.py). Standard input holds the run's key (one line) and the request: {"out": path, "jobs":
[...]}; it is read whole and closed before any student code runs, and nothing of the request is left on disk or in
sys.argv.

Each job finds the exercise's function -- in a notebook, by running the code cells in an IPython shell up to the
cell that defines it (prelude "cells"), or only their imports, definitions and literal constants (prelude
"definitions": no simulator run); in the package, by importing it -- and calls it (through the spec's adapter,
armlab_grader.hidden.<adapter>, when the exercise is a method or needs built objects) on each case's arguments.
Before any student code runs, each job's forbidden functions are replaced by tripwires (CallWatch) that note a
call made from the student's own code, whatever name it was reached by (getattr with a built-up string, an alias,
functools.partial). The results (numbers and nested lists, NaN allowed; never pickle) and the forbidden calls
seen are written signed with the run's key. It decides nothing: the grader's process compares the results with the
values of the reference.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import re
import sys
import types
from pathlib import Path

import numpy as np

from .child_common import close_stdin, read_key, read_rest, write_signed


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


def resolve(name: str):
    """The object a forbidden name (armlab_course.grading.hidden.FORBIDDEN: dotted, perhaps without its package) refers
    to, or None: the name as given, under armlab, or an attribute of a loaded armlab module or of a library module
    the kit uses."""
    parts = name.split(".")
    for dotted in (name, f"armlab.{name}"):
        try:
            return _package_object(dotted)
        except (LookupError, AttributeError, ImportError, ValueError):
            pass
    for module_name in sorted(sys.modules):
        if module_name in ("armlab", "armlab_course") or \
                module_name.startswith(("armlab.", "armlab_course.", "modern_robotics", "scipy.")):
            obj = sys.modules[module_name]
            try:
                for attribute in parts:
                    obj = getattr(obj, attribute)
                return obj
            except AttributeError:
                continue
    return None


class CallWatch:
    """The forbidden functions of a job and the calls of them made directly from student code while it is active.

    Before any student code runs, every forbidden function (a module's functions, a class's methods, a C function)
    is replaced, in its module or class and wherever a loaded module holds it under any name, by a tripwire: a thin
    function that notes the call when the calling frame is the student's, then calls the original. So a call is
    seen whatever name it was reached by (getattr with a built-up string, an alias, functools.partial), at the cost
    of one frame lookup per call of a forbidden function only (a profile hook on every call slowed the simulator's
    open tasks fourfold)."""

    _active: CallWatch | None = None
    _installed: dict[int, set[str]] = {}        # id(original) -> the forbidden names it goes by, for every job

    def __init__(self, names: list[str]) -> None:
        self.names: set[str] = set()
        for name in names:
            for holder, attribute, original in self._targets(resolve(name)):
                self._install(holder, attribute, original, name)
                self.names.add(name)
        self.seen: list[str] = []
        self.regions: list[tuple[str, int, int]] = []     # (file, first line, last line) of package regions
        self.active = False

    @staticmethod
    def _targets(obj) -> list[tuple[object, str, object]]:
        """(holder, attribute, callable) for each function of a forbidden object: a module's own functions and
        classes' methods, a class's methods, or the function itself (held by its module)."""
        if obj is None:
            return []
        if isinstance(obj, types.ModuleType):
            return [t for v in list(vars(obj).values()) if getattr(v, "__module__", None) == obj.__name__
                    and not isinstance(v, types.ModuleType) for t in CallWatch._targets(v)]
        if isinstance(obj, type):
            return [(obj, k, v) for k, v in list(vars(obj).items())
                    if isinstance(v, (types.FunctionType, staticmethod, classmethod))]
        if callable(obj) and not isinstance(obj, type):
            module = sys.modules.get(getattr(obj, "__module__", None) or "")
            name = getattr(obj, "__name__", None)
            if module is not None and name and getattr(module, name, None) is obj:
                return [(module, name, obj)]
            return [(None, name, obj)]
        return []

    def _install(self, holder, attribute: str, original, name: str) -> None:
        """Put a tripwire in place of `original` (once per run), in `holder` and in every loaded module holding it."""
        if id(original) in CallWatch._installed:
            CallWatch._installed[id(original)].add(name)
            return
        inner = original.__func__ if isinstance(original, (staticmethod, classmethod)) else original
        known_as = CallWatch._installed[id(original)] = {name}

        def tripwire(*args, **kwargs):
            watch = CallWatch._active
            if watch is not None and not watch.names.isdisjoint(known_as) and watch._students(sys._getframe(1)):
                watch.seen.append(min(watch.names & known_as))
            return inner(*args, **kwargs)

        for key in ("__name__", "__qualname__", "__doc__", "__module__"):
            try:
                setattr(tripwire, key, getattr(inner, key))
            except (AttributeError, TypeError):
                pass
        wired = type(original)(tripwire) if isinstance(original, (staticmethod, classmethod)) else tripwire
        if holder is not None:
            setattr(holder, attribute, wired)
        if isinstance(holder, type):
            return
        for module in list(sys.modules.values()):         # aliases: `from x import f` in modules already loaded
            try:
                for key, value in list(vars(module).items()):
                    if value is original:
                        setattr(module, key, wired)
            except TypeError:
                continue

    def add_region(self, function) -> None:
        """Count calls made from `function`'s own lines (a package exercise) as the student's."""
        func = getattr(function, "__func__", function)
        try:
            lines, start = inspect.getsourcelines(func)
            self.regions.append((inspect.getsourcefile(func) or "", start, start + len(lines)))
        except (OSError, TypeError):
            pass

    def _students(self, frame) -> bool:
        if frame is None:
            return False
        filename = frame.f_code.co_filename
        if filename.startswith("<ipython-input"):
            return True
        return any(filename == f and a <= frame.f_lineno <= b for f, a, b in self.regions)

    def __enter__(self):
        CallWatch._active = self
        self.active = True
        return self

    def __exit__(self, *exc) -> None:
        self.active = False
        CallWatch._active = None


def _plain(value):
    """A JSON-able copy of a result: arrays and tuples become (nested) lists of floats."""
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return np.asarray(value, dtype=float).tolist()


def run_job(job: dict, watch: CallWatch) -> dict:
    """{"results": per call its value or error (an error for every call when the function cannot be found),
    "forbidden": the forbidden calls `watch` saw}. A plain function gets its list arguments as arrays; an adapter
    gets the JSON arguments as they are."""
    try:
        if job.get("notebook"):
            function = _notebook_function(Path(job["notebook"]), job["function"], job.get("prelude", "cells"))
        else:
            function = _package_object(job["function"])
            for member in ([function] if not isinstance(function, type) else list(vars(function).values())):
                watch.add_region(member)
        adapter = getattr(importlib.import_module("armlab_grader.hidden"), job["adapter"]) if job.get("adapter") \
            else None
    except Exception as e:                                       # the student's cells, reported for every call
        return {"results": [{"error": f"{type(e).__name__}: {e}"[:300]} for _ in job["cases"]], "forbidden": []}
    results = []
    for args in job["cases"]:
        try:
            with watch:
                if adapter is None:
                    value = function(*[np.asarray(a) if isinstance(a, list) else a for a in args])
                else:
                    value = adapter(function, *args)
            results.append({"value": _plain(value)})
        except Exception as e:                                   # the student's error, reported per case
            results.append({"error": f"{type(e).__name__}: {e}"[:300]})
    return {"results": results, "forbidden": sorted(set(watch.seen))}


def main() -> int:
    key = read_key()
    request = json.loads(read_rest())
    close_stdin()
    sys.argv = [""]
    # every job's forbidden functions found before any student code runs (so that none can be swapped first)
    watches = [CallWatch(job.get("forbidden", [])) for job in request["jobs"]]
    out = [run_job(job, watch) for job, watch in zip(request["jobs"], watches, strict=True)]
    write_signed(request["out"], out, key)
    return 0


if __name__ == "__main__":
    sys.exit(main())
