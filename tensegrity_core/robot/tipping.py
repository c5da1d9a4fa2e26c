"""Quasi-static tipping: which cables to move so a robot rolls over one edge after another.

A robot at rest on a floor stands on a face of the convex hull of its end caps (three caps
on the ground). It tips over an edge ``(a, b)`` of that face once its centre of mass, seen
from above, leaves the support triangle across that edge: the floor's reaction on the third
cap ``c`` would have to pull. Moving cables changes the shape and moves the centre of
mass. One tipping step is derived with the robot's own statics (:mod:`.statics`: its cable
element, form-finding, stability), as follows.

1. **Support.** The robot's rest shape (free, prestressed) is placed on the face with the
   edge along x: ``a`` at the origin, ``b`` on +x, ``c`` on +y, the caps touching the floor.
   The statics hold ``a`` in x, y, z, ``b`` in y, z and ``c`` in z: a statically determinate
   support that carries the weight and lets the base spread freely (a frictionless floor;
   friction would only stiffen the base). Gravity acts on every mass (rods half at each cap).
2. **Reaction.** Every cap the equilibrium would push into the floor is held on it too
   (an active set, from the third cap on): the robot stands on three caps or more. ``R`` =
   the floor's vertical reaction on the caps on the third cap's side of the edge, from the
   form-found equilibrium under the cables' rest lengths ``l0``. The robot tips when
   ``R < 0``: those caps would have to pull. On three caps ``R = W y / y_c`` (weight ``W``,
   centre of mass at ``y``): the centre of mass crosses the edge. Its margin ``y`` is
   reported too.
3. **Which cables.** Each actuated cable ``j`` is reeled in by a tenth of its range below its
   nominal rest length; ``s_j = -dR / dl0_j`` (a difference of two equilibria) says whether
   reeling in (``s_j > 0``) or paying out (``s_j < 0``) unloads the far caps, and its reach
   is ``|s_j|`` times the room the motor has that way. Cables are taken in decreasing order
   of reach until the reaches add up to ``spread x R`` (or every cable that helps is taken),
   and all of them are moved by one fraction ``f`` of their room. ``spread = 1`` takes the
   fewest cables; a larger ``spread`` shares the move among more cables, each moved less
   (``f`` falls as the reaches taken add up), so the move is shorter at the motors' slew
   limit (the 6-bar's move off a closed face: 2 cables by 0.42 m at 1, 7 by 0.19 m at 3).
4. **How far.** ``f`` is found by continuation in steps of 0.05 (each equilibrium
   form-found from the last, so the path stays on one branch: a robot held at three caps has
   another, hanging, equilibrium) and bisection on ``R(f) = -overshoot x R(0)`` (a little
   beyond the tip, so that it happens despite friction and damping). If even ``f = 1`` is
   not enough, the next cable joins.
5. **Next face.** The robot turns about the edge onto the other hull face that shares it;
   the rest shape is placed there with ``a`` and ``b`` where they were, and the next edge is
   the one of the new face whose outward direction is closest to the requested heading (not
   the edge just crossed).

:func:`tipping_steps` runs it for a number of steps; :func:`gait_of_steps` lays the steps
out in time as a :class:`~tensegrity_core.robot.gait.Gait` (move, hold while it tips,
release to the nominal rest lengths, rest; each step starts from the shape its derivation
assumes); :func:`rolling_gait` does both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.general.formfind import form_find
from tensegrity_core.general.statics import internal_nodal_forces
from tensegrity_core.general.structure import STANDARD_GRAVITY
from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.gait import Gait
from tensegrity_core.robot.statics import rest_shape

FloatArray = NDArray[np.float64]

#: How far beyond the tip the far caps' reaction is driven, as a fraction of it at rest.
OVERSHOOT = 0.1
#: The probe of the sensitivities: a tenth of each cable's range below its rest length.
PROBE = 0.1
#: The rolling gait's ``spread`` (module docstring, step 3): its moves shared among the cables
#: whose reaches add up to three times the far caps' reaction (docs/design/mujoco.md, "A decisive roll").
GAIT_SPREAD = 3.0


@dataclass(frozen=True)
class TipStep:
    """One derived tipping step: the robot on ``face`` (node indices; ``edge`` first) tips
    over ``edge`` onto ``next_face`` once the ``cables`` (cable indices) are moved to
    ``rest_lengths`` [m]. ``margin`` [m]: the centre of mass's distance inside the edge at the
    nominal rest lengths, ``margin_after`` [m] with the cables shortened (negative: beyond).
    ``com`` (2,) [m]: the centre of mass's position on the floor (world x, y) before the step;
    ``heading`` (2,): the edge's outward direction on the floor."""

    face: tuple[int, int, int]
    edge: tuple[int, int]
    next_face: tuple[int, int, int]
    cables: tuple[int, ...]
    rest_lengths: tuple[float, ...]
    margin: float
    margin_after: float
    com: tuple[float, float]
    heading: tuple[float, float]


