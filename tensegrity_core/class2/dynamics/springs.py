"""The four spring members of the class-2 mechanism as functions of the kinematic context.

Springs CD (k3, c3), DE (k2, c2), EF (k1, c1), BE (k4, c4) -- :data:`SPRINGS` order of
:mod:`tensegrity_core.class2.geometry` -- with node-difference vectors ``d_j`` (second node
minus first) and Jacobians ``J_j = dd_j/dq``::

    d_CD = (L cos b - rho2, L sin b)          d_DE = (h - L cos b, lambda1/2 - L sin b)
    d_EF = (-s/2, lambda2 - lambda1/2)        d_BE = (h, lambda1/2),     h = (rho2 - rho1)/2

EF's y component is evaluated as ``(rho2 - rho1)(3 rho1 + rho2) / (4 lambda2 + 2 lambda1)``,
free of cancellation. A spring with axial force coefficient ``phi_j`` (force vector
``phi_j d_j`` on its second node, tension positive) contributes ``-J_j^T (phi_j d_j)`` to the
generalised force; a linear zero-free-length spring has ``phi_j = k_j``, its damper adds
``c_j (d_j . ddot_j) / (|d_j|^2 + eps^2)`` (the damper force along the spring is
``c_j dL_j/dt``; ``eps = ZERO_LENGTH_REL L``).

The arithmetic functions (:func:`spring_tensions`, :func:`spring_vectors`,
:func:`spring_forces`) take a
:class:`~tensegrity_core.class2.dynamics.kinematics.Kinematics` of floats or of arrays;
vectors are flat ``(x_CD, y_CD, x_DE, y_DE, x_EF, y_EF, x_BE, y_BE)``. The array functions
(:func:`spring_jacobians`, :func:`spring_second_derivatives`) give the derivatives for the
Jacobians of the equations of motion.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.dynamics.kinematics import Kinematics, Real
from tensegrity_core.class2.geometry import SPRINGS
from tensegrity_core.class2.params import Class2Params

#: One coefficient per spring, in CD, DE, EF, BE order.
Coefficients: TypeAlias = tuple[float, float, float, float]
#: The springs' vectors ``(x_CD, y_CD, ..., x_BE, y_BE)`` [m].
SpringVectors: TypeAlias = tuple[Real, Real, Real, Real, Real, Real, Real, Real]
#: :data:`SpringVectors` followed by the axial force coefficients ``(phi_CD, ..., phi_BE)``
#: [N/m] (plain floats where no damper adds a state-dependent part).
SpringTensions: TypeAlias = tuple[Real, Real, Real, Real, Real, Real, Real, Real,
                                  Real | float, Real | float, Real | float, Real | float]


def _per_spring(values: Iterable[float]) -> Coefficients:
    a, b, c, d = values
    return a, b, c, d


def stiffnesses(params: Class2Params) -> Coefficients:
    """``(k_CD, k_DE, k_EF, k_BE) = (k3, k2, k1, k4)`` [N/m]."""
    return _per_spring(float(getattr(params, m.stiffness)) for m in SPRINGS)


def dampings(params: Class2Params) -> Coefficients:
    """``(c_CD, c_DE, c_EF, c_BE) = (c3, c2, c1, c4)`` [N s/m]."""
    return _per_spring(0.0 if m.damping is None else float(getattr(params, m.damping)) for m in SPRINGS)


def spring_tensions(L: float, stiffness: Coefficients, damping: Coefficients | None, eps2: float,
                    k: Kinematics[Real]) -> SpringTensions[Real]:
    """The springs' vectors and axial force coefficients at context ``k``:
    ``(x_CD, y_CD, x_DE, y_DE, x_EF, y_EF, x_BE, y_BE, phi_CD, phi_DE, phi_EF, phi_BE)``.

    ``phi_j`` [N/m] (force ``phi_j d_j`` on the second node, tension positive) is the
    stiffness (``stiffness``, four values) plus, when ``damping`` (four values) is not None,
    the damper's ``c_j (d_j . ddot_j)/(|d_j|^2 + eps2)`` with the rates ``ddot_j = J_j qdot``
    written out. The parameters come first so that ``functools.partial`` binds them."""
    r1, r2, sb, cb, v1, v2, vb, s, lam1, lam2, e1, g2 = k
    lsb = L * sb
    lcb = L * cb
    h = 0.5 * (r2 - r1)
    y_e = 0.5 * lam1
    x3, y3, x4, y4 = lcb - r2, lsb, h - lcb, y_e - lsb
    x7, y7 = -0.5 * s, (r2 - r1) * (3.0 * r1 + r2) / (4.0 * lam2 + 2.0 * lam1)
    p3: Real | float
    p4: Real | float
    p7: Real | float
    p8: Real | float
    p3, p4, p7, p8 = stiffness
    if damping is not None:
        c3, c4, c7, c8 = damping
        sd = v1 + v2
        hd = 0.5 * (v2 - v1)
        y_ed = -0.5 * e1 * sd
        lsb_vb = lsb * vb
        lcb_vb = lcb * vb
        p3 = p3 + c3 * (x3 * (-v2 - lsb_vb) + y3 * lcb_vb) / (x3 * x3 + y3 * y3 + eps2)
        p4 = p4 + c4 * (x4 * (hd + lsb_vb) + y4 * (y_ed - lcb_vb)) / (x4 * x4 + y4 * y4 + eps2)
        p7 = p7 + c7 * (-0.5 * x7 * sd + y7 * (0.5 * e1 * sd - g2 * v1)) / (x7 * x7 + y7 * y7 + eps2)
        p8 = p8 + c8 * (h * hd + y_e * y_ed) / (h * h + y_e * y_e + eps2)
    return x3, y3, x4, y4, x7, y7, h, y_e, p3, p4, p7, p8


_NO_STIFFNESS: Final[Coefficients] = (0.0, 0.0, 0.0, 0.0)


def spring_vectors(L: float, k: Kinematics[Real]) -> SpringVectors[Real]:
    """Node-difference vectors of the springs, flat ``(x_CD, y_CD, ..., x_BE, y_BE)`` [m]."""
    return spring_tensions(L, _NO_STIFFNESS, None, 0.0, k)[:8]


def spring_forces(L: float, stiffness: Coefficients, damping: Coefficients | None, eps2: float,
                  k: Kinematics[Real]) -> tuple[Real, Real, Real]:
    """Generalised force ``Q = -sum_j J_j^T (phi_j d_j)`` [N, N, N m] of the springs
    (``stiffness``) and their dampers (``damping`` or None) at context ``k``
    (:func:`spring_tensions`): the hot path of every right-hand side (floats or arrays).
    DE and BE share the rho-columns of their Jacobians."""
    x3, y3, x4, y4, x7, y7, x8, y8, p3, p4, p7, p8 = spring_tensions(L, stiffness, damping, eps2, k)
    sb, cb, e1, g2 = k[2], k[3], k[10], k[11]
    fx4, fy4 = p4 * x4, p4 * y4
    fx = fx4 + p8 * x8
    fy = fy4 + p8 * y8
    fy7 = p7 * y7
    fx3, fy3 = p3 * x3, p3 * y3
    q1 = -0.5 * (fx + e1 * fy + p7 * x7) + (0.5 * e1 - g2) * fy7
    q2 = -fx3 + 0.5 * (fx - e1 * fy - p7 * x7 + e1 * fy7)
    q3 = L * (cb * (fy3 - fy4) + sb * (fx4 - fx3))
    return -q1, -q2, -q3


def spring_jacobians(L: float, k: Kinematics[Real]) -> NDArray[np.float64]:
    """``J_j = dd_j/dq``, shape ``(..., 4, 2, 3)`` over the context's shape."""
    _, _, sb, cb, _, _, _, s, _, _, e1_, g2 = k
    lsb, lcb = L * np.asarray(sb), L * np.asarray(cb)
    e1 = np.asarray(e1_)
    J = np.zeros(np.shape(s) + (4, 2, 3))
    J[..., 0, 0, 1] = -1.0                                                        # CD
    J[..., 0, 0, 2], J[..., 0, 1, 2] = -lsb, lcb
    J[..., 1, 0, :2] = (-0.5, 0.5)                                                # DE
    J[..., 1, 0, 2] = lsb
    J[..., 1, 1, 0] = J[..., 1, 1, 1] = -0.5 * e1
    J[..., 1, 1, 2] = -lcb
    J[..., 2, 0, :2] = -0.5                                                       # EF
    J[..., 2, 1, 0], J[..., 2, 1, 1] = 0.5 * e1 - g2, 0.5 * e1
    J[..., 3, 0, :2] = (-0.5, 0.5)                                                # BE
    J[..., 3, 1, 0] = J[..., 3, 1, 1] = -0.5 * e1
    return J


