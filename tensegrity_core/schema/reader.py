"""Reading a parsed description with key paths: the checks every format is made of.

A :class:`Reader` walks parsed data (dicts, lists and scalars, located or not) and checks
each value where the format's schema reads it; a failed check raises the format's error
class with the key path, the line (when the data came from YAML) and the file, e.g.
``scene.yaml: effects[3].fold_limit.restitution: must be <= 1, got 1.5 (line 14)``.
Unknown keys are named with the closest allowed key. Numbers are checked by
:func:`number_reason`, which formats that word their own messages use as well.

Every number must be at most :data:`MAX_MAGNITUDE` in magnitude: larger values are not
physical in SI units for anything this package models, and their squares and products
(lengths from coordinates, stiffness from EA, sample counts from durations) overflow or
lose all precision in the solvers.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping
from typing import Any, Final, TypedDict, Unpack

from tensegrity_core.schema.errors import KeyPath, SchemaError, excerpt, suggest, type_name
from tensegrity_core.schema.located import line_of

#: The largest magnitude any number of a description may have (SI units).
MAX_MAGNITUDE: Final = 1e15


class Bounds(TypedDict, total=False):
    """Bounds of a number (the keyword arguments of :func:`number_reason`)."""

    lo: float | None
    hi: float | None
    lo_open: bool
    hi_open: bool
    allow_inf: bool


def is_number(value: Any) -> bool:
    """True for int and float values (not booleans)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def number_reason(value: Any, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False,
                  hi_open: bool = False, allow_inf: bool = False) -> tuple[float, str | None]:
    """``(float(value), None)`` if ``value`` is a number within the bounds, else
    ``(nan, reason)`` with ``reason`` like ``"must be > 0, got -1"``. Non-finite values and
    values beyond :data:`MAX_MAGNITUDE` are refused (``allow_inf``: infinity is allowed,
    also written ``inf``/``.inf``)."""
    if allow_inf and isinstance(value, str) and value.strip().lower() in ("inf", "+inf", "infinity", ".inf"):
        value = math.inf
    if not is_number(value):
        return math.nan, f"must be a number, got {type_name(value)} ({excerpt(value)})"
    try:
        x = float(value)
    except OverflowError:
        x = math.inf if value > 0 else -math.inf
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        return math.nan, f"must be finite, got {excerpt(value)}"
    if math.isfinite(x) and abs(x) > MAX_MAGNITUDE:
        return math.nan, f"must be at most {MAX_MAGNITUDE:g} in magnitude, got {excerpt(value)}"
    if lo is not None and (x < lo or (lo_open and x == lo)):
        return math.nan, f"must be {'>' if lo_open else '>='} {lo:g}, got {excerpt(value)}"
    if hi is not None and (x > hi or (hi_open and x == hi)):
        return math.nan, f"must be {'<' if hi_open else '<='} {hi:g}, got {excerpt(value)}"
    return x, None


class Reader:
    """Checks on parsed data that raise ``error`` (a :class:`SchemaError` class) located by
    key path, line and ``file``. ``path`` arguments are key-path tuples of the value being
    read; ``container``/``key`` say where it sits, for its line."""

    def __init__(self, error: type[SchemaError] = SchemaError, file: str | None = None) -> None:
        self.error_class = error
        self.file = file

    def error(self, reason: str, path: KeyPath, container: Any = None, key: Any = None) -> SchemaError:
        """The error ``reason`` at key path ``path``, on the line of ``container[key]``."""
        return self.error_class(reason, key=path, line=line_of(container, key), file=self.file)

    def mapping(self, value: Any, path: KeyPath, parent: Any = None, key: Any = None) -> dict[Any, Any]:
        """``value`` if it is a mapping."""
        if not isinstance(value, dict):
            raise self.error(f"must be a mapping, got {type_name(value)} ({excerpt(value)})", path, parent, key)
        return value

    def keys(self, d: Mapping[Any, Any], path: KeyPath, allowed: Iterable[object],
             required: Iterable[object] = ()) -> None:
        """Every key of ``d`` is in ``allowed`` (an unknown one is named with the closest
        allowed key) and every key of ``required`` is there."""
        allowed = tuple(allowed)
        for k in d:
            if k not in allowed:
                listing = f"; allowed: {', '.join(map(str, allowed))}" if allowed else "; it takes no options"
                raise self.error(f"unknown key {excerpt(k)}{suggest(k, allowed)}{listing}", path + (k,), d, k)
        for k in required:
            if k not in d:
                raise self.error(f"missing required key {k!r}", path, d, None)

    def number(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, default: float | None = None,
               **bounds: Unpack[Bounds]) -> float:
        """``d[key]`` as a float within ``bounds`` (see :func:`number_reason`), or
        ``default`` when the key is absent (required when ``default`` is None)."""
        if key not in d:
            if default is None:
                raise self.error(f"missing required key {key!r}", path, d, None)
            return default
        return self.value_number(d[key], path + (key,), d, key, **bounds)

    def value_number(self, value: Any, path: KeyPath, container: Any, key: Any, **bounds: Unpack[Bounds]) -> float:
        """``value`` (at ``path``) as a float within ``bounds``."""
        x, reason = number_reason(value, **bounds)
        if reason is not None:
            raise self.error(reason, path, container, key)
        return x

    def vector(self, value: Any, n: int, path: KeyPath, container: Any, key: Any, *,
               what: str = "numbers") -> tuple[float, ...]:
        """``value`` as a tuple of ``n`` numbers."""
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise self.error(f"must be a list of {n} {what}, got {type_name(value)} ({excerpt(value)})", path,
                             container, key)
        return tuple(self.value_number(x, path + (i,), value, i) for i, x in enumerate(value))

    def string(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, default: str | None = None,
               choices: Collection[str] | None = None) -> str:
        """``d[key]`` as a string (one of ``choices`` if given), or ``default``."""
        if key not in d:
            if default is None:
                raise self.error(f"missing required key {key!r}", path, d, None)
            return default
        value = d[key]
        if not isinstance(value, str):
            raise self.error(f"must be a string, got {type_name(value)} ({excerpt(value)})", path + (key,), d, key)
        if choices is not None and value not in choices:
            raise self.error(f"must be one of {', '.join(choices)}, got {excerpt(value)}{suggest(value, choices)}",
                             path + (key,), d, key)
        return value

    def integer(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, default: int | None = None,
                lo: int | None = None) -> int:
        """``d[key]`` as an int (>= ``lo`` if given), or ``default``."""
        if key not in d:
            if default is None:
                raise self.error(f"missing required key {key!r}", path, d, None)
            return default
        value = d[key]
        if isinstance(value, bool) or not isinstance(value, int) or (lo is not None and value < lo):
            bound = "a non-negative integer" if lo == 0 else ("an integer" if lo is None else f"an integer >= {lo}")
            raise self.error(f"must be {bound}, got {excerpt(value)}", path + (key,), d, key)
        return value
