"""The total potential of a quasi-static class-2 scene and its derivatives.

With massless struts the force balance is the stationarity of::

    Pi(q, t) = U(q) + V_gravity(q) + V_loads(q) + sum_i W_i(t, rho_i),   W_i = int_0^rho_i u_i(t, r) dr

(``u_i`` the input laws, tension-positive forces [N]; ``q = (rho1, rho2, beta)`` [m, m, rad]).
With ``Q`` the listed effects' generalised force (``Q = -d(U + V)/dq``)::

    G  = dPi/dq     = (u1 - Q1, u2 - Q2, -Q3)                      [N, N, N m]
    K  = d2Pi/dq2   = -dQ/dq + diag(du1/drho1, du2/drho2, 0)
    Gt = d2Pi/dq dt = (du1/dt, du2/dt, 0)

Two forms of the same formulas (the effects and laws work on floats and on arrays alike):
:meth:`TotalPotential.evaluate` at one configuration (lists of floats: the path follower's
Newton iterations) and :meth:`TotalPotential.evaluate_array` at N configurations (the
samples of a run).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.dynamics.kinematics import kinematics, kinematics_array
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL
from tensegrity_core.sim.class2.setup import ConservativeEffect
from tensegrity_core.sim.inputs import Law

FloatArray = NDArray[np.float64]
#: ``(G, K, Gt)`` at one configuration: lists of 3, 3 x 3 and 3 floats.
Derivatives = tuple[list[float], list[list[float]], list[float]]


class TotalPotential:
    """``Pi`` and its derivatives for the force ``effects`` (springs, gravity, loads) and the
    input ``laws`` (two, one per actuator) of a mechanism with strut length ``L`` [m]."""

    def __init__(self, effects: Iterable[ConservativeEffect], laws: Iterable[Law], L: float):
        self.effects = tuple(effects)
        self.laws = tuple(laws)
        self.L = L
        self.limit = LAMBDA_MIN_REL * L
        self._force_stiffness = tuple((e.force, e.stiffness) for e in self.effects)

    def with_laws(self, laws: Iterable[Law]) -> TotalPotential:
        """The same effects under other input laws (a new command)."""
        return TotalPotential(self.effects, laws, self.L)

    def evaluate(self, q: Sequence[float], t: float) -> Derivatives:
        """``(G, K, Gt)`` at one configuration: lists of 3, 3 x 3 and 3 floats. Raises the
        kinematic context's :class:`~tensegrity_core.errors.SingularityError` or
        :class:`~tensegrity_core.errors.DomainError` outside the mechanism's domain."""
        r1, r2 = q[0], q[1]
        k = kinematics(self.L, (r1, r2, q[2], 0.0, 0.0, 0.0), self.limit)
        (force, stiffness), *others = self._force_stiffness      # a quasi-static scene has springs
        Q1, Q2, Q3 = force(k)
        K11, K12, K13, K22, K23, K33 = stiffness(k)
        for force, stiffness in others:
            a, b, c = force(k)
            Q1 += a
            Q2 += b
            Q3 += c
            s11, s12, s13, s22, s23, s33 = stiffness(k)
            K11 += s11
            K12 += s12
            K13 += s13
            K22 += s22
            K23 += s23
            K33 += s33
        l1, l2 = self.laws
        u1, du1, dt1 = l1.local(t, r1)
        u2, du2, dt2 = l2.local(t, r2)
        K11 += du1
        K22 += du2
        return [u1 - Q1, u2 - Q2, -Q3], [[K11, K12, K13], [K12, K22, K23], [K13, K23, K33]], [dt1, dt2, 0.0]

    def value(self, q: Sequence[float], t: float) -> float:
        """``Pi(q, t)`` [J] at one configuration."""
        k = kinematics(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0), self.limit)
        l1, l2 = self.laws
        pi: float = sum(e.energy(k) for e in self.effects) + l1.potential(t, q[0]) + l2.potential(t, q[1])
        return pi

    def evaluate_array(self, t: FloatArray,
                       q: FloatArray) -> tuple[FloatArray, tuple[float | FloatArray, ...], FloatArray, FloatArray]:
        """``(G (N, 3), K, Gt (N, 3), u (N, 2))`` at times ``t`` (N,) and configurations ``q``
        (N, 3): ``K`` as its unique entries ``(K11, K12, K13, K22, K23, K33)`` (arrays), ``u``
        the input laws' values (the actuator forces)."""
        k = kinematics_array(self.L, q, np.zeros_like(q))
        Q1: float | FloatArray = 0.0
        Q2: float | FloatArray = 0.0
        Q3: float | FloatArray = 0.0
        entries: list[float | FloatArray] = [0.0] * 6
        for e in self.effects:
            a, b, c = e.force(k)
            Q1, Q2, Q3 = Q1 + a, Q2 + b, Q3 + c
            entries = [x + y for x, y in zip(entries, e.stiffness(k))]
        (u1, du1, dt1), (u2, du2, dt2) = (law.arrays(t, q[:, a]) for a, law in enumerate(self.laws))
        entries[0] = entries[0] + du1
        entries[3] = entries[3] + du2
        n = len(t)
        G = np.empty((n, 3))
        G[:, 0] = u1 - Q1
        G[:, 1] = u2 - Q2
        G[:, 2] = -Q3
        Gt = np.zeros((n, 3))
        Gt[:, 0] = dt1
        Gt[:, 1] = dt2
        return G, tuple(entries), Gt, np.stack([u1, u2], -1)
