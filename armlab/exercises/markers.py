"""Exercise regions in source text: `# BEGIN SOLUTION <id>` ... `# END SOLUTION` lines (same indentation, never
nested, never empty), `<id>` a registered exercise (armlab.exercises.registry). A stub replaces a region's body by
one line raising NotImplementedError with the exercise's message (its id, the notebook that teaches it, what to
write), so the surrounding code still imports and runs up to the point of use.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .registry import exercise

__all__ = ["Region", "ExerciseMarkerError", "find_regions", "stub_regions", "stub_line", "is_blank"]

_BEGIN = re.compile(r"^(?P<indent>[ \t]*)# BEGIN SOLUTION(?:[ \t]+(?P<id>\S+))?[ \t]*$")
_END = re.compile(r"^(?P<indent>[ \t]*)# END SOLUTION[ \t]*$")


class ExerciseMarkerError(ValueError):
    """Exercise markers that do not pair up or name no registered exercise: names the file and line."""


@dataclass(frozen=True)
class Region:
    """One exercise region: the lines (0-based, markers included) from begin to end, the markers' indentation and
    the exercise id."""

    begin: int
    end: int
    indent: str
    exercise_id: str


def find_regions(text: str, where: str = "<text>") -> list[Region]:
    """The exercise regions of a source text, in order; ExerciseMarkerError for nested, unclosed, unopened, empty,
    differently indented or unregistered markers (`where` names the file in the message)."""
    regions, open_at, indent, current = [], None, "", ""
    for i, line in enumerate(text.splitlines()):
        begin, end = _BEGIN.match(line), _END.match(line)
        if begin:
            if open_at is not None:
                raise ExerciseMarkerError(f"{where}:{i + 1}: BEGIN SOLUTION inside the region opened at line "
                                          f"{open_at + 1}")
            if not begin["id"]:
                raise ExerciseMarkerError(f"{where}:{i + 1}: BEGIN SOLUTION names no exercise (write "
                                          f"'# BEGIN SOLUTION <id>', an id of armlab.exercises.EXERCISES)")
            try:
                exercise(begin["id"])
            except KeyError as e:
                raise ExerciseMarkerError(f"{where}:{i + 1}: {e.args[0]}") from None
            open_at, indent, current = i, begin["indent"], begin["id"]
        elif end:
            if open_at is None:
                raise ExerciseMarkerError(f"{where}:{i + 1}: END SOLUTION without a BEGIN SOLUTION")
            if end["indent"] != indent:
                raise ExerciseMarkerError(f"{where}:{i + 1}: END SOLUTION indented differently from its BEGIN at "
                                          f"line {open_at + 1}")
            if i == open_at + 1:
                raise ExerciseMarkerError(f"{where}:{i + 1}: empty solution region")
            regions.append(Region(open_at, i, indent, current))
            open_at = None
    if open_at is not None:
        raise ExerciseMarkerError(f"{where}:{open_at + 1}: BEGIN SOLUTION never closed")
    return regions


def stub_line(exercise_id: str) -> str:
    """The one line (without indentation) a blank region of the exercise holds in the student release."""
    return f"raise NotImplementedError({exercise(exercise_id).message()!r})"


def is_blank(text: str, exercise_id: str, where: str = "<text>") -> bool:
    """True when every region of exercise `exercise_id` in a source text still holds only its stub (or the text has
    no region of it): the student has not written it yet."""
    stub = stub_line(exercise_id)
    lines = text.splitlines()
    bodies = [[line.strip() for line in lines[r.begin + 1:r.end] if line.strip()]
              for r in find_regions(text, where) if r.exercise_id == exercise_id]
    return all(body == [stub] for body in bodies)


def stub_regions(text: str, where: str = "<text>") -> str:
    """The text with every region's body replaced by one line raising NotImplementedError(<the exercise's message>);
    the markers stay, so the student writes between them."""
    lines = text.splitlines()
    out, last = [], 0
    for region in find_regions(text, where):
        out += lines[last:region.begin + 1]
        out.append(region.indent + stub_line(region.exercise_id))
        last = region.end
    out += lines[last:]
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")
