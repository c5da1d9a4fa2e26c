"""The equations of motion in matrix form: validated functions that broadcast over states.

Each takes ``q`` (and ``qdot``) with trailing dimension 3 and broadcasts over the leading
ones; states with lambda1 or lambda2 below ``lambda_min L`` raise
:class:`~tensegrity_core.errors.SingularityError` (naming the first offending state), states
that do not exist :class:`~tensegrity_core.errors.DomainError`. They are thin views of the
kernel (:mod:`.kinematics`, :mod:`.effects`, :mod:`.inertia`) for analysis, control design and
tests; simulations use :class:`~tensegrity_core.class2.dynamics.equations.Class2Dynamics`
or the scene simulator, which compose the same kernel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.effects import Damping, Springs, stiffness_matrix
from tensegrity_core.class2.dynamics.equations import Class2Dynamics, require_finite
from tensegrity_core.class2.dynamics.inertia import Inertia
from tensegrity_core.class2.dynamics.kinematics import Kinematics, kinematics_array
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL, check_lambda_min
from tensegrity_core.class2.dynamics.springs import spring_jacobians, squared_length_derivatives
from tensegrity_core.class2.energy import potential_energy
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import DomainError


def _as_state(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise DomainError(f"trailing dimension of {name} must be 3 (rho1, rho2, beta), got shape {arr.shape}")
    return arr


def _context(q: NDArray[np.float64], qdot: NDArray[np.float64] | None, params: Class2Params,
             lambda_min: float) -> Kinematics[NDArray[np.float64]]:
    limit = check_lambda_min(lambda_min) * params.L
    return kinematics_array(params.L, q, np.zeros_like(q) if qdot is None else qdot, limit)


def spring_vectors(q: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                   lambda_min: float = LAMBDA_MIN_REL) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Node-difference vectors of the springs and their Jacobians.

    Returns ``(d, J)`` with ``d`` of shape ``(..., 4, 2)`` [m] (second node minus first, in
    :data:`~tensegrity_core.class2.geometry.SPRINGS` order CD, DE, EF, BE) and ``J = dd/dq``
    of shape ``(..., 4, 2, 3)``.
    """
    k = _context(_as_state("q", q), None, params, lambda_min)
    d, _, _ = squared_length_derivatives(params.L, k)
    return d, spring_jacobians(params.L, k)


