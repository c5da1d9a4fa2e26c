"""Force effects of the class-2 mechanism: springs, dampers, gravity and dead loads.

Every effect maps a kinematic context
(:class:`~tensegrity_core.class2.dynamics.kinematics.Kinematics`) to its generalised force
``Q`` [N, N, N m] (``M qddot + C = sum Q - (T1, T2, 0)``), and gives its derivatives
``(dQ/dq, dQ/dqdot)`` at one state for the Jacobian of the equations of motion;
conservative effects also give their energy and the unique entries of its Hessian
(``stiffness``). Forces, energies and stiffnesses are written with arithmetic only: they
run on one state's floats and on arrays of states alike.

- :class:`Springs`: the linear zero-free-length springs, ``U = 1/2 sum k_j |d_j|^2``;
- :class:`Damping`: their axial dampers, force ``c_j dL_j/dt`` along each spring
  (dissipated power ``qdot^T H qdot = sum c_j Ldot_j^2``, ``H = sum c_j g_j g_j^T / n_j``);
- :class:`Gravity`: the weight of the four struts (mass ``m`` each, at their centres);
- :class:`Loads`: dead forces on nodes, ``Q = sum_n J_n^T F_n``.

Only in-plane components act: the mechanism's supports take the rest.
:func:`force_terms` composes the listed effects' forces, evaluating springs and dampers
together in one pass when both are listed (:func:`spring_force_term`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial
from typing import Final, Protocol, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.kinematics import Kinematics, Real
from tensegrity_core.class2.dynamics.limits import ZERO_LENGTH_REL
from tensegrity_core.class2.dynamics.springs import (
    Coefficients,
    dampings,
    spring_forces,
    spring_vectors,
    squared_length_derivatives,
    stiffnesses,
)
from tensegrity_core.class2.params import Class2Params

_NO_STIFFNESS: Final[Coefficients] = (0.0, 0.0, 0.0, 0.0)

#: A generalised force ``(Q1, Q2, Q3)`` [N, N, N m] (floats or arrays).
Force: TypeAlias = tuple[Real, Real, Real]
#: Unique entries ``(K11, K12, K13, K22, K23, K33)`` of a symmetric 3x3 stiffness.
StiffnessEntries: TypeAlias = tuple[Real, Real, Real, Real, Real, Real]
#: ``(dQ/dq, dQ/dqdot)``, each (3, 3), at one state.
ForceJacobian: TypeAlias = tuple[NDArray[np.float64], NDArray[np.float64]]


class ForceTerm(Protocol):
    """``k -> Q``: a generalised force at a kinematic context of floats or of arrays."""

    def __call__(self, k: Kinematics[Real], /) -> Force[Real]: ...


class Effect(Protocol):
    """A force effect: its generalised force and, at one state, the force's derivatives."""

    @property
    def name(self) -> str: ...

    def force(self, k: Kinematics[Real], /) -> Force[Real]: ...

    def jacobian(self, k: Kinematics[float], /) -> ForceJacobian: ...


class ConservativeEffect(Effect, Protocol):
    """An effect with a potential: its energy [J] and the unique entries of its Hessian."""

    def energy(self, k: Kinematics[Real], /) -> Real: ...

    def stiffness(self, k: Kinematics[Real], /) -> StiffnessEntries[Real]: ...


def stiffness_matrix(entries: Sequence[ArrayLike]) -> NDArray[np.float64]:
    """Symmetric (..., 3, 3) matrix from unique entries ``(K11, K12, K13, K22, K23, K33)``."""
    K11, K12, K13, K22, K23, K33 = entries
    K = np.empty(np.broadcast_shapes(*(np.shape(e) for e in entries)) + (3, 3))
    K[..., 0, 0], K[..., 0, 1], K[..., 0, 2] = K11, K12, K13
    K[..., 1, 0], K[..., 1, 1], K[..., 1, 2] = K12, K22, K23
    K[..., 2, 0], K[..., 2, 1], K[..., 2, 2] = K13, K23, K33
    return K


def spring_force_term(L: float, stiffness: Coefficients | None, damping: Coefficients | None) -> ForceTerm:
    """``k -> Q`` of the spring members: ``stiffness`` (springs) and/or ``damping`` (dampers),
    each four coefficients in CD, DE, EF, BE order or None (a ``functools.partial`` of
    :func:`~tensegrity_core.class2.dynamics.springs.spring_forces`: no Python frame of its own)."""
    return partial(spring_forces, L, _NO_STIFFNESS if stiffness is None else stiffness, damping,
                   (ZERO_LENGTH_REL * L) ** 2)


