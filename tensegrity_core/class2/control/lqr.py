"""The linearised class-2 dynamics and the discrete-time LQR gains of the tracking law.

State ``x = (rho1, rho2, beta, rho1', rho2', beta')`` [m, m, rad, m/s, m/s, rad/s], input
``u = (f1, f2)`` [N] (tensile positive). About a reference ``(x_r, u_r)`` the error
``e = x - x_r`` obeys ``e' = A e + B (u - u_r)`` with ``A = d(x')/dx`` from the model's
analytic Jacobian (:func:`~tensegrity_core.class2.rhs_jacobian`) and
``B = [0; -M^-1 E]``, ``E = [[1, 0], [0, 1], [0, 0]]`` (the generalised force on rho_i is
``-f_i``). The state is augmented by the integral ``z`` of the end-effector error,
``z' = D(q) - D_r ~ J_D e_q`` with ``J_D = dD/dq = [[1, 0, -L sin b], [0, 0, L cos b]]``,
so that a constant unmodelled load leaves no settled error of D.

The controller is sampled (evaluated at ``t_k``, output held for one period ``dt``), so the
augmented pair is discretised exactly for a zero-order hold (``expm`` of the block
matrix ``[[A, B], [0, 0]] dt``) and the gain comes from the discrete algebraic Riccati
equation (``scipy.linalg.solve_discrete_are``). The weights are Bryson's rule on physical
scales (:class:`LQRWeights`): an error of one scale costs as much as a force of one
force scale.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any, Final, TypeAlias

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2 import mass_matrix, rhs_jacobian
from tensegrity_core.class2.control.errors import SINGULAR_PATH, PlanningError
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import ParameterError

#: Size of the augmented state ``(q, qdot, z)``.
AUGMENTED: Final = 8
_E: Final = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])

#: A short vector of floats: ``q`` (rho1, rho2, beta) or forces ``(f1, f2)``.
Vector: TypeAlias = Sequence[float] | NDArray[np.float64]
#: A pair of matrices, e.g. ``(A, B)`` of ``x' = A x + B u``.
MatrixPair: TypeAlias = tuple[NDArray[np.float64], NDArray[np.float64]]


def linearize(q: ArrayLike, qdot: ArrayLike, f: Vector, params: Class2Params = PAPER_PARAMS) -> MatrixPair:
    """``(A, B)`` of ``x' = A x + B u`` about the state ``(q, qdot)`` and forces ``f`` [N]:
    ``A`` (6, 6) from the model's analytic Jacobian, ``B`` (6, 2) = ``[0; -M^-1 E]``."""
    q, qdot = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    A = rhs_jacobian(q, qdot, float(f[0]), float(f[1]), params)
    B = np.zeros((6, 2))
    B[3:] = -np.linalg.solve(mass_matrix(q, params), _E)
    return A, B


def end_effector_jacobian(q: Vector, L: float) -> NDArray[np.float64]:
    """``dD/dq`` (2, 3) of ``D = (rho1 + L cos beta, L sin beta)`` [m/m, m/rad]."""
    sb, cb = math.sin(float(q[2])), math.cos(float(q[2]))
    return np.array([[1.0, 0.0, -L * sb], [0.0, 0.0, L * cb]])


def augment(A: NDArray[np.float64], B: NDArray[np.float64], q: Vector, L: float) -> MatrixPair:
    """The pair with the integral of the end-effector error appended (8 states)."""
    Aa = np.zeros((AUGMENTED, AUGMENTED))
    Aa[:6, :6] = A
    Aa[6:, :3] = end_effector_jacobian(q, L)
    Ba = np.zeros((AUGMENTED, 2))
    Ba[:6] = B
    return Aa, Ba


def discretize(A: NDArray[np.float64], B: NDArray[np.float64], dt: float) -> MatrixPair:
    """Exact zero-order-hold discretisation ``(Ad, Bd)`` of ``x' = A x + B u`` over ``dt`` [s]."""
    n, m = B.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n] = A * dt
    block[:n, n:] = B * dt
    E = scipy.linalg.expm(block)
    return E[:n, :n], E[:n, n:]


