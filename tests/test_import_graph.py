"""The package's import graph has no cycle: built with ast from the sources (no module is imported), an edge from
each module to every armlab module it imports, at module level and inside functions (a lazy import still ties the
two modules together). `from pkg import name` is an edge to pkg.name when that is a module, else to pkg. A package
importing its own submodules (its __init__ re-exporting them) is the one allowed way up: edges from a module to the
packages that contain it are not counted, since Python runs those before the module anyway."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "armlab"


def module_names() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The armlab modules `name` (at `path`) imports anywhere in its source."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module
            for a in node.names:
                found.add(f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source)
    return {m for m in found if m in modules and m != name and not name.startswith(m + ".")}


def import_graph() -> dict[str, set[str]]:
    modules = module_names()
    return {name: imports_of(name, path, modules) for name, path in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle [a, b, ..., a] of the directed graph, or None (iterative depth-first search)."""
    state: dict[str, int] = {}          # 1 = on the current path, 2 = done
    for start in sorted(graph):
        if start in state:
            continue
        path, stack = [start], [iter(sorted(graph[start]))]
        state[start] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            elif nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(sorted(graph[nxt])))
    return None


def test_find_cycle_finds_a_cycle_and_accepts_a_tree():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_the_graph_sees_the_imports_it_should():
    graph = import_graph()
    assert "armlab.station.contract" in graph["armlab.sim.arm"]
    assert "armlab.station.contract" in graph["armlab.hardware.interbotix"]
    assert "armlab.kinematics" in graph["armlab.sim.arm"]          # `from armlab import kinematics`
    assert "armlab.tasks.perception" in graph["armlab.tasks.handling"]   # `from . import perception`


def test_armlab_import_graph_is_acyclic():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle in armlab: " + " -> ".join(cycle)


@pytest.mark.parametrize("backend", ["armlab.sim", "armlab.hardware"])
def test_backends_import_the_contract_and_nothing_that_builds_stations(backend):
    graph = import_graph()
    reach, todo = set(), [m for m in graph if m == backend or m.startswith(backend + ".")]
    while todo:
        m = todo.pop()
        if m not in reach:
            reach.add(m)
            todo.extend(graph[m])
    assert "armlab.station.contract" in reach
    assert not reach & {"armlab.station", "armlab.station.registry", "armlab"}, sorted(reach)


def private_uses(path: Path, modules: dict[str, Path]) -> list[str]:
    """`from armlab.x import _name` and `x._name` (x an armlab module imported under that name) in `path`: another
    module's private names. A module's own privates, dunders and the grading harness's hidden checks (which test the
    kit from outside) are not counted."""
    tree = ast.parse(path.read_text(), str(path))
    parts = path.relative_to(ROOT).with_suffix("").parts
    package = parts[:-1]                       # the package a relative import starts from
    aliases, found = {}, []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        source = node.module or ""
        if node.level:
            base = package[:len(package) - (node.level - 1)]
            source = ".".join(base + ((node.module,) if node.module else ()))
        if source.startswith("armlab"):
            for alias in node.names:
                full = f"{source}.{alias.name}"
                if full in modules:
                    aliases[alias.asname or alias.name] = full
                elif alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: from {source} import {alias.name}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("armlab") and alias.asname:
                    aliases[alias.asname] = alias.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases \
                and node.attr.startswith("_") and not node.attr.startswith("__"):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.value.id}.{node.attr}")
    return found


def test_no_module_reads_another_modules_private_names():
    modules = module_names()
    found = [use for name, path in modules.items() if not name.startswith("armlab_course.grading.hidden")
             for use in private_uses(path, modules)]
    assert not found, "private names read across modules:\n" + "\n".join(found)


def test_private_uses_finds_both_forms(tmp_path):
    probe = PACKAGE / "_probe_private_uses.py"
    try:
        probe.write_text("from armlab.calibration.intrinsics import _SUBPIX_CRITERIA\n"
                         "from .calibration.intrinsics import _SUBPIX_CRITERIA as c\n"
                         "from armlab import kinematics\nx = kinematics._wrap(1.0)\n")
        found = private_uses(probe, module_names())
        assert len(found) == 3 and "_SUBPIX_CRITERIA" in found[0] + found[1] and "kinematics._wrap" in found[2], found
    finally:
        probe.unlink()


# -- the seam between the engine and the course ------------------------------------------------------------------

COURSE = "armlab_course"
DISPATCH = "armlab.__main__"     # may hand the grade / check / exercises commands to the course, inside a function


def course_imports(path: Path) -> list[tuple[int, str, bool]]:
    """Every import of the course package in a source file, at any depth: (line, module, at module level)."""
    tree = ast.parse(path.read_text(), str(path))
    top = {id(node) for node in tree.body}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module or ""]
        else:
            continue
        found += [(node.lineno, n, id(node) in top) for n in names if n == COURSE or n.startswith(COURSE + ".")]
    return found


def engine_packages() -> list[str]:
    """armlab's subpackages and the top-level modules (as one group, "armlab")."""
    return ["armlab"] + sorted({m.split(".")[1] for m in module_names() if m.count(".") >= 1
                                and (PACKAGE / m.split(".")[1]).is_dir()})


@pytest.mark.parametrize("package", engine_packages())
def test_the_engine_imports_nothing_of_the_course(package):
    """Per package of the engine: no module imports armlab_course, at module level or inside a function; the one
    exception is the command line's dispatch (armlab/__main__.py), and only lazily, inside a function."""
    modules = {name: path for name, path in module_names().items()
               if (name.split(".")[1] if name.count(".") and (PACKAGE / name.split(".")[1]).is_dir() else "armlab")
               == package}
    assert modules, package
    found = []
    for name, path in sorted(modules.items()):
        for line, module, at_top in course_imports(path):
            if name != DISPATCH or at_top:
                found.append(f"{path.relative_to(ROOT)}:{line}: imports {module}")
    assert not found, "the engine imports the course:\n" + "\n".join(found)


def test_the_seams_check_sees_an_import_of_the_course(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("import os\nfrom armlab_course.exercises import registry\n\n\ndef f():\n"
                     "    import armlab_course.grading.cli\n")
    assert course_imports(probe) == [(2, "armlab_course.exercises", True), (6, "armlab_course.grading.cli", False)]
