"""The fold limit as a unilateral contact: impact law and contact-mode selection.

Coordinates ``q_i`` (``i`` in the limited set, here the actuator lengths) must stay >= 0.
The contact force ``lambda_i >= 0`` acts on ``q_i`` alone (the stop inside the actuator
pushes its two nodes apart), so the equations of motion read ``M qddot = R + sum lambda_i e_i``
with ``R = Q - C`` the other generalised forces. Both problems below are linear
complementarity problems in the contacts' own space, with the matrix ``W = (M^-1)_AA`` of
the contacts ``A`` involved (symmetric positive definite, so each has exactly one solution,
:func:`lcp`). The derivation is in ``docs/scenes.md`` ("The fold limit").

**Impact** (contacts ``A`` at zero length, some approaching at ``u = qdot_A- < 0``): Poisson's
law in two phases. Compression: the impulses ``P_c >= 0`` that stop the approach,
``0 <= P_c _|_ u + W P_c >= 0`` (plastic: no contact of ``A`` may enter its stop, one
moving away keeps going unless the others' impulses turn it back). Restitution: the stops
give back ``r P_c`` (``r`` the restitution coefficient), and should that drive a contact into
its stop, a plastic correction ``0 <= P_x _|_ v + W P_x >= 0``. The kinetic energy changes by
``-(1 - r^2)/2 P_c^T W P_c - 1/2 P_x^T W P_x <= 0`` whatever the number of contacts; for one
contact ``qdot_i+ = -r qdot_i-``.

**Sticking**: contacts slower than the rest velocity stop (their impulses may pull: they
stick), the others keep out of their stops -- the projection of the velocity onto
``{v_Z = 0, v_O >= 0}`` in the kinetic-energy metric, a convex cone that holds rest, so it
never adds energy (setting a velocity component to zero would: through the coupling of
``M`` it changes the kinetic energy to first order).

**Contact mode** (which contacts at rest on their stops stay held): the contact forces
``lambda_C >= 0`` solve ``0 <= lambda _|_ b + W lambda >= 0`` with ``b = (M^-1 R)_C`` the
contacts' accelerations if all were let go; the held set is where ``lambda > 0``.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import nnls

FloatArray = NDArray[np.float64]


def lcp(W: ArrayLike, b: ArrayLike) -> FloatArray:
    """The solution ``x`` of the linear complementarity problem ``x >= 0``, ``w = W x + b >= 0``,
    ``x^T w = 0`` for a symmetric positive definite ``W``.

    It is the minimiser of ``x^T W x / 2 + b^T x`` over ``x >= 0`` (those are its optimality
    conditions), i.e. with ``W = C C^T`` the non-negative least-squares problem
    ``min |C^T x + C^-1 b|``, which scipy's ``nnls`` (Lawson-Hanson active set) solves to
    rounding -- no tolerance to choose."""
    W = np.atleast_2d(np.asarray(W, dtype=float))
    b = np.atleast_1d(np.asarray(b, dtype=float))
    if not b.size:
        return np.zeros(0)
    if np.all(b >= 0.0):                   # nothing pushes into a stop: all let go
        return np.zeros_like(b)
    C = cholesky(W, lower=True)
    x, _ = nnls(C.T, -solve_triangular(C, b, lower=True))
    return np.asarray(x, dtype=float)


def impact(Minv: ArrayLike, qdot: ArrayLike, contacts: Collection[int],
           restitution: float) -> tuple[FloatArray, FloatArray]:
    """Post-impact velocities ``(qdot+, P)`` when the coordinates ``contacts``, at zero length,
    take impulses ``P >= 0`` (one per contact, in sorted order) under Poisson's law with the
    ``restitution`` coefficient; ``Minv`` is ``M^-1`` at the impact configuration."""
    Minv = np.asarray(Minv, dtype=float)
    qdot = np.asarray(qdot, dtype=float)
    A = sorted(contacts)
    W = Minv[np.ix_(A, A)]
    u = qdot[A]
    P = (1.0 + restitution) * lcp(W, u)
    v = u + W @ P
    if np.any(v < 0.0):
        P = P + lcp(W, v)
    return qdot + Minv[:, A] @ P, P


def stick(Minv: ArrayLike, qdot: ArrayLike, contacts: Collection[int], rest_velocity: float) -> FloatArray:
    """Velocities after the ``contacts`` (at zero length) slower than ``rest_velocity`` [m/s]
    stop and the others keep out of their stops (see the module docstring); ``Minv = M^-1``."""
    Minv = np.asarray(Minv, dtype=float)
    qdot = np.array(qdot, dtype=float)
    A = sorted(contacts)
    v = qdot[A]
    Z = [k for k in range(len(A)) if abs(v[k]) < rest_velocity]
    if not Z:
        return qdot
    O = [k for k in range(len(A)) if k not in Z]
    W = Minv[np.ix_(A, A)]
    WZZ = W[np.ix_(Z, Z)]
    P = np.zeros(len(A))
    if O:
        WOZ = W[np.ix_(O, Z)]
        schur = W[np.ix_(O, O)] - WOZ @ np.linalg.solve(WZZ, WOZ.T)
        P[O] = lcp(schur, v[O] - WOZ @ np.linalg.solve(WZZ, v[Z]))
    P[Z] = -np.linalg.solve(WZZ, v[Z] + W[np.ix_(Z, O)] @ P[O])
    qdot += Minv[:, A] @ P
    qdot[[A[k] for k in Z]] = 0.0             # (zero but for rounding)
    return qdot


def held_set(Minv: ArrayLike, a_free: ArrayLike, candidates: Collection[int]) -> frozenset[int]:
    """The contacts among ``candidates`` (at rest at zero length) that stay held, given the
    accelerations ``a_free`` with none of them held and ``Minv = M^-1``."""
    C = sorted(candidates)
    if not C:
        return frozenset()
    Minv = np.asarray(Minv, dtype=float)
    lam = lcp(Minv[np.ix_(C, C)], np.asarray(a_free, dtype=float)[C])
    return frozenset(c for c, value in zip(C, lam) if value > 0.0)
