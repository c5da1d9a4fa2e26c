"""Distances from an actuator configuration to the singular sets of the class-2 mechanism.

Every distance here is measured in the actuator plane ``(rho1, rho2)`` (Euclidean, divided
by the strut length ``L``, so dimensionless; 0 means on the set, negative means outside
the configuration domain across that set). With ``K = 2 k3 + k2`` the sets are lines:

``lambda1``       ``rho1 + rho2 = 2L``: E on the X axis, D on the X axis (beta = 0, the
                  same set), ``|dD/drho| -> infinity``. Distance ``(2L - rho1 - rho2) / (sqrt(2) L)``.
``lambda2``       ``rho1 = L``: F reaches A and the speed of F, ``rho1 rho1' / lambda2``,
                  is unbounded. Distance ``(L - rho1) / L``.
``beta_half_pi``  ``K rho2 = k2 rho1``: the equilibrium puts D straight above B
                  (beta = pi/2, the paper's range limit); ``det(dD/drho) = 0`` and the IK
                  discriminant vanishes here (docs/class2.md). Distance
                  ``|K rho2 - k2 rho1| / (sqrt(K^2 + k2^2) L)``.
``folded``        ``rho1 = rho2 = 0``: every node on the Y axis (a point on the
                  ``beta_half_pi`` line). Distance ``sqrt(rho1^2 + rho2^2) / L``.

The functions here are pure formulas on ``(rho1, rho2)``; the full report with the values
of beta, the Jacobian and the IK discriminant is :func:`~tensegrity_core.class2.singularities.report.classify_singularities`.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.params import Class2Params

#: Names of the singular sets, in the order used by :func:`singularity_distances`.
SINGULAR_SETS: Final = ("lambda1", "lambda2", "beta_half_pi", "folded")

#: What each set is and what is singular on it, in a few words (for messages naming the set).
SINGULAR_MEANINGS: Final = {
    "lambda1": "rho1 + rho2 = 2L: struts AE, CE flat, D on the X axis, |dD/drho| unbounded",
    "lambda2": "rho1 = L: F at A, its speed unbounded, the equations of motion break down",
    "beta_half_pi": "D straight above B, on the fold y = L: det dD/drho = 0",
    "folded": "rho1 = rho2 = 0: every node on the Y axis, det dD/drho = 0",
}

_SQRT2: Final = math.sqrt(2.0)


def singularity_distances(rho1: float, rho2: float, params: Class2Params) -> dict[str, float]:
    """Signed dimensionless distance of ``(rho1, rho2)`` to each set in :data:`SINGULAR_SETS`.

    ``lambda1`` and ``lambda2`` are signed (negative outside the domain); the other two are
    unsigned distances to a line and a point.
    """
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    return {
        "lambda1": (2.0 * L - rho1 - rho2) / (_SQRT2 * L),
        "lambda2": (L - rho1) / L,
        "beta_half_pi": abs(K * rho2 - k2 * rho1) / (math.hypot(K, k2) * L),
        "folded": math.hypot(rho1, rho2) / L,
    }


def nearest_singularity(rho1: float, rho2: float, params: Class2Params) -> tuple[str, float]:
    """``(name, distance)`` of the nearest singular set (scalar, fast path used by FK/IK).

    The folded point lies on the ``beta_half_pi`` line, so it is never strictly nearer; at
    ``rho1 = rho2 = 0`` the name ``"folded"`` is reported.
    """
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    best_name, best = "lambda1", (2.0 * L - rho1 - rho2) / (_SQRT2 * L)
    d = (L - rho1) / L
    if d < best:
        best_name, best = "lambda2", d
    d = abs(K * rho2 - k2 * rho1) / (math.hypot(K, k2) * L)
    if d < best:
        best_name, best = "beta_half_pi", d
    if rho1 == 0.0 and rho2 == 0.0:
        best_name = "folded"
    return best_name, best


def dynamics_singularity(rho1: float, rho2: float, params: Class2Params) -> tuple[str, float]:
    """``(name, lambda / L)`` of the nearer of the two sets where the equations of motion
    break down: ``lambda1 = sqrt(4L^2 - (rho1 + rho2)^2)`` and ``lambda2 = sqrt(L^2 - rho1^2)``
    (the mass matrix grows like ``1/lambda^2``; :mod:`~tensegrity_core.class2.dynamics`
    refuses below ``LAMBDA_MIN_REL = 1e-4``, the scene simulator stops at 1e-3).

    Unlike the actuator-plane distances above it is defined for negative lengths too (the
    unconstrained dynamics cross zero length) and is 0 on or beyond a set. The conditioning
    measure for running simulations: relative rounding error of ``M`` ~ ``eps (L/lambda)^2``.
    """
    L = params.L
    s = rho1 + rho2
    lam1 = math.sqrt(max(0.0, (2.0 * L - abs(s)) * (2.0 * L + abs(s)))) / L
    lam2 = math.sqrt(max(0.0, (L - abs(rho1)) * (L + abs(rho1)))) / L
    return ("lambda1", lam1) if lam1 <= lam2 else ("lambda2", lam2)


def singularity_distance_array(rho1: ArrayLike, rho2: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Vectorised minimum distance to the singular sets (the value of :func:`nearest_singularity`)."""
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    r1 = np.asarray(rho1, dtype=np.float64)
    r2 = np.asarray(rho2, dtype=np.float64)
    d1 = (2.0 * L - r1 - r2) / (_SQRT2 * L)
    d2 = (L - r1) / L
    d3 = np.abs(K * r2 - k2 * r1) / (math.hypot(K, k2) * L)
    return np.minimum(np.minimum(d1, d2), d3)
