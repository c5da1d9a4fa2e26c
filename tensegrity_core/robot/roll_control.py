"""A closed-loop rolling gait: read which face the robot rests on, tip it over the edge
towards a heading, count the faces it reaches.

An open-loop gait (:mod:`.tipping`, laid out in time) plans every move from where the
derivation says the robot will be; once a real (or simulated) robot lands elsewhere, the
rest of the table meets it in a state it was not derived for. :class:`RollController`
instead decides each move from the **contact state** (which caps touch the floor, the
``cap_contact`` reading; faces as :mod:`.faces` counts them) and the caps' positions on the
floor, sampled at the control rate:

1. **Resting.** A set of at least three touching caps held for ``hold`` [s] is a face (as
   :func:`.faces.faces_visited` counts them). The face the robot is resting on is the hull
   face of its rest shape among the touching caps (with four or more touching: the one whose
   caps are lowest). A face not visited before counts as one face rolled
   (:func:`.faces.faces_rolled`'s rule).
2. **Choosing.** Resting for ``settle`` [s] with the motors released (every actuated cable at
   its nominal rest length), and fewer than the requested faces rolled: the edge of the face
   whose outward direction on the floor, from the caps' positions, is closest to ``heading``
   (not the edge it came over); the move of :func:`.tipping.tipping_step` derived for that
   face and edge on the robot's rest shape (:class:`TipMoves`: from the robot's shipped table
   of moves, ``examples/tips/NAME.yaml``, or derived once per face and edge, then kept).
3. **Tipping.** The move's cables are driven from their nominal rest lengths towards the
   move at ``speed`` [m/s] (below the motors' own limit, so the robot tips quasi-statically,
   just past the edge), until the robot turns about the edge: at the first sample where both
   caps of the edge touch, the face's third cap is off the floor and the centre of mass
   (lumped masses, :meth:`.Robot.lumped_masses`) seen from above is beyond the edge, or a
   cap of another face touches, every cable is released (back to 2. once it rests on a
   face). A move that has not tipped the robot within ``give_up`` [s] is released and the
   next best edge is tried.

Why drive the move slowly and let go as the robot turns: the move stores strain energy in
the cables (the 6-bar's two-cable move off a closed face, commanded at once and held: up to
0.51 kJ above rest, tensions to 1.2 kN) and throws the robot over the edge (24 J of kinetic
energy at the peak). Held until the next face touches, the robot lands in its deformed shape
with 0.40 kJ still stored and 16 J of kinetic energy, and the release springs it back over
that face's next edge (an open face of the 6-bar is a shallow well: the rise of the centre of
mass over its short edges, ~0.03 m, equals the drop onto it). Driven at 0.2 m/s and released
as it turns, the motors pay out during the fall: the robot lands near its rest shape, with
no strain energy left above rest and 6.6 J of kinetic energy, and the new face holds it
(docs/robots.md, "A closed-loop rolling gait").

Commands are rest lengths [m] of the robot's actuated cables (in the description's order).
The controller is pure: :meth:`RollController.update` maps one sample to a command; it
keeps the derived moves, the face history and its phase between calls.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.statics import rest_shape
from tensegrity_core.robot.tipping import hull_faces, tipping_step
from tensegrity_core.schema import read_file

FloatArray = NDArray[np.float64]
Face = tuple[int, int, int]
#: The shipped tables of tipping moves (``NAME.yaml`` for the shipped robot ``NAME``):
#: :meth:`TipMoves.table` of every face and edge, derived offline (~1.5 s per move).
TIPS_DIR = Path(__file__).parent / "examples" / "tips"


@dataclass
class TipMoves:
    """The tipping moves of a robot (:func:`.tipping.tipping_step` on its rest shape), read from
    its shipped table (:data:`TIPS_DIR`, used only if it was derived for the same actuated
    cables and rest lengths) or derived on first use for each (face, edge) and kept:
    ``command(face, edge)`` is the rest lengths [m] of every actuated cable (the move's cables
    moved, the others nominal), None where no move tips it."""

    robot: Robot
    _shape: FloatArray = field(init=False, repr=False)
    _moves: dict[tuple[frozenset[int], frozenset[int]], FloatArray | None] = field(
        default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        self._shape = rest_shape(self.robot).nodes
        self.faces: list[Face] = hull_faces(self._shape)
        act = self.robot.cables.actuated
        self.nominal: FloatArray = self.robot.cables.rest_length[act].copy()
        self._cables = [self.robot.cables.names[j] for j in act]
        shipped = TIPS_DIR / f"{self.robot.name}.yaml"
        if shipped.is_file():
            data = read_file(shipped, what="table of tipping moves")[0]
            if data["cables"] == self._cables and np.array_equal(np.asarray(data["nominal"]), self.nominal):
                names = {n: i for i, n in enumerate(self.robot.node_names)}
                for m in data["moves"]:
                    key = (frozenset(names[n] for n in m["face"]), frozenset(names[n] for n in m["edge"]))
                    self._moves[key] = None if m["rest_lengths"] is None else np.asarray(m["rest_lengths"], float)

    def command(self, face: Face, edge: tuple[int, int]) -> FloatArray | None:
        """The rest lengths [m] of the actuated cables that tip the robot resting on ``face``
        (a hull face, in :func:`hull_faces`' order) over ``edge`` (two of its nodes); None if
        no move of them does."""
        key = (frozenset(face), frozenset(edge))
        if key not in self._moves:
            a, b = edge
            c = next(i for i in face if i not in edge)
            turns = [face, (face[1], face[2], face[0]), (face[2], face[0], face[1])]
            oriented = (a, b, c) if (a, b, c) in turns else (b, a, c)
            try:
                cables, rest, _, _ = tipping_step(self.robot, self._shape, oriented, self.robot.cables.rest_length)
            except ConvergenceError:
                self._moves[key] = None
            else:
                row = self.nominal.copy()
                act = list(self.robot.cables.actuated)
                for j, r in zip(cables, rest):
                    row[act.index(j)] = r
                self._moves[key] = row
        move = self._moves[key]
        return None if move is None else move.copy()

    def table(self) -> dict[str, Any]:
        """Every face's moves over each of its edges (derived where not known yet), as the
        shipped tables hold them: the actuated ``cables``, their ``nominal`` rest lengths [m]
        and per face and edge (node names) the ``rest_lengths`` [m] or null."""
        names = self.robot.node_names
        moves = []
        for face in self.faces:
            for i in range(3):
                edge = (face[i], face[(i + 1) % 3])
                row = self.command(face, edge)
                moves.append({"face": [names[j] for j in face], "edge": [names[j] for j in edge],
                              "rest_lengths": None if row is None else [round(float(v), 9) for v in row]})
        return {"robot": self.robot.name, "cables": self._cables, "nominal": [float(v) for v in self.nominal],
                "moves": moves}


def outward_edges(face: Face, floor_xy: FloatArray) -> list[tuple[tuple[int, int], FloatArray]]:
    """The three edges of ``face`` with their outward unit directions on the floor, from the
    nodes' floor positions ``floor_xy`` (n, 2) [m]."""
    out: list[tuple[tuple[int, int], FloatArray]] = []
    for i in range(3):
        a, b, c = face[i], face[(i + 1) % 3], face[(i + 2) % 3]
        e = floor_xy[b] - floor_xy[a]
        n = np.array([e[1], -e[0]]) / max(float(np.linalg.norm(e)), 1e-12)
        if n @ (floor_xy[c] - floor_xy[a]) > 0:
            n = -n
        out.append(((a, b), n))
    return out


class RollController:
    """Rolls ``robot`` over ``faces`` new faces towards ``heading`` (a direction on the floor,
    world x, y) from the contact state (module docstring). ``hold`` [s]: how long a contact
    set must last to count as a face; ``settle`` [s]: how long the robot rests released on a
    face before the next move; ``give_up`` [s]: how long a move may take to tip it;
    ``speed`` [m/s]: how fast the move's rest lengths are driven from nominal."""

    def __init__(self, robot: Robot, faces: int, *, heading: ArrayLike = (1.0, 0.0), hold: float = 0.05,
                 settle: float = 0.5, give_up: float = 8.0, speed: float = 0.2, moves: TipMoves | None = None):
        if faces < 0:
            raise ValueError(f"the number of faces to roll must be >= 0, got {faces}")
        h = np.asarray(heading, dtype=float)
        if h.shape != (2,) or not np.all(np.isfinite(h)) or not np.any(h != 0.0):
            raise ValueError(f"the heading must be a nonzero direction (x, y) on the floor, got {heading!r}")
        h = h / np.max(np.abs(h))       # scaled first: the norm of (1e-300, 0) underflows, of 1e308s overflows
        if not (speed > 0 and np.isfinite(speed)):
            raise ValueError(f"the speed of a move must be a positive number of m/s, got {speed!r}")
        self.moves = moves if moves is not None and moves.robot is robot else TipMoves(robot)
        self.target = faces
        self.heading = h / np.linalg.norm(h)
        self.hold, self.settle, self.give_up, self.speed = hold, settle, give_up, speed
        self._mass = robot.lumped_masses()
        self.visited: list[Face] = []                   # faces rested on, in order (repeats merged)
        self._touching: frozenset[int] = frozenset()
        self._since = 0.0                               # when the current contact set began [s]
        self._command = self.moves.nominal.copy()
        self._tipping_since: float | None = None        # when the current move was commanded [s]
        self._pivot: tuple[frozenset[int], int] = (frozenset(), -1)  # the move's edge and third cap
        self._tried: list[tuple[int, int]] = []         # edges of the current face already tried
        self._came: frozenset[int] | None = None        # the edge the robot came over

    @property
    def rolled(self) -> int:
        """Faces reached that had not been rested on before (the first excluded)."""
        return max(len(set(self.visited)) - 1, 0)

    @property
    def done(self) -> bool:
        """Whether the requested faces are rolled and the motors released."""
        return self.rolled >= self.target and self._tipping_since is None

    def resting_face(self, t: float, nodes: FloatArray) -> Face | None:
        """The hull face the robot rests on at ``t`` [s] (step 1; ``nodes`` (n, 3) [m]), or None."""
        if len(self._touching) < 3 or t - self._since < self.hold * (1 - 1e-9):
            return None
        on = [f for f in self.moves.faces if set(f) <= self._touching]
        return min(on, key=lambda f: float(nodes[list(f), 2].sum())) if on else None

    def update(self, t: float, touching: ArrayLike, nodes: ArrayLike) -> FloatArray:
        """The command (actuated cables' rest lengths [m]) at time ``t`` [s] from the touching
        caps ``touching`` (node indices) and the node positions ``nodes`` (n, 3) [m, world,
        floor z = 0 up]."""
        now = frozenset(int(i) for i in np.asarray(touching, dtype=int).ravel())
        if now != self._touching:
            self._touching, self._since = now, t
        self._decide(t, now, np.asarray(nodes, dtype=float))
        if self._tipping_since is None:
            return self._command.copy()
        # the move driven at ``speed`` from the nominal rest lengths (step 3)
        reach = self.speed * (t - self._tipping_since)
        out: FloatArray = self.moves.nominal + np.clip(self._command - self.moves.nominal, -reach, reach)
        return out

    def _decide(self, t: float, now: frozenset[int], X: FloatArray) -> None:
        """Steps 1-3 on one sample: rest, choose, command or release the move."""
        if self._tipping_since is not None and (self._turning(now, X) or self._landed(now)):
            self._release()                             # it falls over the edge: let go (step 3)
        face = self.resting_face(t, X)
        if face is not None and (not self.visited or self.visited[-1] != face):
            if self.visited:
                self._came = frozenset(self.visited[-1]) & frozenset(face)
            self.visited.append(face)
            self._tried = []
            self._release()                             # it tipped: let go, settle
            return
        if self._tipping_since is not None:
            if t - self._tipping_since >= self.give_up:
                self._release()
            return
        if face is None or self.rolled >= self.target or t - self._since < self.settle:
            return
        choices = [(float(n @ self.heading), edge) for edge, n in outward_edges(face, X[:, :2])
                   if frozenset(edge) != self._came and edge not in self._tried]
        if not choices:
            self._tried = []
            return
        _, edge = max(choices)
        self._tried.append(edge)
        move = self.moves.command(face, edge)
        if move is not None:
            self._command = move
            self._tipping_since = t
            self._pivot = (frozenset(edge), next(i for i in face if i not in edge))

    def _turning(self, touching: frozenset[int], nodes: FloatArray) -> bool:
        """Whether the robot turns about the current move's edge (step 3): both its caps
        touching, the third cap off the floor, the centre of mass beyond the edge."""
        edge, third = self._pivot
        if not edge <= touching or third in touching:
            return False
        a, b = sorted(edge)
        outward = next(n for e, n in outward_edges((a, b, third), nodes[:, :2]) if set(e) == edge)
        com = self._mass @ nodes[:, :2] / self._mass.sum()
        return float(outward @ (com - nodes[a, :2])) > 0.0

    def _landed(self, touching: frozenset[int]) -> bool:
        """Whether the caps of a hull face other than the one the move started on touch."""
        start = set(self.visited[-1])
        return any(set(f) <= touching and set(f) != start for f in self.moves.faces)

    def _release(self) -> None:
        self._command = self.moves.nominal.copy()
        self._tipping_since = None
