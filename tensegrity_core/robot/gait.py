"""Gaits: tables of cable rest lengths over time, played once or periodically.

A gait names the cables it drives and gives their rest lengths [m] at increasing times [s]
from 0 (one row per time, one value per cable), interpolated ``linear``-ly or held
(``previous``, a zero-order hold). With a ``period`` (after the last row) it is periodic:
after the last row it runs on to the first row at ``period`` and repeats ``cycles`` times,
then holds the first row. ``time_scale`` stretches every time (a sweep varies a gait's
speed through it) and ``start`` delays the whole gait.

As a file (YAML)::

    name: six_bar_roll
    cables: [c0_4, c0_8, ...]           # actuated cables (or actuator members)
    times: [0.0, 0.4, 0.9, ...]         # s, from 0, increasing
    rest_lengths:                       # m, one row per time, one value per cable
      - [0.996, 0.996, ...]
    interpolation: linear               # or previous
    period: 12.0                        # s, optional: periodic
    cycles: 1                           # repetitions of a periodic gait
    time_scale: 1.0
    start: 0.0                          # s

A scene lists it among its inputs (``inputs: {gait: {file: six_bar_roll, cycles: 2}}``, or
the table inline): :meth:`Gait.laws` compiles it into one
:class:`~tensegrity_core.sim.inputs.Series` law per cable, whose breakpoints are the rows'
times, so integrators restart at every corner of the table.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from tensegrity_core.schema import KeyPath, Reader, SchemaError, ShippedFiles, excerpt, read_file, resolve_source

if TYPE_CHECKING:
    from tensegrity_core.sim.inputs import Series

GAITS_DIR: Final = Path(__file__).parent / "examples" / "gaits"
GAIT_KEYS: Final = ("name", "description", "cables", "times", "rest_lengths", "interpolation", "period", "cycles",
                    "time_scale", "start")
#: Keys a scene may give beside ``file`` to change a gait read from a file.
OVERRIDES: Final = ("cycles", "time_scale", "start")
INTERPOLATIONS: Final = ("linear", "previous")


class GaitError(SchemaError):
    """A gait is invalid (key path, line and file as for every description)."""


_SHIPPED: Final = ShippedFiles(GAITS_DIR, "gait", "shipped gaits", GaitError)


@dataclass(frozen=True)
class Gait:
    """A checked gait (module docstring): ``rest_lengths[i][j]`` is cable ``cables[j]``'s rest
    length [m] at ``times[i]`` [s]."""

    name: str
    cables: tuple[str, ...]
    times: tuple[float, ...]
    rest_lengths: tuple[tuple[float, ...], ...]
    interpolation: str = "linear"
    period: float | None = None
    cycles: int = 1
    time_scale: float = 1.0
    start: float = 0.0
    description: str = ""

    @property
    def duration(self) -> float:
        """When the gait ends [s] (from t = 0, with ``start``): it holds its last value after."""
        one = self.period if self.period is not None else self.times[-1]
        return self.start + self.time_scale * one * self.cycles

    def table(self) -> tuple[np.ndarray, np.ndarray]:
        """``(t (N,), rest lengths (N, cables))`` of the whole gait, every cycle laid out."""
        t0 = np.asarray(self.times, dtype=float)
        rows = np.asarray(self.rest_lengths, dtype=float)
        if self.period is None:
            t, v = t0, rows
        else:
            P = self.period
            t = np.concatenate([c * P + t0 for c in range(self.cycles)] + [[self.cycles * P]])
            v = np.concatenate([rows] * self.cycles + [rows[:1]])
        return self.start + self.time_scale * t, v

    def laws(self) -> dict[str, Series]:
        """One :class:`Series` law per cable (rest lengths [m] over time)."""
        from tensegrity_core.sim.inputs import Series  # the scenes import gaits: no cycle at import

        t, v = self.table()
        times = tuple(t.tolist())
        return {name: Series(times, tuple(v[:, j].tolist()), self.interpolation, f"gait {self.name}")
                for j, name in enumerate(self.cables)}

    def with_options(self, **changes: Any) -> Gait:
        """The same gait with other ``cycles``, ``time_scale`` or ``start``."""
        return replace(self, **changes)


def gait_to_dict(gait: Gait) -> dict[str, Any]:
    """The gait as plain data (the file format); ``gait_from_dict`` reads it back."""
    out: dict[str, Any] = {"name": gait.name}
    if gait.description:
        out["description"] = gait.description
    out |= {"cables": list(gait.cables), "times": list(gait.times),
            "rest_lengths": [list(r) for r in gait.rest_lengths], "interpolation": gait.interpolation}
    if gait.period is not None:
        out["period"] = gait.period
    for key, default in (("cycles", 1), ("time_scale", 1.0), ("start", 0.0)):
        if getattr(gait, key) != default:
            out[key] = getattr(gait, key)
    return out


def gait_names() -> list[str]:
    """Names of the shipped gaits."""
    return _SHIPPED.names()


def read_gait(reader: Reader, value: object, path: KeyPath, parent: Any, key: Any, base: Path) -> Gait:
    """A gait from a scene's (or a gait file's) data, checked by ``reader`` (so errors are the
    reader's format's, located): a mapping with the table inline, or ``file`` (a path
    relative to ``base``, or a shipped gait's name) with optional :data:`OVERRIDES`."""
    d = reader.mapping(value, path, parent, key)
    if "file" not in d:
        return _table(reader, d, path)
    reader.keys(d, path, ("file",) + OVERRIDES)
    source = gait_file(reader.string(d, "file", path), base,
                       lambda message: reader.error(message, path + ("file",), d, "file"))
    gait = gait_from_file(source)
    return _options(reader, d, path, gait)


def gait_file(name: str, base: Path, error: Callable[[str], Exception]) -> Path:
    """The file a gait's ``file`` names: a path relative to ``base`` or a shipped gait's name
    (the rules of :func:`~tensegrity_core.schema.resolve_source`); ``error`` makes the
    exception of a refusal from its message."""
    found = resolve_source(name, what="gait", shipped=_SHIPPED, error=error, folder=base, text=None, data=False)
    assert found.path is not None                 # neither text nor data is accepted
    return found.path


def gait_from_file(path: str | Path) -> Gait:
    """The gait in a YAML (or JSON, TOML) file; errors name the file."""
    path = Path(path)
    data, _, _ = read_file(path, error=GaitError, what="gait file")
    reader = Reader(GaitError, path.name)
    gait = _table(reader, reader.mapping(data, ()), ())
    return gait if gait.name else replace(gait, name=path.stem)


def gait_from_dict(data: object, name: str = "gait") -> Gait:
    """The gait in parsed data."""
    reader = Reader(GaitError)
    gait = _table(reader, reader.mapping(data, ()), ())
    return gait if gait.name else replace(gait, name=name)


def _table(reader: Reader, d: Mapping[Any, Any], path: KeyPath) -> Gait:
    reader.keys(d, path, GAIT_KEYS, required=("cables", "times", "rest_lengths"))
    name = reader.string(d, "name", path, default="")
    description = reader.string(d, "description", path, default="")
    cables_raw = d["cables"]
    if not isinstance(cables_raw, list) or not cables_raw or not all(isinstance(c, str) for c in cables_raw):
        raise reader.error(f"must be a non-empty list of cable names, got {excerpt(cables_raw)}", path + ("cables",),
                           d, "cables")
    if len(set(cables_raw)) != len(cables_raw):
        twice = next(c for c in cables_raw if cables_raw.count(c) > 1)
        raise reader.error(f"cable {excerpt(twice)} is listed twice", path + ("cables",), d, "cables")
    times_raw = d["times"]
    if not isinstance(times_raw, list) or not times_raw:
        raise reader.error(f"must be a non-empty list of times (s), got {excerpt(times_raw)}", path + ("times",), d,
                           "times")
    times = [reader.value_number(t, path + ("times", i), times_raw, i, unit="s", lo=0.0) for i, t in enumerate(times_raw)]
    if times[0] != 0.0:
        raise reader.error(f"the first time must be 0 s, got {times[0]:g}", path + ("times", 0), times_raw, 0)
    for i in range(1, len(times)):
        if not times[i] > times[i - 1]:
            raise reader.error(f"times must increase, but {times[i]:g} s follows {times[i - 1]:g} s",
                               path + ("times", i), times_raw, i)
    rows_raw = d["rest_lengths"]
    if not isinstance(rows_raw, list) or len(rows_raw) != len(times):
        raise reader.error(f"must be a list of {len(times)} rows (one per time), got {excerpt(rows_raw)}",
                           path + ("rest_lengths",), d, "rest_lengths")
    rows = []
    for i, row in enumerate(rows_raw):
        values = reader.vector(row, len(cables_raw), path + ("rest_lengths", i), rows_raw, i,
                               unit="m", what="rest lengths (m), one per cable")
        for j, v in enumerate(values):
            if not v > 0:
                raise reader.error(f"rest length of {excerpt(cables_raw[j])} must be > 0 m, got {v:g}",
                                   path + ("rest_lengths", i, j), row, j)
        rows.append(values)
    interpolation = reader.string(d, "interpolation", path, default="linear", choices=INTERPOLATIONS)
    period = None
    if "period" in d:
        period = reader.number(d, "period", path, unit="s", lo=times[-1], lo_open=True)
    gait = Gait(name=name, cables=tuple(cables_raw), times=tuple(times), rest_lengths=tuple(rows),
                interpolation=interpolation, period=period, description=description)
    return _options(reader, d, path, gait)


def _options(reader: Reader, d: Mapping[Any, Any], path: KeyPath, gait: Gait) -> Gait:
    cycles = reader.integer(d, "cycles", path, default=gait.cycles, lo=1)
    if cycles > 1 and gait.period is None:
        raise reader.error(f"{cycles} cycles need a periodic gait (a period after the last row)", path + ("cycles",),
                           d, "cycles")
    scale = reader.number(d, "time_scale", path, unit="", default=gait.time_scale, lo=0.0, lo_open=True)
    start = reader.number(d, "start", path, unit="s", default=gait.start, lo=0.0)
    out = gait.with_options(cycles=cycles, time_scale=scale, start=start)
    samples = len(out.times) * out.cycles
    if samples > 10_000_000 or not math.isfinite(out.duration):
        raise reader.error(f"{samples} gait samples ({out.cycles} cycles of {len(out.times)} rows) are too many",
                           path, d, None)
    return out
