"""Every name the static check forbids (armlab_course.grading.hidden: FORBIDDEN, FORBIDDEN_EVERYWHERE) is a real
object: a
module, or an attribute path in the kit or a library the students have. A misspelt name would forbid nothing."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import pkgutil
from pathlib import Path
from types import ModuleType

import pytest

import armlab
import armlab_course
from armlab_course.exercises import EXERCISES, exercise
from armlab_course.grading import hidden

LIBRARIES = ("cv2", "numpy", "numpy.polynomial", "scipy", "scipy.optimize", "scipy.stats", "scipy.ndimage",
             "scipy.spatial.transform", "modern_robotics")
SKIP = ("armlab.hardware", "armlab.__main__", "armlab_course.grading", "armlab.viz", "armlab.demo")   # side effects or
# hardware on import; none of them holds a forbidden name


_FIELD = object()          # an instance field of a dataclass: a real attribute, though not one of the class


def _modules() -> dict[str, ModuleType]:
    found = {}
    for name in LIBRARIES:
        try:
            found[name] = importlib.import_module(name)
        except ImportError:
            continue
    walked = [*pkgutil.walk_packages(armlab.__path__, "armlab."),
              *pkgutil.walk_packages(armlab_course.__path__, "armlab_course.")]
    for info in walked:
        if info.name.startswith(SKIP):
            continue
        try:
            found[info.name] = importlib.import_module(info.name)
        except ImportError:
            continue
    return found


def _resolves(name: str, modules: dict[str, ModuleType]) -> bool:
    """True when `name` is a module, or a module (named in full or by its last component) followed by attributes, or
    an attribute path starting at any of those modules' names."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        head = ".".join(parts[:k])
        roots = [m for full, m in modules.items() if full == head or full.endswith("." + head)]
        roots += [getattr(m, head) for m in modules.values() if k == 1 and hasattr(m, head)]
        for obj in roots:
            for part in parts[k:]:
                fields = {f.name for f in dataclasses.fields(obj)} if isinstance(obj, type) and \
                    dataclasses.is_dataclass(obj) else set()
                obj = getattr(obj, part, None) if part not in fields else _FIELD
                if obj is None:
                    break
            if obj is not None:
                return True
    return False


def _notebook_names(exercise_id: str) -> set[str]:
    """Names the exercise's notebook binds at top level (a notebook's own helper may be forbidden too)."""
    path = Path(__file__).resolve().parents[2] / "notebooks" / "src" / f"{exercise(exercise_id).notebook}.py"
    if not path.is_file():
        return set()
    names = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
    return names


@pytest.fixture(scope="module")
def modules():
    return _modules()


def test_every_forbidden_name_resolves_to_a_real_object(modules):
    names = {(e, n) for e, ns in hidden.FORBIDDEN.items() for n in ns}
    names |= {("everywhere", n) for n in hidden.FORBIDDEN_EVERYWHERE}
    unresolved = sorted(f"{e}: {n}" for e, n in names if not _resolves(n, modules)
                        and not (e != "everywhere" and n in _notebook_names(e)))
    assert not unresolved, "forbidden names that are no object of the kit or its libraries:\n" + "\n".join(unresolved)


def test_the_resolver_can_fail(modules):
    assert not _resolves("cv2.findHomographyy", modules) and not _resolves("kinematics.no_such_thing", modules)
    assert _resolves("cv2.findHomography", modules) and _resolves("Camera.project", modules)
    assert _resolves("RobotModel.dh", modules) and not _resolves("RobotModel.dhh", modules)


def test_every_exercise_but_a_written_one_has_its_hidden_module():
    for e in EXERCISES:
        if e.kind == "written":
            assert not hidden.specs_of(e.id)
        else:
            assert hidden.module_of(e.id) is not None, f"{e.id}: no module armlab_course.grading.hidden.{e.hidden}"
            assert hidden.specs_of(e.id), f"{e.id}: its hidden module declares no SPECS"