def hull_faces(points: ArrayLike) -> list[tuple[int, int, int]]:
    """The triangular faces of the convex hull of ``points`` (n, 3), each ordered
    counter-clockwise seen from outside."""
    X = np.asarray(points, dtype=float)
    hull = ConvexHull(X)
    centre = X.mean(axis=0)
    faces = []
    for tri in hull.simplices:
        a, b, c = (int(i) for i in tri)
        if np.cross(X[b] - X[a], X[c] - X[a]) @ (X[a] - centre) < 0:
            b, c = c, b
        faces.append((a, b, c))
    return faces


def _rotation_between(u: FloatArray, v: FloatArray) -> FloatArray:
    """The rotation taking unit ``u`` to unit ``v`` (Rodrigues; a half turn about a
    perpendicular axis when they are opposite)."""
    axis = np.cross(u, v)
    s, c = float(np.linalg.norm(axis)), float(u @ v)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        p = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
        p /= np.linalg.norm(p)
        out: FloatArray = 2 * np.outer(p, p) - np.eye(3)
        return out
    k = axis / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    out = np.eye(3) + s * K + (1 - c) * (K @ K)
    return out


def place_on_face(X: ArrayLike, face: tuple[int, int, int], radius: float) -> FloatArray:
    """``X`` (n, 3) turned rigidly so that ``face`` (outward-ordered) faces down, its caps'
    centres ``radius`` [m] above the floor z = 0, the face's first node above the origin and
    its edge ``(face[0], face[1])`` along +x."""
    P = np.asarray(X, dtype=float)
    a, b, c = face
    n = np.cross(P[b] - P[a], P[c] - P[a])
    n /= np.linalg.norm(n)
    Y = P @ _rotation_between(n, np.array([0.0, 0.0, -1.0])).T
    e = Y[b] - Y[a]
    yaw = -np.arctan2(e[1], e[0])
    Rz = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    Y = (Y - Y[a]) @ Rz.T
    Y[:, 2] += radius
    out: FloatArray = Y
    return out