class Springs:
    """Linear zero-free-length springs: ``Q = -dU/dq``, ``U = 1/2 sum k_j |d_j|^2``."""

    name = "springs"

    def __init__(self, params: Class2Params):
        self.L = params.L
        self.k = stiffnesses(params)
        self.force = spring_force_term(self.L, self.k, None)

    def energy(self, k: Kinematics[Real]) -> Real:
        x3, y3, x4, y4, x7, y7, x8, y8 = spring_vectors(self.L, k)
        k3, k2, k1, k4 = self.k
        return 0.5 * (k3 * (x3 * x3 + y3 * y3) + k2 * (x4 * x4 + y4 * y4) + k1 * (x7 * x7 + y7 * y7)
                      + k4 * (x8 * x8 + y8 * y8))

    def stiffness(self, k: Kinematics[Real]) -> StiffnessEntries[Real]:
        """Unique entries ``(K11, K12, K13, K22, K23, K33)`` of ``d2U/dq2`` (floats or arrays).

        ``d2U/dq2 = sum k_j (J_j^T J_j + sum_a d_ja d2d_ja/dq2)``, with ``eta1 = -4L^2/lambda1^3``
        and ``eta2 = -L^2/lambda2^3`` the second derivatives of lambda1 (in s) and lambda2."""
        r1, r2, sb, cb, _, _, _, s, lam1, lam2, e1, g2 = k
        L = self.L
        k3, k2, k1, k4 = self.k
        eta1 = -4.0 * L * L / lam1**3
        eta2 = -L * L / lam2**3
        e1sq = e1 * e1
        sym = 0.25 + 0.25 * e1sq               # (J^T J)_11 = (J^T J)_22 of DE and BE; _12 is sym - 0.5
        ey = 0.5 * e1 - g2
        dy7 = (r2 - r1) * (3.0 * r1 + r2) / (4.0 * lam2 + 2.0 * lam1)
        # the curvature terms sum_a d_ja d2d_ja/dq2 of DE, EF and BE, alike in K11, K12, K22
        curv = eta1 * ((0.5 * k2) * (0.5 * lam1 - L * sb) - (0.5 * k1) * dy7 + (0.25 * k4) * lam1)
        k24sym = (k2 + k4) * sym
        K11 = k24sym + k1 * (0.25 + ey * ey + eta2 * dy7) + curv
        K12 = k24sym - 0.5 * (k2 + k4) + k1 * (0.25 + 0.5 * ey * e1) + curv
        K22 = k3 + k24sym + k1 * (0.25 + 0.25 * e1sq) + curv
        K13 = (0.5 * k2 * L) * (e1 * cb - sb)
        K23 = (k3 * L) * sb + (0.5 * k2 * L) * (e1 * cb + sb)
        K33 = (k3 * L) * r2 * cb + (k2 * L) * (0.5 * (r2 - r1) * cb + 0.5 * lam1 * sb)
        return K11, K12, K13, K22, K23, K33

    def jacobian(self, k: Kinematics[float]) -> ForceJacobian:
        return -stiffness_matrix(self.stiffness(k)), np.zeros((3, 3))


class Damping:
    """Linear dampers along the springs: force ``c_j dL_j/dt`` (dissipated power ``sum c_j Ldot_j^2``)."""

    name = "damping"

    def __init__(self, params: Class2Params):
        self.L = params.L
        self.c = dampings(params)
        self.eps2 = (ZERO_LENGTH_REL * params.L) ** 2
        self.force = spring_force_term(self.L, None, self.c)

    def _norms(self, d: NDArray[np.float64]) -> NDArray[np.float64]:
        """``n_j = |d_j|^2 + eps^2`` over vectors ``d`` (..., 4, 2)."""
        n: NDArray[np.float64] = np.sum(d * d, -1) + self.eps2
        return n

    def matrix(self, k: Kinematics[Real]) -> NDArray[np.float64]:
        """``H(q) = sum_j c_j g_j g_j^T / n_j``, ``g_j = J_j^T d_j``, ``n_j = |d_j|^2 + eps^2``
        (``= sum c_j grad L_j grad L_j^T`` away from zero lengths); shape ``(..., 3, 3)``."""
        d, g, _ = squared_length_derivatives(self.L, k)
        H: NDArray[np.float64] = np.einsum("...j,...jc,...je->...ce", np.asarray(self.c) / self._norms(d), g, g)
        return H

    def jacobian(self, k: Kinematics[float]) -> ForceJacobian:
        """``(dQ/dq, dQ/dqdot)`` at one state: ``Q = -H(q) qdot`` and, with ``w_j = g_j . qdot``
        and ``G_j`` the Hessian of ``|d_j|^2 / 2``::

            d(H qdot)/dq = sum c_j [(g_j (G_j qdot)^T + w_j G_j) / n_j - 2 w_j g_j g_j^T / n_j^2].
        """
        qdot = np.array((k[4], k[5], k[6]), dtype=float)
        d, g, G = squared_length_derivatives(self.L, k)
        n = self._norms(d)
        a = np.asarray(self.c) / n
        w = g @ qdot
        Gq = np.einsum("jce,e->jc", G, qdot)
        H = np.einsum("j,jc,je->ce", a, g, g)
        dHq = (np.einsum("j,jc,je->ce", a, g, Gq) + np.einsum("j,jce->ce", a * w, G)
               - 2.0 * np.einsum("j,jc,je->ce", a * w / n, g, g))
        return -dHq, -H


