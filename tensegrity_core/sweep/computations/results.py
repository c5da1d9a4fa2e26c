"""The scalar results a sweep's computations can keep: :class:`ResultDef` (which columns a
result gives and how to read them from a computation's outcome), :class:`ResultSpec` (a result
a sweep keeps, prepared) and :func:`scalar` (a one-column result). See
:mod:`tensegrity_core.sweep.computations`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass(frozen=True)
class ResultDef:
    doc: str
    columns: Callable          # (options, data) -> [(column, dtype)]
    extract: Callable          # (outcome, options, data) -> [value per column]
    options: dict = field(default_factory=dict)
    prepare: Callable | None = None   # (options, probe, folder) -> data


@dataclass(frozen=True)
class ResultSpec:
    """A result the sweep keeps: its name, checked options, fixed data and columns."""

    name: str
    options: dict
    columns: tuple
    data: object = None


def scalar(column: str, dtype: str, read: Callable, doc: str, **options) -> ResultDef:
    """A result with one column read by ``read(outcome)``."""
    return ResultDef(doc=doc, columns=lambda o, d: [(column, dtype)], extract=lambda out, o, d: [read(out)],
                     options=options)