class _Supported:
    """The robot on one face in the edge frame: equilibria under rest lengths, the floor's
    reaction on the third cap and the centre of mass's margin."""

    def __init__(self, robot: Robot, X: FloatArray, face: tuple[int, int, int]):
        self.robot = robot
        a, b, c = face
        if X[c, 1] < 0:                                   # c on +y: mirror the frame's y (a reflection
            X = X * np.array([1.0, -1.0, 1.0])            # keeps lengths; the margin is |y| inside)
        self.X = X
        self.face = face
        self.mass = robot.lumped_masses()
        self.weight = float(self.mass.sum()) * (float(np.linalg.norm(robot.gravity)) or STANDARD_GRAVITY)
        self.gravity = np.array([0.0, 0.0, -self.weight / float(self.mass.sum())])
        self.caps: list[int] = robot.rods.ends.reshape(-1).tolist()
        self.radius_of: dict[int, float] = dict(zip(self.caps, np.repeat(robot.rods.cap_radius, 2).tolist()))

    def _solve(self, rest_lengths: FloatArray, down: list[int], start: FloatArray) -> tuple[FloatArray, FloatArray] | None:
        """The equilibrium form-found from ``start`` with the edge's caps held (``a`` in x, y,
        z, ``b`` in y, z) and the caps ``down`` held on the floor (z), and the floor's
        vertical reactions [N] on every node (zero where nothing holds it)."""
        a, b, _ = self.face
        pinned = np.zeros((self.robot.n_nodes, 3), dtype=bool)
        pinned[a] = True
        pinned[b, 1:] = True
        start = start.copy()
        start[[a, b], 2] = self.X[[a, b], 2]
        for i in down:
            pinned[i, 2] = True
            start[i, 2] = self.radius_of[i]
        s = self.robot.structure(rest_lengths, nodes=start, pinned=pinned, gravity=False)
        s = s.replace(gravity=self.gravity / self.robot.force_unit(rest_lengths))
        result = form_find(s)
        if not (result.success and result.stable):
            return None
        X = result.nodes
        unit = self.robot.force_unit(rest_lengths)
        reaction = np.where(pinned[:, 2], -(internal_nodal_forces(s, X) + s.external_forces)[:, 2] * unit, 0.0)
        return X, reaction

    def state(self, rest_lengths: FloatArray, start: FloatArray) -> tuple[float, float, bool, FloatArray]:
        """``(reaction [N], centre of mass's margin [m], found, nodes)`` of the equilibrium
        reached from ``start`` (n, 3). The caps on the floor are found by an active set: the
        third cap first, then every cap the equilibrium would push into the floor. The
        reaction is the floor's on the caps on the third cap's side of the edge (``y > 0``):
        the robot tips when it would have to pull. ``found`` is False (reaction nan) where
        there is no stable equilibrium."""
        a, b, c = self.face
        down = [c]
        X = start
        for _ in range(len(self.caps)):
            out = self._solve(rest_lengths, down, X)
            if out is None:
                return float("nan"), float("nan"), False, start
            X, reaction = out
            depth = np.array([self.radius_of[i] - X[i, 2] for i in self.caps])
            tol = 1e-6 * float(np.ptp(self.X))
            entering = [i for i, d in zip(self.caps, depth) if d > tol and i not in down and i not in (a, b)]
            if not entering:
                break
            down += entering
        far = [i for i in down if X[i, 1] > 0]
        return float(reaction[far].sum()), float(self.mass @ X[:, 1] / self.mass.sum()), True, X


def tipping_step(robot: Robot, X: FloatArray, face: tuple[int, int, int],
                 nominal: FloatArray, spread: float = 1.0) -> tuple[tuple[int, ...], FloatArray, float, float]:
    """``(cables, rest lengths [m], margin [m], margin after [m])``: the move of actuated
    cables that tips the robot, resting with its rest shape ``X`` on ``face`` (edge first),
    over the edge ``face[:2]`` (module docstring, steps 1-4; ``spread`` >= 1 in step 3). Raises
    :class:`ConvergenceError` if no choice of the actuated cables does it, ValueError for a
    ``spread`` below 1."""
    if not spread >= 1.0:
        raise ValueError(f"spread must be at least 1 (the reaches taken cover the far caps' reaction), got {spread:g}")
    radius = float(robot.rods.cap_radius.max())
    sup = _Supported(robot, place_on_face(X, face, radius), face)
    r0, m0, ok, X0 = sup.state(nominal, sup.X)
    if not (ok and r0 > 0):
        raise ConvergenceError(f"robot {robot.name!r} does not rest on face {face} at its nominal rest lengths "
                               f"(reaction {r0:.4g} N on cap {face[2]})")
    act = robot.cables.actuated
    shorten = nominal[act] - robot.motors.range[:, 0]           # room to reel in and to pay out [m]
    lengthen = robot.motors.range[:, 1] - nominal[act]
    slopes = np.zeros(len(act))
    for k, j in enumerate(act):
        probe = nominal.copy()
        probe[j] -= PROBE * shorten[k]
        r, _, _, _ = sup.state(probe, X0)
        slopes[k] = (r0 - r) / (PROBE * shorten[k]) if np.isfinite(r) else 0.0
    # reeling in lowers the reaction where the slope is positive, paying out where negative
    move = np.where(slopes >= 0, -shorten, lengthen)            # signed full move of each cable [m]
    reach = np.abs(slopes) * np.abs(move)
    order = [int(k) for k in np.argsort(-reach) if reach[k] > 0]
    target = -OVERSHOOT * r0
    chosen: list[int] = []
    for k in order:
        chosen.append(k)
        if reach[chosen].sum() < spread * r0 and len(chosen) < len(order):
            continue
        found = _fraction(sup, nominal, act[chosen], move[chosen], target, X0)
        if found is not None:
            f, m = found
            rest = nominal[act[chosen]] + f * move[chosen]
            return tuple(int(j) for j in act[chosen]), rest, m0, m
    raise ConvergenceError(f"no move of robot {robot.name!r}'s actuated cables tips it over edge {face[:2]} "
                           f"(reaction {r0:.4g} N on cap {face[2]}, centre of mass {m0:.4g} m inside the edge)")


