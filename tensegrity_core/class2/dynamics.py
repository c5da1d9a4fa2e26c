"""Lagrangian equations of motion of the class-2 mechanism, in closed form.

Coordinates and units: ``q = (rho1, rho2, beta)`` [m, m, rad] as in
:mod:`tensegrity_core.class2.geometry`; ``qdot`` [m/s, m/s, rad/s]; actuator forces
``f1, f2`` [N], **positive = tensile** (the actuator pulls its two nodes together; the
generalised force on ``rho_i`` is ``-f_i``, the paper's Eq. 48). Energies in J.

Model: struts AE, BF, BD, CE are thin rods of mass ``m``, ``I = m L^2/12``; springs are
massless, linear, zero free length, with axial dampers (``c_j`` on the spring of stiffness
``k_j``: EF k1/c1, DE k2/c2, CD k3/c3, BE k4/c4); actuators are massless. The equations::

    M(q) qddot + C(q, qdot) + H(q) qdot + grad U(q) + (f1, f2, 0) = 0

were derived from first principles in
:mod:`tensegrity_core.class2.derivation.derive_dynamics` (sympy), which also proves the
closed forms below. With ``s = rho1 + rho2``, ``lambda1 = sqrt(4L^2 - s^2)``,
``lambda2 = sqrt(L^2 - rho1^2)``::

    mu = m/2 + 2 m L^2 / (3 lambda1^2)         (inertia of the AE-CE pair along s)
    M = [[m + mu + m L^2/(3 lambda2^2), mu, -m L sin(beta)/2],
         [mu,                          mu, 0               ],
         [-m L sin(beta)/2,            0,  m L^2/3         ]]
    C = (kappa1 sdot^2 + kappa2 rho1dot^2 - m L cos(beta) betadot^2 / 2,  kappa1 sdot^2,  0)
    kappa1 = 2 m L^2 s / (3 lambda1^4),  kappa2 = m L^2 rho1 / (3 lambda2^4)

Springs and dampers enter through the vector ``d_j`` between the spring's two nodes and its
Jacobian ``J_j = dd_j/dq``: ``grad U = sum k_j J_j^T d_j`` and the damping force
``H qdot = sum c_j (d_j . ddot_j) / |d_j|^2 J_j^T d_j``, i.e. ``H = sum c_j grad L_j grad L_j^T``.
A zero-length spring has no direction; the damper term uses ``|d_j|^2 + (eps L)^2`` with
``eps = 1e-12`` in the denominator, which changes nothing measurable for ``|d_j| > 1e-9 L``
and makes the force continuous (it is bounded by ``c_j |ddot_j|`` in any case).

The mass matrix solve exploits ``M22 = M12`` and ``M23 = 0``: the Schur complement of the
``rho1`` row is ``m + m L^2/(3 lambda2^2) - 3 m sin^2(beta)/4 >= m/4``, so ``M`` is never
singular inside the domain. It does grow like ``1/lambda^2`` near ``lambda1 = 0`` (struts AE
and CE flat on the X axis) and ``lambda2 = 0`` (strut BF flat), where the coordinates
``q`` break down; every function raises :class:`SingularityError` (``kind`` "lambda1" or
"lambda2", ``distance`` = the lambda [m], ``limit`` = ``lambda_min * L``) when a lambda is below
``lambda_min * L`` and :class:`DomainError` when the configuration does not exist
(``lambda^2 < 0``). ``lambda_min`` defaults to :data:`LAMBDA_MIN_REL`: rounding ``s`` leaves a
relative error of about ``1e-15 (L/lambda)^2`` in ``M``, i.e. ``1e-7`` at the default limit.

Negative actuator lengths are accepted: the formulas are analytic for ``|rho1| < L``,
``|s| < 2L`` and the unconstrained equations do cross ``rho = 0`` (a real actuator cannot;
stop the integration with :mod:`tensegrity_core.class2.dynamics_events`).

All module-level functions broadcast over leading dimensions of ``q`` and ``qdot``;
:class:`Class2Dynamics` adds a scalar fast path (pure ``math``) and a batch path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tensegrity_core.class2.energy import potential_energy
from tensegrity_core.class2.geometry import SPRINGS
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import DomainError, ParameterError, SingularityError

#: Default refusal threshold for lambda1, lambda2, relative to L.
LAMBDA_MIN_REL = 1e-4
#: Regularisation of the damper direction at zero spring length, relative to L.
ZERO_LENGTH_REL = 1e-12


# ---------------------------------------------------------------------------------------
# Validation of states
# ---------------------------------------------------------------------------------------

def _singular_message(kind: str, lam: float, limit: float, rho1: float, rho2: float, L: float) -> str:
    if kind == "lambda1":
        where = (f"rho1 + rho2 = {rho1 + rho2:.9g} m is within {abs(2 * L - abs(rho1 + rho2)):.3g} m of "
                 f"+-2L = +-{2 * L:g} m (struts AE and CE flat)")
    else:
        where = f"rho1 = {rho1:.9g} m is within {abs(L - abs(rho1)):.3g} m of +-L = +-{L:g} m (strut BF flat)"
    return (f"{kind} = {lam:.3g} m is below the limit {limit:.3g} m: {where}; the mass matrix grows "
            f"like 1/{kind}^2 there and is not trusted")


def _absent_message(kind: str, rho1: float, rho2: float, L: float) -> str:
    if kind == "lambda1":
        return (f"configuration does not exist: |rho1 + rho2| = {abs(rho1 + rho2):.9g} m exceeds 2L = "
                f"{2 * L:g} m (struts AE and CE cannot meet at E)")
    return f"configuration does not exist: |rho1| = {abs(rho1):.9g} m exceeds L = {L:g} m (node F cannot reach the Y axis)"


def _check_lambda_sq(kind: str, lam_sq: float, limit: float, rho1: float, rho2: float, L: float) -> float:
    """Scalar check; returns lambda. Raises DomainError / SingularityError."""
    if lam_sq >= limit * limit:
        return math.sqrt(lam_sq)
    if lam_sq >= 0.0:
        lam = math.sqrt(lam_sq)
        raise SingularityError(_singular_message(kind, lam, limit, rho1, rho2, L),
                               kind=kind, distance=lam, limit=limit)
    if lam_sq < 0.0:
        raise DomainError(_absent_message(kind, rho1, rho2, L),
                          distance=math.sqrt(-lam_sq))
    raise DomainError(f"state is not finite: rho1 = {rho1!r}, rho2 = {rho2!r}")


def _check_lambda_sq_array(kind: str, lam_sq: np.ndarray, limit: float, rho1, rho2, L: float) -> np.ndarray:
    """Array check; returns lambda. Reports the first offending state."""
    ok = lam_sq >= limit * limit
    if not np.all(ok):
        idx = np.unravel_index(np.argmin(np.where(ok, 1, 0)), np.shape(lam_sq)) if np.ndim(lam_sq) else ()
        where = f" (state {tuple(int(i) for i in idx)})" if idx else ""
        r1 = float(np.broadcast_to(rho1, np.shape(lam_sq))[idx])
        r2 = float(np.broadcast_to(rho2, np.shape(lam_sq))[idx])
        try:
            _check_lambda_sq(kind, float(lam_sq[idx]), limit, r1, r2, L)
        except (SingularityError, DomainError) as err:
            err.args = (str(err) + where,)
            raise
    return np.sqrt(lam_sq)


def _as_state(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise DomainError(f"trailing dimension of {name} must be 3 (rho1, rho2, beta), got shape {arr.shape}")
    return arr


def _lambdas_checked(q: np.ndarray, params: Class2Params, lambda_min: float):
    """``(lambda1, lambda2)`` for an array of states, after the singularity checks."""
    L = params.L
    rho1, rho2 = q[..., 0], q[..., 1]
    s = rho1 + rho2
    limit = lambda_min * L
    lam1 = _check_lambda_sq_array("lambda1", (2.0 * L - s) * (2.0 * L + s), limit, rho1, rho2, L)
    lam2 = _check_lambda_sq_array("lambda2", (L - rho1) * (L + rho1), limit, rho1, rho2, L)
    return lam1, lam2


def _require_finite(name: str, result: np.ndarray, inputs: dict[str, object]) -> np.ndarray:
    if np.all(np.isfinite(result)):
        return result
    bad = [k for k, v in inputs.items() if not np.all(np.isfinite(np.asarray(v, dtype=float)))]
    raise DomainError(f"{name}: non-finite input {', '.join(bad) or '(overflow)'}")


# ---------------------------------------------------------------------------------------
# Spring vectors d_j, their Jacobians J_j = dd_j/dq and the Hessians of their components
# ---------------------------------------------------------------------------------------

def spring_vectors(q, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL):
    """Node-difference vectors of the springs and their Jacobians.

    Returns ``(d, J)`` with ``d`` of shape ``(..., 4, 2)`` [m] (second node minus first, in
    :data:`SPRINGS` order CD, DE, EF, BE) and ``J = dd/dq`` of shape ``(..., 4, 2, 3)``.
    The EF vector's y component ``lambda2 - lambda1/2`` is evaluated as
    ``(rho2 - rho1)(3 rho1 + rho2) / (4 lambda2 + 2 lambda1)``, free of cancellation.
    """
    q = _as_state("q", q)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    return _spring_vectors(q, lam1, lam2, params.L)


def _spring_vectors(q, lam1, lam2, L):
    rho1, rho2, beta = q[..., 0], q[..., 1], q[..., 2]
    s = rho1 + rho2
    h = 0.5 * (rho2 - rho1)
    e1 = s / lam1                      # -d lambda1 / d rho_i
    g2 = rho1 / lam2                   # -d lambda2 / d rho1
    lsb, lcb = L * np.sin(beta), L * np.cos(beta)
    zero, half = np.zeros_like(s), np.full_like(s, 0.5)
    ef_dy = (rho2 - rho1) * (3.0 * rho1 + rho2) / (4.0 * lam2 + 2.0 * lam1)
    d = np.stack([
        np.stack([lcb - rho2, lsb], -1),                   # CD
        np.stack([h - lcb, 0.5 * lam1 - lsb], -1),         # DE
        np.stack([-0.5 * s, ef_dy], -1),                   # EF
        np.stack([h, 0.5 * lam1], -1),                     # BE
    ], -2)
    rows = [
        ((zero, -1.0 + zero, -lsb), (zero, zero, lcb)),
        ((-half, half, lsb), (-0.5 * e1, -0.5 * e1, -lcb)),
        ((-half, -half, zero), (0.5 * e1 - g2, 0.5 * e1, zero)),
        ((-half, half, zero), (-0.5 * e1, -0.5 * e1, zero)),
    ]
    J = np.stack([np.stack([np.stack(r, -1) for r in spring], -2) for spring in rows], -3)
    return d, J


def _spring_hessians(q, lam1, lam2, L):
    """Second derivatives of the components of each ``d_j``, shape ``(..., 4, 2, 3, 3)``."""
    rho1, beta = q[..., 0], q[..., 2]
    eta1 = -4.0 * L**2 / lam1**3      # d^2 lambda1 / ds^2
    eta2 = -(L**2) / lam2**3          # d^2 lambda2 / d rho1^2
    lsb, lcb = L * np.sin(beta), L * np.cos(beta)
    out = np.zeros(np.shape(rho1) + (4, 2, 3, 3))
    out[..., 0, 0, 2, 2] = -lcb
    out[..., 0, 1, 2, 2] = -lsb
    out[..., 1, 0, 2, 2] = lcb
    out[..., 1, 1, :2, :2] = (0.5 * eta1)[..., None, None]
    out[..., 1, 1, 2, 2] = lsb
    out[..., 2, 1, :2, :2] = (-0.5 * eta1)[..., None, None]
    out[..., 2, 1, 0, 0] += eta2
    out[..., 3, 1, :2, :2] = (0.5 * eta1)[..., None, None]
    return out


def _coefficients(params: Class2Params):
    k = np.array([getattr(params, m.stiffness) for m in SPRINGS])
    c = np.array([getattr(params, m.damping) for m in SPRINGS])
    return k, c


# ---------------------------------------------------------------------------------------
# Matrix form (numpy, broadcasting)
# ---------------------------------------------------------------------------------------

def _inertia_terms(q, lam1, lam2, params: Class2Params):
    m, L = params.m, params.L
    mu = 0.5 * m + 2.0 * m * L**2 / (3.0 * lam1**2)
    b_f = m * L**2 / (3.0 * lam2**2)
    return mu, b_f


def mass_matrix(q, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """Mass matrix ``M(q)``, shape ``(..., 3, 3)`` [kg, kg m, kg m^2]; symmetric positive definite."""
    q = _as_state("q", q)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    mu, b_f = _inertia_terms(q, lam1, lam2, params)
    m, L = params.m, params.L
    m13 = -0.5 * m * L * np.sin(q[..., 2])
    zero = np.zeros_like(mu)
    rows = [(params.m + mu + b_f, mu, m13), (mu, mu, zero), (m13, zero, m * L**2 / 3.0 + zero)]
    return _require_finite("mass_matrix", np.stack([np.stack(r, -1) for r in rows], -2), {"q": q})


def velocity_terms(q, qdot, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """Coriolis/centrifugal terms ``C(q, qdot)`` [N, N, N m] (``C_i = Gamma_ijk qdot_j qdot_k``)."""
    q, qdot = _as_state("q", q), _as_state("qdot", qdot)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    m, L = params.m, params.L
    s = q[..., 0] + q[..., 1]
    sdot = qdot[..., 0] + qdot[..., 1]
    kappa1 = 2.0 * m * L**2 * s / (3.0 * lam1**4)
    kappa2 = m * L**2 * q[..., 0] / (3.0 * lam2**4)
    c2 = kappa1 * sdot**2
    c1 = c2 + kappa2 * qdot[..., 0] ** 2 - 0.5 * m * L * np.cos(q[..., 2]) * qdot[..., 2] ** 2
    out = np.stack([c1, c2, np.zeros_like(c1)], -1)
    return _require_finite("velocity_terms", out, {"q": q, "qdot": qdot})


def damping_matrix(q, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """Damping matrix ``H(q) = sum_j c_j grad L_j grad L_j^T``, shape ``(..., 3, 3)``; symmetric PSD.

    The damper force on the coordinates is ``H(q) qdot`` [N, N, N m]; the dissipated power is
    ``qdot^T H qdot = sum c_j Ldot_j^2`` = twice the Rayleigh function.
    """
    q = _as_state("q", q)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    d, J = _spring_vectors(q, lam1, lam2, params.L)
    g = np.einsum("...jac,...ja->...jc", J, d)                   # grad (|d_j|^2 / 2)
    _, c = _coefficients(params)
    w = c / (np.sum(d * d, -1) + (ZERO_LENGTH_REL * params.L) ** 2)
    return _require_finite("damping_matrix", np.einsum("...j,...jc,...je->...ce", w, g, g), {"q": q})


def potential_gradient(q, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """``dU/dq`` [N, N, N m] = the paper's W without the actuator forces (corrected Eqs. A.16-A.18)."""
    q = _as_state("q", q)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    d, J = _spring_vectors(q, lam1, lam2, params.L)
    k, _ = _coefficients(params)
    return _require_finite("potential_gradient", np.einsum("j,...jac,...ja->...c", k, J, d), {"q": q})


