"""Analytic Jacobian of the class-2 equations of motion, for implicit integrators.

With ``y = (q, qdot)`` and ``qddot = a(q, qdot) = -M^-1 (C + H qdot + grad U + F)``,
``F = (f1, f2, 0)``::

    d(dy/dt)/dy = [[0, I], [da/dq, da/dqdot]],
    da/dqdot = -M^-1 (dC/dqdot + H + dF/dqdot),
    da/dq    = -M^-1 ((dM/dq_k) qddot + dC/dq + d(H qdot)/dq + hess U + dF/dq).

Per spring ``j`` with node-difference vector ``d`` (Jacobian ``J``, component Hessians
``D_a``), ``g = J^T d`` is the gradient and ``G = J^T J + sum_a d_a D_a`` the Hessian of
``|d|^2/2``; then ``hess U = sum k_j G_j`` and, with ``w = g . qdot`` and
``n = |d|^2 + (eps L)^2`` (the same regularisation as :mod:`dynamics`),
``d(H qdot)/dq = sum c_j [ (g (G qdot)^T + w G) / n - 2 w g g^T / n^2 ]``.
The inertia derivatives are those of the closed forms in :mod:`dynamics`
(``mu' = 4 m L^2 s / (3 lambda1^4)``, ``b_F' = 2 m L^2 rho1 / (3 lambda2^4)``, ...).
Verified against central finite differences in the tests.
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.class2.dynamics import (
    LAMBDA_MIN_REL,
    ZERO_LENGTH_REL,
    _as_state,
    _coefficients,
    _lambdas_checked,
    _require_finite,
    _spring_hessians,
    _spring_vectors,
    acceleration,
    mass_matrix,
)
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import DomainError


def potential_hessian(q, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """Hessian of the potential energy ``d^2U/dq^2`` (3, 3) [N/m, N, N m] at one state."""
    q = _as_state("q", q)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    d, J = _spring_vectors(q, lam1, lam2, params.L)
    G = _squared_length_hessians(q, lam1, lam2, params.L, d, J)
    k, _ = _coefficients(params)
    return np.einsum("j,...jce->...ce", k, G)


def _squared_length_hessians(q, lam1, lam2, L, d, J):
    D = _spring_hessians(q, lam1, lam2, L)
    return np.einsum("...jac,...jae->...jce", J, J) + np.einsum("...ja,...jace->...jce", d, D)


def rhs_jacobian(q, qdot, f1=0.0, f2=0.0, params: Class2Params = PAPER_PARAMS, *, dforce_dy=None,
                 lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """``d(dy/dt)/dy`` (6, 6) at one state ``y = (q, qdot)``; see the module docstring.

    ``dforce_dy``: optional (2, 6) array of ``d(f1, f2)/dy`` for state-dependent forces.
    """
    q, qdot = _as_state("q", q), _as_state("qdot", qdot)
    if q.shape != (3,) or qdot.shape != (3,):
        raise DomainError(f"rhs_jacobian takes one state: q and qdot of shape (3,), got {q.shape} and {qdot.shape}")
    m, L = params.m, params.L
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    rho1, rho2, beta = q
    v1, v2, vb = qdot
    s, sd = rho1 + rho2, v1 + v2
    M = mass_matrix(q, params, lambda_min=lambda_min)
    qdd = acceleration(q, qdot, f1, f2, params, lambda_min=lambda_min)

    # Inertia: (dM/dq_k) qddot as column k.
    dmu = 4.0 * m * L**2 * s / (3.0 * lam1**4)
    dbf = 2.0 * m * L**2 * rho1 / (3.0 * lam2**4)
    dm13 = -0.5 * m * L * np.cos(beta)
    sdd = qdd[0] + qdd[1]
    dM_qdd = np.array([
        [dmu * sdd + dbf * qdd[0], dmu * sdd, dm13 * qdd[2]],
        [dmu * sdd, dmu * sdd, 0.0],
        [0.0, 0.0, dm13 * qdd[0]],
    ])

    # Velocity terms C1 = kappa1 sd^2 + kappa2 v1^2 - (m L/2) cos(beta) vb^2, C2 = kappa1 sd^2.
    kappa1 = 2.0 * m * L**2 * s / (3.0 * lam1**4)
    kappa2 = m * L**2 * rho1 / (3.0 * lam2**4)
    dkappa1 = 2.0 * m * L**2 * (lam1**2 + 4.0 * s**2) / (3.0 * lam1**6)
    dkappa2 = m * L**2 * (lam2**2 + 4.0 * rho1**2) / (3.0 * lam2**6)
    dC_dq = np.array([
        [dkappa1 * sd**2 + dkappa2 * v1**2, dkappa1 * sd**2, 0.5 * m * L * np.sin(beta) * vb**2],
        [dkappa1 * sd**2, dkappa1 * sd**2, 0.0],
        [0.0, 0.0, 0.0],
    ])
    dC_dqd = np.array([
        [2.0 * (kappa1 * sd + kappa2 * v1), 2.0 * kappa1 * sd, -m * L * np.cos(beta) * vb],
        [2.0 * kappa1 * sd, 2.0 * kappa1 * sd, 0.0],
        [0.0, 0.0, 0.0],
    ])

    # Springs and dampers.
    d, J = _spring_vectors(q, lam1, lam2, L)
    G = _squared_length_hessians(q, lam1, lam2, L, d, J)
    g = np.einsum("jac,ja->jc", J, d)
    k, c = _coefficients(params)
    n = np.sum(d * d, -1) + (ZERO_LENGTH_REL * L) ** 2
    w = g @ qdot
    Gq = np.einsum("jce,e->jc", G, qdot)
    hess_U = np.einsum("j,jce->ce", k, G)
    H = np.einsum("j,jc,je->ce", c / n, g, g)
    dHq_dq = (np.einsum("j,jc,je->ce", c / n, g, Gq) + np.einsum("j,jce->ce", c * w / n, G)
              - 2.0 * np.einsum("j,jc,je->ce", c * w / n**2, g, g))

    dF_dq = np.zeros((3, 3))
    dF_dqd = np.zeros((3, 3))
    if dforce_dy is not None:
        dfy = np.asarray(dforce_dy, dtype=float)
        if dfy.shape != (2, 6):
            raise DomainError(f"dforce_dy must have shape (2, 6), got {dfy.shape}")
        dF_dq[:2] = dfy[:, :3]
        dF_dqd[:2] = dfy[:, 3:]

    Minv = np.linalg.inv(M)
    jac = np.zeros((6, 6))
    jac[:3, 3:] = np.eye(3)
    jac[3:, :3] = -Minv @ (dM_qdd + dC_dq + dHq_dq + hess_U + dF_dq)
    jac[3:, 3:] = -Minv @ (dC_dqd + H + dF_dqd)
    return _require_finite("rhs_jacobian", jac, {"q": q, "qdot": qdot, "f1": f1, "f2": f2, "dforce_dy": dforce_dy if dforce_dy is not None else 0.0})
