"""What a robot's run did, from the samples a ROS client receives: how far it rolled [m], over
how many faces, and the peak cable tensions [N]. No ROS: the caller collects the samples.

- Distance: the horizontal displacement (world x, y) of the robot's centre, the mean of its
  rods' centres (``body_states``: every rod of a shipped robot has the same mass, so this is
  the rods' centre of mass), from the first sample to the last.
- Faces: the caps touching the floor over time (``contacts``) give the faces the robot rested
  on (:func:`tensegrity_core.robot.faces.faces_visited`: a set of at least three caps held
  for ``hold`` s) and the faces rolled (:func:`~tensegrity_core.robot.faces.faces_rolled`: new
  faces after the first; a rock back onto a face is not a new one).
- Faces touched (given the robot's hull faces, as cap names): every hull face whose caps all
  touched the floor at one ``contacts`` sample, however briefly
  (:func:`~tensegrity_core.robot.faces.faces_touched`): a robot that rolls through a face
  without resting on it has still crossed its edges; the number beyond the first is the
  strict count of faces crossed.
- Tensions: the largest tension [N] of each motor cable over the run (``joint_states``
  effort, positive pulling).
- Rest (:func:`rest_time`): a gait's goal ends when the motors reach its last rest lengths,
  not when the robot stops; a robot still rolling then goes on over more faces (its caps
  roll on the floor, which has no rolling resistance, docs/robots.md). The robot is at rest
  once, for ``hold`` s, one face (the same set of at least three caps) touched the floor and
  its centre stayed within ``speed * hold`` [m] (horizontally) of where it is.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tensegrity_core.robot.faces import faces_rolled, faces_touched, faces_visited

#: s a face and the centre must hold still for the robot to be at rest
REST_HOLD_S = 0.5
#: m/s: the largest mean horizontal speed of the centre over ``REST_HOLD_S`` of a robot at rest.
REST_SPEED = 0.02


@dataclass(frozen=True)
class RollSummary:
    """``displacement`` (x, y) [m] of the centre and its length ``distance`` [m]; ``faces``
    rolled over and the ``visited`` faces (time [s], caps); ``peak_tensions`` [N] by measured cable;
    ``touched`` hull faces touched beyond the first (None: no hull given)."""

    displacement: tuple[float, float]
    distance: float
    faces: int
    visited: tuple[tuple[float, tuple[str, ...]], ...]
    peak_tensions: dict[str, float]
    touched: int | None = None

    def lines(self, top: int = 3) -> list[str]:
        """The summary as printed lines, every number with its unit."""
        dx, dy = self.displacement
        out = [f"distance rolled: {self.distance:.3f} m (centre moved by ({dx:+.3f}, {dy:+.3f}) m in x, y)",
               f"faces rolled: {self.faces} ({len(self.visited)} faces rested on"
               + ("" if self.touched is None else f"; {self.touched} faces crossed, counting those touched however "
                  "briefly") + ")"]
        if not self.peak_tensions:
            out.append("peak tensions: no joint states with a measured tension received")
        else:
            ranked = sorted(self.peak_tensions.items(), key=lambda kv: -kv[1])
            out.append("peak tensions: " + ", ".join(f"{name} {value:.1f} N" for name, value in ranked[:top])
                       + f" (largest {min(top, len(ranked))} of {len(ranked)} motor cables)")
        return out


def roll_summary(centres: Sequence[Sequence[float]], contact_times: Sequence[float],
                 contacts: Sequence[Sequence[str]], cable_names: Sequence[str],
                 tensions: Sequence[Sequence[float]], *, hold: float = 0.05,
                 hull: Sequence[Sequence[str]] | None = None) -> RollSummary:
    """The summary of a run (module note): ``centres`` (N, 3) [m] the robot's centre at each
    body-states sample, in time order; ``contacts[i]`` the caps touching at
    ``contact_times[i]`` [s]; ``tensions`` (M, cables) [N] of ``cable_names`` at each joint state;
    ``hull`` the robot's hull faces (three cap names each) for the faces touched."""
    c = np.asarray(centres, dtype=float)
    if len(c):
        d = c[-1, :2] - c[0, :2]
    else:
        d = np.zeros(2)
    caps = sorted({name for names in contacts for name in names})
    matrix = np.array([[cap in set(names) for cap in caps] for names in contacts], dtype=bool).reshape(len(contacts),
                                                                                                       len(caps))
    visited = faces_visited(np.asarray(contact_times, dtype=float), matrix, hold)
    faces = tuple((t, tuple(caps[i] for i in sorted(face))) for t, face in visited)
    peaks: dict[str, float] = {}
    if len(tensions) and len(cable_names):
        tension = np.asarray(tensions, dtype=float).reshape(-1, len(cable_names))
        peaks = {name: float(np.nanmax(tension[:, j])) for j, name in enumerate(cable_names)
                 if not np.isnan(tension[:, j]).all()}          # NaN: a cable whose tension is not measured
    touched = None
    if hull is not None:
        index = {name: i for i, name in enumerate(sorted({n for f in hull for n in f} | set(caps)))}
        rows = [[index[n] for n in names if n in index] for names in contacts]
        triples = [(index[a], index[b], index[c]) for a, b, c in hull]
        touched = max(len(faces_touched(rows, triples)) - 1, 0)
    return RollSummary((float(d[0]), float(d[1])), float(np.hypot(*d)), faces_rolled(visited), faces, peaks,
                       touched)


def rest_time(times: Sequence[float], centres: Sequence[Sequence[float]], contact_times: Sequence[float],
              contacts: Sequence[Sequence[str]], after: float, *, hold: float = REST_HOLD_S,
              speed: float = REST_SPEED) -> float | None:
    """The first body-states sample time ``t >= after`` [s] at which the robot is at rest
    (module note): over ``[t - hold, t]`` every contacts sample is the same set of at least
    three caps and every centre (``centres`` (N, 3) [m] at ``times`` [s]) within
    ``speed * hold`` [m] of the centre at ``t`` in x, y. None: not at rest in the samples."""
    if not len(times) or not len(contact_times):
        return None
    t = np.asarray(times, dtype=float)
    xy = np.asarray(centres, dtype=float)[:, :2]
    ct = np.asarray(contact_times, dtype=float)
    sets = [frozenset(names) for names in contacts]
    for i in np.flatnonzero(t >= after):
        lo = t[i] - hold
        if lo < min(t[0], ct[0]):
            continue                                # not watched for ``hold`` s yet
        near = np.hypot(*(xy[(t >= lo) & (t <= t[i])] - xy[i]).T)
        faces = {sets[k] for k in np.flatnonzero((ct >= lo) & (ct <= t[i]))}
        if near.max() <= speed * hold and len(faces) == 1 and len(next(iter(faces))) >= 3:
            return float(t[i])
    return None
