"""The fold limit as a unilateral contact: impact law and contact-mode selection.

Coordinates ``q_i`` (``i`` in the limited set, here the actuator lengths) must stay >= 0.
The contact force ``lambda_i >= 0`` acts on ``q_i`` alone (the stop inside the actuator
pushes its two nodes apart), so the equations of motion read ``M qddot = R + sum lambda_i e_i``
with ``R = Q - C`` the other generalised forces.

**Impact** (``q_i`` reaches 0 with ``qdot_i < 0``): an impulse ``P e_i`` changes the velocity
by ``M^-1 P e_i``. Newton's law ``qdot_i+ = -r qdot_i-`` (``r`` the restitution coefficient)
fixes ``P = -(1 + r) qdot_i- / (M^-1)_ii >= 0``; coordinates already held at 0 take their
own impulses so that they stay at rest, unless that would need a pulling impulse (then they
let go). Kinetic energy falls by ``(1 - r^2) qdot_i-^2 / (2 (M^-1)_ii)`` for a single contact.

**Contact mode** (which coordinates stay held): among the coordinates at 0 with zero
velocity, the held set ``S`` solves the linear complementarity problem
``lambda_S >= 0`` and ``qddot_j >= 0`` for the others. ``M`` is positive definite, so the
problem has exactly one solution; with two coordinates the four sets are simply tried.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Collection, Iterable, Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def _subsets(items: Iterable[int]) -> Iterator[tuple[int, ...]]:
    ordered = sorted(items)
    for r in range(len(ordered), -1, -1):
        yield from itertools.combinations(ordered, r)


def select_mode(solve: Callable[[Collection[int]], tuple[FloatArray, FloatArray]],
                candidates: Collection[int], tol: float) -> tuple[frozenset[int], FloatArray, FloatArray]:
    """The held set among ``candidates`` (indices) satisfying the complementarity conditions.

    ``solve(S)`` returns ``(a, lam)``: accelerations (all coordinates) and contact forces
    (indexed like the coordinates, zero off ``S``) with the coordinates in ``S`` held.
    ``tol`` absorbs rounding in the sign tests. Returns ``(S, a, lam)``; when rounding
    leaves no exact solution, the set with the least violation.
    """
    best: tuple[float, frozenset[int], FloatArray, FloatArray] | None = None
    for S in _subsets(candidates):
        a, lam = solve(S)
        violation = max([-lam[i] for i in S] + [-a[j] for j in candidates if j not in S] + [0.0])
        if violation <= tol:
            return frozenset(S), a, lam
        if best is None or violation < best[0]:
            best = (violation, frozenset(S), a, lam)
    assert best is not None           # the empty set is always tried
    return best[1], best[2], best[3]


def impact(M: ArrayLike, qdot: ArrayLike, hit: int, held: Collection[int],
           restitution: float) -> tuple[FloatArray, frozenset[int]]:
    """Post-impact velocities when coordinate ``hit`` reaches its limit with ``qdot[hit] < 0``
    while the coordinates in ``held`` are at rest on theirs.

    Returns ``(qdot_plus, still_held)``: the held coordinates whose impulse is compressive
    (>= 0) stay at rest; one that would need a pulling impulse is released (its velocity
    after the impact is then >= 0). Impulses solve ``M dqdot = sum P_j e_j`` with
    ``qdot_hit+ = -restitution qdot_hit-`` and ``qdot_j+ = 0`` for ``j`` kept.
    """
    M = np.asarray(M, dtype=float)
    qdot = np.asarray(qdot, dtype=float)
    Minv = np.linalg.inv(M)
    target_hit = -restitution * qdot[hit]
    best: tuple[float, FloatArray, frozenset[int]] | None = None
    for kept in _subsets(held):
        idx = [hit, *kept]
        want = np.array([target_hit] + [0.0] * len(kept))
        W = Minv[np.ix_(idx, idx)]
        P = np.linalg.solve(W, want - qdot[idx])
        new = qdot + Minv[:, idx] @ P
        violation = max([-p for p in P] + [-new[j] for j in held if j not in kept] + [0.0])
        if violation <= 1e-12 * (1.0 + np.abs(qdot).max()):
            new[list(kept)] = 0.0
            new[hit] = target_hit
            return new, frozenset(kept)
        if best is None or violation < best[0]:
            best = (violation, new, frozenset(kept))
    assert best is not None           # the empty set is always tried
    return best[1], best[2]