def _fraction(sup: _Supported, nominal: FloatArray, cables: NDArray[np.int64], move: FloatArray,
              target: float, X0: FloatArray) -> tuple[float, float] | None:
    """The smallest fraction ``f`` of the cables' signed full ``move`` [m] that brings the third cap's reaction
    to ``target`` [N], and the margin [m] there: a continuation in steps of 0.05 from the
    nominal equilibrium ``X0`` (each equilibrium form-found from the last, so the path stays
    on one branch), then bisection. None if the path leaves the floor or loses stability."""
    def state(f: float, start: FloatArray) -> tuple[float, float, bool, FloatArray]:
        rest = nominal.copy()
        rest[cables] += f * move
        return sup.state(rest, start)

    prev, X = 0.0, X0
    for f in np.linspace(0.05, 1.0, 20):
        r, _, found, X_new = state(float(f), X)
        if not found:
            return None
        if r <= target:
            lo, hi, X_lo = prev, float(f), X
            for _ in range(30):
                mid = 0.5 * (lo + hi)
                rr, _, ok, X_mid = state(mid, X_lo)
                if not ok:
                    return None
                if rr > target:
                    lo, X_lo = mid, X_mid
                else:
                    hi = mid
            return hi, state(hi, X_lo)[1]
        prev, X = float(f), X_new
    return None


def tipping_steps(robot: Robot, n_steps: int, heading: ArrayLike = (1.0, 0.0), spread: float = 1.0) -> list[TipStep]:
    """``n_steps`` tipping steps of ``robot`` from its drawing, rolling towards ``heading``
    (a direction on the floor; module docstring, step 5), each move derived with ``spread``
    (step 3)."""
    X = rest_shape(robot).nodes
    nominal = robot.cables.rest_length.copy()
    faces = hull_faces(X)
    radius = float(robot.rods.cap_radius.max())
    drawn = robot.nodes
    # start on the hull face lowest in the drawing, turned as drawn
    face = min(faces, key=lambda f: float(drawn[list(f), 2].sum()))
    W = _placed(X, face, radius, drawn[face[0]], drawn[face[1]])
    want = np.asarray(heading, dtype=float) / np.linalg.norm(heading)
    came: frozenset[int] | None = None
    steps: list[TipStep] = []
    mass = robot.lumped_masses()
    for _ in range(n_steps):
        edge, out_dir = _edge_towards(W, face, want, came)
        a, b = edge
        c = next(i for i in face if i not in edge)
        oriented = (a, b, c) if (a, b, c) in _rotations(face) else (b, a, c)
        nxt = next(f for f in faces if set(edge) <= set(f) and set(f) != set(face))
        cables, rest, m0, m1 = tipping_step(robot, X, oriented, nominal, spread)
        com = mass @ W / mass.sum()
        p, q, r = sorted(nxt)
        steps.append(TipStep(face=oriented, edge=(oriented[0], oriented[1]), next_face=(p, q, r), cables=cables,
                             rest_lengths=tuple(float(r) for r in rest), margin=m0, margin_after=m1,
                             com=(float(com[0]), float(com[1])), heading=(float(out_dir[0]), float(out_dir[1]))))
        landing = next(f for f in _rotations(nxt) if f[:2] == (oriented[1], oriented[0]))
        W = _placed(X, landing, radius, W[oriented[1]], W[oriented[0]])
        face, came = landing, frozenset(edge)
    return steps


