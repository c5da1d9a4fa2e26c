"""A gait as the points of a joint trajectory, and a rolling gait cut to its first faces. No ROS.

``tensegrity gait`` sends a gait (:class:`tensegrity_core.robot.gait.Gait`) as one
``control_msgs/FollowJointTrajectory`` goal: joint names = the gait's cables, positions =
rest lengths [m], ``time_from_start`` [s] = the gait's times with its ``start``,
``time_scale`` and cycles laid out (:meth:`Gait.table`). The cable controller interpolates
linearly between points, as a gait with ``interpolation: linear`` does; a zero-order-hold
gait (``previous``) gets, before each row, a point ``HOLD_EDGE_S`` earlier that holds the
row before it. A gait that starts later than 0 s holds its first row from 0.

A gait named on the command line is a shipped gait (``tensegrity_core/robot/examples/gaits``)
or the gait a shipped robot scene plays (``six_bar_roll``, ``three_bar_crawl``).

Rolling gaits derived by :func:`tensegrity_core.robot.tipping.gait_of_steps` have one shape:
the nominal rest lengths, then per tip a move row and a hold row (equal rows), then the
release to nominal. :func:`first_faces` keeps the first ``faces`` tips and releases after
them with that function's rule (the slowest motor's travel time x ``margin``, at least 0.05 s).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tensegrity_core.robot.gait import GAITS_DIR, Gait, GaitError, gait_file, gait_from_file, gait_names, read_gait

#: s: how long before a row of a zero-order-hold gait the previous row still holds.
HOLD_EDGE_S = 1e-6
#: The release's time margin and shortest move [s] of a derived rolling gait.
RELEASE_MARGIN = 1.2
SHORTEST_MOVE_S = 0.05


@dataclass(frozen=True)
class TrajectoryPoints:
    """``positions[i][j]`` [m] is joint ``joint_names[j]``'s rest length ``times[i]`` [s] after the start."""

    joint_names: tuple[str, ...]
    times: tuple[float, ...]
    positions: tuple[tuple[float, ...], ...]

    @property
    def duration(self) -> float:
        """s from the start to the last point."""
        return self.times[-1]


def trajectory_points(gait: Gait) -> TrajectoryPoints:
    """The points of the trajectory that plays ``gait`` (module note)."""
    t, rows = gait.table()
    times, positions = [], []
    if t[0] > 0:
        times.append(0.0)
        positions.append(tuple(float(v) for v in rows[0]))
    for i, (ti, row) in enumerate(zip(t.tolist(), rows)):
        if gait.interpolation == "previous" and i > 0 and ti - HOLD_EDGE_S > times[-1]:
            times.append(ti - HOLD_EDGE_S)
            positions.append(positions[-1])
        times.append(float(ti))
        positions.append(tuple(float(v) for v in row))
    return TrajectoryPoints(gait.cables, tuple(times), tuple(positions))


def tips(gait: Gait) -> int | None:
    """How many tips a rolling gait laid out by ``gait_of_steps`` holds (module note), or None
    when ``gait`` does not have that shape."""
    rows = gait.rest_lengths
    n = len(rows)
    if gait.period is not None or n < 4 or n % 2 or rows[0] != rows[-1]:
        return None
    if any(rows[k] != rows[k + 1] for k in range(1, n - 1, 2)):
        return None
    return (n - 2) // 2


def first_faces(gait: Gait, faces: int, max_speed: Sequence[float]) -> Gait:
    """``gait`` (a rolling gait of :func:`tips` tips) cut to its first ``faces`` tips, then the
    release to the nominal rest lengths; ``max_speed`` [m/s] of each cable's motor (inf: no
    slew limit). :class:`GaitError` when the gait is not such a gait or has fewer tips."""
    available = tips(gait)
    if available is None:
        raise GaitError(f"gait {gait.name!r} is not a rolling gait of tips (nominal, then a move and a hold per "
                        "tip, then the release): it cannot be cut to a number of faces")
    if not 1 <= faces <= available:
        raise GaitError(f"gait {gait.name!r} rolls {available} faces: faces must be in [1, {available}], got {faces}")
    rows = list(gait.rest_lengths[:1 + 2 * faces])
    times = list(gait.times[:1 + 2 * faces])
    nominal = gait.rest_lengths[0]
    travel = np.abs(np.asarray(rows[-1]) - np.asarray(nominal))
    speed = np.asarray(max_speed, dtype=float)
    seconds = np.divide(travel, speed, out=np.zeros_like(travel), where=np.isfinite(speed))
    release = max(SHORTEST_MOVE_S, RELEASE_MARGIN * float(np.max(seconds)))
    times.append(round(times[-1] + release, 4))
    rows.append(nominal)
    return Gait(name=gait.name, cables=gait.cables, times=tuple(times), rest_lengths=tuple(rows),
                interpolation=gait.interpolation, time_scale=gait.time_scale, start=gait.start,
                description=f"the first {faces} of {available} faces of {gait.name}")


def gait_named(name: str) -> Gait:
    """A shipped gait, or the gait of a shipped robot scene; :class:`GaitError` (with the
    choices) when there is neither."""
    from tensegrity_core.schema import Reader
    from tensegrity_core.schema.documents import read_file
    from tensegrity_core.sim.scene.reader import SHIPPED_SCENES, scene_path

    if name in gait_names():
        return gait_from_file(gait_file(name, GAITS_DIR, GaitError))
    if name in SHIPPED_SCENES.names():
        path = scene_path(name)
        data: Any = read_file(path, error=GaitError, what="scene file")[0]
        inputs = data.get("inputs") if isinstance(data, dict) else None
        if isinstance(inputs, dict) and "gait" in inputs:
            reader = Reader(GaitError, path.name)
            return read_gait(reader, inputs["gait"], ("inputs", "gait"), inputs, "gait", path.parent)
        raise GaitError(f"scene {name!r} plays no gait")
    choices = sorted(set(gait_names()) | {s for s in SHIPPED_SCENES.names() if _plays_gait(s)})
    raise GaitError(f"no shipped gait or robot scene named {name!r}; gaits: {', '.join(choices)}")


def _plays_gait(scene: str) -> bool:
    from tensegrity_core.schema.documents import read_file
    from tensegrity_core.sim.scene.reader import scene_path

    data = read_file(scene_path(scene), error=GaitError, what="scene file")[0]
    return isinstance(data, dict) and isinstance(data.get("inputs"), dict) and "gait" in data["inputs"]

