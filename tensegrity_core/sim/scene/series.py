"""Series input laws: a column of a CSV file against a time column, read and checked once.

A scene's ``law: series`` names a CSV ``file`` (relative to the scene's folder), a ``column``
and optionally the ``time`` column (default: the first) and the ``interpolation``. The file
is a header row of column names, then rows of numbers; times must increase. It is read as
every description file is (bounded in size, UTF-8 checked: :func:`~tensegrity_core.schema.read_text`).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from tensegrity_core.schema import KeyPath, Reader, SchemaError, excerpt, read_text, suggest
from tensegrity_core.sim.inputs import INTERPOLATIONS, Series
from tensegrity_core.sim.scene.references import series_file


def read_series(reader: Reader, d: dict[str, Any], path: KeyPath, base: Path) -> Series:
    """The :class:`~tensegrity_core.sim.inputs.Series` of the law ``d`` at key path ``path``;
    ``reader``'s checks raise its error class, naming the key path (and the line)."""
    file = reader.string(d, "file", path)
    column = reader.string(d, "column", path)
    interpolation = reader.string(d, "interpolation", path, default="linear", choices=INTERPOLATIONS)
    csv = series_file(file, base)
    shown = excerpt(str(csv))
    try:
        text = read_text(csv, error=reader.error_class, what="CSV file")
    except SchemaError as err:
        raise reader.error(err.reason, path + ("file",), d, "file") from None
    first_line, _, rows = text.partition("\n")
    try:
        table = np.loadtxt(io.StringIO(rows), delimiter=",", ndmin=2)
    except ValueError as err:
        raise reader.error(f"cannot read {shown} as numbers after a header row: {excerpt(str(err))}",
                           path + ("file",), d, "file") from None
    header = [h.strip() for h in first_line.strip().split(",")]
    time_col = reader.string(d, "time", path, default=header[0])
    for k, col in (("time", time_col), ("column", column)):
        if col not in header:
            raise reader.error(f"{shown} has no column {excerpt(col)}{suggest(col, header)}; columns: "
                               f"{', '.join(header[:40])}", path + (k,), d, k)
    if table.shape[1] != len(header) or table.shape[0] < 1:
        raise reader.error(f"{shown}: {table.shape[0]} rows of {table.shape[1]} numbers for "
                           f"{len(header)} header columns", path + ("file",), d, "file")
    t = table[:, header.index(time_col)]
    v = table[:, header.index(column)]
    if not (np.isfinite(t).all() and np.isfinite(v).all()):
        raise reader.error(f"{shown} contains non-finite values", path + ("file",), d, "file")
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise reader.error(f"{shown}: times must increase, but row {i + 3} ({t[i + 1]:g} s) does not "
                           f"follow row {i + 2} ({t[i]:g} s)", path + ("file",), d, "file")
    if interpolation == "cubic" and len(t) < 3:
        raise reader.error("cubic interpolation needs at least 3 samples", path + ("interpolation",), d,
                           "interpolation")
    return Series(tuple(t.tolist()), tuple(v.tolist()), interpolation, str(csv))
