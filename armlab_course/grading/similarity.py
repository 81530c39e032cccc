"""Similarity of exercise regions, the way courses check for copying (MOSS's winnowing, JPlag's normalised tokens):
each student's region of an exercise against the instructor's reference region and against every classmate's region
of the same exercise. `write_similarity` writes OUT/similarity.csv (every pair compared) and OUT/similarity.md (one
line per flagged pair, for the instructor's eyes only: it is not in any student's folder).

Method (stdlib only, deterministic):
- tokens: Python's own `tokenize` reads the region's text; every identifier becomes `N`, every number `0`, every
  string (f-strings whole) `S`; keywords and operators stay as written; comments, line breaks, indentation,
  grouping parentheses and trailing commas are dropped. Renaming variables, changing constants and reflowing the
  layout (by hand or by a formatter) change nothing.
- fingerprints: the k-grams of tokens (K tokens) hashed with BLAKE2b (the same hash in every process, unlike Python's
  `hash`), then winnowed (Schleimer, Wilkerson and Aiken 2003): the least hash of every window of W consecutive
  k-grams, the rightmost on ties. Any run of at least K + W - 1 tokens shared by two regions shares a fingerprint.
- score of two regions: the share of the smaller one's fingerprints found in the other, |A & B| / min(|A|, |B|)
  (JPlag's "maximum similarity"): symmetric; 1 for a copy; a copy padded with code of one's own keeps its score.

An exercise with several regions is compared as the union of their fingerprints. Blank regions (the release's stub)
and regions too short to fingerprint (fewer than MIN_FINGERPRINTS) are never compared: they give no row.
"""

from __future__ import annotations

import hashlib
import io
import keyword
import textwrap
import tokenize
from collections.abc import Iterable
from pathlib import Path

from armlab_course.exercises.markers import stub_lines
from armlab_course.exercises.registry import exercise

from .csv_cells import csv_text
from .report import atomic_write
from .submission import Submission, exercise_file, regions_of, source_texts

__all__ = ["K", "W", "MIN_FINGERPRINTS", "FLAG_AT", "REFERENCE", "tokens", "fingerprints", "score",
           "similarity_rows", "similarity_csv", "flagged_md", "reference_bodies", "write_similarity"]

K = 8                   # tokens per k-gram: shorter shared runs are noise (`N = N . N ( N , N )` is 8 tokens)
W = 4                   # winnowing window: every shared run of K + W - 1 = 11 tokens is found
MIN_FINGERPRINTS = 3    # a region with fewer (under about a dozen tokens: `return np.zeros(3)` is 7) is not compared
FLAG_AT = 0.8           # a score from here on is a line in OUT/similarity.md
REFERENCE = "reference"  # the `matched` cell of a comparison with the instructor's reference

_DROPPED = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER,
            tokenize.ENCODING}
_FSTRING_START = getattr(tokenize, "FSTRING_START", None)      # Python 3.12+: f-strings come in pieces
_FSTRING_END = getattr(tokenize, "FSTRING_END", None)


def _normalised(text: str) -> list[str]:
    """The normalised tokens of `text`; tokenize.TokenError or SyntaxError (IndentationError) where it stops."""
    out: list[str] = []
    depth = 0                                                # inside an f-string (3.12+): one `S` for all of it
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if _FSTRING_START is not None and tok.type == _FSTRING_START:
            depth += 1
            if depth == 1:
                out.append("S")
        elif _FSTRING_END is not None and tok.type == _FSTRING_END:
            depth -= 1
        elif depth or tok.type in _DROPPED:
            continue
        elif tok.type == tokenize.NAME:
            out.append(tok.string if keyword.iskeyword(tok.string) else "N")
        elif tok.type == tokenize.NUMBER:
            out.append("0")
        elif tok.type == tokenize.STRING:
            out.append("S")
        else:
            out.append(tok.string)
    return out


def _layout_free(toks: list[str]) -> list[str]:
    """`toks` without what a formatter adds or removes: grouping parentheses (a `(` not after a name or a closing
    bracket, so not a call, with its `)`) and a comma right before a closing bracket."""
    out: list[str] = []
    opened: list[bool] = []                                  # per open `(`: kept (a call) or dropped (a group)
    previous = ""
    for i, tok in enumerate(toks):
        if tok == "(":
            opened.append(previous in ("N", ")", "]"))
            keep = opened[-1]
        elif tok == ")":
            keep = opened.pop() if opened else True
        else:
            keep = not (tok == "," and i + 1 < len(toks) and toks[i + 1] in (")", "]", "}"))
        if keep:
            out.append(tok)
        previous = tok
    return out


def tokens(body: str) -> list[str]:
    """The normalised tokens of a region body (Python source, maybe indented). A body `tokenize` cannot read whole
    (an unclosed bracket, inconsistent indentation) is read line by line, a line it cannot read being left out."""
    text = textwrap.dedent(body)
    try:
        return _layout_free(_normalised(text))
    except (tokenize.TokenError, SyntaxError):
        out: list[str] = []
        for line in text.splitlines():
            try:
                out += _normalised(line.strip() + "\n")
            except (tokenize.TokenError, SyntaxError):
                continue
        return _layout_free(out)


def _hash(gram: list[str]) -> int:
    return int.from_bytes(hashlib.blake2b("\x1f".join(gram).encode(), digest_size=8).digest(), "big")


