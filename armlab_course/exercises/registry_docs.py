"""The docs' exercise figures, from the registry (as `python -m armlab exercises --json` gives it), so they cannot
drift: generated blocks, and the claims hand-written text makes about exercises.

A generated block sits between an opening and a closing HTML comment, its kind and optional scope in the opening:

    <!-- BEGIN GENERATED summary notebooks=04-08 (tools/exercise-docs; do not edit) -->
    ...
    <!-- END GENERATED -->

Kinds: "summary" (the counts and points, what is graded automatically and what by hand) and "table" (one row per
exercise). `refresh` rewrites every block of a text; `tools/exercise-docs` (make exercise-docs) rewrites the docs and
`--check` says which are stale. `disagreements` reads the text outside the blocks for claims about exercises --
"`fk.euler` (5 points, code)", "(`fk.euler`, 5", "| `fk.euler` | 5 | code |", "exercise fk.euler (notebook 02)",
"**Exercise `fk.euler`", "26 exercises, 158 points", "/ 141 automatic (+17 by hand" -- and names each one the
registry contradicts (an id it does not have, other points, another kind or notebook, another count).
"""

from __future__ import annotations

import re
from pathlib import Path

__all__ = ["KINDS", "BLOCK", "render", "refresh", "disagreements", "doc_files"]

KINDS = ("summary", "table")
BLOCK = re.compile(r"(?P<open><!-- BEGIN GENERATED (?P<kind>\w+)(?: notebooks=(?P<lo>\d\d)-(?P<hi>\d\d))?\b[^>]*-->\n)"
                   r"(?P<body>.*?)(?P<close><!-- END GENERATED -->)", re.DOTALL)
_HOW = {"code": "hidden inputs", "open": "outcome on hidden seeds", "written": "by hand"}


