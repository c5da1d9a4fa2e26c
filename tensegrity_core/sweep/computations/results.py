"""The scalar results a sweep's computations can keep: :class:`ResultDef` (which columns a
result gives and how to read them from a computation's outcome), :class:`ResultSpec` (a result
a sweep keeps, prepared) and :func:`scalar` (a one-column result). See
:mod:`tensegrity_core.sweep.computations`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar

from tensegrity_core.sweep.checks import Check

#: The outcome of a computation's run that a result reads.
Out = TypeVar("Out")
Out_co = TypeVar("Out_co", covariant=True)
#: Checked option values by name.
Options = dict[str, Any]
#: A result column: ``(name, dtype)``, dtype ``float`` (missing = NaN), ``int``, ``bool`` or ``str``.
Column = tuple[str, str]


class Probe(Protocol[Out_co]):
    """The base's own outcome, computed once on the machine that reads the sweep file: whole
    (``full``) or as far as names and sizes need."""

    def __call__(self, full: bool = True) -> Out_co: ...


@dataclass(frozen=True)
class ResultDef(Generic[Out]):
    doc: str
    columns: Callable[[Options, Any], list[Column]]       # (options, data) -> [(column, dtype)]
    extract: Callable[[Out, Options, Any], list[Any]]       # (outcome, options, data) -> [value per column]
    options: dict[str, Check] = field(default_factory=dict)
    prepare: Callable[[Options, Probe[Out], str], Any] | None = None   # (options, probe, folder) -> data


@dataclass(frozen=True)
class ResultSpec:
    """A result the sweep keeps: its name, checked options, fixed data and columns."""

    name: str
    options: Options
    columns: tuple[Column, ...]
    data: Any = None


def scalar(column: str, dtype: str, read: Callable[[Out], Any], doc: str, **options: Check) -> ResultDef[Out]:
    """A result with one column read by ``read(outcome)``."""
    return ResultDef(doc=doc, columns=lambda o, d: [(column, dtype)], extract=lambda out, o, d: [read(out)],
                     options=options)