def fingerprints(bodies: Iterable[str]) -> frozenset[int]:
    """The winnowed k-gram hashes of the region bodies (k-grams never span two regions)."""
    out: set[int] = set()
    for body in bodies:
        toks = tokens(body)
        hashes = [_hash(toks[i:i + K]) for i in range(len(toks) - K + 1)]
        chosen = -1
        for start in range(max(len(hashes) - W + 1, 1 if hashes else 0)):
            window = hashes[start:start + W]
            least = min(window)
            position = start + max(i for i, h in enumerate(window) if h == least)
            if position != chosen:
                out.add(least)
                chosen = position
    return frozenset(out)


def score(a: frozenset[int], b: frozenset[int]) -> float:
    """|a & b| / min(|a|, |b|), in [0, 1]; 0 when either is empty."""
    smaller = min(len(a), len(b))
    return len(a & b) / smaller if smaller else 0.0


def _comparable(bodies: list[str], exercise_id: str) -> frozenset[int] | None:
    """The fingerprints of an exercise's written regions; None when there is nothing to compare (every region blank,
    or too short)."""
    stub = stub_lines(exercise_id)
    written = [b for b in bodies if [line.strip() for line in b.splitlines() if line.strip()] != stub]
    prints = fingerprints(written)
    return prints if len(prints) >= MIN_FINGERPRINTS else None


def similarity_rows(students: dict[str, dict[str, list[str]]], reference: dict[str, list[str]]
                    ) -> list[tuple[str, str, str, float]]:
    """(student, exercise, matched, score) for each student's written exercise against the reference (`matched` is
    REFERENCE) and against each classmate who wrote it (their name; a classmate named like REFERENCE is written
    `./reference`). students: per student, per exercise id, its region bodies; reference: the instructor's, per
    exercise id. Rows sorted: by student, exercise, the reference first, then classmates by name; scores to 3
    decimals."""
    rows = []
    exercise_ids = sorted({e for bodies in students.values() for e in bodies})
    for exercise_id in exercise_ids:
        prints = {s: p for s in sorted(students) if exercise_id in students[s]
                  for p in [_comparable(students[s][exercise_id], exercise_id)] if p is not None}
        ref = _comparable(reference.get(exercise_id, []), exercise_id)
        for student, mine in prints.items():
            if ref is not None:
                rows.append((student, exercise_id, REFERENCE, round(score(mine, ref), 3)))
            rows += [(student, exercise_id, f"./{other}" if other == REFERENCE else other,
                      round(score(mine, theirs), 3)) for other, theirs in prints.items() if other != student]
    return sorted(rows, key=lambda r: (r[0], r[1], r[2] != REFERENCE, r[2]))


def similarity_csv(rows: list[tuple[str, str, str, float]]) -> str:
    """OUT/similarity.csv: student, exercise, matched, score (student-controlled names neutralised: csv_cells)."""
    return csv_text(["student", "exercise", "matched", "score"], rows)


def _plain(name: str) -> str:
    """A student-controlled name on one line of markdown: control characters escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in name)


def flagged_md(rows: list[tuple[str, str, str, float]]) -> str:
    """OUT/similarity.md: for the instructor only, one line per comparison scoring FLAG_AT or more, by student."""
    flagged = [r for r in rows if r[3] >= FLAG_AT]
    out = ["# Similar regions (for the instructor's eyes only)", "",
           f"Each line is a region scoring {FLAG_AT:g} or more against the reference or a classmate's region of the "
           f"same exercise, after names, literals and layout are normalised (armlab_course.grading.similarity; every "
           f"score is in similarity.csv). A high score is a reason to read both regions side by side, not a "
           f"verdict.", ""]
    if not flagged:
        return "\n".join(out + ["No region reaches it.", ""])
    student = None
    for name, exercise_id, matched, value in flagged:
        if name != student:
            out += ([""] if student is not None else []) + [f"## {_plain(name)}", ""]
            student = name
        against = "the reference" if matched == REFERENCE else _plain(matched)
        out.append(f"- {exercise_id}: {value:.3f} against {against}")
    return "\n".join(out) + "\n"


def reference_bodies(reference: Path, exercise_ids: Iterable[str]) -> dict[str, list[str]]:
    """The instructor's region bodies of each code exercise in the checkout `reference`."""
    out = {}
    for exercise_id in exercise_ids:
        name = exercise_file(exercise(exercise_id))
        if exercise(exercise_id).kind != "written" and (reference / name).is_file():
            out[exercise_id] = regions_of(source_texts(reference / name), exercise_id, name)
    return out


def write_similarity(submissions: Iterable[Submission], reference: Path, out: Path,
                     exercise_ids: Iterable[str]) -> list[tuple[str, str, str, float]]:
    """Compare the submissions' regions of the graded `exercise_ids` (with the reference checkout's and with each
    other's) and write OUT/similarity.csv and OUT/similarity.md atomically; returns the rows."""
    ids = set(exercise_ids)
    students = {s.name: {e: b for e, b in s.bodies.items() if e in ids} for s in submissions}
    rows = similarity_rows(students, reference_bodies(Path(reference), sorted(ids)))
    atomic_write(Path(out) / "similarity.csv", similarity_csv(rows))
    atomic_write(Path(out) / "similarity.md", flagged_md(rows))
    return rows
