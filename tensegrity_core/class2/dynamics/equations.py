"""The class-2 equations of motion composed from force effects and the struts' inertia.

::

    M(q) qddot + C(q, qdot) = sum_e Q_e(q, qdot) - (T1, T2, 0)   [+ contact forces]

:class:`EquationsOfMotion` composes a tuple of effects (:mod:`.effects`) with the
:class:`~tensegrity_core.class2.dynamics.inertia.Inertia`: the kinematic context, the
generalised force, the solve in a contact mode and the Jacobian rows of the accelerations.
The scene simulator's class-2 back end composes the effects a scene lists (plus the drive
and the fold limit); :class:`Class2Dynamics` is the paper's model -- springs and their
dampers, actuator forces as inputs -- with a scalar fast path (pure ``math``, a few
microseconds per state) and a batch path (numpy arrays).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.effects import Damping, Effect, ForceJacobian, Springs, force_terms
from tensegrity_core.class2.dynamics.inertia import Inertia
from tensegrity_core.class2.dynamics.kinematics import Kinematics, Real, kinematics, kinematics_array
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL, check_lambda_min
from tensegrity_core.class2.energy import potential_energy
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import DomainError, ParameterError


def require_finite(name: str, result: NDArray[np.float64], inputs: Mapping[str, ArrayLike]) -> NDArray[np.float64]:
    """``result``, or :class:`DomainError` naming the non-finite ones of ``inputs``."""
    if np.all(np.isfinite(result)):
        return result
    bad = [k for k, v in inputs.items() if not np.all(np.isfinite(np.asarray(v, dtype=float)))]
    raise DomainError(f"{name}: non-finite input {', '.join(bad) or '(overflow)'}")


def _non_finite(y: Sequence[float], f1: float, f2: float) -> DomainError:
    return DomainError("acceleration: non-finite input in (rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot, f1, f2) "
                       f"= {(*y, f1, f2)!r}")


class EquationsOfMotion:
    """``M qddot + C = sum Q_e - (T1, T2, 0)`` for the force ``effects`` (in composition
    order) of one parameter set; states with lambda1 or lambda2 below ``lambda_min L`` are
    refused."""

    def __init__(self, params: Class2Params, effects: Iterable[Effect], *, lambda_min: float = LAMBDA_MIN_REL):
        self.params = params
        self.L = params.L
        self.lambda_min = check_lambda_min(lambda_min)
        self.limit = self.lambda_min * params.L
        self.effects = tuple(effects)
        self.forces = force_terms(self.effects)
        self.inertia = Inertia(params)

    def kinematics(self, y: Sequence[float]) -> Kinematics[float]:
        """Checked context of one state (a sequence of floats, ``q, qdot`` first)."""
        return kinematics(self.L, y, self.limit)

    def kinematics_array(self, q: ArrayLike, qdot: ArrayLike) -> Kinematics[NDArray[np.float64]]:
        """Checked context of arrays of states."""
        return kinematics_array(self.L, q, qdot, self.limit)

    def generalized_force(self, k: Kinematics[Real]) -> tuple[Real | float, Real | float, Real | float]:
        """``sum_e Q_e`` (floats or arrays; 0.0 for no effects)."""
        Q1: Real | float
        Q2: Real | float
        Q3: Real | float
        Q1 = Q2 = Q3 = 0.0
        for force in self.forces:
            a, b, c = force(k)
            Q1 += a
            Q2 += b
            Q3 += c
        return Q1, Q2, Q3

    def force_jacobian(self, k: Kinematics[float]) -> ForceJacobian:
        """``(d sum Q_e/dq, d sum Q_e/dqdot)``, each (3, 3), at one state."""
        dQ_dq = np.zeros((3, 3))
        dQ_dqd = np.zeros((3, 3))
        for e in self.effects:
            A, B = e.jacobian(k)
            dQ_dq += A
            dQ_dqd += B
        return dQ_dq, dQ_dqd

    def acceleration_jacobian(self, k: Kinematics[float], a: Sequence[float] | NDArray[np.float64], dT: NDArray[np.float64],
                              free: Iterable[int]) -> NDArray[np.float64]:
        """Rows ``d qddot_F / dy`` (len(free), n) at one state with accelerations ``a`` (3,),
        for the free coordinates ``free`` of a contact mode (held ones have ``qddot = 0``);
        ``dT`` (2, n) the derivatives of the actuator forces ``(T1, T2)`` by ``y`` (n states)::

            M_FF d qddot_F = (dQ/dy - dC/dy - (dM/dq . qddot) - (dT, 0))_F
        """
        dQ_dq, dQ_dqd = self.force_jacobian(k)
        dMa, dC_dq, dC_dqd = self.inertia.jacobian_terms(k, a)
        dR = np.zeros((3, dT.shape[1]))
        dR[:, :3] = dQ_dq - dC_dq - dMa
        dR[:, 3:6] = dQ_dqd - dC_dqd
        dR[:2] -= dT
        M = self.inertia.mass_matrix(k)
        rows = list(free)
        # numpy's stubs type solve() of float64 arrays as floating[Any]
        return np.linalg.solve(M[np.ix_(rows, rows)], dR[rows])  # type: ignore[return-value]


class Class2Dynamics:
    """The paper's equations of motion for one parameter set, with fast scalar and batch paths.

    Springs and their dampers, actuator forces ``f1, f2`` [N] (tensile positive) as inputs:
    ``M qddot + C + H qdot + grad U + (f1, f2, 0) = 0``. State ``y = (rho1, rho2, beta,
    rho1_dot, rho2_dot, beta_dot)`` [m, m, rad, m/s, m/s, rad/s]. ``lambda_min`` (relative
    to ``L``) is the refusal threshold for lambda1 and lambda2
    (:mod:`~tensegrity_core.class2.dynamics.limits`).
    """

    def __init__(self, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> None:
        if not isinstance(params, Class2Params):
            raise ParameterError(f"params must be a Class2Params, got {type(params).__name__}")
        self.equations = EquationsOfMotion(params, (Springs(params), Damping(params)), lambda_min=lambda_min)
        self._L = params.L
        self._limit = self.equations.limit
        (self._force,) = self.equations.forces          # springs and dampers in one pass
        self._solve = self.equations.inertia.solve_free

    @property
    def params(self) -> Class2Params:
        return self.equations.params

    @property
    def lambda_min(self) -> float:
        return self.equations.lambda_min

    def acceleration_scalar(self, rho1: float, rho2: float, beta: float, rho1_dot: float, rho2_dot: float,
                            beta_dot: float, f1: float = 0.0, f2: float = 0.0) -> tuple[float, float, float]:
        """``qddot`` for one state from plain floats (pure ``math``, no numpy)."""
        y = (rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot)
        k = kinematics(self._L, y, self._limit)
        Q1, Q2, Q3 = self._force(k)
        out = self._solve(k, Q1 - f1, Q2 - f2, Q3)
        if math.isfinite(out[0] + out[1] + out[2]):
            return out
        raise _non_finite(y, f1, f2)

    def rhs(self, t: float, y: NDArray[np.float64] | Sequence[float], f1: float = 0.0,
            f2: float = 0.0) -> NDArray[np.float64]:
        """``dy/dt`` for ``scipy.integrate.solve_ivp``: ``y`` of shape (6,), constant forces.

        For state- or time-dependent forces wrap it: ``lambda t, y: dyn.rhs(t, y, f1(t, y), f2(t, y))``.
        """
        yl = y.tolist() if isinstance(y, np.ndarray) else y
        k = kinematics(self._L, yl, self._limit)
        Q1, Q2, Q3 = self._force(k)
        a1, a2, a3 = self._solve(k, Q1 - f1, Q2 - f2, Q3)
        if math.isfinite(a1 + a2 + a3):
            return np.array((yl[3], yl[4], yl[5], a1, a2, a3))
        raise _non_finite(tuple(yl), f1, f2)

    def acceleration_array(self, q: ArrayLike, qdot: ArrayLike, f1: ArrayLike = 0.0,
                           f2: ArrayLike = 0.0) -> NDArray[np.float64]:
        """``qddot`` (..., 3) for arrays ``q, qdot`` (trailing dimension 3) and forces
        broadcastable to their leading shape."""
        k = self.equations.kinematics_array(q, qdot)
        with np.errstate(invalid="ignore", over="ignore"):   # non-finite input is reported below
            Q1, Q2, Q3 = self._force(k)
            a = self._solve(k, Q1 - np.asarray(f1, dtype=float), Q2 - np.asarray(f2, dtype=float), Q3)
        out = np.stack(np.broadcast_arrays(*a), -1)
        return require_finite("acceleration", out, {"q": q, "qdot": qdot, "f1": f1, "f2": f2})

    def acceleration_batch(self, states: ArrayLike, f1: ArrayLike = 0.0, f2: ArrayLike = 0.0) -> NDArray[np.float64]:
        """``qddot`` for states of shape ``(N, 6)`` and forces broadcastable to ``(N,)`` -> ``(N, 3)``."""
        y = np.asarray(states, dtype=float)
        if y.ndim < 1 or y.shape[-1] != 6:
            raise DomainError(f"trailing dimension of states must be 6 (q, qdot), got shape {y.shape}")
        return self.acceleration_array(y[..., :3], y[..., 3:], f1, f2)

    def jacobian(self, t: float, y: ArrayLike, f1: float = 0.0, f2: float = 0.0,
                 dforce_dy: ArrayLike | None = None) -> NDArray[np.float64]:
        """Analytic ``d(dy/dt)/dy``, shape (6, 6), for implicit integrators (Radau, BDF)::

            d(dy/dt)/dy = [[0, I], [da/dq, da/dqdot]],
            M da/dq    = dQ/dq - dC/dq - (dM/dq_k) qddot - dF/dq,
            M da/dqdot = dQ/dqdot - dC/dqdot - dF/dqdot,      F = (f1, f2, 0)

        ``dforce_dy`` (2, 6): derivatives of ``(f1, f2)`` with respect to ``y`` when the
        forces depend on the state (feedback laws, the paper's ``f_i = 10 rho_i t``).
        """
        ya = np.asarray(y, dtype=np.float64)
        if ya.shape != (6,):
            raise DomainError(f"the Jacobian takes one state y of shape (6,), got {ya.shape}")
        dT = np.zeros((2, 6))
        if dforce_dy is not None:
            dfy = np.asarray(dforce_dy, dtype=float)
            if dfy.shape != (2, 6):
                raise DomainError(f"dforce_dy must have shape (2, 6), got {dfy.shape}")
            dT = dfy
        yl: list[float] = ya.tolist()
        rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot = yl
        a = self.acceleration_scalar(rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot, f1, f2)
        eom = self.equations
        k = eom.kinematics(yl)
        jac = np.zeros((6, 6))
        jac[:3, 3:] = np.eye(3)
        jac[3:] = eom.acceleration_jacobian(k, a, dT, (0, 1, 2))
        return require_finite("rhs_jacobian", jac, {"y": ya, "f1": f1, "f2": f2, "dforce_dy": dT})

    def energy(self, y: ArrayLike) -> float:
        """Mechanical energy ``T + U`` [J] of state ``y`` (6,)."""
        ya = np.asarray(y, dtype=np.float64)
        k = self.equations.kinematics(ya.tolist())
        return float(self.equations.inertia.kinetic_energy(k) + potential_energy(ya[:3], self.params))
