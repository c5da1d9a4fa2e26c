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
the nominal rest lengths, then per tip a move row and a hold row (equal rows), a release row
and a rest row (the nominal rest lengths). :func:`first_faces` keeps the first ``faces`` tips
with their releases and rests.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from tensegrity_core.robot.gait import GAITS_DIR, Gait, GaitError, gait_file, gait_from_file, gait_names, read_gait

#: s: how long before a row of a zero-order-hold gait the previous row still holds.
HOLD_EDGE_S = 1e-6


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
    if gait.period is not None or n < 5 or (n - 1) % 4:
        return None
    if any(rows[k] != rows[k + 1] for k in range(1, n - 1, 2)) or any(rows[k] != rows[0] for k in range(4, n, 4)):
        return None
    return (n - 1) // 4


def first_faces(gait: Gait, faces: int) -> Gait:
    """``gait`` (a rolling gait of :func:`tips` tips) cut to its first ``faces`` tips, each
    with its release and rest. :class:`GaitError` when the gait is not such a gait or has
    fewer tips."""
    available = tips(gait)
    if available is None:
        raise GaitError(f"gait {gait.name!r} is not a rolling gait of tips (nominal, then a move, a hold, a release "
                        "and a rest per tip): it cannot be cut to a number of faces")
    if not 1 <= faces <= available:
        raise GaitError(f"gait {gait.name!r} rolls {available} faces: faces must be in [1, {available}], got {faces}")
    return Gait(name=gait.name, cables=gait.cables, times=gait.times[:1 + 4 * faces],
                rest_lengths=gait.rest_lengths[:1 + 4 * faces], interpolation=gait.interpolation,
                time_scale=gait.time_scale, start=gait.start,
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

