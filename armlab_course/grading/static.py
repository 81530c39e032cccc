"""The static check: does a student's region call the library or kit function that would do the exercise for them?

The region's text is parsed with `ast` in the grader's process; nothing is imported or run. The lists live next to
the hidden checks (armlab_course.grading.hidden.FORBIDDEN, FORBIDDEN_EVERYWHERE). A forbidden name counts when the
region
refers to it: a call or attribute (`cv2.findHomography(...)`, `camera.project`), a free name (`fk_pox` after a
`from ... import`), an import of it, or a string naming it (`getattr(cv2, "findHomography")`); the last dotted part
of each listed name is what is compared. Names the region binds itself (its variables, its own functions) and the
exercise's own function names do not count.

Code a region builds or loads at run time is refused too (RUN_TIME_CODE): exec, eval, compile or __import__ by name,
an import of importlib, runpy or builtins, a loader's exec_module, run_path or reload. What they would run cannot be
read here; the harness's audit hook watches them at run time (armlab_course.grading.harness).
"""

from __future__ import annotations

import ast
import textwrap

from armlab_course.exercises.registry import exercise

from .results import STATIC_CHECK, CheckResult

__all__ = ["STATIC_CHECK", "RUN_TIME_CODE", "forbidden_of", "forbidden_uses", "run_time_code", "static_check"]

# names that build, load or run code at run time: builtins by their bare name (`compile` only so: re.compile is
# fine), modules by import, a loader's methods by attribute
RUN_TIME_CODE = {"names": ("exec", "eval", "compile", "__import__", "__builtins__", "globals", "vars"),
                 "modules": ("importlib", "runpy", "builtins", "imp", "code", "codeop"),
                 "attributes": ("exec", "eval", "__import__", "import_module", "reload", "exec_module",
                                "spec_from_file_location", "run_path", "run_module", "load_module", "__builtins__",
                                "__globals__", "__closure__", "__wrapped__")}


def forbidden_of(exercise_id: str) -> tuple[str, ...]:
    """The names forbidden in the exercise's regions (its own list and the ones forbidden everywhere), or () when the
    grader's hidden module is not there (a student release)."""
    try:
        from .hidden import FORBIDDEN, FORBIDDEN_EVERYWHERE
    except ImportError:
        return ()
    return tuple(FORBIDDEN.get(exercise_id, ())) + FORBIDDEN_EVERYWHERE


class Unreadable(ValueError):
    """A region the static check cannot read: nested too deeply for the parser, or too large."""


def _parse(body: str) -> tuple[ast.Module | None, int]:
    """The region's statements, dedented (a region sits inside a function or a loop), and how many lines were put
    before them; None when it does not parse (the notebook run reports that); Unreadable when the parser gives up
    (nesting deeper than Python's recursion limit, memory)."""
    text = textwrap.dedent(body)
    for offset, attempt in ((0, text), (1, "def _region():\n" + textwrap.indent(text, "    "))):
        try:
            return ast.parse(attempt), offset
        except SyntaxError:
            continue
        except (RecursionError, MemoryError) as e:
            raise Unreadable(f"the region is nested too deeply to be checked ({type(e).__name__})") from None
    return None, 0


def _bound(tree: ast.Module) -> set[str]:
    """Names the region binds itself: assignment targets, loop variables, its own functions, classes, arguments."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and isinstance(node.ctx, (ast.Store, ast.Del)):
            names.add(node.id)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
    return names


def forbidden_uses(body: str, names: tuple[str, ...], own: tuple[str, ...] = ()) -> list[tuple[str, int]]:
    """The forbidden `names` (dotted; the last part is compared) the region `body` refers to, each with the line (1 =
    the region's first) of its first use, in the order of `names`."""
    tree, offset = _parse(body)
    if tree is None:
        return []
    wanted = {n.rsplit(".", 1)[-1]: n for n in names}
    skip = _bound(tree) | {o.rsplit(".", 1)[-1] for o in own}
    found: dict[str, int] = {}

    def hit(part: str, node: ast.AST) -> None:
        if part in wanted and wanted[part] not in found:
            found[wanted[part]] = getattr(node, "lineno", 1) - offset

    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            hit(node.attr, node)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load) and node.id not in skip:
            hit(node.id, node)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                for part in alias.name.split("."):
                    hit(part, node)
        elif isinstance(node, ast.ImportFrom):
            for part in (node.module or "").split("."):
                hit(part, node)
            for alias in node.names:
                hit(alias.name, node)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            hit(node.value.rsplit(".", 1)[-1], node)
    return sorted(found.items(), key=lambda item: names.index(item[0]))


def run_time_code(body: str) -> list[tuple[str, int]]:
    """What in the region `body` builds, loads or runs code at run time (RUN_TIME_CODE), each with its line (1 = the
    region's first), in the order found."""
    tree, offset = _parse(body)
    if tree is None:
        return []
    bound = _bound(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load) and node.id in RUN_TIME_CODE["names"] \
                and node.id not in bound:
            found.append((node.id, node.lineno - offset))
        elif isinstance(node, ast.Attribute) and node.attr in RUN_TIME_CODE["attributes"]:
            found.append((node.attr, node.lineno - offset))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            modules = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            found += [(m, node.lineno - offset) for m in modules if m.split(".")[0] in RUN_TIME_CODE["modules"]]
    return sorted(found, key=lambda item: item[1])


def static_check(exercise_id: str, bodies: list[str]) -> CheckResult | None:
    """One check for the exercise's regions: passed when none refers to a forbidden name, else failed with a message
    naming the first; None when the exercise has no list (a student release)."""
    names = forbidden_of(exercise_id)
    if not names:
        return None
    own = exercise(exercise_id).functions
    for k, body in enumerate(bodies, start=1):
        try:
            uses = forbidden_uses(body, names, own)
        except Unreadable as e:
            return CheckResult(STATIC_CHECK, False, f"{e}: write it as plain statements")
        for found, why in ((uses, "the exercise is to write it, not to call the library's or the kit's version"),
                           (run_time_code(body), "a region runs the code written in it, not code it builds or "
                                                 "loads at run time")):
            if found:
                name, line = found[0]
                where = f"region {k}, line {line}" if len(bodies) > 1 else f"line {line} of the region"
                return CheckResult(STATIC_CHECK, False, f"the region uses {name} ({where}): {why}")
    return CheckResult(STATIC_CHECK, True)
