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
    """``unit``: the unit of every column (SI, as ``"N/m"``; ``"1"`` dimensionless, ``"count"``
    a number of things, ``""`` for a boolean), or ``(options, data, column) -> unit`` when the
    columns differ."""

    doc: str
    columns: Callable[[Options, Any], list[Column]]       # (options, data) -> [(column, dtype)]
    extract: Callable[[Out, Options, Any], list[Any]]       # (outcome, options, data) -> [value per column]
    options: dict[str, Check] = field(default_factory=dict)
    prepare: Callable[[Options, Probe[Out], str], Any] | None = None   # (options, probe, folder) -> data
    unit: str | Callable[[Options, Any, str], str] = "1"

    def units(self, options: Options, data: Any, columns: list[Column]) -> tuple[str, ...]:
        """The unit of each of ``columns``."""
        unit = self.unit
        return tuple(unit if isinstance(unit, str) else unit(options, data, name) for name, _ in columns)


@dataclass(frozen=True)
class ResultSpec:
    """A result the sweep keeps: its name, checked options, fixed data, columns and their
    units (:attr:`ResultDef.unit`)."""

    name: str
    options: Options
    columns: tuple[Column, ...]
    data: Any = None
    units: tuple[str, ...] = ()


def scalar(column: str, dtype: str, read: Callable[[Out], Any], doc: str, unit: str, **options: Check) -> ResultDef[Out]:
    """A result with one column read by ``read(outcome)``, in ``unit`` (:attr:`ResultDef.unit`)."""
    return ResultDef(doc=doc, columns=lambda o, d: [(column, dtype)], extract=lambda out, o, d: [read(out)],
                     options=options, unit=unit)
