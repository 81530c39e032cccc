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
import importlib.util
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


def resolve(name: str, namespaces: tuple[dict, ...] = ()):
    """The object a forbidden name (armlab_course.grading.hidden.FORBIDDEN: dotted, perhaps without its package) refers
    to, or None: the name as given, under armlab, a name bound in one of `namespaces` (a notebook's), or an
    attribute of an armlab module (imported here when no loaded one has it) or of a library module the kit uses."""
    parts = name.split(".")
    for dotted in (name, f"armlab.{name}"):
        try:
            return _package_object(dotted)
        except (LookupError, AttributeError, ImportError, ValueError):
            pass
    for namespace in namespaces:                       # a notebook's own helper (the shell's namespace)
        if parts[0] in namespace:
            obj = namespace[parts[0]]
            try:
                for attribute in parts[1:]:
                    obj = getattr(obj, attribute)
                return obj
            except AttributeError:
                pass
    for loading in (False, True):
        if loading:
            _import_kit_modules(parts[0])
            try:                    # the library whose functions are named bare (IKinSpace, JacobianBody, ...)
                importlib.import_module("modern_robotics")
            except ImportError:
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


def _import_kit_modules(first: str) -> None:
    """Import the kit's modules (armlab.*) named `first` (a file first.py or a package first/), or else those whose
    source defines `first` at top level, found by their files without importing anything else: a forbidden name such
    as "extrinsics._opencv_pose" is then found before any student code runs even when nothing has loaded its module
    yet (else a region importing that module itself would call the kit's function unwatched)."""
    spec = importlib.util.find_spec("armlab")
    if spec is None or not spec.submodule_search_locations:
        return
    defines = re.compile(rf"^(def|class) {re.escape(first)}\b|^{re.escape(first)}\s*[:=]", re.MULTILINE)
    for folder in spec.submodule_search_locations:
        root = Path(folder)
        paths = [*root.rglob(f"{first}.py"), *root.rglob(f"{first}/__init__.py")]
        if not paths:                                       # a bare name: the modules that define it
            paths = [p for p in root.rglob("*.py") if defines.search(p.read_text(encoding="utf-8", errors="replace"))]
        for path in paths:
            parts = path.relative_to(root).with_suffix("").parts
            name = ".".join(("armlab", *(parts[:-1] if parts[-1] == "__init__" else parts)))
            if name.startswith(("armlab.hardware", "armlab.__main__")):
                continue
            try:
                importlib.import_module(name)
            except Exception:                              # a module that cannot load here holds nothing to watch
                continue


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
        self.wanted = list(names)
        self.names: set[str] = set()
        self.wire()
        self.seen: list[str] = []
        self.regions: list[tuple[str, int, int]] = []     # (file, first line, last line) of package regions
        self.active = False
        _Audit.install()

    def wire(self, namespaces: tuple[dict, ...] = ()) -> None:
        """Put tripwires on every forbidden function found now: again after a job's notebook cells have run (the
        notebook's own helpers, modules its cells loaded or reloaded)."""
        for name in self.wanted:
            obj = resolve(name, namespaces)
            targets = self._targets(obj)
            for namespace in namespaces:        # a notebook's own function: its holder is the notebook's namespace
                if isinstance(obj, types.FunctionType) and namespace.get(name.split(".")[0]) is obj:
                    targets = [(namespace, name.split(".")[0], obj)]
            for holder, attribute, original in targets:
                self._install(holder, attribute, original, name)
                self.names.add(name)
        if _Audit.installed:
            _Audit.remember()

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
        if getattr(original, "__armlab_tripwire__", False):   # already wired (found again under another name)
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
        tripwire.__armlab_tripwire__ = True
        CallWatch._installed[id(tripwire)] = known_as
        wired = type(original)(tripwire) if isinstance(original, (staticmethod, classmethod)) else tripwire
        if holder is not None and not isinstance(holder, dict):
            setattr(holder, attribute, wired)
        elif isinstance(holder, dict):
            holder[attribute] = wired
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
            func = inspect.unwrap(func)          # a slot's stand-in wrapper (armlab.slots.standin): the function itself
            lines, start = inspect.getsourcelines(func)
            self.regions.append((inspect.getsourcefile(func) or "", start, start + len(lines)))
        except (OSError, TypeError, ValueError):
            pass

    def _students(self, frame) -> bool:
        """Whether the call made by `frame` is the student's: walking out from it, the first frame that is either
        the student's (a notebook cell, a package region's lines, or code built at run time by exec, eval or
        compile) or the kit's (a file of armlab or of the grader) decides; library frames in between (numpy's
        vectorize, functools, the import system) pass the call on to whoever called them."""
        while frame is not None:
            whose = self._whose(frame)
            if whose is not None:
                return whose
            frame = frame.f_back
        return False

    def _whose(self, frame) -> bool | None:
        """True for the student's frame, False for the kit's, None for a library's. Code built at run time is the
        student's unless a module made it for itself (a dataclass's __init__, a namedtuple's methods: their globals
        are that module's own)."""
        filename = frame.f_code.co_filename
        if filename.startswith("<ipython-input") or \
                any(filename == f and a <= frame.f_lineno <= b for f, a, b in self.regions):
            return True
        if _built_at_run_time(filename):
            name = frame.f_globals.get("__name__", "")
            module = sys.modules.get(name) if name != "__main__" else None
            if module is None or getattr(module, "__dict__", None) is not frame.f_globals:
                return True
            return False if name.split(".")[0] in ("armlab", "armlab_grader", "armlab_course") else None
        return False if _kits(filename) else None

    def __enter__(self):
        CallWatch._active = self
        self.active = True
        return self

    def __exit__(self, *exc) -> None:
        self.active = False
        CallWatch._active = None


