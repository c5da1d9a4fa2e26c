"""Where a sweep's rows go: a journal while it runs, one table (Parquet or CSV) at the end.

While the sweep runs, every finished batch is appended to the *journal* next to the output,
``<output>.partial.jsonl`` (a header line with the sweep's fingerprint, then one JSON row per
line, flushed and synced per batch), so a killed sweep keeps every point that finished; a
line cut short by the kill is dropped when the journal is read again. At the end the rows of
the previous output (with ``--resume``), of the journal and of this run are combined, each
point once, sorted by point, written to a temporary file and renamed over the output; then
the journal is removed. ``--resume`` reads the output and the journal, checks that they
belong to this sweep (the fingerprint and every row's inputs), and runs only the points not
there (and the ``lost`` ones).

The table has one row per point: ``point``, the varied quantities, ``seed``, the results,
``status``, ``message``, ``run_time`` [s] and ``sweep_id`` (the fingerprint).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from tensegrity_core.sweep.errors import SweepError, require
from tensegrity_core.sweep.points import Point
from tensegrity_core.sweep.task import FINAL_STATUSES, Row

#: A column of the table: ``(name, dtype)``, dtype None for inferred (the varied quantities).
TableColumn = tuple[str, str | None]

FORMATS = (".parquet", ".csv")
DTYPES = {"float": "float64", "int": "Int64", "bool": "boolean", "str": "string"}


def journal_path(output: Path) -> Path:
    return output.with_name(output.name + ".partial.jsonl")


def check_output_path(output: Path) -> None:
    """Refuse an output that cannot be written before anything runs."""
    if output.suffix.lower() not in FORMATS:
        raise SweepError(f"the output must end in .parquet or .csv, got {str(output)!r}")
    if not output.parent.is_dir():
        raise SweepError(f"the output's folder {str(output.parent)!r} does not exist")
    if output.is_dir():
        raise SweepError(f"the output {str(output)!r} is a folder")


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    try:
        if a == b:
            return True
    except (TypeError, ValueError):
        pass
    return str(a) == str(b)


def _clean(value: Any) -> Any:
    """A table cell as a plain Python value (pandas' NA -> None, numpy scalars -> Python)."""
    if value is None:
        return None
    try:
        import pandas as pd  # type: ignore[import-untyped]  # (pandas-stubs is not a dependency)

        if value is pd.NA:
            return None
    except ImportError:  # pragma: no cover
        pass
    return value.item() if hasattr(value, "item") else value


class Store:
    """The output table and its journal for one sweep run.

    ``columns``: every column of a row, in order, with its dtype (``None`` for inferred).
    ``inputs``: the columns that define a point (checked against earlier rows on resume)."""

    def __init__(self, output: Path | None, sweep_id: str, columns: list[TableColumn], inputs: list[str]):
        self.output = Path(output) if output is not None else None
        self.sweep_id = sweep_id
        self.columns = columns
        self.inputs = inputs
        self.journal = journal_path(self.output) if self.output is not None else None    # None iff output is
        self._fh: TextIO | None = None

    # -- earlier rows ----------------------------------------------------------------------
    def previous(self, points: Sequence[Point]) -> dict[int, Row]:
        """Rows of this sweep already in the output or the journal, by point (resume)."""
        output, journal = self.output, self.journal
        if output is None or journal is None:
            raise SweepError("--resume needs an output (-o) to resume from")
        rows: dict[int, Row] = {}
        if output.exists():
            for row in self._read_table(output):
                rows.setdefault(int(row["point"]), row)
        if journal.exists():
            for row in self._read_journal(journal):
                rows.setdefault(int(row["point"]), row)
        by_index = {p.index: p for p in points}
        names = [c for c, _ in self.columns]
        for index, row in rows.items():
            where = f"{output.name}: point {index}"
            if index not in by_index:
                raise SweepError(f"{where} is not a point of this sweep (it has {len(points)}); "
                                 f"the output belongs to another sweep: choose another -o or remove it")
            if row.get("sweep_id") != self.sweep_id:
                raise SweepError(f"{where} comes from another sweep (sweep_id {row.get('sweep_id')!r}, this "
                                 f"sweep {self.sweep_id!r}: the base, computation, results or seed changed); "
                                 f"choose another -o or remove it")
            if set(row) != set(names):
                raise SweepError(f"{where} has other columns than this sweep's; choose another -o or remove it")
            for column, value in zip(self.inputs, self._point_inputs(by_index[index])):
                if not _same(row[column], value):
                    raise SweepError(f"{where} has {column} = {row[column]!r}, this sweep {value!r}: the output "
                                     f"belongs to another sweep; choose another -o or remove it")
        return {i: r for i, r in rows.items() if r.get("status") in FINAL_STATUSES}

    def _point_inputs(self, point: Point) -> tuple[Any, ...]:
        return (point.index, *point.values, point.seed)

    def _read_table(self, path: Path) -> list[Row]:
        pd = require("pandas")
        try:
            if path.suffix.lower() == ".parquet":
                df = pd.read_parquet(path)
            else:
                exact = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
                df = pd.read_csv(path, keep_default_na=False, **exact,    # pandas 3 reads floats exactly
                                 na_values={c: ["", "NaN", "nan", "<NA>"] for c, _ in self.columns
                                            if c not in ("message", "status")})
        except Exception as err:  # noqa: BLE001 - any unreadable file: say which and why
            raise SweepError(f"cannot read the earlier results {str(path)!r}: {err}") from None
        return [{k: _clean(v) for k, v in rec.items()} for rec in df.to_dict("records")]

    def _read_journal(self, journal: Path) -> list[Row]:
        rows: list[Row] = []
        with open(journal, encoding="utf-8") as fh:
            header = fh.readline()
            try:
                head = json.loads(header)
            except json.JSONDecodeError:
                return rows          # killed before its header was complete
            if head.get("sweep_id") != self.sweep_id:
                raise SweepError(f"{journal.name} comes from another sweep (sweep_id "
                                 f"{head.get('sweep_id')!r}, this sweep {self.sweep_id!r}); remove it or run "
                                 f"without --resume")
            for line in fh:
                try:
                    row = json.loads(line)
                except json.JSONDecodeError:
                    continue         # the line a kill cut short
                if isinstance(row, dict) and "point" in row:
                    rows.append(row)
        return rows

    # -- this run --------------------------------------------------------------------------
    def open(self, keep: list[Row]) -> None:
        """Start the journal with its header and the rows kept from earlier runs (rewritten
        cleanly, so a line cut short by a kill is not continued)."""
        journal = self.journal
        if journal is None:                     # no output
            return
        tmp = journal.with_name(journal.name + ".tmp")
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(json.dumps({"sweep_id": self.sweep_id, "columns": [c for c, _ in self.columns]}) + "\n")
            for row in keep:
                fh.write(json.dumps(row) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, journal)
        self._fh = open(journal, "a", encoding="utf-8")

    def append(self, rows: list[Row]) -> None:
        if self._fh is None:
            return
        self._fh.write("".join(json.dumps({**r, "sweep_id": self.sweep_id}) + "\n" for r in rows))
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def table(self, rows: list[Row]) -> Any:
        """The rows as a pandas DataFrame in the sweep's column order and dtypes."""
        pd = require("pandas")
        rows = sorted(rows, key=lambda r: r["point"])
        data: dict[str, Any] = {}
        for column, dtype in self.columns:
            values = [r.get(column, self.sweep_id if column == "sweep_id" else None) for r in rows]
            if dtype is None:
                data[column] = pd.Series(values, dtype=None if values else "float64")
            elif dtype == "float":
                data[column] = pd.Series([math.nan if v is None else float(v) for v in values], dtype="float64")
            else:
                data[column] = pd.Series(values, dtype=DTYPES[dtype])
        return pd.DataFrame(data)

    def finish(self, rows: list[Row]) -> Any:
        """Write the combined table (atomically) and remove the journal; the table (a pandas
        DataFrame)."""
        self.close()
        df = self.table(rows)
        output, journal = self.output, self.journal
        if output is None or journal is None:
            return df
        require("pyarrow") if output.suffix.lower() == ".parquet" else None
        tmp = output.with_name(output.name + ".tmp")
        try:
            if output.suffix.lower() == ".parquet":
                df.to_parquet(tmp, index=False)
            else:
                df.to_csv(tmp, index=False)
            os.replace(tmp, output)
        except OSError as err:
            tmp.unlink(missing_ok=True)
            raise SweepError(f"cannot write {str(output)!r}: {err.strerror}") from None
        except BaseException:          # interrupted while writing: no half-written file is left
            tmp.unlink(missing_ok=True)
            raise
        journal.unlink(missing_ok=True)
        return df