def mass_matrix(q: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """Mass matrix ``M(q)``, shape ``(..., 3, 3)`` [kg, kg m, kg m^2]; symmetric positive definite."""
    qa = _as_state("q", q)
    M = Inertia(params).mass_matrix(_context(qa, None, params, lambda_min))
    return require_finite("mass_matrix", M, {"q": qa})


def velocity_terms(q: ArrayLike, qdot: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                   lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """Coriolis/centrifugal terms ``C(q, qdot)`` [N, N, N m] (``C_i = Gamma_ijk qdot_j qdot_k``)."""
    qa, qdota = np.broadcast_arrays(_as_state("q", q), _as_state("qdot", qdot))
    C = Inertia(params).velocity_terms(_context(qa, qdota, params, lambda_min))
    return require_finite("velocity_terms", C, {"q": qa, "qdot": qdota})


def damping_matrix(q: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                   lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """Damping matrix ``H(q) = sum_j c_j grad L_j grad L_j^T``, shape ``(..., 3, 3)``; symmetric PSD.

    The damper force on the coordinates is ``H(q) qdot`` [N, N, N m]; the dissipated power is
    ``qdot^T H qdot = sum c_j Ldot_j^2`` = twice the Rayleigh function.
    """
    qa = _as_state("q", q)
    H = Damping(params).matrix(_context(qa, None, params, lambda_min))
    return require_finite("damping_matrix", H, {"q": qa})


def potential_gradient(q: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                       lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """``dU/dq`` [N, N, N m] = the paper's W without the actuator forces (corrected Eqs. A.16-A.18)."""
    qa = _as_state("q", q)
    Q = Springs(params).force(_context(qa, None, params, lambda_min))
    out = -np.stack(np.broadcast_arrays(*Q), -1)
    return require_finite("potential_gradient", out, {"q": qa})


def potential_hessian(q: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                      lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """Hessian of the potential energy ``d^2U/dq^2`` (..., 3, 3) [N/m, N, N m]."""
    qa = _as_state("q", q)
    K = stiffness_matrix(Springs(params).stiffness(_context(qa, None, params, lambda_min)))
    return require_finite("potential_hessian", K, {"q": qa})


def generalized_forces(q: ArrayLike, qdot: ArrayLike, f1: ArrayLike = 0.0, f2: ArrayLike = 0.0,
                       params: Class2Params = PAPER_PARAMS, *,
                       lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """Non-conservative generalised forces ``f_e = -H(q) qdot - (f1, f2, 0)`` [N, N, N m].

    The paper's Eqs. (48-50) with a damping coefficient per spring; tensile ``f_i > 0``.
    """
    qa, qdota = _as_state("q", q), _as_state("qdot", qdot)
    shape = np.broadcast_shapes(qa.shape[:-1], qdota.shape[:-1])
    qa, qdota = np.broadcast_to(qa, shape + (3,)), np.broadcast_to(qdota, shape + (3,))
    with np.errstate(invalid="ignore", over="ignore"):     # non-finite input is reported below
        Q = Damping(params).force(_context(qa, qdota, params, lambda_min))
        F = np.stack(np.broadcast_arrays(np.asarray(f1, dtype=float), np.asarray(f2, dtype=float),
                                         np.zeros(shape)), -1)
        out = np.stack(np.broadcast_arrays(*Q), -1) - F
    return require_finite("generalized_forces", out, {"qdot": qdota, "f1": f1, "f2": f2})


def kinetic_energy(q: ArrayLike, qdot: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                   lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """Kinetic energy of the four struts ``T = 1/2 qdot^T M qdot`` [J] (equals the paper's Eq. 46)."""
    qa, qdota = np.broadcast_arrays(_as_state("q", q), _as_state("qdot", qdot))
    T = Inertia(params).kinetic_energy(_context(qa, qdota, params, lambda_min))
    return require_finite("kinetic_energy", T, {"q": qa, "qdot": qdota})


def mechanical_energy(q: ArrayLike, qdot: ArrayLike, params: Class2Params = PAPER_PARAMS, *,
                      lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """``T + U`` [J]; conserved when the dampers and actuator forces are zero."""
    return kinetic_energy(q, qdot, params, lambda_min=lambda_min) + potential_energy(q, params)


def acceleration(q: ArrayLike, qdot: ArrayLike, f1: ArrayLike = 0.0, f2: ArrayLike = 0.0,
                 params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """``qddot`` [m/s^2, m/s^2, rad/s^2] from the equations of motion; broadcasts over states."""
    return Class2Dynamics(params, lambda_min=lambda_min).acceleration_array(
        _as_state("q", q), _as_state("qdot", qdot), f1, f2)


def rhs_jacobian(q: ArrayLike, qdot: ArrayLike, f1: float = 0.0, f2: float = 0.0,
                 params: Class2Params = PAPER_PARAMS, *, dforce_dy: ArrayLike | None = None,
                 lambda_min: float = LAMBDA_MIN_REL) -> NDArray[np.float64]:
    """``d(dy/dt)/dy`` (6, 6) at one state ``y = (q, qdot)``
    (:meth:`~tensegrity_core.class2.dynamics.equations.Class2Dynamics.jacobian`).

    ``dforce_dy``: optional (2, 6) array of ``d(f1, f2)/dy`` for state-dependent forces.
    """
    qa, qdota = _as_state("q", q), _as_state("qdot", qdot)
    if qa.shape != (3,) or qdota.shape != (3,):
        raise DomainError(f"rhs_jacobian takes one state: q and qdot of shape (3,), got {qa.shape} and {qdota.shape}")
    return Class2Dynamics(params, lambda_min=lambda_min).jacobian(0.0, np.concatenate([qa, qdota]), f1, f2,
                                                                  dforce_dy=dforce_dy)
