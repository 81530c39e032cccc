"""Child side of the hidden checks: `python -m armlab_grader.harness`, run by the grader in the sandbox with the
grading work tree (run.py), talking to the judge (armlab_course.grading.judge) over its standard input and a
duplicate of its standard output, one plain-data message a line (armlab_grader.wire; docs/grading.md, "The judge").
The first message names the jobs (functions, adapters, forbidden names; no inputs); then each request carries one
call's arguments and gets that call's result. The child holds no seed, generator, reference, scorer or key: it calls
the student's functions on the inputs it is given, nothing is left on disk or in sys.argv, and the student's prints
go to the run's log, not into the answers.

Each job finds the exercise's function -- in a notebook, by running the code cells in an IPython shell up to the
cell that defines it (prelude "cells"), or only their imports, definitions and literal constants (prelude
"definitions": no simulator run); in the package, by importing it -- and calls it (through the spec's adapter,
armlab_grader.adapters.<adapter>, when the exercise is a method or needs built objects) on each case's arguments.
Before any student code runs, each job's forbidden functions are replaced by tripwires (CallWatch) that note a
call made from the student's own code, whatever name it was reached by (getattr with a built-up string, an alias,
functools.partial). The results (numbers, nested lists, arrays as plain data; never pickle) and the forbidden calls
seen go back with each answer. It decides nothing: the judge compares the results with the values of the reference,
or replays and scores what they tell the robot.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import linecache
import os
import re
import sys
import traceback
import types
from pathlib import Path

import numpy as np

from . import wire


def _definitions(source: str) -> str:
    """The cell's top-level imports, function and class definitions and assignments of literal constants, each on its
    own lines (every other line blank, so that a traceback's line numbers are the cell's)."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return source                                  # let the shell report it
    keep, drop = set(), set()
    for node in tree.body:
        first = min([node.lineno, *(d.lineno for d in getattr(node, "decorator_list", []))])
        lines = set(range(first, node.end_lineno + 1))
        kept = isinstance(node, (ast.Import, ast.ImportFrom, ast.FunctionDef, ast.ClassDef))
        if isinstance(node, ast.Assign):
            try:
                ast.literal_eval(node.value)
                kept = True
            except ValueError:
                pass
        (keep if kept else drop).update(lines)
    if keep & drop:                                    # statements sharing a line: kept ones only, renumbered
        return ast.unparse(ast.Module(body=[n for n in tree.body if n.lineno in keep - drop], type_ignores=[]))
    return "\n".join(line if i in keep else "" for i, line in enumerate(source.splitlines(), start=1))


# IPython's file name of each notebook cell run (its code's co_filename) -> the cell as the student knows it
# ("02_forward_kinematics cell 8": the notebook and the code cell's index, as the grader's check names say)
_CELLS: dict[str, str] = {}
MAX_FRAMES = 8


def where(error: BaseException, regions: list[tuple[str, int, int]]) -> list[list]:
    """The student's own frames of `error`'s traceback, innermost last (at most MAX_FRAMES): [place, line,
    function], place being a notebook cell ("02_forward_kinematics cell 8", the line within the cell) or the package
    file of a region ("armlab/kinematics.py", the line within the file). Frames of the kit, of libraries and of the
    grader are left out."""
    frames = []
    for frame in traceback.extract_tb(error.__traceback__):
        if frame.filename in _CELLS:
            frames.append([_CELLS[frame.filename], frame.lineno, frame.name])
        elif any(frame.filename == f and a <= (frame.lineno or 0) <= b for f, a, b in regions):
            frames.append([os.path.relpath(frame.filename), frame.lineno, frame.name])
    return frames[-MAX_FRAMES:]


def _notebook_function(notebook: Path, name: str, prelude: str = "cells"):
    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance()
    shell.reset(new_session=False)                     # a fresh namespace per job
    shell.enable_gui = lambda gui=None: None      # '%matplotlib inline' outside a kernel: no event loop to start
    defines = re.compile(rf"^(def|class) {re.escape(name)}\b", re.MULTILINE)
    earlier = None
    code_cells = [c for c in json.loads(notebook.read_text(encoding="utf-8"))["cells"] if c["cell_type"] == "code"]
    for index, cell in enumerate(code_cells):
        source = "".join(cell["source"])
        before = set(linecache.cache)
        result = shell.run_cell(_definitions(source) if prelude == "definitions" else source, silent=True)
        _CELLS.update((name, f"{notebook.stem} cell {index}") for name in set(linecache.cache) - before
                      if name.startswith("<ipython-input"))
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


