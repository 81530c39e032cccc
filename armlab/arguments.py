"""The kit's argument checks: every public function coerces its inputs through here, so that bad input raises the
kit's ValueError or TypeError whose message starts with the argument's name, never numpy's or Python's own
(OverflowError for an integer above 1e308, "could not convert string to float", an AttributeError deep inside).

- `finite_array(value, name, shapes)`: a finite float array of one of the allowed shapes.
- `finite_float(value, name, ...)`: one finite float, optionally within bounds.
- `int_in_range(value, name, lo, hi)`: one integer within bounds (booleans and floats refused).
- `instance_of(value, name, cls)`: the type an argument must have (TypeError naming it).
- `plain(value)`: numbers as a reader writes them (-10.0, not np.float64(-10.0)), for error messages.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np

__all__ = ["finite_array", "finite_float", "int_in_range", "instance_of", "plain"]

Shape = tuple[int | None, ...]


def plain(value) -> str:
    """A short, plain text of a value for an error message: numbers and arrays of numbers printed as Python floats
    and ints (-10.0, [1.0, 2.0]), never as numpy reprs; anything else as its repr, cut at 80 characters."""
    try:
        if isinstance(value, (np.ndarray, list, tuple)) and np.asarray(value).dtype.kind in "biuf":
            a = np.asarray(value)
            if a.size <= 12:
                return str(a.tolist()) if not isinstance(value, tuple) else str(tuple(a.tolist()))
            return f"an array of shape {a.shape}"
        if isinstance(value, (np.generic,)):
            return repr(value.item())
    except (ValueError, TypeError, OverflowError):
        pass
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _shape_text(shape: Shape) -> str:
    return "(" + ", ".join("N" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"


def _fits(shape: tuple[int, ...], allowed: Shape) -> bool:
    return len(shape) == len(allowed) and all(a is None or a == n for a, n in zip(allowed, shape))


def finite_array(value, name: str, shapes: Shape | Sequence[Shape] | None = None, what: str = "",
                 plural: bool = False, allow_nan: bool = False) -> np.ndarray:
    """`value` as a float64 array of finite numbers with one of the allowed `shapes` (a shape, or a list of them;
    None in a shape = any length; None = any shape).

    Raises TypeError naming `name` when `value` is not numbers (None, text, booleans, complex, objects), ValueError
    naming `name` for a ragged or wrongly shaped array, a number too large for a float, NaN or infinity. `what`
    (e.g. "x, y, z in world mm") is added to the messages; `plural`: `name` is a plural noun ("joint angles");
    `allow_nan`: NaN is a missing value here (a depth with no return) and passes; infinity never does.
    """
    hint = f" ({what})" if what else ""
    if value is None or isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be numbers{hint}, got {type(value).__name__} {plain(value)}")
    try:
        raw = np.asarray(value)
    except (ValueError, TypeError) as e:         # ragged nesting, objects numpy cannot hold
        raise ValueError(f"{name} must be a regular array of numbers{hint}: {e}") from None
    if raw.dtype.kind == "b" or raw.dtype.kind == "c" or raw.dtype.kind in "USV":
        kind = {"b": "booleans", "c": "complex numbers"}.get(raw.dtype.kind, "text")
        raise TypeError(f"{name} must be real numbers{hint}, got {kind}")
    if raw.dtype.kind == "O" and any(isinstance(v, (bool, np.bool_, str, bytes, complex)) or v is None
                                     for v in raw.ravel()[:1000]):
        raise TypeError(f"{name} must be real numbers{hint}, got {plain(value)}")
    try:
        a = raw.astype(float, copy=False)
    except OverflowError:
        raise ValueError(f"{name} {'hold' if plural else 'holds'} a number too large for a float (above 1e308)"
                         f"{hint}") from None
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be numbers{hint}, got {plain(value)}") from None
    if shapes is not None:
        allowed = [shapes] if not shapes or not isinstance(shapes[0], (tuple, list)) else list(shapes)
        if not any(_fits(a.shape, tuple(s)) for s in allowed):
            wanted = " or ".join(_shape_text(tuple(s)) for s in allowed)
            raise ValueError(f"{name} must have shape {wanted}{hint}, got shape {a.shape}")
    if not np.isfinite(a).all() and not (allow_nan and not np.isinf(a).any()):
        if allow_nan:
            raise ValueError(f"{name} {'contain' if plural else 'contains'} infinity{hint}")
        raise ValueError(f"{name} {'contain' if plural else 'contains'} NaN or infinity{hint}")
    return a


def finite_float(value, name: str, minimum: float | None = None, maximum: float | None = None,
                 positive: bool = False, what: str = "") -> float:
    """`value` as one finite float, within [minimum, maximum] and > 0 when `positive`; TypeError / ValueError
    naming `name` otherwise (booleans and text are refused, a (1,) array is not a number)."""
    hint = f" ({what})" if what else ""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.ndarray)):
        raise TypeError(f"{name} must be a number{hint}, got {type(value).__name__} {plain(value)}")
    a = finite_array(value, name, (), what)
    x = float(a)
    if positive and not x > 0:
        raise ValueError(f"{name} must be a positive number{hint}, got {plain(x)}")
    if minimum is not None and x < minimum:
        raise ValueError(f"{name} must be at least {plain(minimum)}{hint}, got {plain(x)}")
    if maximum is not None and x > maximum:
        raise ValueError(f"{name} must be at most {plain(maximum)}{hint}, got {plain(x)}")
    return x


def int_in_range(value, name: str, minimum: int | None = None, maximum: int | None = None, what: str = "") -> int:
    """`value` as one int within [minimum, maximum]; TypeError naming `name` for anything that is not an integer
    (booleans, floats, text), ValueError naming it when out of range."""
    hint = f" ({what})" if what else ""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer{hint}, got {type(value).__name__} {plain(value)}")
    n = int(value)
    if (minimum is not None and n < minimum) or (maximum is not None and n > maximum):
        lo = "" if minimum is None else f"at least {minimum}"
        hi = "" if maximum is None else f"at most {maximum}"
        rng = " and ".join(t for t in (lo, hi) if t)
        shown = str(n) if abs(n) < 10**15 else f"{'-' if n < 0 else ''}an integer of {len(str(abs(n)))} digits"
        raise ValueError(f"{name} must be {rng}{hint}, got {shown}")
    return n


def instance_of(value, name: str, cls: type | tuple[type, ...], what: str = ""):
    """`value` itself when it is an instance of `cls`; TypeError naming `name` and the type wanted otherwise."""
    if not isinstance(value, cls):
        names = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        hint = f" ({what})" if what else ""
        raise TypeError(f"{name} must be a {names}{hint}, got {type(value).__name__}")
    return value