def _built_at_run_time(filename: str) -> bool:
    """Code compiled while the program runs (exec, eval, compile: "<string>" and the like) rather than loaded from
    a file; the import system's own frozen modules are not."""
    return filename.startswith("<") and not filename.startswith(("<frozen ", "<ipython-input"))


_KIT_ROOTS: list[str] = []
_KIT_FILES: dict[str, bool] = {}


def _kits(filename: str) -> bool:
    """A file of the kit (the armlab package) or of the grader's child (armlab_grader), outside the regions."""
    if filename not in _KIT_FILES:
        if not _KIT_ROOTS:
            for name in ("armlab", "armlab_grader", "armlab_course"):
                try:
                    spec = importlib.util.find_spec(name)      # (finds a top-level package without importing it)
                except (ImportError, ValueError):
                    continue
                for folder in (spec.submodule_search_locations or []) if spec else []:
                    _KIT_ROOTS.append(os.path.join(os.path.realpath(folder), ""))
        real = os.path.realpath(filename) if os.path.isabs(filename) else filename
        _KIT_FILES[filename] = any(real.startswith(root) for root in _KIT_ROOTS)
    return _KIT_FILES[filename]


class _Audit:
    """A Python audit hook (sys.addaudithook: it cannot be removed, and runs before any student code) that tells the
    active watch of code the student's own code built and ran (exec, eval: noted as "exec/eval/compile"), of a kit
    file's name given to compile() outside the import system (a forged file name), and of a module's code run a
    second time (importlib.reload of a kit module while a region runs, a fresh copy by spec_from_file_location or
    runpy, a module deleted from sys.modules and imported again: "a second copy of <file>"), whose functions would
    carry no tripwire. Outside a call (a notebook's cells before the job) a plain importlib.reload is let be, as the
    job's watch is wired again after the cells (CallWatch.wire); any other second copy is noted for every job."""

    installed = False
    ran: set[str] = set()                 # files whose module code has run (every module loaded when installed)
    loaded: set[str] = set()              # files of the modules loaded when the watches were last wired
    copies: list[str] = []                # second copies made outside a call

    @classmethod
    def install(cls) -> None:
        if cls.installed:
            return
        cls.installed = True
        cls.remember()
        cls.ran |= cls.loaded
        sys.addaudithook(cls.hook)

    @classmethod
    def remember(cls) -> None:
        """Note the files of the modules loaded now."""
        cls.loaded |= {f for m in list(sys.modules.values()) if isinstance(f := getattr(m, "__file__", None), str)}

    @staticmethod
    def _by_import_system(frame) -> bool:
        while frame is not None:
            if frame.f_code.co_filename.startswith("<frozen importlib"):
                return True
            frame = frame.f_back
        return False

    @staticmethod
    def _reloading(frame) -> bool:
        while frame is not None:
            code = frame.f_code
            if code.co_name == "reload" and code.co_filename.endswith(os.path.join("importlib", "__init__.py")):
                return True
            frame = frame.f_back
        return False

    @classmethod
    def _note(cls, watch: CallWatch | None, note: str) -> None:
        if watch is not None:
            watch.seen.append(note)
        else:
            cls.copies.append(note)

    @classmethod
    def hook(cls, event: str, args: tuple) -> None:
        if event not in ("exec", "compile"):
            return
        watch = CallWatch._active
        frame = sys._getframe(1)
        if event == "exec" and args and isinstance(args[0], types.CodeType) and args[0].co_name == "<module>" \
                and os.path.isabs(args[0].co_filename) and _kits(args[0].co_filename):
            filename = args[0].co_filename
            # a kit module run again while a module of that file is, or was, loaded (a failed import tried again
            # is no copy); libraries re-run their own modules (cv2's loader does), so only the kit's count
            loaded = filename in cls.loaded or any(getattr(m, "__file__", None) == filename
                                                   for m in list(sys.modules.values()))
            if filename in cls.ran and loaded and (watch is not None or not cls._reloading(frame)):
                cls._note(watch, f"a second copy of {os.path.basename(filename)}")
            cls.ran.add(filename)
        if event == "compile":
            if len(args) > 1 and isinstance(args[1], str) and os.path.isabs(args[1]) and _kits(args[1]) \
                    and not cls._by_import_system(frame):
                cls._note(watch, f"the kit's {os.path.basename(args[1])} compiled again")   # a forged file name
        elif watch is not None and watch._whose(frame) and not cls._by_import_system(frame):
            watch.seen.append("exec/eval/compile")       # code the student's own code built and ran


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
                    from IPython.core.interactiveshell import InteractiveShell

                    self.watch.wire((InteractiveShell.instance().user_ns,))
                else:
                    function = _package_object(job["function"])
                    for member in ([function] if not isinstance(function, type) else list(vars(function).values())):
                        self.watch.add_region(member)
                    self.watch.wire()
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
        answer.update(nonce=nonce, seq=request["seq"], forbidden=sorted(set(job.watch.seen) | set(_Audit.copies)))
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
