"""Dynamically consistent references from an end-effector path (inverse dynamics through D).

D = (rho1 + L cos beta, L sin beta) fixes two of the three coordinates: on the paper's
branch ``beta = asin(y/L)`` and ``rho1 = x - L cos beta``, with their rates and
accelerations from ``D', D''``. The third, rho2, is what the unactuated row of the
equations of motion needs: with ``C3 = 0`` and ``M32 = 0``,

    M31 rho1'' + M33 beta'' + (H qdot)_3 + dU/dbeta(rho1, rho2, beta) = 0,

an equation in rho2 alone once rho1, beta and their derivatives are known
(``d(dU/dbeta)/drho2 = (L/2)(K sin beta + k2 s cos beta / lambda1) > 0`` on the paper's
range, so its root is unique). It is solved by Newton's method on the whole time grid at
once; rho2's rates come from a quintic spline through the solution (at rest at both ends), and the damping term
(which contains rho2') is brought up to date by a second sweep. The two actuated
rows then give the feedforward forces ``f = -(M qddot + C + H qdot + grad U)[:2]``. At rest
(``D' = D'' = 0``) the equation is ``dU/dbeta = 0``: the reference passes through the IK
solutions, and ends at the static one with the holding forces.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2 import (  # the model's public names (its modules may move)
    damping_matrix,
    mass_matrix,
    potential_gradient,
    potential_hessian,
    velocity_terms,
)
from tensegrity_core.class2.control.errors import OUTSIDE_WORKSPACE, SINGULAR_PATH, PlanningError
from tensegrity_core.class2.control.paths import EndEffectorPath
from tensegrity_core.class2.control.reference import Reference
from tensegrity_core.class2.params import Class2Params
from tensegrity_core.errors import TensegrityError

#: Newton's method stops below this change of rho2 (relative to L).
_NEWTON_TOL: Final = 1e-13
_NEWTON_ITER: Final = 30
#: Sweeps for the damping term: the first solves without rho2' (the damping row is ~c small),
#: the second with the first's rho2' (the first-order correction of a singular perturbation;
#: its residual in the unactuated row is ~c^2 small, 1e-5 N m on the demo's moves). More
#: sweeps do not converge: differentiating the previous sweep amplifies grid-scale noise
#: by ~c/(slope * step).
_DAMPING_SWEEPS: Final = 2
#: The paths start and end at rest with D's derivatives 1..4 zero, so rho2' = rho2'' = 0 there.
_AT_REST: Final = ([(1, 0.0), (2, 0.0)], [(1, 0.0), (2, 0.0)])


def grid(duration: float, step: float) -> NDArray[np.float64]:
    """Uniform times from 0 to ``duration`` with a spacing of at most ``step`` [s]."""
    n = max(2, int(np.ceil(duration / step - 1e-9)) + 1)
    return np.linspace(0.0, duration, n)


def end_effector_reference(path: EndEffectorPath, params: Class2Params,
                           rho2_guess: Callable[[NDArray[np.float64]], ArrayLike], *, step: float = 0.002,
                           target: tuple[float, float] | None = None) -> Reference:
    """The reference that makes D follow ``path`` exactly (see the module docstring).

    ``path.sample(t)`` gives ``(D, D', D'')``; ``rho2_guess(t)`` [m] starts Newton's method
    (the static IK solutions along the path). Raises :class:`PlanningError` where the
    path leaves the paper's branch (``|y| >= L``) or no rho2 exists.
    """
    t = grid(path.duration, step)
    D, Dd, Ddd = path.sample(t)
    L, m = params.L, params.m
    y_rel = D[:, 1] / L
    if np.any(y_rel <= 0.0) or np.any(y_rel >= 1.0):
        raise PlanningError("the path leaves 0 < y < L, where beta = asin(y/L) is on the paper's branch",
                            code=SINGULAR_PATH)
    beta = np.arcsin(y_rel)
    sb, cb = np.sin(beta), np.cos(beta)
    bd = Dd[:, 1] / (L * cb)
    bdd = (Ddd[:, 1] + L * sb * bd**2) / (L * cb)
    r1 = D[:, 0] - L * cb
    r1d = Dd[:, 0] + L * sb * bd
    r1dd = Ddd[:, 0] + L * cb * bd**2 + L * sb * bdd
    inertial = -0.5 * m * L * sb * r1dd + (m * L**2 / 3.0) * bdd     # M31 rho1'' + M33 beta''

    # imported here: a controller that only holds never plans (its start is ~0.7 s of CPU cheaper)
    from scipy.interpolate import make_interp_spline

    r2 = np.asarray(rho2_guess(t), dtype=float).copy()
    r2d = np.zeros_like(r2)
    try:
        for _ in range(_DAMPING_SWEEPS):
            r2 = _solve_rho2(r1, r2, beta, r1d, r2d, bd, inertial, params)
            spline = make_interp_spline(t, r2, k=5, bc_type=_AT_REST)
            r2d = spline.derivative(1)(t)
        r2dd = spline.derivative(2)(t)
        q = np.stack([r1, r2, beta], -1)
        qd = np.stack([r1d, r2d, bd], -1)
        qdd = np.stack([r1dd, r2dd, bdd], -1)
        rows = (np.einsum("nij,nj->ni", mass_matrix(q, params), qdd) + velocity_terms(q, qd, params)
                + np.einsum("nij,nj->ni", damping_matrix(q, params), qd) + potential_gradient(q, params))
    except TensegrityError as err:
        raise PlanningError(f"no dynamic reference along the path: {err}", code=OUTSIDE_WORKSPACE) from None
    return Reference(t[1] - t[0], q, qd, -rows[:, :2], params, kind="end_effector", target=target)


def _solve_rho2(r1: NDArray[np.float64], r2: NDArray[np.float64], beta: NDArray[np.float64],
                r1d: NDArray[np.float64], r2d: NDArray[np.float64], bd: NDArray[np.float64],
                inertial: NDArray[np.float64], params: Class2Params) -> NDArray[np.float64]:
    """Newton's method on the unactuated row for rho2 on every grid point at once."""
    L = params.L
    for _ in range(_NEWTON_ITER):
        q = np.stack([r1, r2, beta], -1)
        qd = np.stack([r1d, r2d, bd], -1)
        g = potential_gradient(q, params)[:, 2] + inertial + np.einsum("ni,ni->n", damping_matrix(q, params)[:, 2], qd)
        slope = potential_hessian(q, params)[:, 2, 1]
        if np.any(slope <= 0.0):
            raise PlanningError("the path reaches configurations where rho2 no longer sets beta "
                                "(beyond the paper's range)", code=SINGULAR_PATH)
        delta = g / slope
        r2 = r2 - delta
        if np.any(r2 < 0.0) or np.any(r1 + r2 >= 2.0 * L):
            raise PlanningError("the path needs actuator lengths outside the mechanism's domain "
                                "(rho2 < 0 or rho1 + rho2 >= 2L; a faster move needs larger swings of rho2: "
                                "allow more time)", code=OUTSIDE_WORKSPACE)
        if np.max(np.abs(delta)) < _NEWTON_TOL * L:
            return r2
    raise PlanningError("Newton's method for rho2 along the path did not converge", code=SINGULAR_PATH)
