"""Small value checks for the options of computations and results in a sweep file.

Each check takes the raw YAML value and returns the checked value or raises
:class:`OptionError` with a message that shows the value; the sweep file reader adds the
key path and the line.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from tensegrity_core.schema.errors import SchemaError, suggest, type_name

#: A check of one option: the raw YAML value -> the checked value (or :class:`OptionError`).
Check = Callable[[Any], Any]


class OptionError(SchemaError):
    """An option's value is not allowed (the bare reason: the reader that applies the check
    locates it by key path and line, :meth:`~tensegrity_core.schema.Reader.checked`)."""


def number(*, lo: float | None = None, lo_open: bool = False) -> Callable[[object], float]:
    """A finite number (``> lo`` when ``lo_open``, else ``>= lo``)."""
    def check(v: object) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise OptionError(f"must be a number, got {type_name(v)} ({v!r})")
        if not math.isfinite(v):
            raise OptionError(f"must be finite, got {v!r}")
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise OptionError(f"must be {'>' if lo_open else '>='} {lo:g}, got {v!r}")
        return float(v)
    return check


def integer(*, lo: int = 0, what: str = "") -> Callable[[object], int]:
    """An integer ``>= lo``; ``what`` it stands for, in the refusal of one below ``lo``."""
    def check(v: object) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise OptionError(f"must be an integer, got {type_name(v)} ({v!r})")
        if v < lo:
            raise OptionError(f"must be >= {lo}{f' ({what})' if what else ''}, got {v!r}")
        return int(v)
    return check


def choice(*options: str) -> Callable[[object], str]:
    """One of ``options``."""
    def check(v: object) -> str:
        if v not in options:
            raise OptionError(f"must be one of {', '.join(options)}, got {v!r}{suggest(v, options)}")
        return v
    return check


def text(v: object) -> str:
    """A non-empty string."""
    if not isinstance(v, str) or not v.strip():
        raise OptionError(f"must be a non-empty string, got {type_name(v)} ({v!r})")
    return v


def boolean(v: object) -> bool:
    if not isinstance(v, bool):
        raise OptionError(f"must be true or false, got {type_name(v)} ({v!r})")
    return v