def _rotations(face: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    a, b, c = face
    return [(a, b, c), (b, c, a), (c, a, b)]


def _placed(X: FloatArray, face: tuple[int, int, int], radius: float, at_a: FloatArray,
            at_b: FloatArray) -> FloatArray:
    """The rest shape on ``face`` with its nodes ``face[0]``, ``face[1]`` over ``at_a``,
    ``at_b`` (world, on the floor)."""
    P = place_on_face(X, face, radius)
    e = np.asarray(at_b, dtype=float)[:2] - np.asarray(at_a, dtype=float)[:2]
    yaw = np.arctan2(e[1], e[0])
    Rz = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    out: FloatArray = P @ Rz.T + np.array([at_a[0], at_a[1], 0.0])
    return out


def _edge_towards(W: FloatArray, face: tuple[int, int, int], want: FloatArray,
                  came: frozenset[int] | None) -> tuple[tuple[int, int], FloatArray]:
    """The edge of ``face`` (placed at ``W``) whose outward direction on the floor is closest
    to ``want``, other than the edge ``came`` through; and that direction."""
    best: tuple[float, tuple[int, int], FloatArray] | None = None
    for i in range(3):
        a, b, c = face[i], face[(i + 1) % 3], face[(i + 2) % 3]
        if came is not None and frozenset((a, b)) == came:
            continue
        e = W[b, :2] - W[a, :2]
        n = np.array([e[1], -e[0]]) / np.linalg.norm(e)
        if n @ (W[c, :2] - W[a, :2]) > 0:
            n = -n
        score = float(n @ want)
        if best is None or score > best[0]:
            best = (score, (a, b), n)
    assert best is not None
    return best[1], best[2]


def gait_of_steps(robot: Robot, steps: list[TipStep], *, hold: float, rest: float, name: str,
                  description: str = "", margin: float = 1.2) -> Gait:
    """The steps laid out in time, each from the nominal rest lengths as its derivation
    assumes (the robot at its rest shape on the face): per step the motors move the step's
    cables to its rest lengths (every other actuated cable at its nominal rest length), hold
    them for ``hold`` [s] while the robot tips, release every cable to its nominal rest
    length and rest there for ``rest`` [s] before the next step. Each move and release is as
    fast as the motors allow (``margin`` x the slowest motor's travel time, at least 0.05 s;
    a motor without a slew limit counts 0.05 s, its lag acting on top)."""
    act = robot.cables.actuated
    nominal = robot.cables.rest_length[act]
    speed = robot.motors.max_speed
    rows: list[FloatArray] = [nominal.copy()]
    times = [0.0]

    def move_to(row: FloatArray, then: float) -> None:
        travel = np.abs(row - rows[-1])
        dt = max(0.05, margin * float(np.max(np.divide(travel, speed, out=np.zeros_like(travel),
                                                       where=np.isfinite(speed)))))
        times.append(times[-1] + dt)
        rows.append(row)
        times.append(times[-1] + then)
        rows.append(row)

    for step in steps:
        target = nominal.copy()
        for j, r in zip(step.cables, step.rest_lengths):
            target[int(np.flatnonzero(act == j)[0])] = r
        move_to(target, hold)
        move_to(nominal.copy(), rest)
    return Gait(name=name, cables=tuple(robot.cables.names[j] for j in act),
                times=tuple(round(t, 4) for t in times),
                rest_lengths=tuple(tuple(round(float(v), 6) for v in r) for r in rows), description=description)


def rolling_gait(robot: Robot, n_steps: int, *, heading: ArrayLike = (1.0, 0.0), hold: float = 0.5,
                 rest: float = 0.3, spread: float = GAIT_SPREAD, name: str = "roll") -> tuple[Gait, list[TipStep]]:
    """The derived rolling gait of ``n_steps`` tips towards ``heading`` (:func:`tipping_steps`
    with ``spread``, laid out by :func:`gait_of_steps`; times rounded to 0.1 ms, rest lengths
    to 1 um), and its steps. ``hold`` [s] keeps the cables moved until the tip has landed
    (released earlier, the 6-bar's landing depends on the integration step), ``rest`` [s]
    waits at the nominal rest lengths after the release (docs/design/mujoco.md, "A decisive
    roll")."""
    steps = tipping_steps(robot, n_steps, heading, spread)
    h = np.asarray(heading, dtype=float)
    text = (f"{robot.name} rolling towards ({h[0]:g}, {h[1]:g}) over {n_steps} faces, derived quasi-statically "
            f"(tensegrity_core.robot.tipping)")
    return gait_of_steps(robot, steps, hold=hold, rest=rest, name=name, description=text), steps
