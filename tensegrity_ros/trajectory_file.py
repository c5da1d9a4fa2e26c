"""Reading actuator trajectories from CSV or YAML files (``tensegrity follow FILE``).

CSV: a header row, then one row per point: ``time`` [s from the start], ``rho1``, ``rho2``
[m], optionally ``rho1_velocity``, ``rho2_velocity`` [m/s] and ``rho1_acceleration``,
``rho2_acceleration`` [m/s^2] (both of a pair or neither)::

    time,rho1,rho2
    2.0,0.71,0.69
    4.0,0.72,0.70
    6.0,0.70,0.70

(from rest at 0.70 m, the lengths meet the default goal tolerance, 0.1 mm, 4.1 s after the
last point: within the controller's default ``goal_time_tolerance`` of 6 s). YAML: the
same as a mapping, with the goal's tolerances (this one meets 0.1 mm 3.5 s after its
point)::

    joint_names: [rho1, rho2]            # optional, this order by default
    points:
      - {time: 1.0, positions: [0.72, 0.68], velocities: [0.0, 0.0]}
    path_tolerance: {rho1: 0.01, rho2: 0.01}   # [m], optional
    goal_tolerance: {rho1: 1.0e-4}             # [m], optional
    goal_time_tolerance: 5.0                   # [s], optional

Both are read as every description file is (:mod:`tensegrity_core.schema`: at most
``LIMITS.max_bytes``, UTF-8, YAML nesting and aliases bounded). Each number is checked to
be a finite number here, and the times [s] to be >= 0 and to increase strictly from point to
point; what the other numbers mean (the workspace, the tolerances) the controller checks when
it plans the goal. Errors are :class:`TrajectoryFileError` with
the file, the key path (YAML) or the column (CSV), and the line.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from tensegrity_core.class2.names import ACTUATED_JOINTS
from tensegrity_core.schema import KeyPath, Limits, Reader, SchemaError, excerpt, read_file, read_text

#: Bounds of a trajectory file (at most 8 MiB).
LIMITS: Final = Limits(max_bytes=8 * 1024 * 1024)
TOP: Final = ("joint_names", "points", "path_tolerance", "goal_tolerance", "goal_time_tolerance")
POINT_KEYS: Final = ("time", "positions", "velocities", "accelerations")
_CSV_PAIRS: Final = (("rho1", "rho2"), ("rho1_velocity", "rho2_velocity"), ("rho1_acceleration", "rho2_acceleration"))


class TrajectoryFileError(SchemaError):
    """A trajectory file that cannot be read; ``str()`` names the file, the place and the line."""


@dataclass
class TrajectoryFile:
    """A trajectory as read: ``times`` [s], and per point ``positions`` [m] (one per joint of
    ``joint_names``), optionally ``velocities`` [m/s] and ``accelerations`` [m/s^2];
    tolerances per joint [m] and of the goal's time [s]."""

    joint_names: list[str]
    times: list[float]
    positions: list[list[float]]
    velocities: list[list[float]] = field(default_factory=list)
    accelerations: list[list[float]] = field(default_factory=list)
    path_tolerance: dict[str, float] = field(default_factory=dict)
    goal_tolerance: dict[str, float] = field(default_factory=dict)
    goal_time_tolerance: float = 0.0


