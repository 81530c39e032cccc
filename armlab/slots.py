"""Slots: the engine's functions whose work a student writes, and the kit's own method standing in while one is blank.

A slot is named by a plain id (e.g. "fk.dh_link_transform"). While a slot is blank its body raises SlotNotWritten
carrying that id; a kit function decorated with `standin(slot_id, reference, instead)` then logs one line (once per
slot and process) saying what the kit does instead, and returns `reference(*args, **kwargs)`: the kit's own method,
a different one from what the slot asks for (the PoX model for the DH chain, OpenCV's solvePnP for the planar pose,
...). Any other error propagates, including another slot's SlotNotWritten and a student's own NotImplementedError.

The engine knows nothing of the course: the course layer (armlab_course.exercises) subclasses SlotNotWritten for
its exercises and builds its notebook helpers on `standin`; the student release's stubs raise SlotNotWritten with
the course's message baked in. This module imports nothing of armlab either.
"""

from __future__ import annotations

import functools
import importlib
import logging
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["SlotNotWritten", "standin", "standins_used", "standing_in", "is_standin_for", "kit_or_standin"]

F = TypeVar("F", bound=Callable)

# The note that a stand-in answers: a WARNING of the "armlab.slots" logger. With no logging set up (a notebook, a
# script) Python's last-resort handler writes the bare message to stderr; an application that configures logging
# formats, routes or silences it like any other record.
_log = logging.getLogger("armlab.slots")
_announced: set[str] = set()       # slots whose stand-in has answered in this process (noted once each)
_standing_in: set[str] = set()     # slots whose last call went to the stand-in


class SlotNotWritten(NotImplementedError):
    """Raised by a blank slot: `slot_id` says which; `label` names it in the stand-in's note (default "slot <id>");
    the message says what to write where."""

    def __init__(self, slot_id: str, message: str = "", label: str = ""):
        if not isinstance(slot_id, str) or not slot_id:
            raise TypeError(f"a slot id is a non-empty string, got {slot_id!r}")
        self.slot_id = slot_id
        self.label = label or f"slot {slot_id}"
        super().__init__(message or f"{self.label} is not written yet")

    def __reduce__(self):
        return SlotNotWritten, (self.slot_id, str(self), self.label)


def standins_used() -> set[str]:
    """The slots whose stand-in has answered during this process."""
    return set(_announced)


def standing_in(slot_id: str) -> bool:
    """Whether the last call of a function standing in for `slot_id` went to its stand-in."""
    return slot_id in _standing_in


def is_standin_for(function: Callable) -> str:
    """The slot id a function decorated with `standin` stands in for ('' for any other function)."""
    return getattr(function, "__standin_slot__", "")


def standin(slot_id: str, reference: Callable, instead: str) -> Callable[[F], F]:
    """Decorate a kit function whose work includes the slot `slot_id`: when that slot's SlotNotWritten is raised, log
    one line (a warning of the "armlab.slots" logger, once per slot) saying `instead` is used, and return
    reference(*args, **kwargs). Any other error propagates."""
    if not isinstance(slot_id, str) or not slot_id:
        raise TypeError(f"a slot id is a non-empty string, got {slot_id!r}")

    def decorate(function: F) -> F:
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                result = function(*args, **kwargs)
            except SlotNotWritten as e:
                if e.slot_id != slot_id:
                    raise
                _standing_in.add(slot_id)
                if slot_id not in _announced:
                    _announced.add(slot_id)
                    _log.warning("note: %s is not written yet: %s", e.label, instead)
                return reference(*args, **kwargs)
            _standing_in.discard(slot_id)
            return result

        wrapper.__standin_slot__ = slot_id
        return wrapper  # type: ignore[return-value]

    return decorate


def kit_or_standin(module: str, name: str, standin: Any) -> Any:
    """The kit's `name` from `module` (absolute, dotted) where that module is installed -- kit code that answers an
    exercise, which the student release leaves out (the instructor's tree) -- else `standin`, the release's lesser
    method. An import error raised inside an installed module propagates."""
    try:
        found = importlib.import_module(module)
    except ModuleNotFoundError as e:
        if e.name != module:
            raise
        return standin
    return getattr(found, name)
