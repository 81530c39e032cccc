"""The hidden checks (instructor only: not in the student release, see RELEASE_EXCLUDES, and never copied into the
sandbox): per exercise, fresh inputs drawn from the grader's own seed. They run in the judge, the grader's own
process (armlab_course.grading.judge): it sends each call's inputs as plain data to the sandboxed child
(armlab_course.grading.harness), which calls the student's function and answers in plain data; the expected values
come from the same protocol run on the reference work tree before any student code runs; the comparison, and every
open task's replay and score, happen here, so nothing the student's code does can change them.

Each exercise's hidden checks live in a module of their own, named by its declaration (Exercise.hidden, by default
its id with the dot as an underscore: `fk_dh_transform`): SPECS (a tuple of HiddenSpec) and FORBIDDEN (the library
and kit functions that would do the exercise for the student; armlab_course.grading.static reads the region's text for
them, nothing is run). An exercise without such a module is graded by its public checks only.

The adapters a spec names run in the child (armlab_course.grading.adapters, copied into the sandbox): they build what
the student's function takes (a Camera, a colour model, a sim arm, detections) from plain data and turn its result
into plain data. A spec's judge hook (HiddenSpec.judge) runs here.
"""

from __future__ import annotations

import functools
import importlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from armlab_course.exercises.registry import EXERCISES, exercise

__all__ = ["HiddenSpec", "SPECS", "FORBIDDEN", "FORBIDDEN_EVERYWHERE", "specs_of", "cases_of", "compare",
           "how_it_differs", "module_of"]

SEED = 20261101


@dataclass(frozen=True)
class HiddenSpec:
    """function: the name in the exercise's notebook, or the dotted path of a package exercise's function (or class);
    cases: from a numpy Generator, a list of hidden checks, each a list of argument lists (JSON-able: floats, bools,
    lists); atol: the tolerance of the comparison (in the function's units); adapter: the name of a function of
    armlab_course.grading.adapters the child calls as adapter(function, *args) instead of function(*args) ('' for
    none);
    prelude: how the child reaches a notebook function ('cells': every code cell before it runs; 'definitions':
    only their imports, definitions and literal constants, no simulator run); agree: the fraction of a result's
    numbers that must match the expected ones within atol (1.0: all); outcome: an open task graded on outcomes,
    each number of a result a criterion met (1.0) or not (0.0), so the expected value is all ones and the reference
    does not run for it (the kit's tests hold the reference to full marks); judge: the judge-side hook,
    judge(call, *args) -> the value compared, where call(*request_args) asks the child for one call of the function
    (through the adapter) and returns its plain answer (raising judge.ChildError with the student's error): it
    renders inputs, scores answers and, for an open task, replays what the answers tell the robot on the judge's own
    simulator (None: the case's arguments are sent as they are and the answer is the value).

    What a failed check tells the student (compare), in the words of the notebook, never the inputs: `what` the
    numbers compared are and their `unit` (the size of the largest difference is shown in it); or `parts`, the
    (name, unit) of each number of a result in turn (repeating), when they differ (the part that misses most is
    named); or `criteria`, what each number of a pass/fail result (1.0 / 0.0) says, repeating per `per` (e.g.
    "block"): the first one not met is named."""

    function: str
    cases: Callable[[np.random.Generator], list[list[list]]]
    atol: float = 1e-6
    adapter: str = ""
    prelude: str = "cells"
    agree: float = 1.0
    outcome: bool = False
    judge: Callable | None = None
    what: str = "the result"
    unit: str = ""
    parts: tuple[tuple[str, str], ...] = ()
    criteria: tuple[str, ...] = ()
    per: str = ""


# Calls that would do an exercise for the student: a name matches any reference to it in the region (a call, an
# attribute, an import, a string naming it), its last dotted part compared. FORBIDDEN_EVERYWHERE applies to every
# exercise: the kit's reference paths (armlab_course.exercises.references) are never a solution.
FORBIDDEN_EVERYWHERE: tuple[str, ...] = ("armlab_course.exercises.references", "with_reference")


def module_of(exercise_id: str) -> ModuleType | None:
    """The module holding the exercise's hidden checks, None when it has none (a written answer, or no module)."""
    name = exercise(exercise_id).hidden
    if not name:
        return None
    try:
        return importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as e:
        if e.name != f"{__name__}.{name}":
            raise
        return None


def specs_of(exercise_id: str) -> tuple[HiddenSpec, ...]:
    """The exercise's hidden specs (none: an empty tuple)."""
    module = module_of(exercise_id)
    return tuple(module.SPECS) if module is not None else ()