@dataclass(frozen=True)
class LQRWeights:
    """Scales of Bryson's rule [SI]: the cost is ``sum |e_D|^2/position^2 +
    |e_D'|^2/velocity^2 + |e_rho|^2/length^2 + |e_rho'|^2/rate^2 + |z|^2/integral^2 +
    |u - u_r|^2/force^2`` over the samples.

    ``position`` [m] and ``velocity`` [m/s] weigh the end-effector's error (what a user
    asks for); ``length`` [m] and ``rate`` [m/s] the actuators' (a light regulariser: D does
    not see rho2 directly); ``integral`` [m s] the integral of D's error; ``force`` [N] the
    feedback force. Smaller scales mean a faster, stiffer loop needing larger forces.
    """

    position: float = 0.01
    velocity: float = 0.1
    length: float = 0.05
    rate: float = 0.5
    integral: float = 0.01
    force: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ParameterError(f"LQR weight scale {f.name} must be a finite number > 0, got {v!r}")

    def matrices(self, q: Vector, L: float) -> MatrixPair:
        """``(Q, R)``, (8, 8) and (2, 2), at the configuration ``q``."""
        JD = end_effector_jacobian(q, L)
        DtD = JD.T @ JD
        rho = np.diag([1.0, 1.0, 0.0])
        Q = np.zeros((AUGMENTED, AUGMENTED))
        Q[:3, :3] = DtD / self.position**2 + rho / self.length**2
        Q[3:6, 3:6] = DtD / self.velocity**2 + rho / self.rate**2
        Q[6:, 6:] = np.eye(2) / self.integral**2
        return Q, np.eye(2) / self.force**2


@dataclass(frozen=True)
class Gain:
    """A designed gain: ``u = u_r - K (x - x_r, z)``; ``poles`` the eigenvalues of the
    closed discrete loop ``Ad - Bd K`` (all inside the unit circle)."""

    K: NDArray[np.float64]
    poles: NDArray[np.inexact[Any]]
    dt: float

    @property
    def continuous_poles(self) -> NDArray[np.complex128]:
        """The poles as continuous-time rates ``log(z)/dt`` [1/s] (real part < 0: decaying)."""
        rates: NDArray[np.complex128] = np.log(self.poles.astype(complex)) / self.dt
        return rates


#: The default scales (a module-level instance: a frozen value shared as a default argument).
DEFAULT_WEIGHTS: Final = LQRWeights()


def design_gain(q: Vector, qdot: Vector, f: Vector, params: Class2Params, weights: LQRWeights, dt: float) -> Gain:
    """The discrete LQR gain (2, 8) for the loop sampled every ``dt`` [s], linearised about
    the reference state ``(q, qdot)`` with reference forces ``f`` [N]. A state where the loop
    has no stabilising gain (on or at a singular set, where the linearisation is not finite
    or the Riccati equation has no solution) raises PlanningError (code SINGULAR_PATH)."""
    A, B = linearize(q, qdot, f, params)
    Ad, Bd = discretize(*augment(A, B, q, params.L), dt)
    Q, R = weights.matrices(q, params.L)
    at = f"rho = ({float(q[0]):.4g}, {float(q[1]):.4g}) m, beta = {float(q[2]):.4g} rad"
    if not all(np.all(np.isfinite(m)) for m in (Ad, Bd, Q)):
        raise PlanningError(f"no feedback gain at {at}: the linearised dynamics are not finite there "
                            "(a singular configuration)", code=SINGULAR_PATH)
    try:
        P = scipy.linalg.solve_discrete_are(Ad, Bd, Q, R)
    except np.linalg.LinAlgError as err:
        raise PlanningError(f"no stabilising feedback gain at {at} (a singular configuration): {err}",
                            code=SINGULAR_PATH) from None
    K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
    return Gain(K, np.linalg.eigvals(Ad - Bd @ K), float(dt))
