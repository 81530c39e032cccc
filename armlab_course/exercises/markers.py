"""Exercise regions in source text: `# BEGIN SOLUTION <id>` ... `# END SOLUTION` lines (same indentation, never
nested, never empty), `<id>` a registered exercise (armlab_course.exercises.registry). A stub replaces a region's body
by two lines raising the exercise's not-written error (its message: the id, the notebook that teaches it, what to
write; in an engine file the engine's own SlotNotWritten, in a notebook the course's ExerciseNotWritten), so the
surrounding code still imports and runs up to the point of use.

Check cells: a notebook's code cell with a `# CHECK <id> [<id> ...]` line (CHECK_LINE) tests those exercises.

Written answers: a markdown cell holding `<!-- BEGIN ANSWER <id> -->` ... `<!-- END ANSWER -->`; the release
replaces the answer by one prompt line (answer_prompt).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .registry import exercise

__all__ = ["CHECK_LINE", "Region", "ExerciseMarkerError", "find_regions", "stub_regions", "stub_lines", "is_blank",
           "find_answers", "blank_answers", "answer_prompt", "is_blank_answer"]

_BEGIN = re.compile(r"^(?P<indent>[ \t]*)# BEGIN SOLUTION(?:[ \t]+(?P<id>\S+))?[ \t]*$")
_END = re.compile(r"^(?P<indent>[ \t]*)# END SOLUTION[ \t]*$")
CHECK_LINE = re.compile(r"^\s*# CHECK[ \t]+(?P<ids>.+?)\s*$", re.MULTILINE)


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
                                          f"'# BEGIN SOLUTION <id>', an id of armlab_course.exercises.EXERCISES)")
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


def stub_lines(exercise_id: str, where: str = "") -> list[str]:
    """The lines (without indentation) a blank region of the exercise holds in the student release. In an engine file
    (`where` under armlab/) the stub raises the engine's own armlab.slots.SlotNotWritten with the course's message and
    label written in, so the released engine imports no course code; elsewhere (a notebook) it raises the course's
    ExerciseNotWritten."""
    e = exercise(exercise_id)                               # KeyError for an unregistered id
    if where.startswith("armlab/"):
        return ["from armlab.slots import SlotNotWritten", f"raise SlotNotWritten({e.id!r},",
                f"                     {e.message()!r},", f"                     {e.label()!r})"]
    return ["from armlab_course.exercises import ExerciseNotWritten", f"raise ExerciseNotWritten({e.id!r})"]


def is_blank(text: str, exercise_id: str, where: str = "<text>") -> bool:
    """True when every region of exercise `exercise_id` in a source text still holds only a stub (either kind, see
    stub_lines) or the text has no region of it: the student has not written it yet."""
    stubs = [[line.strip() for line in stub_lines(exercise_id, where)] for where in ("", "armlab/")]
    lines = text.splitlines()
    bodies = [[line.strip() for line in lines[r.begin + 1:r.end] if line.strip()]
              for r in find_regions(text, where) if r.exercise_id == exercise_id]
    return all(body in stubs for body in bodies)


def stub_regions(text: str, where: str = "<text>") -> str:
    """The text with every region's body replaced by the stub raising ExerciseNotWritten(<id>); the markers stay, so
    the student writes between them."""
    lines = text.splitlines()
    out, last = [], 0
    for region in find_regions(text, where):
        out += lines[last:region.begin + 1]
        out += [region.indent + line for line in stub_lines(region.exercise_id, where)]
        last = region.end
    out += lines[last:]
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")


# each marker alone on its line (in a notebook source's markdown, after "# "): marker text quoted in prose is not one
_ANSWER = re.compile(r"^(?:# )?<!--[ \t]*BEGIN ANSWER[ \t]+(?P<id>\S+)[ \t]*-->[ \t]*$(?P<body>.*?)"
                     r"^(?:# )?<!--[ \t]*END ANSWER[ \t]*-->[ \t]*$", re.S | re.M)
_ANSWER_OPEN = re.compile(r"^(?:# )?<!--[ \t]*(BEGIN|END) ANSWER\b.*-->[ \t]*$", re.M)


def answer_prompt(exercise_id: str) -> str:
    """The line a blank written answer holds in the student release."""
    e = exercise(exercise_id)
    return f"*Your answer here (exercise {e.id}, {e.points} points, graded by hand).*"


def _answers(text: str, where: str) -> list[re.Match]:
    found = list(_ANSWER.finditer(text))
    if len(_ANSWER_OPEN.findall(text)) != 2 * len(found):
        raise ExerciseMarkerError(f"{where}: answer markers that do not pair up (write '<!-- BEGIN ANSWER <id> -->' "
                                  f"... '<!-- END ANSWER -->')")
    for m in found:
        try:
            if exercise(m["id"]).kind != "written":
                raise ExerciseMarkerError(f"{where}: BEGIN ANSWER {m['id']}: not a written exercise")
        except KeyError as e:
            raise ExerciseMarkerError(f"{where}: {e.args[0]}") from None
    return found


def find_answers(texts, where: str = "<notebook>") -> dict[str, str]:
    """The written answers in markdown texts (a notebook's markdown cells): {exercise id: the answer, stripped}.
    ExerciseMarkerError for markers that do not pair up, an unregistered or non-written id, or an id answered
    twice."""
    out: dict[str, str] = {}
    for text in texts:
        for m in _answers(text, where):
            if m["id"] in out:
                raise ExerciseMarkerError(f"{where}: two answers to {m['id']}")
            out[m["id"]] = m["body"].strip()
    return out


def is_blank_answer(exercise_id: str, answer: str) -> bool:
    """True when a written answer (as find_answers gives it) is empty or still the release's prompt."""
    return answer.strip() in ("", answer_prompt(exercise_id))


def blank_answers(text: str, where: str = "<markdown>") -> str:
    """A markdown text with every written answer replaced by its prompt line (the markers stay)."""
    _answers(text, where)
    return _ANSWER.sub(lambda m: f"<!-- BEGIN ANSWER {m['id']} -->\n\n{answer_prompt(m['id'])}\n\n<!-- END ANSWER -->",
                       text)