class Gravity:
    """Weight of the four struts (mass ``m`` each, at their centres) in the field ``g`` [m/s^2].

    With ``X, Y`` the sums of the strut centres' coordinates, ``X = s + 1.5 rho1 + (L/2) cos b``,
    ``Y = (lambda1 + lambda2 + L sin b)/2``; ``V = -m (g_x X + g_y Y)``, ``Q = -dV/dq``.
    The z component acts against the supports of the horizontal mechanism and does no work.
    """

    name = "gravity"

    def __init__(self, params: Class2Params, vector: Sequence[float] | NDArray[np.float64]):
        self.L = params.L
        self.m = params.m
        self.gx, self.gy = float(vector[0]), float(vector[1])

    def force(self, k: Kinematics[Real]) -> Force[Real]:
        _, _, sb, cb, _, _, _, _, _, _, e1, g2 = k
        mgx, mgy, hl = self.m * self.gx, self.m * self.gy, 0.5 * self.L
        return (2.5 * mgx - 0.5 * (e1 + g2) * mgy, mgx - 0.5 * e1 * mgy, hl * (mgy * cb - mgx * sb))

    def energy(self, k: Kinematics[Real]) -> Real:
        r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
        X = s + 1.5 * r1 + 0.5 * self.L * cb
        Y = 0.5 * (lam1 + lam2 + self.L * sb)
        return -self.m * (self.gx * X + self.gy * Y)

    def stiffness(self, k: Kinematics[Real]) -> StiffnessEntries[Real]:
        """Unique entries of ``d2V/dq2`` (floats or arrays)."""
        _, _, sb, cb, _, _, _, _, lam1, lam2, _, _ = k
        L = self.L
        eta1 = -4.0 * L * L / lam1**3
        eta2 = -L * L / lam2**3
        mgx, mgy = self.m * self.gx, self.m * self.gy
        zero = 0.0 * lam1
        rho = -0.5 * mgy * eta1
        return rho - 0.5 * mgy * eta2, rho, zero, rho, zero, 0.5 * L * (mgx * cb + mgy * sb)

    def jacobian(self, k: Kinematics[float]) -> ForceJacobian:
        return -stiffness_matrix(self.stiffness(k)), np.zeros((3, 3))


class Loads:
    """Dead forces ``F_n`` [N] on nodes (in-plane components act): ``Q = sum J_n^T F_n``,
    ``V = -sum F_n . P_n``. ``forces`` maps node indices (0..5 for A..F) to 3-vectors."""

    name = "loads"

    def __init__(self, params: Class2Params, forces: Mapping[int, Sequence[float] | NDArray[np.float64]]):
        self.L = params.L
        F = np.zeros((6, 2))
        for node, vec in forces.items():
            F[node] += vec[:2]
        self.F = F
        on_b_to_f: list[list[float]] = F[1:].tolist()
        (self.fbx, _), (self.fcx, _), (self.fdx, self.fdy), (self.fex, self.fey), (_, self.ffy) = on_b_to_f

    def force(self, k: Kinematics[Real]) -> Force[Real]:
        _, _, sb, cb, _, _, _, _, _, _, e1, g2 = k
        L = self.L
        q1 = self.fbx + self.fcx + self.fdx + 0.5 * (self.fex - e1 * self.fey) - g2 * self.ffy
        q2 = self.fcx + 0.5 * (self.fex - e1 * self.fey)
        q3 = L * (cb * self.fdy - sb * self.fdx)
        return q1, q2, q3

    def energy(self, k: Kinematics[Real]) -> Real:
        """``V = -sum F_n . P_n`` (floats or arrays); A is fixed and B, C, F have a zero coordinate."""
        r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
        L = self.L
        return -(self.fbx * r1 + self.fcx * s + self.fdx * (r1 + L * cb) + self.fdy * L * sb
                 + 0.5 * (self.fex * s + self.fey * lam1) + self.ffy * lam2)

    def stiffness(self, k: Kinematics[Real]) -> StiffnessEntries[Real]:
        """Unique entries of ``d2V/dq2`` (floats or arrays)."""
        _, _, sb, cb, _, _, _, _, lam1, lam2, _, _ = k
        L = self.L
        zero = 0.0 * lam1
        rho = 0.5 * self.fey * 4.0 * L * L / lam1**3
        return rho + self.ffy * L * L / lam2**3, rho, zero, rho, zero, L * (cb * self.fdx + sb * self.fdy)

    def jacobian(self, k: Kinematics[float]) -> ForceJacobian:
        return -stiffness_matrix(self.stiffness(k)), np.zeros((3, 3))


def force_terms(effects: Sequence[Effect]) -> tuple[ForceTerm, ...]:
    """The callables ``k -> Q`` whose sum is the effects' generalised force, in the effects'
    order; listed springs and dampers become one term (one pass over the springs)."""
    springs = next((e for e in effects if isinstance(e, Springs)), None)
    damping = next((e for e in effects if isinstance(e, Damping)), None)
    out: list[ForceTerm] = []
    for e in effects:
        if springs is not None and damping is not None and e is damping:
            continue
        if e is springs and damping is not None:
            out.append(spring_force_term(springs.L, springs.k, damping.c))
        else:
            out.append(e.force)
    return tuple(out)