def read_trajectory(path: str | Path) -> TrajectoryFile:
    """The trajectory in the ``.csv`` or ``.yaml``/``.yml`` file ``path``."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return _from_csv(read_text(path, limits=LIMITS, error=TrajectoryFileError, what="trajectory file"), path.name)
    if suffix in (".yaml", ".yml"):
        data, _, _ = read_file(path, limits=LIMITS, error=TrajectoryFileError, what="trajectory file")
        return _TrajectoryReader(path.name).trajectory(data)
    raise TrajectoryFileError(f"give a .csv or .yaml file, got {path.name!r}", file=path.name)


def _from_csv(text: str, file: str) -> TrajectoryFile:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise TrajectoryFileError("empty file", file=file)
    header = [h.strip() for h in rows[0]]
    missing = [c for c in ("time", *ACTUATED_JOINTS) if c not in header]
    if missing:
        raise TrajectoryFileError(f"header needs the columns time, rho1, rho2 (missing {', '.join(missing)})",
                                  line=1, file=file)
    out = TrajectoryFile(list(ACTUATED_JOINTS), [], [])
    lists = [out.positions, out.velocities, out.accelerations]
    pairs = [p for p in _CSV_PAIRS if p[0] in header or p[1] in header]
    for a, b in pairs:
        if a not in header or b not in header:
            raise TrajectoryFileError(f"give both columns {a} and {b} or neither", line=1, file=file)
    for n, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise TrajectoryFileError(f"{len(row)} values for {len(header)} columns", line=n, file=file)
        value = dict(zip(header, row))
        t = _csv_number(value, "time", n, file)
        reason = _time_reason(t, out.times)
        if reason:
            raise TrajectoryFileError(reason, key=("time",), line=n, file=file)
        out.times.append(t)
        for (a, b), target in zip(_CSV_PAIRS, lists):
            if (a, b) in pairs:
                target.append([_csv_number(value, a, n, file), _csv_number(value, b, n, file)])
    return out


def _csv_number(row: dict[str, str], column: str, line: int, file: str) -> float:
    """The finite number in ``column`` of a CSV row (on ``line``)."""
    try:
        x = float(row[column])
    except ValueError:
        raise TrajectoryFileError(f"{excerpt(row[column])} is not a number", key=(column,), line=line,
                                  file=file) from None
    if not math.isfinite(x):
        raise TrajectoryFileError(f"must be finite, got {excerpt(row[column])}", key=(column,), line=line, file=file)
    return x


def _time_reason(t: float, before: list[float]) -> str:
    """Why ``t`` [s] cannot be the time of the point after the points at ``before``, or ''."""
    i = len(before)
    if t < 0.0:
        return f"point {i}: time {t:g} s is negative (times are seconds from the start)"
    if before and t <= before[-1]:
        return f"point {i} at {t:g} s does not follow point {i - 1} at {before[-1]:g} s (times must increase strictly)"
    return ""


class _TrajectoryReader(Reader):
    """The YAML trajectory's schema over the shared checks."""

    def __init__(self, file: str | None) -> None:
        super().__init__(TrajectoryFileError, file)

    def trajectory(self, data: object) -> TrajectoryFile:
        d = self.mapping(data, ())
        self.keys(d, (), TOP, required=("points",))
        names = self.joint_names(d)
        out = TrajectoryFile(names, [], [])
        points = self.sequence(d["points"], ("points",), d, "points", of="points {time, positions}")
        for i, point in enumerate(points):
            path: KeyPath = ("points", i)
            p = self.mapping(point, path, points, i)
            self.keys(p, path, POINT_KEYS, required=("time", "positions"))
            t = self.number(p, "time", path, unit="s")
            reason = _time_reason(t, out.times)
            if reason:
                raise self.error(reason, path + ("time",), p, "time")
            out.times.append(t)
            for key, target, unit in (("positions", out.positions, "m"), ("velocities", out.velocities, "m/s"),
                                      ("accelerations", out.accelerations, "m/s^2")):
                if key in p:
                    values = self.sequence(p[key], path + (key,), p, key, of="numbers")
                    target.append([self.value_number(v, path + (key, j), values, j, unit=unit)
                                   for j, v in enumerate(values)])
        out.path_tolerance = self.tolerances(d, "path_tolerance", names)
        out.goal_tolerance = self.tolerances(d, "goal_tolerance", names)
        out.goal_time_tolerance = self.number(d, "goal_time_tolerance", (), unit="s", default=0.0, lo=0.0)
        return out

    def joint_names(self, d: dict[Any, Any]) -> list[str]:
        if "joint_names" not in d:
            return list(ACTUATED_JOINTS)
        names = self.sequence(d["joint_names"], ("joint_names",), d, "joint_names", of="joint names")
        for j, name in enumerate(names):
            if not isinstance(name, str):
                raise self.error(f"must be a joint name, got {excerpt(name)}", ("joint_names", j), names, j)
        return list(names)

    def tolerances(self, d: dict[Any, Any], key: str, names: list[str]) -> dict[str, float]:
        """Joint name (one of the trajectory's ``names``) -> tolerance [m] (a finite number;
        the controller checks the rest)."""
        tol = self.mapping(d.get(key, {}), (key,), d, key)
        self.keys(tol, (key,), names)
        return {str(k): self.number(tol, k, (key,), unit="m") for k in tol}
