"""The kit's reference path for a package exercise that is still blank.

In the student release a package exercise's region is a stub raising ExerciseNotWritten
(armlab_course.exercises.registry)
for that exercise. So that the simulator, the viewer and the demonstrations of later notebooks keep working while a
student has not written it yet, the kit calls such a function through `reference_fallback`: when (and only when) the
ExerciseNotWritten of that very exercise is what raised, it says so in one line, once per exercise, and returns what
the kit's reference path gives instead -- a different method, never the solution (the manufacturer's PoX model for
the DH chain, OpenCV's solvePnP for the tag pose, ...). In the instructor's repository, and once the student has
written the exercise, the reference is never used.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from typing import TypeVar

from .registry import Exercise, ExerciseNotWritten, exercise

__all__ = ["reference_fallback", "with_reference", "require_written", "fallbacks_used"]

F = TypeVar("F", bound=Callable)
# The note that a reference path stands in: a WARNING of the "armlab_course.exercises" logger. With no logging set up (a
# notebook, a script) Python's last-resort handler writes the bare message to stderr; an application that configures
# logging formats, routes or silences it like any other record.
_log = logging.getLogger("armlab_course.exercises")
_announced: set[str] = set()
_standing_in: set[str] = set()     # exercises whose last call went to the reference


def fallbacks_used() -> set[str]:
    """The exercises whose reference path has stood in during this process."""
    return set(_announced)


def _declared(which: Exercise | str) -> Exercise:
    return which if isinstance(which, Exercise) else exercise(which)


def reference_fallback(which: Exercise | str, reference: Callable, instead: str) -> Callable[[F], F]:
    """Decorate a kit function whose work includes the package exercise `which` (its declaration in
    armlab_course.exercises.registry): when that exercise's ExerciseNotWritten is raised, log one line (a warning of the
    "armlab_course.exercises" logger, once per exercise) saying `instead` is used, and return
    reference(*args, **kwargs).
    Any other error, including one from a student's own attempt or another exercise's stub, propagates."""
    declared = _declared(which)                             # KeyError now for an unregistered id

    def decorate(function: F) -> F:
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                result = function(*args, **kwargs)
            except ExerciseNotWritten as e:
                if e.exercise_id != declared.id:
                    raise
                _standing_in.add(declared.id)
                if declared.id not in _announced:
                    _announced.add(declared.id)
                    _log.warning("note: exercise %s (notebook %s) is not written yet: %s", declared.id,
                                 declared.notebook_number, instead)
                return reference(*args, **kwargs)
            _standing_in.discard(declared.id)
            return result

        wrapper.__wrapped_exercise__ = declared.id
        return wrapper  # type: ignore[return-value]

    return decorate


def with_reference(function: Callable, which: Exercise | str, reference: Callable, instead: str) -> Callable:
    """For a notebook: the student's `function` for exercise `which`, with `reference` standing in (after one logged
    line saying `instead`) while the exercise's stub is still blank. The notebook's demonstrations call this; its
    check cells call the student's function itself, so they fail until it is written."""
    return reference_fallback(which, reference, instead)(function)


def require_written(which: Exercise | str) -> None:
    """For a check cell: raise the exercise's ExerciseNotWritten while it is blank, so that the check cannot pass on
    the kit's reference path. A package exercise is blank when its region in the imported package's source still
    holds only the stub; a notebook exercise when the last call of its function (through with_reference) went to
    the reference."""
    from pathlib import Path

    from .markers import is_blank

    e = _declared(which)
    if e.in_package:
        source = Path(__file__).resolve().parents[2] / e.where
        blank = is_blank(source.read_text(encoding="utf-8"), e.id, e.where)
    else:
        blank = e.id in _standing_in
    if blank:
        raise ExerciseNotWritten(e.id)
