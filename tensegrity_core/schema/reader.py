"""Reading a parsed description with key paths: the checks every format is made of.

A :class:`Reader` walks parsed data (dicts, lists and scalars, located or not) and checks
each value where the format's schema reads it; a failed check raises the format's error
class with the key path, the line (when the data came from YAML) and the file, e.g.
``scene.yaml: effects[3].fold_limit.restitution: must be <= 1, got 1.5 (line 14)``.
Unknown keys are named with the closest allowed key. Numbers are checked by
:func:`number_reason`, whole columns of numbers by :mod:`~tensegrity_core.schema.columns`.

Every format's schema is a subclass of :class:`Reader` (scenes, structures, sweeps,
actuator trajectories, robots, gaits) and holds only what is its own. Formats whose
messages name entries in words rather than by key path (a structure's
``member 's2': EA must be > 0, got -5``) pass that name as ``entry``: it is put before the
reason, and the key path is still set on the error.

Every number must be at most :data:`MAX_MAGNITUDE` in magnitude: larger values are not
physical in SI units for anything this package models, and their squares and products
(lengths from coordinates, stiffness from EA, sample counts from durations) overflow or
lose all precision in the solvers. Every number is read with its unit (``unit="N"``;
``""`` for a dimensionless one), which a refusal states beside its bound and the value:
``EA: must be at most 1e+15 N in magnitude, got 1e+308 N``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from typing import Any, Final, TypedDict, TypeVar, Unpack

from tensegrity_core.schema.errors import KeyPath, SchemaError, described, excerpt, suggest
from tensegrity_core.schema.located import line_of

_T = TypeVar("_T")

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


def with_unit(x: float, unit: str) -> str:
    """``x`` and its unit in words: ``"1e+15 N"``, ``"0.5"`` for a dimensionless number."""
    return f"{x:g} {unit}" if unit else f"{x:g}"


def number_reason(value: Any, *, unit: str, lo: float | None = None, hi: float | None = None,
                  lo_open: bool = False, hi_open: bool = False, allow_inf: bool = False) -> tuple[float, str | None]:
    """``(float(value), None)`` if ``value`` is a number within the bounds, else
    ``(nan, reason)`` with ``reason`` like ``"must be > 0 m, got -1 m"``: the bound and the
    value with ``unit`` (SI, as written in the description: ``"m"``, ``"N/m"``; ``""`` for a
    dimensionless number, whose bound is then said to be dimensionless). Non-finite values
    and values beyond :data:`MAX_MAGNITUDE` are refused (``allow_inf``: infinity is allowed,
    also written ``inf``/``.inf``)."""
    if allow_inf and isinstance(value, str) and value.strip().lower() in ("inf", "+inf", "infinity", ".inf"):
        value = math.inf
    if not is_number(value):
        return math.nan, f"must be a number, got {described(value)}"
    try:
        x = float(value)
    except OverflowError:
        x = math.inf if value > 0 else -math.inf
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        return math.nan, f"must be finite, got {excerpt(value)}"
    got = f"{excerpt(value)} {unit}" if unit else excerpt(value)
    dimensionless = "" if unit else " (dimensionless)"
    if math.isfinite(x) and abs(x) > MAX_MAGNITUDE:
        return math.nan, f"must be at most {with_unit(MAX_MAGNITUDE, unit)}{dimensionless} in magnitude, got {got}"
    if lo is not None and (x < lo or (lo_open and x == lo)):
        return math.nan, f"must be {'>' if lo_open else '>='} {with_unit(lo, unit)}{dimensionless}, got {got}"
    if hi is not None and (x > hi or (hi_open and x == hi)):
        return math.nan, f"must be {'<' if hi_open else '<='} {with_unit(hi, unit)}{dimensionless}, got {got}"
    return x, None


class Reader:
    """Checks on parsed data that raise ``error`` (a :class:`SchemaError` class) located by
    key path, line and ``file``. ``path`` arguments are key-path tuples of the value being
    read (of the mapping ``d`` for the methods that read ``d[key]``); ``container``/``key``
    say where it sits, for its line. ``entry``: the value in words, for formats whose
    messages name entries (see the module's docstring)."""

    def __init__(self, error: type[SchemaError] = SchemaError, file: str | None = None) -> None:
        self.error_class = error
        self.file = file

    def error(self, reason: str, path: KeyPath, container: Any = None, key: Any = None) -> SchemaError:
        """The error ``reason`` at key path ``path``, on the line of ``container[key]``."""
        return self.error_class(reason, key=path, line=line_of(container, key), file=self.file)

    def mapping(self, value: Any, path: KeyPath, parent: Any = None, key: Any = None, *,
                entry: str = "") -> dict[Any, Any]:
        """``value`` if it is a mapping."""
        if not isinstance(value, dict):
            raise self.error(_worded(entry, f"must be a mapping, got {described(value)}"), path,
                             parent, key)
        return value

    def sequence(self, value: Any, path: KeyPath, parent: Any = None, key: Any = None, *, of: str = "",
                 nonempty: bool = False, entry: str = "") -> list[Any]:
        """``value`` if it is a list (``nonempty``: with an item); ``of`` names the items in
        the message (``"effects"``)."""
        if not isinstance(value, list) or (nonempty and not value):
            kind = ("a non-empty list" if nonempty else "a list") + (f" of {of}" if of else "")
            raise self.error(_worded(entry, f"must be {kind}, got {described(value)}"), path,
                             parent, key)
        return value

    def keys(self, d: Mapping[Any, Any], path: KeyPath, allowed: Iterable[object], required: Iterable[object] = (),
             *, aliases: Mapping[Any, Any] | None = None, entry: str = "") -> dict[Any, Any]:
        """Every key of ``d`` is in ``allowed`` (an unknown one is named with the closest
        allowed key) and every key of ``required`` is there. ``aliases`` maps other spellings
        to allowed keys (giving a key twice, as itself and by an alias, is refused). Returns
        each allowed key found -> the key as written in ``d``."""
        allowed = tuple(allowed)
        out: dict[Any, Any] = {}
        for k in d:
            canon = aliases.get(k, k) if aliases else k
            if canon not in allowed:
                listing = f"; allowed: {', '.join(map(str, allowed))}" if allowed else "; it takes no options"
                raise self.error(_worded(entry, f"unknown key {excerpt(k)}{suggest(k, allowed)}{listing}", ":"),
                                 path + (k,), d, k)
            if canon in out:
                raise self.error(_worded(entry, f"{excerpt(k)} repeats {canon!r}", ":"), path + (k,), d, k)
            out[canon] = k
        for k in required:
            if k not in out:
                raise self.error(_worded(entry, f"missing required key {k!r}", ":"), path, d, None)
        return out

    def number(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, unit: str, default: float | None = None,
               entry: str = "", **bounds: Unpack[Bounds]) -> float:
        """``d[key]`` as a float in ``unit`` within ``bounds`` (see :func:`number_reason`),
        or ``default`` when the key is absent (required when ``default`` is None)."""
        if key not in d:
            if default is None:
                raise self.error(_worded(entry, f"missing required key {key!r}", ":"), path, d, None)
            return default
        return self.value_number(d[key], path + (key,), d, key, unit=unit, entry=entry, **bounds)

    def value_number(self, value: Any, path: KeyPath, container: Any, key: Any, *, unit: str, entry: str = "",
                     **bounds: Unpack[Bounds]) -> float:
        """``value`` (at ``path``) as a float in ``unit`` within ``bounds``."""
        x, reason = number_reason(value, unit=unit, **bounds)
        if reason is not None:
            raise self.error(_worded(entry, reason), path, container, key)
        return x

    def vector(self, value: Any, n: int, path: KeyPath, container: Any, key: Any, *, unit: str | Sequence[str],
               what: str = "numbers", entry: str = "") -> tuple[float, ...]:
        """``value`` as a tuple of ``n`` numbers in ``unit`` (or in ``unit[i]`` each, for a
        vector of mixed quantities); ``what`` names them in the message."""
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise self.error(_worded(entry, f"must be a list of {n} {what}, got {described(value)}"), path, container, key)
        units = [unit] * n if isinstance(unit, str) else list(unit)
        return tuple(self.value_number(x, path + (i,), value, i, unit=units[i], entry=entry)
                     for i, x in enumerate(value))

    def string(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, default: str | None = None,
               choices: Collection[str] | None = None, entry: str = "") -> str:
        """``d[key]`` as a string (one of ``choices`` if given), or ``default``."""
        if key not in d:
            if default is None:
                raise self.error(_worded(entry, f"missing required key {key!r}", ":"), path, d, None)
            return default
        value = d[key]
        if not isinstance(value, str):
            raise self.error(_worded(entry, f"must be a string, got {described(value)}"),
                             path + (key,), d, key)
        if choices is not None and value not in choices:
            raise self.error(_worded(entry, f"must be one of {', '.join(choices)}, got {excerpt(value)}"
                                            f"{suggest(value, choices)}"), path + (key,), d, key)
        return value

    def integer(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, default: int | None = None,
                lo: int | None = None, hi: int | None = None, entry: str = "") -> int:
        """``d[key]`` as an int (``lo <= value <= hi`` for the bounds given), or ``default``."""
        if key not in d:
            if default is None:
                raise self.error(_worded(entry, f"missing required key {key!r}", ":"), path, d, None)
            return default
        value = d[key]
        if (isinstance(value, bool) or not isinstance(value, int) or (lo is not None and value < lo)
                or (hi is not None and value > hi)):
            if lo == 0 and hi is None:
                bound = "a non-negative integer"
            else:
                limits = " and ".join(([f">= {lo}"] if lo is not None else []) + ([f"<= {hi}"] if hi is not None else []))
                bound = f"an integer {limits}".rstrip()
            raise self.error(_worded(entry, f"must be {bound}, got {excerpt(value)}"), path + (key,), d, key)
        return value

    def boolean(self, d: Mapping[Any, Any], key: Any, path: KeyPath, *, default: bool | None = None,
                entry: str = "") -> bool:
        """``d[key]`` as true or false, or ``default``."""
        if key not in d:
            if default is None:
                raise self.error(_worded(entry, f"missing required key {key!r}", ":"), path, d, None)
            return default
        value = d[key]
        if not isinstance(value, bool):
            raise self.error(_worded(entry, f"must be true or false, got {described(value)}"),
                             path + (key,), d, key)
        return value

    def checked(self, d: Mapping[Any, Any], key: Any, path: KeyPath, check: Callable[[Any], _T]) -> _T:
        """``check(d[key])``, for checks kept as functions (a sweep's options): the
        :class:`SchemaError` a check raises with its bare reason is raised here at
        ``path + (key,)`` (and the key path the check gave, below it), on the key's line."""
        try:
            return check(d[key])
        except SchemaError as err:
            raise self.error(err.reason, path + (key,) + err.key, d, key) from None


def _worded(entry: str, reason: str, sep: str = "") -> str:
    """``reason`` after ``entry`` (the value in words) and ``sep``, when there is an entry."""
    return f"{entry}{sep} {reason}" if entry else reason
