"""Forward kinematics of the class-2 mechanism: the stable equilibrium for locked actuators.

With the actuator lengths ``rho1, rho2`` [m] locked, node D can only turn about B, and the
potential energy is a sinusoid in beta (see :mod:`tensegrity_core.class2.energy`)::

    U(beta) = const - (1/2) (d L cos beta + e L sin beta),
    d = (2 k3 + k2) rho2 - k2 rho1,   e = k2 lambda1 >= 0,   R = hypot(d, e).

Its only minimum is ``beta = atan2(e, d)`` in ``[0, pi]`` -- the root of the paper's Eq. (10)
chosen by energy; the plain ``arctan`` of Eq. (10) returns the maximum ``beta - pi``
whenever ``d < 0``. There ``cos beta = d / R``, ``sin beta = e / R`` and
``d2U/dbeta2 = L R / 2 > 0``. On the configuration domain ``R > 0`` (proof in
docs/class2.md), so the equilibrium is unique and stable; it leaves the paper's range
``[0, pi/2]`` exactly when ``d < 0``. The end-effector is ``D = (rho1 + L cos beta, L sin beta)``
(Eqs. 3-4).

Angles are in radians from the +X axis, counter-clockwise; lengths in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Final, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.energy import potential_energy
from tensegrity_core.class2.geometry import check_actuator_lengths, node_positions
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.class2.singularities.distances import nearest_singularity
from tensegrity_core.errors import DomainError, SingularityError

if TYPE_CHECKING:
    from _typeshed import ConvertibleToFloat

#: Angular tolerance [rad] of the range test ``0 <= beta <= pi/2`` (round-off on the fold).
BETA_RANGE_TOL: Final = 1e-12
#: ``R / ((2 k3 + 2 k2) L)`` below which beta is reported indeterminate (a = b = 0).
DEGENERATE_LIMIT: Final = 1e-12

_HALF_PI: Final = 0.5 * math.pi


def as_real(name: str, value: ConvertibleToFloat) -> float:
    """``value`` as a finite float, or :class:`DomainError` naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise DomainError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise DomainError(f"{name} must be finite, got {v!r}")
    return v


def in_paper_range(beta: float) -> bool:
    """``0 <= beta <= pi/2`` up to :data:`BETA_RANGE_TOL` (the paper's range, Sect. 2)."""
    return -BETA_RANGE_TOL <= beta <= _HALF_PI + BETA_RANGE_TOL


def range_note(beta: float) -> str:
    """The note FK attaches to an equilibrium outside the paper's range ('' inside)."""
    if in_paper_range(beta):
        return ""
    return (
        "no stable equilibrium in the paper's range [0, pi/2]: "
        f"the minimum is at beta = {beta:.6g} rad"
    )


@dataclass(frozen=True)
class FKResult:
    """The stable equilibrium of the mechanism for locked actuator lengths.

    Attributes
    ----------
    rho1, rho2 : actuator lengths [m].
    beta : angle of strut BD from +X [rad], the energy minimum, in [0, pi].
    alpha : angle of strut AE from +X [rad], in [0, pi/2] (Eq. 1).
    x, y : end-effector D [m] (Eqs. 3-4).
    stiffness_beta : d2U/dbeta2 at beta [J/rad^2] (= L R / 2 for the closed form).
    stable : ``stiffness_beta > 0``.
    in_paper_range : ``0 <= alpha, beta <= pi/2``.
    singularity_distance : distance to the nearest singular set (dimensionless, actuator
        plane / L; see :mod:`tensegrity_core.class2.singularities`); the conditioning
        measure the ROS nodes warn on. ``jacobian_cond`` is the other one.
    nearest_singularity : name of that set.
    note : '' or why the answer needs attention (e.g. outside the paper's range).
    """

    rho1: float
    rho2: float
    beta: float
    alpha: float
    x: float
    y: float
    stiffness_beta: float
    stable: bool
    in_paper_range: bool
    singularity_distance: float
    nearest_singularity: str
    note: str
    params: Class2Params = field(default=PAPER_PARAMS, repr=False, compare=False)

    @property
    def q(self) -> tuple[float, float, float]:
        """Generalised coordinates ``(rho1, rho2, beta)``."""
        return (self.rho1, self.rho2, self.beta)

    @cached_property
    def nodes(self) -> NDArray[np.float64]:
        """Node positions A..F, shape (6, 2) [m]."""
        return node_positions(self.q, self.params)

    @cached_property
    def jacobian(self) -> NDArray[np.float64]:
        """``dD/drho`` (2x2, rows x, y; columns rho1, rho2); raises on the lambda1 set."""
        return jacobian_D_rho(self.rho1, self.rho2, self.params)

    @property
    def jacobian_cond(self) -> float:
        """2-norm condition number of :attr:`jacobian` (inf on a singular set)."""
        try:
            return float(np.linalg.cond(self.jacobian))
        except SingularityError:
            return math.inf

    def as_dict(self) -> dict[str, Any]:
        """Plain-data view (for JSON): every field but ``params``, plus ``nodes``."""
        return {
            "rho1": self.rho1, "rho2": self.rho2, "beta": self.beta, "alpha": self.alpha,
            "x": self.x, "y": self.y, "stiffness_beta": self.stiffness_beta,
            "stable": self.stable, "in_paper_range": self.in_paper_range,
            "singularity_distance": self.singularity_distance,
            "nearest_singularity": self.nearest_singularity, "note": self.note,
            "nodes": {n: [float(v) for v in p] for n, p in zip("ABCDEF", self.nodes)},
        }


