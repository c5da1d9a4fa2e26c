"""Reading actuator trajectories from CSV or YAML files (``tensegrity follow FILE``).

CSV: a header row, then one row per point: ``time`` [s from the start], ``rho1``, ``rho2``
[m], optionally ``rho1_velocity``, ``rho2_velocity`` [m/s] and ``rho1_acceleration``,
``rho2_acceleration`` [m/s^2] (both of a pair or neither)::

    time,rho1,rho2
    1.0,0.72,0.68
    2.0,0.75,0.70

YAML: the same as a mapping, with the goal's tolerances::

    joint_names: [rho1, rho2]            # optional, this order by default
    points:
      - {time: 1.0, positions: [0.72, 0.68], velocities: [0.0, 0.0]}
    path_tolerance: {rho1: 0.01, rho2: 0.01}   # [m], optional
    goal_tolerance: {rho1: 1.0e-4}             # [m], optional
    goal_time_tolerance: 2.0                   # [s], optional

The file is bounded (:data:`MAX_BYTES`); numbers are checked by the controller when it
plans the goal (monotonic times, finite values, the workspace), so what is read here is
only structure. Errors are :class:`TrajectoryFileError` naming the file and the place.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

from tensegrity_core.class2.names import ACTUATED_JOINTS

#: Largest trajectory file accepted [bytes].
MAX_BYTES = 8 * 1024 * 1024
_CSV_PAIRS = (("rho1", "rho2"), ("rho1_velocity", "rho2_velocity"), ("rho1_acceleration", "rho2_acceleration"))


class TrajectoryFileError(ValueError):
    """A trajectory file that cannot be read; the message names the file and the place."""


@dataclass
class TrajectoryFile:
    joint_names: list
    times: list
    positions: list
    velocities: list = field(default_factory=list)
    accelerations: list = field(default_factory=list)
    path_tolerance: dict = field(default_factory=dict)
    goal_tolerance: dict = field(default_factory=dict)
    goal_time_tolerance: float = 0.0


def read_trajectory(path) -> TrajectoryFile:
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise TrajectoryFileError(f"{path}: {size} bytes; at most {MAX_BYTES} are accepted")
        text = path.read_text()
    except OSError as err:
        raise TrajectoryFileError(f"cannot read {path}: {err.strerror}") from None
    except UnicodeDecodeError:
        raise TrajectoryFileError(f"{path}: not a text file") from None
    if path.suffix.lower() == ".csv":
        return _from_csv(path, text)
    if path.suffix.lower() in (".yaml", ".yml"):
        return _from_yaml(path, text)
    raise TrajectoryFileError(f"{path}: give a .csv or .yaml file")


def _number(where: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TrajectoryFileError(f"{where}: {value!r} is not a number") from None
    return v


def _from_csv(path: Path, text: str) -> TrajectoryFile:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise TrajectoryFileError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in ("time", *ACTUATED_JOINTS) if c not in header]
    if missing:
        raise TrajectoryFileError(f"{path}: header needs the columns time, rho1, rho2 (missing {', '.join(missing)})")
    out = TrajectoryFile(list(ACTUATED_JOINTS), [], [])
    lists = [out.positions, out.velocities, out.accelerations]
    pairs = [p for p in _CSV_PAIRS if p[0] in header or p[1] in header]
    for a, b in pairs:
        if a not in header or b not in header:
            raise TrajectoryFileError(f"{path}: give both columns {a} and {b} or neither")
    for n, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise TrajectoryFileError(f"{path}: line {n}: {len(row)} values for {len(header)} columns")
        value = dict(zip(header, row))
        out.times.append(_number(f"{path}: line {n}: time", value["time"]))
        for (a, b), target in zip(_CSV_PAIRS, lists):
            if (a, b) in pairs:
                target.append([_number(f"{path}: line {n}: {a}", value[a]), _number(f"{path}: line {n}: {b}", value[b])])
    return out


def _from_yaml(path: Path, text: str) -> TrajectoryFile:
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise TrajectoryFileError(f"{path}: not valid YAML ({str(err).splitlines()[0]})") from None
    if not isinstance(data, dict) or not isinstance(data.get("points"), list):
        raise TrajectoryFileError(f"{path}: expected a mapping with a list 'points'")
    unknown = set(data) - {"joint_names", "points", "path_tolerance", "goal_tolerance", "goal_time_tolerance"}
    if unknown:
        raise TrajectoryFileError(f"{path}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
    names = data.get("joint_names", list(ACTUATED_JOINTS))
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise TrajectoryFileError(f"{path}: joint_names must be a list of names")
    out = TrajectoryFile(list(names), [], [])
    for i, point in enumerate(data["points"]):
        where = f"{path}: points[{i}]"
        if not isinstance(point, dict) or "time" not in point or "positions" not in point:
            raise TrajectoryFileError(f"{where}: needs time and positions")
        out.times.append(_number(f"{where}.time", point["time"]))
        for key, target in (("positions", out.positions), ("velocities", out.velocities),
                            ("accelerations", out.accelerations)):
            if key in point:
                values = point[key]
                if not isinstance(values, list):
                    raise TrajectoryFileError(f"{where}.{key}: must be a list")
                target.append([_number(f"{where}.{key}", v) for v in values])
    for key in ("path_tolerance", "goal_tolerance"):
        tol = data.get(key, {})
        if not isinstance(tol, dict):
            raise TrajectoryFileError(f"{path}: {key} must map joint names to metres")
        setattr(out, key, {str(k): _number(f"{path}: {key}.{k}", v) for k, v in tol.items()})
    gtt = _number(f"{path}: goal_time_tolerance", data.get("goal_time_tolerance", 0.0))
    if not math.isfinite(gtt) or gtt < 0:
        raise TrajectoryFileError(f"{path}: goal_time_tolerance must be a finite number of seconds >= 0")
    out.goal_time_tolerance = gtt
    return out