def spring_second_derivatives(L: float, k: Kinematics[Real]) -> NDArray[np.float64]:
    """Second derivatives of the components of each ``d_j``, shape ``(..., 4, 2, 3, 3)``;
    ``eta1 = -4L^2/lambda1^3`` and ``eta2 = -L^2/lambda2^3`` are those of lambda1 (in s) and
    lambda2 (in rho1)."""
    _, _, sb, cb, _, _, _, _, lam1, lam2, _, _ = k
    eta1 = -4.0 * L * L / np.asarray(lam1) ** 3
    eta2 = -L * L / np.asarray(lam2) ** 3
    lsb, lcb = L * np.asarray(sb), L * np.asarray(cb)
    out = np.zeros(np.shape(eta1) + (4, 2, 3, 3))
    out[..., 0, 0, 2, 2] = -lcb
    out[..., 0, 1, 2, 2] = -lsb
    out[..., 1, 0, 2, 2] = lcb
    out[..., 1, 1, :2, :2] = (0.5 * eta1)[..., None, None]
    out[..., 1, 1, 2, 2] = lsb
    out[..., 2, 1, :2, :2] = (-0.5 * eta1)[..., None, None]
    out[..., 2, 1, 0, 0] += eta2
    out[..., 3, 1, :2, :2] = (0.5 * eta1)[..., None, None]
    return out


def squared_length_derivatives(
    L: float, k: Kinematics[Real]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(d (..., 4, 2), g (..., 4, 3), G (..., 4, 3, 3))``: the vectors, and the gradient
    ``g_j = J_j^T d_j`` and Hessian ``G_j = J_j^T J_j + sum_a d_ja D_ja`` of ``|d_j|^2 / 2``."""
    d = np.moveaxis(np.array(np.broadcast_arrays(*spring_vectors(L, k)), dtype=float), 0, -1)
    d = d.reshape(d.shape[:-1] + (4, 2))
    J = spring_jacobians(L, k)
    D = spring_second_derivatives(L, k)
    g = np.einsum("...jac,...ja->...jc", J, d)
    G = np.einsum("...jac,...jae->...jce", J, J) + np.einsum("...ja,...jace->...jce", d, D)
    return d, g, G
