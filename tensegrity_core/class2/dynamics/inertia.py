"""Inertia of the class-2 mechanism's struts, and the solve for accelerations in each contact mode.

Four struts of mass ``m``, ``I = m L^2/12`` (derived from first principles in
:mod:`studies.derivation.derive_dynamics`, which checks these closed forms)::

    M = [[m + mu + b_F, mu, m13], [mu, mu, 0], [m13, 0, m L^2/3]]
    mu = m/2 + 2 m L^2 / (3 lambda1^2),  b_F = m L^2 / (3 lambda2^2),  m13 = -(m L/2) sin b
    C = (kappa1 sdot^2 + kappa2 rho1dot^2 - (m L/2) cos(b) bdot^2,  kappa1 sdot^2,  0)
    kappa1 = 2 m L^2 s / (3 lambda1^4),  kappa2 = m L^2 rho1 / (3 lambda2^4)

and ``M qddot + C = Q``. The solve exploits ``M22 = M12`` and ``M23 = 0``: the Schur
complement of the ``rho1`` row is ``m + b_F - 3 m sin^2(b)/4 >= m/4``, so ``M`` is never
singular inside the domain (it grows like ``1/lambda^2`` towards the singular sets).

A *contact mode* is a bit set of actuators held at zero length by the fold limit (bit 0:
rho1, bit 1: rho2). In a mode the held coordinates have zero acceleration and the contact
force ``lambda_i`` [N] (pushing ``rho_i`` apart, compressive in the actuator) is the
residual of their rows: ``lambda_S = (M qddot - Q + C)_S``.

Everything takes a :class:`~tensegrity_core.class2.dynamics.kinematics.Kinematics` of floats
or of arrays (the matrices broadcast over its shape).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.dynamics.kinematics import Kinematics, Real
from tensegrity_core.class2.params import Class2Params

#: Contact modes: no actuator held, rho1 held, rho2 held, both held.
FREE: Final = 0
HOLD1: Final = 1
HOLD2: Final = 2
HOLD12: Final = 3


class Inertia:
    """Mass matrix, velocity terms and the structured solves of the struts' inertia."""

    name = "inertia"

    def __init__(self, params: Class2Params) -> None:
        m, L = params.m, params.L
        self.m, self.L = m, L
        self.half_m = 0.5 * m
        self.half_mL = 0.5 * m * L
        self.tt_mL2 = 2.0 * m * L * L / 3.0
        self.t_mL2 = m * L * L / 3.0
        self.inv_I3 = 3.0 / (m * L * L)
        self.tq_m = 0.75 * m

    def terms(self, k: Kinematics[Real]) -> tuple[Real, Real, Real, Real, Real]:
        """``(M11, mu, m13, C1, C2)`` (``M22 = M12 = mu``, ``M33 = m L^2/3``, ``C3 = 0``)."""
        r1, _, sb, cb, v1, v2, vb, s, lam1, lam2, _, _ = k
        il1 = 1.0 / (lam1 * lam1)
        il2 = 1.0 / (lam2 * lam2)
        mu = self.half_m + self.tt_mL2 * il1
        sd = v1 + v2
        c2 = self.tt_mL2 * s * il1 * il1 * sd * sd
        c1 = c2 + self.t_mL2 * r1 * il2 * il2 * v1 * v1 - self.half_mL * cb * vb * vb
        return self.m + mu + self.t_mL2 * il2, mu, -self.half_mL * sb, c1, c2

    def solve_free(self, k: Kinematics[Real], Q1: Real | float, Q2: Real | float,
                   Q3: Real | float) -> tuple[Real, Real, Real]:
        """Accelerations ``(a1, a2, a3)`` with no actuator held, for generalised forces ``Q``."""
        M11, mu, m13, c1, c2 = self.terms(k)
        R1, R2 = Q1 - c1, Q2 - c2
        inv_I3 = self.inv_I3
        sb = k[2]
        a1 = (R1 - R2 - m13 * Q3 * inv_I3) / (M11 - mu - self.tq_m * sb * sb)
        return a1, R2 / mu - a1, (Q3 - m13 * a1) * inv_I3

    def solve(self, k: Kinematics[Real], Q1: Real | float, Q2: Real | float, Q3: Real | float,
              mode: int) -> tuple[Real | float, Real | float, Real | float, Real | float, Real | float]:
        """Accelerations ``(a1, a2, a3)`` and contact forces ``(l1, l2)`` for generalised
        forces ``Q`` in contact ``mode``."""
        a1: Real | float
        a2: Real | float
        a3: Real | float
        if mode == FREE:
            a1, a2, a3 = self.solve_free(k, Q1, Q2, Q3)
            return a1, a2, a3, 0.0, 0.0
        M11, mu, m13, c1, c2 = self.terms(k)
        R1, R2, R3 = Q1 - c1, Q2 - c2, Q3
        inv_I3 = self.inv_I3
        if mode == HOLD1:
            a2, a3 = R2 / mu, R3 * inv_I3
            return 0.0, a2, a3, mu * a2 + m13 * a3 - R1, 0.0
        if mode == HOLD2:
            I3 = 1.0 / inv_I3
            det = M11 * I3 - m13 * m13
            a1 = (R1 * I3 - m13 * R3) / det
            a3 = (M11 * R3 - m13 * R1) / det
            return a1, 0.0, a3, 0.0, mu * a1 - R2
        a3 = R3 * inv_I3
        return 0.0, 0.0, a3, m13 * a3 - R1, -R2

    def mass_matrix(self, k: Kinematics[Real]) -> NDArray[np.float64]:
        """``M(q)``, shape ``(..., 3, 3)`` [kg, kg m, kg m^2]; symmetric positive definite."""
        M11, mu, m13 = np.broadcast_arrays(*self.terms(k)[:3])
        M = np.zeros(np.shape(mu) + (3, 3))
        M[..., 0, 0], M[..., 0, 1], M[..., 0, 2] = M11, mu, m13
        M[..., 1, 0], M[..., 1, 1] = mu, mu
        M[..., 2, 0], M[..., 2, 2] = m13, 1.0 / self.inv_I3
        return M

    def velocity_terms(self, k: Kinematics[Real]) -> NDArray[np.float64]:
        """``C(q, qdot)`` [N, N, N m], shape ``(..., 3)``."""
        c1, c2 = np.broadcast_arrays(*self.terms(k)[3:])
        return np.stack([c1, c2, np.zeros_like(c1)], -1)

    def kinetic_energy(self, k: Kinematics[Real]) -> Real:
        """``T = 1/2 qdot^T M qdot`` [J] (floats or arrays)."""
        _, _, sb, _, v1, v2, vb, _, lam1, lam2, _, _ = k
        mu = self.half_m + self.tt_mL2 / (lam1 * lam1)
        b_f = self.t_mL2 / (lam2 * lam2)
        return 0.5 * (mu * (v1 + v2) ** 2 + (self.m + b_f) * v1 * v1 + self.t_mL2 * vb * vb) \
            - self.half_mL * sb * v1 * vb

    def jacobian_terms(
        self, k: Kinematics[float], a: Sequence[float] | NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(dM/dq . a, dC/dq, dC/dqdot)``, each (3, 3), at one state for accelerations ``a``
        (3,): column ``i`` of the first is ``(dM/dq_i) a``; ``mu' = 4 m L^2 s / (3 lambda1^4)``,
        ``b_F' = 2 m L^2 rho1 / (3 lambda2^4)`` (derivatives of the closed forms above)."""
        r1, _, sb, cb, v1, v2, vb, s, lam1, lam2, _, _ = k
        m, L = self.m, self.L
        dmu = 4.0 * m * L * L * s / (3.0 * lam1**4)
        dbf = 2.0 * m * L * L * r1 / (3.0 * lam2**4)
        dm13 = -0.5 * m * L * cb
        sa = a[0] + a[1]
        dMa = np.array([[dmu * sa + dbf * a[0], dmu * sa, dm13 * a[2]],
                        [dmu * sa, dmu * sa, 0.0],
                        [0.0, 0.0, dm13 * a[0]]])
        sd = v1 + v2
        kappa1 = 2.0 * m * L * L * s / (3.0 * lam1**4)
        kappa2 = m * L * L * r1 / (3.0 * lam2**4)
        dk1 = 2.0 * m * L * L * (lam1**2 + 4.0 * s * s) / (3.0 * lam1**6)
        dk2 = m * L * L * (lam2**2 + 4.0 * r1 * r1) / (3.0 * lam2**6)
        dC_dq = np.array([[dk1 * sd * sd + dk2 * v1 * v1, dk1 * sd * sd, 0.5 * m * L * sb * vb * vb],
                          [dk1 * sd * sd, dk1 * sd * sd, 0.0],
                          [0.0, 0.0, 0.0]])
        dC_dqd = np.array([[2.0 * (kappa1 * sd + kappa2 * v1), 2.0 * kappa1 * sd, -m * L * cb * vb],
                           [2.0 * kappa1 * sd, 2.0 * kappa1 * sd, 0.0],
                           [0.0, 0.0, 0.0]])
        return dMa, dC_dq, dC_dqd
