"""Whole columns of numbers checked at once: the fast path for large descriptions.

A generated structure lists 10^5 nodes or members; checking each number with
:func:`~tensegrity_core.schema.reader.number_reason` costs about a microsecond, numpy checks
a column in a few nanoseconds per value. These helpers only answer "is the whole column
fine?"; when it is not, the format reads the column again value by value with its
:class:`~tensegrity_core.schema.reader.Reader`, which words the first bad value with its
key path and line.
"""

from __future__ import annotations

from typing import Any, Final, Literal, overload

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.schema.reader import MAX_MAGNITUDE

#: The Python types of plain numbers in parsed data (booleans are not numbers).
NUMBER_TYPES: Final = frozenset({int, float})


def plain_numbers(values: list[Any], nested: bool = False) -> bool:
    """Every value (``nested``: every value of every row) is an int or float; numpy would
    also take booleans and numeric strings, which a description must not give for numbers."""
    try:
        if nested:
            return all(set(map(type, row)) <= NUMBER_TYPES for row in values)
        return set(map(type, values)) <= NUMBER_TYPES
    except TypeError:
        return False


@overload
def within_bounds(arr: NDArray[np.float64], each: Literal[False] = False) -> bool: ...
@overload
def within_bounds(arr: NDArray[np.float64], each: Literal[True]) -> NDArray[np.bool_]: ...
def within_bounds(arr: NDArray[np.float64], each: bool = False) -> bool | NDArray[np.bool_]:
    """All (or, with ``each``, elementwise) finite and at most MAX_MAGNITUDE in magnitude."""
    ok = np.isfinite(arr) & (np.abs(arr) <= MAX_MAGNITUDE)
    return ok if each else bool(ok.all())


def number_rows(rows: list[Any], width: int) -> NDArray[np.float64] | None:
    """``rows`` (a list of lists of ``width`` numbers) as an ``(n, width)`` array, or None if
    any row is not such a list of finite numbers of at most MAX_MAGNITUDE."""
    try:
        arr = np.array(rows, dtype=float)
    except (ValueError, TypeError, OverflowError):
        return None
    if arr.shape != (len(rows), width) or not plain_numbers(rows, nested=True):
        return None
    if not within_bounds(arr):
        return None
    return arr
