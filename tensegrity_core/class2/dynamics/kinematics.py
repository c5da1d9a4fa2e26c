"""The kinematic context of a class-2 state: the quantities every effect and the inertia read.

With ``q = (rho1, rho2, beta)`` [m, m, rad], ``qdot`` their rates, ``s = rho1 + rho2``::

    lambda1 = sqrt(4L^2 - s^2),   lambda2 = sqrt(L^2 - rho1^2),
    e1 = s / lambda1 = -d lambda1/d rho_i,   g2 = rho1 / lambda2 = -d lambda2/d rho1

(nodes ``A = (0, 0)``, ``B = (rho1, 0)``, ``C = (s, 0)``, ``D = B + L (cos b, sin b)``,
``E = (s/2, lambda1/2)``, ``F = (0, lambda2)``; :mod:`tensegrity_core.class2.geometry`).

:class:`Kinematics` is a named tuple, so the hot paths unpack it positionally like a plain
tuple; its fields are floats for one state (:func:`kinematics`, checked, a fraction of a
microsecond) or arrays for many (:func:`kinematics_array`). Every formula that reads it is
written with arithmetic only, so the same code runs on both: such functions are generic in
:data:`Real` (``Kinematics[float]`` or ``Kinematics[NDArray[np.float64]]``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Generic, NamedTuple, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.limits import checked_lambda, refuse_pair
from tensegrity_core.errors import DomainError

#: One state's float or an array over many states: the kernel's arithmetic runs on either.
Real = TypeVar("Real", float, NDArray[np.float64])


class Kinematics(NamedTuple, Generic[Real]):
    """Kinematic context of one state (floats) or of many (arrays of one shape)."""

    rho1: Real
    rho2: Real
    sin_beta: Real
    cos_beta: Real
    rho1_dot: Real
    rho2_dot: Real
    beta_dot: Real
    s: Real
    lambda1: Real
    lambda2: Real
    e1: Real
    g2: Real


_new = tuple.__new__          # a third of the cost of Kinematics(...) with twelve arguments


def kinematics(L: float, y: Sequence[float], limit: float) -> Kinematics[float]:
    """Context of one state ``y = (rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot, ...)`` (a
    sequence of floats; extra entries are ignored).

    Raises :class:`~tensegrity_core.errors.SingularityError` when lambda1 or lambda2 is below
    ``limit`` [m] and :class:`~tensegrity_core.errors.DomainError` when the configuration does
    not exist or the state is not finite."""
    r1, r2, b, v1, v2, vb = y[0], y[1], y[2], y[3], y[4], y[5]
    s = r1 + r2
    lam1_sq = (2.0 * L - s) * (2.0 * L + s)
    lam2_sq = (L - r1) * (L + r1)
    limit_sq = limit * limit
    if not (lam1_sq >= limit_sq and lam2_sq >= limit_sq):
        refuse_pair(lam1_sq, lam2_sq, limit, r1, r2, L)
    try:
        sb, cb = math.sin(b), math.cos(b)
    except (ValueError, TypeError):
        raise DomainError(f"state is not finite: beta = {b!r}") from None
    lam1 = math.sqrt(lam1_sq)
    lam2 = math.sqrt(lam2_sq)
    return _new(Kinematics, (r1, r2, sb, cb, v1, v2, vb, s, lam1, lam2, s / lam1, r1 / lam2))


def kinematics_array(
    L: float, q: ArrayLike, qdot: ArrayLike, limit: float | None = None
) -> Kinematics[NDArray[np.float64]]:
    """Context of arrays of states ``q, qdot`` (trailing dimension 3, broadcast together).

    With ``limit`` [m] the states are checked as by :func:`kinematics` (the message names the
    first offending state); without it the caller guarantees valid states."""
    qa = np.asarray(q, dtype=np.float64)
    qdota = np.asarray(qdot, dtype=np.float64)
    r1, r2, b = qa[..., 0], qa[..., 1], qa[..., 2]
    s = r1 + r2
    lam1_sq = (2.0 * L - s) * (2.0 * L + s)
    lam2_sq = (L - r1) * (L + r1)
    if limit is None:
        lam1, lam2 = np.sqrt(lam1_sq), np.sqrt(lam2_sq)
    else:
        lam1 = checked_lambda("lambda1", lam1_sq, limit, r1, r2, L)
        lam2 = checked_lambda("lambda2", lam2_sq, limit, r1, r2, L)
    with np.errstate(invalid="ignore"):           # sin(inf): the callers report non-finite results
        sb, cb = np.sin(b), np.cos(b)
    return _new(Kinematics, (r1, r2, sb, cb, qdota[..., 0], qdota[..., 1], qdota[..., 2], s, lam1, lam2, s / lam1,
                             r1 / lam2))