def _beta_terms(rho1: float, rho2: float, params: Class2Params) -> tuple[float, float, float]:
    """``(d, e, lambda1)`` for a validated configuration (see the module docstring)."""
    L, k2 = params.L, params.k2
    s = rho1 + rho2
    lam1 = math.sqrt((2.0 * L - s) * (2.0 * L + s))
    return (2.0 * params.k3 + k2) * rho2 - k2 * rho1, k2 * lam1, lam1


def _check_determinate(R: float, rho1: float, rho2: float, params: Class2Params) -> None:
    scale = (2.0 * params.k3 + 2.0 * params.k2) * params.L
    if R <= DEGENERATE_LIMIT * scale:
        raise SingularityError(
            f"every beta is an equilibrium at rho1 = {rho1:g} m, rho2 = {rho2:g} m: the "
            "coefficients of U(beta) vanish (lambda1 = 0 and (2 k3 + k2) rho2 = k2 rho1), so "
            "the forward kinematics has no unique answer",
            kind="indeterminate_beta", distance=R / scale, limit=DEGENERATE_LIMIT,
        )


def forward_kinematics(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> FKResult:
    """Closed-form FKP: the energy-minimising beta (Eq. 10) and node D (Eqs. 3-4).

    Raises :class:`DomainError` (with the distance outside) for a non-finite or negative
    length, ``rho1 > L`` or ``rho1 + rho2 > 2L``, and :class:`SingularityError` (kind
    ``"indeterminate_beta"``) in the degenerate case ``a = b = 0`` (unreachable for
    ``k3 > 0`` except through underflow, see docs/class2.md).
    """
    rho1 = as_real("rho1", rho1)
    rho2 = as_real("rho2", rho2)
    L = params.L
    check_actuator_lengths(rho1, rho2, L)
    d, e, lam1 = _beta_terms(rho1, rho2, params)
    R = math.hypot(d, e)
    _check_determinate(R, rho1, rho2, params)
    beta = math.atan2(e, d)
    name, dist = nearest_singularity(rho1, rho2, params)
    in_range = in_paper_range(beta)
    return FKResult(
        rho1, rho2, beta, math.atan2(lam1, rho1 + rho2), rho1 + L * d / R, L * e / R,
        0.5 * L * R, True, in_range, dist, name, "" if in_range else range_note(beta), params,
    )


def _energy_gradient_beta(rho1: float, rho2: float, beta: float, params: Class2Params) -> float:
    """dU/dbeta from node positions: only D moves, dD/dbeta = L (-sin beta, cos beta).

    ``U = 1/2 sum k l^2`` over the springs, so ``dU/dbeta = (k3 (D - C) + k2 (D - E)) . dD/dbeta``.
    Independent of the closed-form coefficients (used by the numeric cross-check).
    """
    p = node_positions((rho1, rho2, beta), params)
    pull = params.k3 * (p[3] - p[2]) + params.k2 * (p[3] - p[4])
    return float(params.L * (-pull[0] * math.sin(beta) + pull[1] * math.cos(beta)))


def forward_kinematics_numeric(
    rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS, *, grid: int = 72
) -> FKResult:
    """FKP by numerically minimising the spring energy over beta (cross-check of the closed form).

    ``U(beta)`` is evaluated from node positions and member lengths (not from Eq. 9), scanned
    on ``grid`` points of ``[-pi, pi)``, minimised with :func:`scipy.optimize.minimize_scalar`
    around the best grid point, then polished to machine precision by a bracketed root of
    the geometric ``dU/dbeta``. ``stiffness_beta`` is a central difference of that gradient.
    Domain errors as :func:`forward_kinematics`.
    """
    from scipy import optimize

    rho1 = as_real("rho1", rho1)
    rho2 = as_real("rho2", rho2)
    L = params.L
    check_actuator_lengths(rho1, rho2, L)
    betas = np.linspace(-math.pi, math.pi, grid, endpoint=False)
    q = np.column_stack([np.full(grid, rho1), np.full(grid, rho2), betas])
    energies = potential_energy(q, params)
    i = int(np.argmin(energies))
    if np.ptp(energies) <= 1e-13 * max(1.0, float(np.max(np.abs(energies)))):
        raise SingularityError(
            f"U(beta) is flat at rho1 = {rho1:g} m, rho2 = {rho2:g} m: every beta is an equilibrium",
            kind="indeterminate_beta", distance=0.0,
        )
    h = 2.0 * math.pi / grid
    res = optimize.minimize_scalar(
        lambda b: float(potential_energy((rho1, rho2, b), params)),
        bounds=(betas[i] - h, betas[i] + h), method="bounded", options={"xatol": 1e-12},
    )
    beta = float(res.x)

    def grad(b: float) -> float:
        return _energy_gradient_beta(rho1, rho2, b, params)

    lo, hi = beta - 1e-6, beta + 1e-6
    if grad(lo) < 0.0 < grad(hi):
        beta = optimize.brentq(grad, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    beta = math.remainder(beta, 2.0 * math.pi)
    step = 1e-5
    stiffness = (grad(beta + step) - grad(beta - step)) / (2.0 * step)
    name, dist = nearest_singularity(rho1, rho2, params)
    in_range = in_paper_range(beta)
    return FKResult(
        rho1, rho2, beta, math.atan2(math.sqrt((2 * L - rho1 - rho2) * (2 * L + rho1 + rho2)), rho1 + rho2),
        rho1 + L * math.cos(beta), L * math.sin(beta), stiffness, stiffness > 0.0, in_range,
        dist, name, range_note(beta), params,
    )


class FKArrays(NamedTuple):
    """Vectorised FK: arrays broadcast from the inputs; NaN exactly where ``valid`` is False."""

    beta: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    valid: NDArray[np.bool_]


def fk_array(rho1: ArrayLike, rho2: ArrayLike, params: Class2Params = PAPER_PARAMS) -> FKArrays:
    """:func:`forward_kinematics` over broadcastable arrays, without a Python loop.

    ``valid`` is False where the scalar function would raise (non-finite, negative length,
    ``rho1 > L``, ``rho1 + rho2 > 2L``, indeterminate beta); those entries are NaN.
    """
    r1 = np.asarray(rho1, dtype=np.float64)
    r2 = np.asarray(rho2, dtype=np.float64)
    L, k2 = params.L, params.k2
    s = r1 + r2
    with np.errstate(invalid="ignore", divide="ignore"):
        lam1 = np.sqrt((2.0 * L - s) * (2.0 * L + s))
        d = (2.0 * params.k3 + k2) * r2 - k2 * r1
        e = k2 * lam1
        R = np.hypot(d, e)
        valid = (
            np.isfinite(r1) & np.isfinite(r2) & (r1 >= 0.0) & (r2 >= 0.0)
            & (r1 <= L) & (s <= 2.0 * L)
            & (R > DEGENERATE_LIMIT * (2.0 * params.k3 + 2.0 * k2) * L)
        )
        beta = np.where(valid, np.arctan2(e, d), np.nan)
        x = np.where(valid, r1 + L * d / R, np.nan)
        y = np.where(valid, L * e / R, np.nan)
    return FKArrays(beta, x, y, valid)


def dbeta_drho(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> tuple[float, float, float]:
    """``(beta, dbeta/drho1, dbeta/drho2)`` of the equilibrium beta [rad, rad/m].

    Implicit function theorem on ``G(rho, beta) = dU/dbeta = (L/2)(-a sin beta + b cos beta) = 0``::

        dbeta/drho_i = -G_rho_i / G_beta = (a_i sin beta - b_i cos beta) / R,
        a_1 = k2, a_2 = -(2 k3 + k2), b_i = k2 (rho1 + rho2) / lambda1,

    (``G_beta = d2U/dbeta2 = L R / 2``). Raises :class:`SingularityError` (kind
    ``"lambda1"``) where ``lambda1 = 0`` (the derivatives are unbounded there).
    """
    rho1 = as_real("rho1", rho1)
    rho2 = as_real("rho2", rho2)
    L, k2 = params.L, params.k2
    check_actuator_lengths(rho1, rho2, L)
    d, e, lam1 = _beta_terms(rho1, rho2, params)
    if lam1 == 0.0:
        raise SingularityError(
            f"dbeta/drho is unbounded at rho1 + rho2 = 2L = {2 * L:g} m (lambda1 = 0)",
            kind="lambda1", distance=0.0,
        )
    R = math.hypot(d, e)
    _check_determinate(R, rho1, rho2, params)
    sb, cb = e / R, d / R
    b_i = k2 * (rho1 + rho2) / lam1
    return math.atan2(e, d), (k2 * sb - b_i * cb) / R, (-(2.0 * params.k3 + k2) * sb - b_i * cb) / R


def jacobian_D_rho(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """Analytic ``dD/drho`` at the equilibrium (2x2; rows x, y; columns rho1, rho2).

    With ``beta_i = dbeta/drho_i`` from :func:`dbeta_drho` and
    ``D = (rho1 + L cos beta, L sin beta)``:
    ``J = [[1 - L sin(beta) beta_1, -L sin(beta) beta_2], [L cos(beta) beta_1, L cos(beta) beta_2]]``
    and ``det J = L cos(beta) beta_2``. Raises :class:`SingularityError` (kind ``"lambda1"``)
    where ``lambda1 = 0``.
    """
    beta, beta1, beta2 = dbeta_drho(rho1, rho2, params)
    L = params.L
    sb, cb = math.sin(beta), math.cos(beta)
    return np.array([[1.0 - L * sb * beta1, -L * sb * beta2], [L * cb * beta1, L * cb * beta2]], dtype=np.float64)