def _all(attribute: str) -> dict:
    out = {}
    for e in EXERCISES:
        module = module_of(e.id)
        if module is not None:
            out[e.id] = getattr(module, attribute)
    return out


def __getattr__(name: str):
    """SPECS and FORBIDDEN (dicts by exercise id, gathered from the exercise modules)."""
    if name == "SPECS":
        return _all("SPECS")
    if name == "FORBIDDEN":
        return _all("FORBIDDEN")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@functools.cache
def cases_of(exercise_id: str) -> list[list[list[list]]] | None:
    """Per spec of the exercise, its hidden checks (each a list of argument lists), or None when it has none (drawn
    once per process; do not modify)."""
    specs = specs_of(exercise_id)
    if not specs:
        return None
    rng = np.random.default_rng([SEED, sum(map(ord, exercise_id))])
    return [json.loads(json.dumps(spec.cases(rng), default=float)) for spec in specs]


def _size(value: float, unit: str) -> str:
    return f"{value:.2g}" + (f" {unit}" if unit else "")


def how_it_differs(spec: HiddenSpec, got: np.ndarray | None, expected: np.ndarray | None) -> str:
    """Which property of a result missed and by how much, in the spec's words and units (see HiddenSpec), without
    the inputs or the expected numbers: a pass/fail result names its first criterion not met; a result of another
    shape says so; else the numbers' (or the part's) largest difference, or for exact results (atol 0) how many of
    them differ."""
    if got is None or expected is None:
        return f"{spec.what}: not a number or an array of numbers"
    if got.shape != expected.shape:
        return f"{spec.what}: shape {got.shape}, expected {expected.shape}"
    if got.size == 0:
        return f"{spec.what}: empty"
    close = np.isclose(got, expected, rtol=0, atol=spec.atol, equal_nan=True).ravel()
    wrong = np.flatnonzero(~close)
    if not wrong.size:
        return f"{spec.what}: too little of it agrees"
    if spec.criteria:
        n = len(spec.criteria)
        first = int(wrong[0])
        where = f"{spec.per} {first // n + 1}: " if spec.per and got.size > n else ""
        return f"{where}not met: {spec.criteria[first % n]} ({len(wrong)} of {got.size} criteria not met)"
    diff = np.abs(got - expected).ravel()
    if np.isnan(diff[wrong]).any():
        return f"{spec.what}: NaN or infinity where a number is expected"
    worst = int(wrong[np.argmax(diff[wrong])])
    what, unit = spec.what, spec.unit
    if spec.parts:
        name, unit = spec.parts[worst % len(spec.parts)]
        what = f"{spec.what} ({name})"
    if spec.atol == 0:
        return f"{spec.what}: {len(wrong)} of its {got.size} numbers differ from the expected"
    return f"{what}: off by up to {_size(float(diff[worst]), unit)} (tolerance {_size(spec.atol, unit)})"


def compare(spec: HiddenSpec, student: list[dict], expected: list[dict] | None, sizes: list[int], first: int = 1
            ) -> list[tuple[bool, str]]:
    """Per hidden check of `spec` (`sizes` calls each, numbered from `first`): passed, and a message naming the
    first call that differs (for an error, with its "at": where in the student's code it was raised, as the grader
    wrote it). `expected`: the reference's results, None for an outcome spec (every number 1.0)."""
    out, k = [], 0
    for i, n in enumerate(sizes, start=first):
        message = ""
        for j in range(k, k + n):
            got = student[j] if j < len(student) else {"error": "no result"}
            if "error" in got:
                message = f"hidden check {i}, call {j - k + 1}{got.get('at', '')}: raised {got['error']}"
                break
            try:
                a = np.asarray(got["value"], dtype=float)
                b = np.ones_like(a) if expected is None else np.asarray(expected[j]["value"], dtype=float)
                comparable = a.shape == b.shape and (a.size > 0 or expected is not None)   # an outcome: some
                close = np.isclose(a, b, rtol=0, atol=spec.atol, equal_nan=True) if comparable else None
                same = close is not None and (close.all() if spec.agree >= 1 else close.mean() >= spec.agree)
            except (ValueError, TypeError):
                same, a, b = False, None, None
            if not same:
                message = f"hidden check {i}, call {j - k + 1}: {how_it_differs(spec, a, b)}"
                if spec.agree < 1:
                    message += f" (fewer than {spec.agree:.0%} of it agrees)"
                break
        out.append((not message, message))
        k += n
    return out