def _actuator_vector(f1, f2, shape) -> np.ndarray:
    f1 = np.broadcast_to(np.asarray(f1, dtype=float), shape)
    f2 = np.broadcast_to(np.asarray(f2, dtype=float), shape)
    return np.stack([f1, f2, np.zeros(shape)], -1)


def generalized_forces(q, qdot, f1=0.0, f2=0.0, params: Class2Params = PAPER_PARAMS, *,
                       lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """Non-conservative generalised forces ``f_e = -H(q) qdot - (f1, f2, 0)`` [N, N, N m].

    The paper's Eqs. (48-50) with a damping coefficient per spring; tensile ``f_i > 0``.
    """
    q, qdot = _as_state("q", q), _as_state("qdot", qdot)
    H = damping_matrix(q, params, lambda_min=lambda_min)
    shape = np.broadcast_shapes(q.shape[:-1], qdot.shape[:-1])
    out = -np.einsum("...ce,...e->...c", H, qdot) - _actuator_vector(f1, f2, shape)
    return _require_finite("generalized_forces", out, {"qdot": qdot, "f1": f1, "f2": f2})


def kinetic_energy(q, qdot, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL):
    """Kinetic energy of the four struts ``T = 1/2 qdot^T M qdot`` [J] (equals the paper's Eq. 46)."""
    q, qdot = _as_state("q", q), _as_state("qdot", qdot)
    lam1, lam2 = _lambdas_checked(q, params, lambda_min)
    mu, b_f = _inertia_terms(q, lam1, lam2, params)
    m, L = params.m, params.L
    v1, v2, vb = qdot[..., 0], qdot[..., 1], qdot[..., 2]
    t = 0.5 * (mu * (v1 + v2) ** 2 + (m + b_f) * v1**2 + m * L**2 / 3.0 * vb**2) \
        - 0.5 * m * L * np.sin(q[..., 2]) * v1 * vb
    return _require_finite("kinetic_energy", t, {"q": q, "qdot": qdot})


def mechanical_energy(q, qdot, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL):
    """``T + U`` [J]; conserved when the dampers and actuator forces are zero."""
    return kinetic_energy(q, qdot, params, lambda_min=lambda_min) + potential_energy(q, params)


def acceleration(q, qdot, f1=0.0, f2=0.0, params: Class2Params = PAPER_PARAMS, *,
                 lambda_min: float = LAMBDA_MIN_REL) -> np.ndarray:
    """``qddot`` [m/s^2, m/s^2, rad/s^2] from the equations of motion; broadcasts over states."""
    return _Constants(params, lambda_min).acceleration_array(
        _as_state("q", q), _as_state("qdot", qdot), f1, f2)


# ---------------------------------------------------------------------------------------
# Fast path: one arithmetic core shared by scalars (math) and arrays (numpy)
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Constants:
    """Parameter combinations used by the arithmetic core (computed once per model)."""

    params: Class2Params
    lambda_min: float

    def __post_init__(self) -> None:
        if not (isinstance(self.lambda_min, (int, float)) and 0.0 < self.lambda_min < 1.0):
            raise ParameterError(f"lambda_min must be a number in (0, 1) (relative to L), got {self.lambda_min!r}")
        p = self.params
        m, L = p.m, p.L
        values = dict(
            L=L, m=m, limit=self.lambda_min * L,
            k1=p.k1, k2=p.k2, k3=p.k3, k4=p.k4, c1=p.c1, c2=p.c2, c3=p.c3, c4=p.c4,
            eps2=(ZERO_LENGTH_REL * L) ** 2,
            half_m=0.5 * m, half_mL=0.5 * m * L, two_thirds_mL2=2.0 * m * L * L / 3.0,
            third_mL2=m * L * L / 3.0, inv_e=3.0 / (m * L * L), three_quarter_m=0.75 * m,
        )
        for name, value in values.items():
            object.__setattr__(self, "_" + name, value)

    def core(self, r1, r2, sb, cb, v1, v2, vb, f1, f2, lam1, lam2):
        """``qddot`` from plain arithmetic: works on floats and on numpy arrays alike."""
        L = self._L
        s = r1 + r2
        sd = v1 + v2
        e1 = s / lam1
        g2 = r1 / lam2
        h = 0.5 * (r2 - r1)
        hd = 0.5 * (v2 - v1)
        lsb = L * sb
        lcb = L * cb
        y_e = 0.5 * lam1
        y_ed = -0.5 * e1 * sd
        eps2 = self._eps2
        # Each spring: node-difference vector (dx, dy), its rate, and the axial force
        # coefficient phi = k + c (d . ddot)/|d|^2 (force vector = phi * d).
        dx = lcb - r2                                        # CD (k3, c3)
        dy = lsb
        phi = self._k3 + self._c3 * (dx * (-lsb * vb - v2) + dy * lcb * vb) / (dx * dx + dy * dy + eps2)
        fx3, fy3 = phi * dx, phi * dy
        dx = h - lcb                                         # DE (k2, c2)
        dy = y_e - lsb
        phi = self._k2 + self._c2 * (dx * (hd + lsb * vb) + dy * (y_ed - lcb * vb)) / (dx * dx + dy * dy + eps2)
        fx4, fy4 = phi * dx, phi * dy
        dx = -0.5 * s                                        # EF (k1, c1)
        dy = (r2 - r1) * (3.0 * r1 + r2) / (4.0 * lam2 + 2.0 * lam1)
        phi = self._k1 + self._c1 * (-0.5 * dx * sd + dy * (0.5 * e1 * sd - g2 * v1)) / (dx * dx + dy * dy + eps2)
        fx7, fy7 = phi * dx, phi * dy
        phi = self._k4 + self._c4 * (h * hd + y_e * y_ed) / (h * h + y_e * y_e + eps2)   # BE (k4, c4)
        # Generalised spring + damper forces Q = sum J_j^T (phi_j d_j); DE and BE share the
        # rho-columns of their Jacobians.
        fx = fx4 + phi * h
        fy = fy4 + phi * y_e
        q1 = -0.5 * (fx + e1 * fy + fx7) + (0.5 * e1 - g2) * fy7
        q2 = -fx3 + 0.5 * (fx - e1 * fy - fx7 + e1 * fy7)
        q3 = lcb * (fy3 - fy4) + lsb * (fx4 - fx3)
        # Inertia and velocity terms.
        il1 = 1.0 / (lam1 * lam1)
        il2 = 1.0 / (lam2 * lam2)
        mu = self._half_m + self._two_thirds_mL2 * il1
        b_f = self._third_mL2 * il2
        c2 = self._two_thirds_mL2 * s * il1 * il1 * sd * sd
        c1 = c2 + self._third_mL2 * r1 * il2 * il2 * v1 * v1 - self._half_mL * cb * vb * vb
        rhs1 = -(c1 + q1 + f1)
        rhs2 = -(c2 + q2 + f2)
        rhs3 = -q3
        # Structured solve: M22 = M12 = mu, M23 = 0.
        m13 = -self._half_mL * sb
        a1 = (rhs1 - rhs2 - m13 * rhs3 * self._inv_e) / (self._m + b_f - self._three_quarter_m * sb * sb)
        return a1, rhs2 / mu - a1, (rhs3 - m13 * a1) * self._inv_e

    def acceleration_scalar(self, r1, r2, beta, v1, v2, vb, f1, f2):
        L = self._L
        s = r1 + r2
        lam1 = _check_lambda_sq("lambda1", (2.0 * L - s) * (2.0 * L + s), self._limit, r1, r2, L)
        lam2 = _check_lambda_sq("lambda2", (L - r1) * (L + r1), self._limit, r1, r2, L)
        out = self.core(r1, r2, math.sin(beta), math.cos(beta), v1, v2, vb, f1, f2, lam1, lam2)
        if math.isfinite(out[0] + out[1] + out[2]):
            return out
        raise DomainError(
            "acceleration: non-finite input in "
            f"(rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot, f1, f2) = {(r1, r2, beta, v1, v2, vb, f1, f2)!r}")

    def acceleration_array(self, q, qdot, f1, f2):
        lam1, lam2 = _lambdas_checked(q, self.params, self.lambda_min)
        beta = q[..., 2]
        a = self.core(q[..., 0], q[..., 1], np.sin(beta), np.cos(beta), qdot[..., 0], qdot[..., 1],
                      qdot[..., 2], np.asarray(f1, dtype=float), np.asarray(f2, dtype=float), lam1, lam2)
        out = np.stack(np.broadcast_arrays(*a), -1)
        return _require_finite("acceleration", out, {"q": q, "qdot": qdot, "f1": f1, "f2": f2})


class Class2Dynamics:
    """The equations of motion for one parameter set, with fast scalar and batch paths.

    State ``y = (rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot)`` [m, m, rad, m/s, m/s, rad/s];
    inputs ``f1, f2`` [N], tensile positive. ``lambda_min`` (relative to ``L``) is the
    refusal threshold for lambda1 and lambda2 (see the module docstring).
    """

    def __init__(self, params: Class2Params = PAPER_PARAMS, *, lambda_min: float = LAMBDA_MIN_REL):
        if not isinstance(params, Class2Params):
            raise ParameterError(f"params must be a Class2Params, got {type(params).__name__}")
        self._k = _Constants(params, lambda_min)

    @property
    def params(self) -> Class2Params:
        return self._k.params

    @property
    def lambda_min(self) -> float:
        return self._k.lambda_min

    def acceleration_scalar(self, rho1: float, rho2: float, beta: float, rho1_dot: float, rho2_dot: float,
                            beta_dot: float, f1: float = 0.0, f2: float = 0.0) -> tuple[float, float, float]:
        """``qddot`` for one state from plain floats (pure ``math``, no numpy)."""
        return self._k.acceleration_scalar(rho1, rho2, beta, rho1_dot, rho2_dot, beta_dot, f1, f2)

    def rhs(self, t: float, y, f1: float = 0.0, f2: float = 0.0) -> np.ndarray:
        """``dy/dt`` for ``scipy.integrate.solve_ivp``: ``y`` of shape (6,), constant forces.

        For state- or time-dependent forces wrap it: ``lambda t, y: dyn.rhs(t, y, f1(t, y), f2(t, y))``.
        """
        r1, r2, b, v1, v2, vb = y.tolist() if isinstance(y, np.ndarray) else y
        a1, a2, a3 = self._k.acceleration_scalar(r1, r2, b, v1, v2, vb, f1, f2)
        return np.array((v1, v2, vb, a1, a2, a3))

    def acceleration_batch(self, states, f1=0.0, f2=0.0) -> np.ndarray:
        """``qddot`` for states of shape ``(N, 6)`` and forces broadcastable to ``(N,)`` -> ``(N, 3)``."""
        y = np.asarray(states, dtype=float)
        if y.ndim < 1 or y.shape[-1] != 6:
            raise DomainError(f"trailing dimension of states must be 6 (q, qdot), got shape {y.shape}")
        return self._k.acceleration_array(y[..., :3], y[..., 3:], f1, f2)

    def jacobian(self, t: float, y, f1: float = 0.0, f2: float = 0.0, dforce_dy=None) -> np.ndarray:
        """Analytic ``d(dy/dt)/dy``, shape (6, 6), for implicit integrators (Radau, BDF).

        ``dforce_dy`` (2, 6): derivatives of ``(f1, f2)`` with respect to ``y`` when the
        forces depend on the state (feedback laws, the paper's ``f_i = 10 rho_i t``).
        """
        from tensegrity_core.class2.dynamics_jacobian import rhs_jacobian

        y = np.asarray(y, dtype=float)
        return rhs_jacobian(y[:3], y[3:], f1, f2, self.params, dforce_dy=dforce_dy, lambda_min=self.lambda_min)

    def energy(self, y) -> float:
        """Mechanical energy ``T + U`` [J] of state ``y`` (6,)."""
        y = np.asarray(y, dtype=float)
        return float(mechanical_energy(y[:3], y[3:], self.params, lambda_min=self.lambda_min))
