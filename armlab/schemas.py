"""Declared schemas of the kit's data files (JSON Schema, draft 2020-12, checked with the `jsonschema` library), the
building blocks they are written with, and `validate`, which refuses a file with its path and the field at fault.

Each loader declares its file's schema beside its format (lab.lab_schema, calibration.storage.SCHEMA,
detection.color.SCHEMA, tasks.teach.SCHEMA, sim.scenes.SCHEMA, calibration.views.SCHEMA (checkerboard.json),
detection.color_labels.SCHEMA (labels.json)) and passes it to files.read_json. The schema says the types, that
every number is finite (here "number" and "integer" exclude NaN, infinity, booleans and integers beyond a float's
range), the ranges, the lengths and the allowed keys; what a schema cannot say (bounds in order, one value against
another) the loader checks after it, naming the field the same way (`field_error`).

Fields are named as a reader finds them: `board.grid_mm`, `waypoints[1].q[3]`.
"""

from __future__ import annotations

import math
import numbers
import sys
from collections.abc import Iterable


def _import_jsonschema() -> None:
    """Import jsonschema without letting it import rfc3987_syntax (installed with Jupyter), which builds an Earley
    parser at import for the "iri" and "iri-reference" formats: about 1 s of CPU in every process that reads one of
    the kit's files (each notebook kernel, each grading run), for a check the kit never asks for (its schemas use no
    "format" and it validates no format). Only when jsonschema is not imported yet; rfc3987_syntax stays importable
    afterwards (a later `import rfc3987_syntax` works; jsonschema's FormatChecker in this process then lacks the two
    IRI formats, which it also lacks wherever rfc3987_syntax is not installed)."""
    if "jsonschema" in sys.modules or "rfc3987_syntax" in sys.modules:
        return
    sys.modules["rfc3987_syntax"] = None          # an ImportError for jsonschema's optional import
    try:
        import jsonschema  # noqa: F401
    finally:
        del sys.modules["rfc3987_syntax"]


_import_jsonschema()

import jsonschema  # noqa: E402
from jsonschema import Draft202012Validator  # noqa: E402
from jsonschema.exceptions import best_match  # noqa: E402

__all__ = ["number", "integer", "vector", "matrix", "camera_matrix", "strict_object", "comment", "file_name",
           "validate", "field_name", "field_error", "MAX_FLOAT_INT"]

MAX_FLOAT_INT = 2**53        # larger integers do not survive a float: no field of the kit's files needs them


def _is_number(_checker, value) -> bool:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    if isinstance(value, int):
        return abs(value) <= 1e308
    return math.isfinite(value)


def _is_integer(checker, value) -> bool:
    if isinstance(value, float):
        return math.isfinite(value) and value.is_integer() and abs(value) <= MAX_FLOAT_INT
    return _is_number(checker, value) and isinstance(value, int) and abs(value) <= MAX_FLOAT_INT


_TYPES = Draft202012Validator.TYPE_CHECKER.redefine_many({"number": _is_number, "integer": _is_integer})
_Validator = jsonschema.validators.extend(Draft202012Validator, type_checker=_TYPES)


def number(minimum: float | None = None, maximum: float | None = None, exclusive_minimum: float | None = None,
           exclusive_maximum: float | None = None, description: str = "") -> dict:
    """A finite number, optionally bounded."""
    s: dict = {"type": "number"}
    for key, value in (("minimum", minimum), ("maximum", maximum), ("exclusiveMinimum", exclusive_minimum),
                       ("exclusiveMaximum", exclusive_maximum), ("description", description or None)):
        if value is not None:
            s[key] = value
    return s


def integer(minimum: int | None = None, maximum: int | None = None) -> dict:
    """An integer (an integral float such as 1280.0 passes), optionally bounded."""
    s: dict = {"type": "integer"}
    if minimum is not None:
        s["minimum"] = minimum
    if maximum is not None:
        s["maximum"] = maximum
    return s


def vector(items: dict, length: int | Iterable[int] | None = None, min_items: int | None = None,
           max_items: int | None = None) -> dict:
    """An array of `items`: exactly `length` of them (or one of several lengths), or between min and max."""
    s: dict = {"type": "array", "items": items}
    if isinstance(length, int):
        s["minItems"] = s["maxItems"] = length
    elif length is not None:
        s["anyOf"] = [{"minItems": n, "maxItems": n} for n in length]
    if min_items is not None:
        s["minItems"] = min_items
    if max_items is not None:
        s["maxItems"] = max_items
    return s


def matrix(rows: int, cols: int, items: dict | None = None) -> dict:
    """A rows x cols array of arrays of numbers."""
    return vector(vector(items or number(), cols), rows)


