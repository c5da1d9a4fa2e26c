"""Potential energy of the class-2 mechanism and the stability of its equilibria.

Springs are linear with zero free length, so the potential energy is
``U = 1/2 (k1 L7^2 + k2 L4^2 + k3 L3^2 + k4 L8^2)`` [J], which expands to the paper's
Eq. (9) (verified in tests). Struts and actuators are rigid here (their stiffnesses
ka, kb enter only the stiffness analysis). With the actuators locked, ``U`` depends on
beta only through::

    U(beta) = const + (L/2) (a cos beta + b sin beta),
    a = k2 rho1 - (2 k3 + k2) rho2,   b = -k2 lambda1,

so ``dU/dbeta = (L/2)(-a sin beta + b cos beta)`` and
``d2U/dbeta2 = -(L/2)(a cos beta + b sin beta)``.
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.geometry import SPRINGS, lambdas, member_lengths
from tensegrity_core.class2.params import Class2Params

_SPRING_IDX: Final = np.array([m.number - 1 for m in SPRINGS])


def spring_stiffnesses(params: Class2Params) -> NDArray[np.float64]:
    """Stiffness of each spring in :data:`SPRINGS` order (CD, DE, EF, BE) [N/m]."""
    return np.array([getattr(params, m.stiffness) for m in SPRINGS], dtype=np.float64)


def potential_energy(q: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Elastic potential energy ``U(q)`` [J]; ``q = (rho1, rho2, beta)``, broadcastable."""
    lengths = member_lengths(q, params)[..., _SPRING_IDX]
    energy: NDArray[np.float64] = 0.5 * np.sum(spring_stiffnesses(params) * lengths**2, axis=-1)
    return energy


def beta_coefficients(
    rho1: ArrayLike, rho2: ArrayLike, params: Class2Params
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(a, b)`` of ``U(beta) = const + (L/2)(a cos beta + b sin beta)``."""
    lam1, _ = lambdas(rho1, rho2, params.L)
    a = params.k2 * np.asarray(rho1) - (2.0 * params.k3 + params.k2) * np.asarray(rho2)
    b = -params.k2 * lam1
    return a, b


def dU_dbeta(q: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Partial derivative of ``U`` with respect to beta at fixed actuator lengths [J/rad]."""
    qa = np.asarray(q, dtype=np.float64)
    a, b = beta_coefficients(qa[..., 0], qa[..., 1], params)
    beta = qa[..., 2]
    return 0.5 * params.L * (-a * np.sin(beta) + b * np.cos(beta))


def d2U_dbeta2(q: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """Second derivative of ``U`` in beta [J/rad^2]; > 0 at a stable equilibrium."""
    qa = np.asarray(q, dtype=np.float64)
    a, b = beta_coefficients(qa[..., 0], qa[..., 1], params)
    beta = qa[..., 2]
    return -0.5 * params.L * (a * np.cos(beta) + b * np.sin(beta))


def equilibrium_beta(rho1: ArrayLike, rho2: ArrayLike, params: Class2Params) -> NDArray[np.float64]:
    """The energy-minimising beta for locked actuators [rad], in [0, pi].

    ``U(beta)`` is a sinusoid; its minimum is at ``atan2(-b, -a) =
    atan2(k2 lambda1, (2 k3 + k2) rho2 - k2 rho1)``. This is the root of the paper's Eq. (10)
    that is a minimum; the plain ``arctan`` of Eq. (10) returns the maximum (beta - pi)
    whenever the denominator is negative. The result exceeds the paper's range
    [0, pi/2] exactly when ``(2 k3 + k2) rho2 < k2 rho1``. When ``a = b = 0``
    (``lambda1 = 0`` and ``(2k3+k2) rho2 = k2 rho1``) every beta is an equilibrium and 0
    is returned; callers check :func:`d2U_dbeta2`.
    """
    a, b = beta_coefficients(rho1, rho2, params)
    return np.arctan2(-b, -a)
