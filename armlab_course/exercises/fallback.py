"""The course's side of the engine's slots (armlab.slots): stand-ins named by an exercise's declaration.

In the student release a package exercise's region is a stub raising the engine's SlotNotWritten for that exercise
(a notebook exercise's stub raises ExerciseNotWritten, its subclass). So that the simulator, the viewer and the
demonstrations of later notebooks keep working while a student has not written it yet, the kit calls such a
function through a stand-in (armlab.slots.standin; here `reference_fallback` and `with_reference`, which check the
id is a registered exercise): when (and only when) that very exercise's stub is what raised, it says so in one line,
once per exercise, and returns what the kit's own method gives instead -- a different method, never the solution.
In the instructor's repository, and once the student has written the exercise, the stand-in is never used.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from armlab import slots

from .registry import Exercise, ExerciseNotWritten, exercise

__all__ = ["reference_fallback", "with_reference", "require_written", "fallbacks_used"]

F = TypeVar("F", bound=Callable)


def fallbacks_used() -> set[str]:
    """The exercises whose stand-in has answered during this process."""
    return slots.standins_used()


def _declared(which: Exercise | str) -> Exercise:
    return which if isinstance(which, Exercise) else exercise(which)


def reference_fallback(which: Exercise | str, reference: Callable, instead: str) -> Callable[[F], F]:
    """Decorate a function whose work includes the exercise `which` (its declaration, or its id): armlab.slots.standin
    for the exercise's id (KeyError now for an unregistered one). While the exercise is blank, one note (a warning of
    the "armlab.slots" logger, once per exercise) says `instead` is used and reference(*args, **kwargs) answers; any
    other error, including one from a student's own attempt or another exercise's stub, propagates."""
    return slots.standin(_declared(which).id, reference, instead)


def with_reference(function: Callable, which: Exercise | str, reference: Callable, instead: str) -> Callable:
    """For a notebook: the student's `function` for exercise `which`, with `reference` standing in (after one logged
    line saying `instead`) while the exercise's stub is still blank. The notebook's demonstrations call this; its
    check cells call the student's function itself, so they fail until it is written."""
    return reference_fallback(which, reference, instead)(function)


def require_written(which: Exercise | str) -> None:
    """For a check cell: raise the exercise's ExerciseNotWritten while it is blank, so that the check cannot pass on
    the kit's stand-in. A package exercise is blank when its region in the imported package's source still holds
    only the stub; a notebook exercise when the last call of its function (through with_reference) went to the
    stand-in."""
    from pathlib import Path

    from .markers import is_blank

    e = _declared(which)
    if e.in_package:
        source = Path(__file__).resolve().parents[2] / e.where
        blank = is_blank(source.read_text(encoding="utf-8"), e.id, e.where)
    else:
        blank = slots.standing_in(e.id)
    if blank:
        raise ExerciseNotWritten(e.id)
