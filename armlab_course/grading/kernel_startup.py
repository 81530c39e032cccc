"""Start-up file of the grader's notebook kernels (its kernelspec runs it with IPKernelApp.exec_files before any cell,
so neither the instructor's nor the student's IPython settings enter). Two jobs:

- Output caps: each write to stdout or stderr is cut at WRITE_LIMIT characters and the whole run at TOTAL_LIMIT, so
  that a cell printing hundreds of MB sends only a little to nbval (its output comparison fails anyway); IPython's
  copy of every cell's stream output into its history (InteractiveShell._tee, IPython 9) is switched off too.
- The checks' machinery guarded: an audit hook (sys.addaudithook: it cannot be removed) compares, before every cell
  runs, the kernel's input and AST transformers, the shell's cell-running methods, the builtins, the callables of
  numpy, math, operator, OpenCV and the kit's modules (as first imported) and the notebook's module aliases (np, cv2,
  ...) with what they were. A cell that follows a change of any of them fails with GraderIntegrityError naming it,
  and so does the grader's probe after each passing cell (armlab_course.grading.nbval_guard): a region that switches
  checks off (an AST transformer turning asserts into pass, a patched np.allclose, a replaced builtin) makes the
  checks fail, not pass.

Everything here is inside one function, deleted after it ran, so the notebook's namespace keeps none of it.
"""


def _armlab_grader_start() -> None:
    import contextlib
    import logging
    import sys
    import types

    # A blank exercise's stand-in says so once per process (a warning of the "armlab.slots" logger, to stderr): in a
    # run of only the cells a check needs (armlab_course.grading.slicing) that line would land in whichever check
    # cell first used the stand-in, and fail its output comparison. A grading run is read by no one: silenced.
    slots_log = logging.getLogger("armlab.slots")
    slots_log.addHandler(logging.NullHandler())
    slots_log.propagate = False

    write_limit, total_limit = 100_000, 20_000_000
    left = [total_limit]

    def capped_stream(stream):
        write = stream.write

        def capped(text):
            if not isinstance(text, str):
                return write(text)
            n = len(text)
            if left[0] <= 0:
                return n
            kept = text[:min(write_limit, left[0])]
            left[0] -= len(kept)
            write(kept if len(kept) == n else kept + f"\n[... {n - len(kept)} characters cut by the grader]\n")
            return n

        stream.write = capped

    for stream in (sys.stdout, sys.stderr):
        capped_stream(stream)
    shell = get_ipython()  # noqa: F821 (a start-up file runs in the kernel's namespace)
    if hasattr(shell, "_tee"):
        shell._tee = lambda channel: contextlib.nullcontext()

    import builtins
    import math
    import operator

    import numpy
    import numpy.linalg
    import numpy.testing

    class GraderIntegrityError(RuntimeError):
        """The kernel's checking machinery was changed by an earlier cell."""

    watched_exact = {"numpy", "numpy.linalg", "numpy.testing", "math", "cmath", "operator", "builtins", "cv2"}
    method_names = ("run_cell", "run_cell_async", "run_ast_nodes", "run_code", "transform_cell", "transform_ast",
                    "showtraceback", "_showtraceback", "should_run_async", "ex", "ev")
    manager = shell.input_transformer_manager

    def watched(name: str) -> bool:
        return name in watched_exact or name in ("armlab", "armlab_course") or \
            name.startswith(("armlab.", "armlab_course."))

    # builtins that IPython and ipykernel themselves swap around each cell (input forwarding, exit, display)
    kernel_managed = {"builtins": {"input", "raw_input", "exit", "quit", "get_ipython", "display", "help",
                                   "copyright", "credits", "license", "breakpoint"}}

    def callables(module) -> dict[str, int]:
        skip = kernel_managed.get(module.__name__, ())
        return {k: id(v) for k, v in list(vars(module).items())
                if callable(v) and not isinstance(v, types.ModuleType) and k not in skip}

    def transformer_state() -> tuple:
        return (id(shell.ast_transformers), tuple(map(id, shell.ast_transformers)),
                id(shell.input_transformers_post), tuple(map(id, shell.input_transformers_post)),
                id(shell.input_transformers_cleanup), tuple(map(id, shell.input_transformers_cleanup)),
                id(shell.input_transformer_manager), tuple(map(id, manager.cleanup_transforms)),
                tuple(map(id, manager.line_transforms)), tuple(map(id, manager.token_transformers)),
                tuple(n for n in method_names if n in vars(shell)),
                tuple(id(getattr(type(shell), n, None)) for n in method_names), id(type(shell)))

    modules: dict[str, tuple[int, dict[str, int]]] = {}
    aliases: dict[str, int] = {}
    base = transformer_state()
    for module in (builtins, math, operator, numpy, numpy.linalg, numpy.testing):
        modules[module.__name__] = (id(module), callables(module))

    def problem() -> str:
        if transformer_state() != base:
            return "the kernel's input or AST transformers, or its cell-running methods, were changed"
        for name, module in list(sys.modules.items()):
            if not watched(name) or module is None:
                continue
            if name not in modules:
                modules[name] = (id(module), callables(module))
                continue
            module_id, ids = modules[name]
            if id(module) != module_id:
                return f"the module {name} was replaced in sys.modules"
            now = vars(module)
            for key, value_id in ids.items():
                if key not in now or id(now[key]) != value_id:
                    return f"{name}.{key} was replaced or deleted"
        for name, value in list(shell.user_ns.items()):
            if name in aliases:
                if id(value) != aliases[name]:
                    return f"the notebook's module alias {name!r} was bound to another object"
            elif isinstance(value, types.ModuleType) and watched(value.__name__):
                aliases[name] = id(value)
        return ""

    def is_cell(code) -> bool:
        filename = getattr(code, "co_filename", "")
        folder = filename.rsplit("/", 2)[-2] if filename.count("/") >= 2 else ""
        return filename.startswith("<ipython-input") or folder.startswith("ipykernel_")

    def audit(event: str, args: tuple) -> None:
        if event == "exec" and args and is_cell(args[0]):
            why = problem()
            if why:
                raise GraderIntegrityError(f"the grader stopped this cell: {why} by an earlier cell, which would "
                                           f"change how the checks judge")

    sys.addaudithook(audit)


_armlab_grader_start()
del _armlab_grader_start
