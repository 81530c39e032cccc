"""The kit's reference path for a package exercise that is still blank.

In the student release a package exercise's region is a stub raising NotImplementedError with the exercise's
message. So that the simulator, the viewer and the demonstrations of later notebooks keep working while a student
has not written it yet, the kit calls such a function through `reference_fallback`: when (and only when) the blank
stub of that very exercise is what raised, it says so in one line, once per exercise, and returns what the kit's
reference path gives instead -- a different method, never the solution (the manufacturer's PoX model for the DH
chain, the tape-measured camera mount for the tag PnP, no depth correction, no sag compensation, ...). In the
instructor's repository, and once the student has written the exercise, the reference is never used.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from typing import TypeVar

from .registry import exercise

__all__ = ["reference_fallback", "with_reference", "require_written", "is_blank_stub", "fallbacks_used"]

F = TypeVar("F", bound=Callable)
_announced: set[str] = set()
_standing_in: set[str] = set()     # exercises whose last call went to the reference


def is_blank_stub(error: BaseException, exercise_id: str) -> bool:
    """True when `error` is the NotImplementedError of exercise `exercise_id`'s blank stub."""
    return isinstance(error, NotImplementedError) and str(error).startswith(f"exercise {exercise_id} (")


def fallbacks_used() -> set[str]:
    """The exercises whose reference path has stood in during this process."""
    return set(_announced)


def reference_fallback(exercise_id: str, reference: Callable, instead: str) -> Callable[[F], F]:
    """Decorate a kit function whose work includes the package exercise `exercise_id`: when the exercise's blank
    stub raises, print one line to stderr (once per exercise) saying `instead` is used, and return
    reference(*args, **kwargs).
    Any other error, including one from a student's own attempt, propagates."""
    exercise(exercise_id)                                  # KeyError now for an unregistered id

    def decorate(function: F) -> F:
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                result = function(*args, **kwargs)
            except NotImplementedError as e:
                if not is_blank_stub(e, exercise_id):
                    raise
                _standing_in.add(exercise_id)
                if exercise_id not in _announced:
                    _announced.add(exercise_id)
                    print(f"note: exercise {exercise_id} (notebook {exercise(exercise_id).notebook_number}) is not "
                          f"written yet: {instead}", file=sys.stderr)
                return reference(*args, **kwargs)
            _standing_in.discard(exercise_id)
            return result

        wrapper.__wrapped_exercise__ = exercise_id
        return wrapper  # type: ignore[return-value]

    return decorate


def with_reference(function: Callable, exercise_id: str, reference: Callable, instead: str) -> Callable:
    """For a notebook: the student's `function` for exercise `exercise_id`, with `reference` standing in (after one
    line on stderr saying `instead`) while the exercise's stub is still blank. The notebook's demonstrations call
    this; its check cells call the student's function itself, so they fail until it is written."""
    return reference_fallback(exercise_id, reference, instead)(function)


def require_written(exercise_id: str) -> None:
    """For a check cell: raise the exercise's own NotImplementedError message while it is blank, so that the check
    cannot pass on the kit's reference path. A package exercise is blank when its region in the imported package's
    source still holds only the stub; a notebook exercise when the last call of its function (through
    with_reference) went to the reference."""
    from pathlib import Path

    from .markers import is_blank

    e = exercise(exercise_id)
    if e.in_package:
        source = Path(__file__).resolve().parents[2] / e.where
        blank = is_blank(source.read_text(encoding="utf-8"), exercise_id, e.where)
    else:
        blank = exercise_id in _standing_in
    if blank:
        raise NotImplementedError(e.message())