def _adapters():
    """The child's adapters (armlab_grader.adapters: plain data into the kit's objects and back), imported by main()
    before any student code runs."""
    return sys.modules["armlab_grader.adapters"]


class _Job:
    """One job of the run: the student's function found once (its error kept and reported for every call), the
    adapter that calls it, and the forbidden calls its watch saw."""

    def __init__(self, job: dict, watch: CallWatch):
        self.job, self.watch = job, watch
        self._loaded: tuple | None = None

    def _load(self) -> tuple:
        if self._loaded is None:
            job = self.job
            try:
                if job.get("notebook"):
                    function = _notebook_function(Path(job["notebook"]), job["function"], job.get("prelude", "cells"))
                else:
                    function = _package_object(job["function"])
                    for member in ([function] if not isinstance(function, type) else list(vars(function).values())):
                        self.watch.add_region(member)
                adapter = getattr(_adapters(), job["adapter"]) if job.get("adapter") else None
                self._loaded = (function, adapter, "")
            except Exception as e:                               # the student's cells, reported for every call
                self._loaded = (None, None, f"{type(e).__name__}: {e}"[:300])
        return self._loaded

    def call(self, args: list) -> dict:
        """{"value": plain data} or {"error": the student's exception in one line, "where": its frames in the
        student's own code (where())}."""
        function, adapter, error = self._load()
        if error:
            return {"error": error}
        args = wire.decode(args)
        try:
            with self.watch:
                if adapter is None:
                    value = function(*[np.asarray(a) if isinstance(a, list) else a for a in args])
                else:
                    value = adapter(function, *args)
            return {"value": wire.encode(_numbers(value))}
        except Exception as e:                                   # the student's error, reported per call
            return {"error": f"{type(e).__name__}: {e}"[:300], "where": where(e, self.watch.regions)}


def _numbers(value):
    """A result as plain data: tuples, lists and dicts element-wise, arrays, strings and None kept (the wire sends
    them), anything else as a float array (TypeError for what is not a number)."""
    if isinstance(value, (tuple, list)):
        return [_numbers(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _numbers(v) for k, v in value.items()}
    if value is None or isinstance(value, (str, np.ndarray)):
        return value
    return np.asarray(value, dtype=float).tolist()


def main() -> int:
    """The child's loop: the first message names the jobs (no inputs); then each request {"seq", "job", "args"}
    gets its answer {"nonce", "seq", "value" or "error", "forbidden"}, until {"end": true} or the pipe closes."""
    reply = os.dup(1)
    os.dup2(2, 1)                      # the student's prints go to the run's log, never into the answers
    sys.argv = [""]
    importlib.import_module("armlab_grader.adapters")
    reader = wire.LineReader(0)
    first = wire.loads(reader.line())
    nonce = str(first["nonce"])
    # every job's forbidden functions found before any student code runs (so that none can be swapped first)
    jobs = [_Job(job, CallWatch(job.get("forbidden", []))) for job in first["jobs"]]
    _write_all(reply, wire.dumps({"nonce": nonce, "ready": len(jobs)}))
    while True:
        try:
            request = wire.loads(reader.line())
        except EOFError:
            return 0
        if request.get("end"):
            return 0
        job = jobs[int(request["job"])]
        answer = job.call(request["args"])
        answer.update(nonce=nonce, seq=request["seq"], forbidden=sorted(set(job.watch.seen)))
        try:
            line = wire.dumps(answer)
        except (TypeError, ValueError) as e:
            line = wire.dumps({"nonce": nonce, "seq": request["seq"], "error": f"unsendable result: {e}"[:300],
                               "forbidden": answer["forbidden"]})
        _write_all(reply, line)


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


if __name__ == "__main__":
    sys.exit(main())
