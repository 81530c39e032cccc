"""CSV for the instructor's spreadsheet: every table the grader writes (grades, answers, similarity) goes through
`csv_text`, which neutralises cells a spreadsheet would read as a formula.

A cell that a student controls (a written answer, a folder name) and that begins with `=`, `+`, `-`, `@`, a tab or a
carriage return is read by Excel, LibreOffice and Google Sheets as a formula (OWASP's "CSV injection"): such a cell
gets a leading apostrophe, which spreadsheets show as text. Numbers the grader writes itself are left as they are.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable

__all__ = ["FORMULA_STARTS", "safe_cell", "csv_text"]

FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def safe_cell(value: object) -> str:
    """`value` as a CSV cell a spreadsheet shows as text: a leading apostrophe when it starts like a formula. Ints
    and floats (the grader's own numbers, negative ones included) are written as they are."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{value:g}" if isinstance(value, float) else str(value)
    text = "" if value is None else str(value)
    return "'" + text if text.startswith(FORMULA_STARTS) else text


def csv_text(header: Iterable[object], rows: Iterable[Iterable[object]]) -> str:
    """A whole CSV table (header, then rows; "\\n" line ends), every cell through safe_cell."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([safe_cell(c) for c in header])
    for row in rows:
        writer.writerow([safe_cell(c) for c in row])
    return buf.getvalue()