def camera_matrix(limit: float = 1e7) -> dict:
    """A camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] (px) with fx, fy > 0, each entry named on its own."""
    entry, focal = number(minimum=-limit, maximum=limit), number(exclusive_minimum=0.0, maximum=limit)

    def row(*items) -> dict:
        return {"type": "array", "prefixItems": list(items), "minItems": 3, "maxItems": 3}

    return row(row(focal, entry, entry), row({"const": 0}, focal, entry), row({"const": 0}, {"const": 0}, {"const": 1}))


def file_name() -> dict:
    """A file name inside the folder that holds the JSON file (no folders, no "..": nothing outside it is read)."""
    return {"type": "string", "pattern": r"^(?!\.\.?$)[^/\\\x00]{1,255}$"}


def comment() -> dict:
    """A free-text note field ("_comment", "notes")."""
    return {"type": "string", "maxLength": 10_000}


def strict_object(properties: dict, required: Iterable[str] = (), allow_comments: bool = True,
                  additional: bool | dict = False) -> dict:
    """An object with the given properties (the `required` ones present), no others unless `additional` says so
    (False: none; True: any; a schema: those); keys starting with "_" are comments when allow_comments."""
    s: dict = {"type": "object", "properties": properties, "required": list(required),
               "additionalProperties": additional}
    if allow_comments:
        s["patternProperties"] = {"^_": comment()}
    return s


def field_name(path: Iterable) -> str:
    """A JSON path (keys and indices) as a reader writes it: board.grid_mm, waypoints[1].q[3]; "(top level)"."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def field_error(source, field: str, problem: str, error: type[Exception] = ValueError) -> Exception:
    """The one form of a refused file: '<source>: <field>: <problem>' as `error` (to raise)."""
    return error(f"{source}: {field}: {problem}")


def _plain(value) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return {math.inf: "Infinity", -math.inf: "-Infinity"}.get(value, "NaN")
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 1e15:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _problem(e: jsonschema.ValidationError) -> str:
    """The validation error in words a student reads: the finite-number rule spelled out, values kept short."""
    if e.validator == "type":
        wanted, value = e.validator_value, e.instance
        if wanted in ("number", "integer") and isinstance(value, (int, float)) and not isinstance(value, bool):
            if isinstance(e.instance, float) and not math.isfinite(e.instance):
                return f"must be a finite number, got {_plain(e.instance)}"
            if wanted == "integer" and isinstance(e.instance, float):
                return f"must be an integer, got {_plain(e.instance)}"
            return f"must be a finite number no larger than 1e308 in size, got {_plain(e.instance)}"
        return f"must be of type {wanted}, got {type(e.instance).__name__} {_plain(e.instance)}"
    if e.validator in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        words = {"minimum": "at least", "maximum": "at most", "exclusiveMinimum": "greater than",
                 "exclusiveMaximum": "less than"}[e.validator]
        return f"must be {words} {e.validator_value}, got {_plain(e.instance)}"
    if e.validator in ("minItems", "maxItems") and isinstance(e.instance, list):
        bound = "at least" if e.validator == "minItems" else "at most"
        exact = e.schema.get("minItems") == e.schema.get("maxItems")
        return f"has {len(e.instance)} values, expected {'' if exact else bound + ' '}{e.validator_value}"
    if e.validator == "anyOf" and isinstance(e.instance, list) and all("minItems" in a for a in e.validator_value):
        return (f"has {len(e.instance)} values, expected "
                + " or ".join(str(a["minItems"]) for a in e.validator_value))
    if e.validator == "enum":
        return f"must be one of {tuple(e.validator_value)}, got {_plain(e.instance)}"
    if e.validator == "const":
        return f"must be {e.validator_value!r}, got {_plain(e.instance)}"
    if e.validator == "additionalProperties":
        return e.message.replace("Additional properties are not allowed", "unknown key(s)")
    return e.message if len(e.message) <= 200 else e.message[:197] + "..."


def validate(data, schema: dict, source, error: type[Exception] = ValueError) -> None:
    """Raise `error` naming `source` (the file) and the field at fault when `data` breaks `schema`; the most
    relevant error is chosen (jsonschema.exceptions.best_match), so one message names one field."""
    try:
        found = best_match(_Validator(schema).iter_errors(data))
    except RecursionError:
        raise error(f"{source}: nested too deeply to be a kit file") from None
    if found is not None:
        path = list(found.absolute_path)
        if found.validator == "required":
            missing = found.message.split("'")[1] if "'" in found.message else found.message
            path.append(missing)
            raise field_error(source, field_name(path), "missing", error)
        raise field_error(source, field_name(path), _problem(found), error)