def _count(n: int, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def _scoped(rows: list[dict], lo: str | None, hi: str | None) -> list[dict]:
    return rows if lo is None else [r for r in rows if lo <= r["notebook"][:2] <= hi]


def _summary(rows: list[dict]) -> str:
    """'26 exercises, 158 points: 141 graded automatically (...) and 17 by hand (7 written answers).'"""
    def part(kind: str) -> tuple[int, int]:
        return sum(1 for r in rows if r["kind"] == kind), sum(r["points"] for r in rows if r["kind"] == kind)

    (code, code_pts), (open_, open_pts), (written, written_pts) = part("code"), part("open"), part("written")
    auto = [f"{_count(code, 'code exercise')}, {code_pts} points, on hidden inputs"] if code else []
    auto += [f"{_count(open_, 'open task')}, {open_pts} points, on their outcome on hidden seeds"] if open_ else []
    text = f"**{_count(len(rows), 'exercise')}, {sum(r['points'] for r in rows)} points**: " \
           f"{code_pts + open_pts} graded automatically ({'; '.join(auto) or 'none'})"
    if written:
        text += f" and {written_pts} by hand ({_count(written, 'written answer')}, graded by the instructor)"
    return text + ".\n"


def _what(r: dict) -> str:
    """The functions an exercise completes, or the figure a written answer is about."""
    return "about " + " and ".join(r["functions"]) if r["kind"] == "written" else \
        ", ".join(f"`{f}`" for f in r["functions"])


def _table(rows: list[dict]) -> str:
    lines = ["| exercise | points | kind | notebook | where | graded on | what to write |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        where = f"`{r['where']}`" if r["where"].startswith("armlab/") else "the notebook"
        lines.append(f"| `{r['id']}` | {r['points']} | {r['kind']} | {r['notebook'][:2]} | {where} | "
                     f"{_HOW[r['kind']]} | {r['title']} ({_what(r)}) |")
    return "\n".join(lines) + "\n"


def render(kind: str, rows: list[dict], notebooks: tuple[str, str] | None = None) -> str:
    """A block's body: `kind` ("summary" or "table") of the exercises `rows` (`python -m armlab exercises --json`),
    only those of notebooks lo-hi (two-digit numbers) when `notebooks` is given."""
    if kind not in KINDS:
        raise ValueError(f"no generated block kind {kind!r}; the kinds: {', '.join(KINDS)}")
    scoped = _scoped(rows, *(notebooks or (None, None)))
    return _summary(scoped) if kind == "summary" else _table(scoped)


def refresh(text: str, rows: list[dict]) -> str:
    """`text` with every generated block's body rendered anew from `rows`."""
    def one(m: re.Match) -> str:
        scope = (m["lo"], m["hi"]) if m["lo"] else None
        return m["open"] + render(m["kind"], rows, scope) + m["close"]

    return BLOCK.sub(one, text)


_ID = r"[a-z]+\.[a-z_]+"
_CLAIMS = (      # (pattern, what it states): groups id, then points / kind / notebook where it states them
    (re.compile(rf"`({_ID})` \((\d+) points?(?:, (code|open|written))?"), ("id", "points", "kind")),
    (re.compile(rf"\(`({_ID})`, (\d+)\b"), ("id", "points")),
    (re.compile(rf"^\| `({_ID})` \| (\d+) \| (code|open|written) \|", re.MULTILINE), ("id", "points", "kind")),
    (re.compile(rf"\bexercise `?({_ID})`? \(notebook (\d\d)\)"), ("id", "notebook")),
    (re.compile(rf"\*\*(?:Exercise|Question|Open task)\b[^`*\n]*`({_ID})`"), ("id",)),
)
_TOTAL = re.compile(r"\b(\d+) exercises(?:,? \(?(\d+) points)?")
_SPLIT = re.compile(r"/ (\d+) automatic \(\+(\d+) by hand")      # the grader's total, as docs quote it


def disagreements(text: str, rows: list[dict]) -> list[str]:
    """What `text` (generated blocks left out) claims about exercises that the registry `rows` contradicts, one
    sentence each, in the order of the text."""
    by_id = {r["id"]: r for r in rows}
    text = BLOCK.sub(lambda m: "\n" * m[0].count("\n"), text)      # blocks out, lines where they were
    found: list[tuple[int, str]] = []
    for pattern, names in _CLAIMS:
        for m in pattern.finditer(text):
            claim = dict(zip(names, m.groups(), strict=True))
            line = text.count("\n", 0, m.start()) + 1
            r = by_id.get(claim["id"])
            if r is None:
                found.append((line, f"line {line}: {m[0]!r} names no exercise of the registry"))
                continue
            truth = {"points": str(r["points"]), "kind": r["kind"], "notebook": r["notebook"][:2]}
            wrong = [f"{k} {claim[k]} (the registry: {truth[k]})" for k in names[1:]
                     if claim[k] is not None and claim[k] != truth[k]]
            if wrong:
                found.append((line, f"line {line}: {m[0]!r}: {', '.join(wrong)}"))
    points = sum(r["points"] for r in rows)
    for m in _TOTAL.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        if int(m[1]) != len(rows) or (m[2] is not None and int(m[2]) != points):
            found.append((line, f"line {line}: {m[0]!r}: the registry has {len(rows)} exercises, {points} points"))
    auto = sum(r["points"] for r in rows if r["kind"] != "written")
    for m in _SPLIT.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        if (int(m[1]), int(m[2])) != (auto, points - auto):
            found.append((line, f"line {line}: {m[0]!r}: the registry has {auto} automatic points, "
                                f"{points - auto} by hand"))
    return [sentence for _, sentence in sorted(found)]


def doc_files(root: Path) -> list[Path]:
    """The documents that speak of exercises: README.md, the student README, docs/**/*.md (not the generated API
    reference) and the notebooks' sources (the saved notebooks where there are no sources: a student release)."""
    root = Path(root)
    files = [root / "README.md", root / "tools/student/README.md"]
    files += sorted(p for p in (root / "docs").rglob("*.md") if "api" not in p.relative_to(root / "docs").parts)
    files += sorted((root / "notebooks/src").glob("*.py")) or sorted((root / "notebooks").glob("*.ipynb"))
    return [p for p in files if p.is_file()]
