"""Inverse kinematics of the class-2 mechanism: actuator lengths that hold D at (x, y).

The paper's route (Sect. 3.2): ``rho1 = x + delta1 sqrt(L^2 - y^2)`` (Eq. 13), then the
quadratic ``xi2 rho2^2 + xi1 rho2 + xi0 = 0`` (Eqs. 14-17) obtained by squaring
``y ((2 k3 + k2) rho2 - k2 rho1) = (x - rho1) k2 lambda1`` (Eq. 10 combined with Eq. 12),
solved by Eq. 18 with ``delta2 = +-1``. With ``c = x - rho1 = L cos beta`` and
``K = 2 k3 + k2`` the discriminant factors exactly (docs/class2.md)::

    xi1^2 - 4 xi2 xi0 = 4 k2^2 c^2 Q^2,   Q^2 = 4 L^2 xi2 - (K + k2)^2 rho1^2 y^2,
    rho2 = k2 (-rho1 (k2 c^2 - K y^2) + delta2 |c| Q) / xi2,

which is how the roots are computed here (no cancellation as ``c -> 0``).

Squaring admits roots that are not equilibria. ``dU/dbeta`` at the target equals
``(y d - c k2 lambda1) / 2`` (``d = K rho2 - k2 rho1``) and ``d2U/dbeta2 = (c d + k2 lambda1 y) / 2``,
so each root is classified exactly: genuine (stationary, minimum), energy maximum
(stationary, ``d2U/dbeta2 < 0``; the only stationary root when y < 0) or not stationary
(the root of the sign-flipped equation, ``|dU/dbeta| = |c k2 lambda1|``). For ``0 < y < L``
and ``0 <= rho1 <= L`` each ``delta1`` has exactly one genuine root, the one with
``delta2 = -delta1``: at most two equilibria, at most one (``delta1 = -1``) in the paper's
range. Each candidate also carries ``fk_residual``, the distance between the target and
the closed-form FK of its lengths, as the independent check.

The same route over arrays of targets, without a Python loop, is
:mod:`tensegrity_core.class2.ik_arrays`.

Lengths in metres, angles in radians from +X, counter-clockwise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final, NamedTuple

import numpy as np

from tensegrity_core.class2.full_workspace import distance_to_full_workspace
from tensegrity_core.class2.kinematics import as_real, in_paper_range
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.class2.singularities.distances import nearest_singularity
from tensegrity_core.errors import DomainError

#: Relative tolerance (times L) within which a length on a domain limit is snapped onto
#: it, and a target with ``|y|`` that close to L onto the fold ``|y| = L`` (there
#: ``c = sqrt(L^2 - y^2)`` turns a rounding error of y into sqrt of it in rho1). The
#: snapped answer reproduces the target to within this tolerance. The snapping of lengths
#: also allows for the rounding of the target amplified by ``d rho1 / d y = y / c``
#: (:func:`snap_tolerance`).
DOMAIN_TOL: Final = 1e-12
#: The machine epsilon of float64, the unit of a rounding.
EPS: Final = float(np.finfo(float).eps)


def snap_tolerance(c: float, L: float) -> float:
    """Snap tolerance [m] for lengths of a target with ``c = |x - rho1| = sqrt(L^2 - y^2)``.

    ``DOMAIN_TOL L`` plus eight roundings of the target carried through ``rho1 = x -+ c``
    (``|d c / d y| = |y| / c <= L / c``) and, as ``det(dD/drho) = c dbeta/drho2``, into
    rho2 alike; ``c = 0`` only after the fold snap, where y is exact. FK of snapped lengths
    reproduces the target to within this tolerance (``fk_residual``).
    """
    return DOMAIN_TOL * L + (8.0 * EPS * L * L / c if c > 0.0 else 0.0)


REASON_RHO1: Final = "rho1 outside [0, L]"
REASON_RHO2: Final = "negative length rho2"
REASON_SUM: Final = "rho1+rho2 > 2L"
REASON_MAXIMUM: Final = "spurious root of the squared equation (energy maximum, not an equilibrium)"
REASON_NOT_STATIONARY: Final = "spurious root of the squared equation (not an equilibrium: dU/dbeta != 0)"
REASON_RANGE: Final = "outside the paper's angle range"
REASON_DUPLICATE: Final = "duplicate of an earlier candidate (double root)"


class IKCandidate(NamedTuple):
    """One real root of the paper's quartic route, with its verdict (an immutable record).

    Attributes
    ----------
    rho1, rho2 : actuator lengths [m] (Eqs. 13 and 18).
    beta : angle of BD [rad] that puts D at the target, ``atan2(y, x - rho1)``.
    alpha : angle of AE [rad] (Eq. 1); NaN when ``|rho1 + rho2| > 2L``.
    delta1, delta2 : branch signs of Eqs. 13 and 18.
    valid : a genuine stable equilibrium in the configuration domain (and in the paper's
        range when the solve asked for it).
    reason : '' when valid, else every failed test joined by '; '.
    in_paper_range : ``0 <= alpha, beta <= pi/2``.
    stiffness_beta : d2U/dbeta2 at the target [J/rad^2] (> 0 for a minimum).
    singularity_distance : distance to the nearest singular set (dimensionless; NaN outside
        the configuration domain).
    fk_residual : ``|FK(rho1, rho2) - (x, y)|`` [m]; NaN outside the configuration domain.
    """

    rho1: float
    rho2: float
    beta: float
    alpha: float
    delta1: int
    delta2: int
    valid: bool
    reason: str
    in_paper_range: bool
    stiffness_beta: float
    singularity_distance: float
    fk_residual: float

    def as_dict(self) -> dict[str, Any]:
        return self._asdict()


@dataclass(frozen=True)
class IKResult:
    """All real candidates for the target D = (x, y) and the summary ``message``.

    ``outside_distance`` [m] is the distance from the target to the workspace of the full
    actuator range (0 inside; :mod:`tensegrity_core.class2.full_workspace`).
    """

    x: float
    y: float
    paper_range: bool
    candidates: tuple[IKCandidate, ...]
    message: str
    outside_distance: float

    @property
    def valid(self) -> tuple[IKCandidate, ...]:
        """The valid candidates only (what the ROS service returns)."""
        return tuple(c for c in self.candidates if c.valid)

    @property
    def success(self) -> bool:
        return any(c.valid for c in self.candidates)

    def nearest(self, seed: Sequence[float]) -> IKCandidate:
        """The valid candidate nearest ``seed = (rho1, rho2)`` in the actuator plane."""
        if len(seed) != 2:
            raise DomainError(f"seed must be (rho1, rho2), got {seed!r}")
        s1, s2 = as_real("seed rho1", seed[0]), as_real("seed rho2", seed[1])
        valid = self.valid
        if not valid:
            raise DomainError(self.message, distance=self.outside_distance)
        return min(valid, key=lambda c: math.hypot(c.rho1 - s1, c.rho2 - s2))

    def as_dict(self) -> dict[str, Any]:
        return {
            "x": self.x, "y": self.y, "paper_range": self.paper_range,
            "success": self.success, "message": self.message,
            "outside_distance": self.outside_distance,
            "solutions": [c.as_dict() for c in self.candidates],
        }


def _snap(v: float, lo: float, hi: float, tol: float) -> float:
    if lo - tol <= v < lo:
        return lo
    if hi < v <= hi + tol:
        return hi
    return v


def _spurious_reason(y: float, c: float, d: float, lam1: float, rho1: float, d1: int, d2: int, K: float,
                     k2: float, L: float) -> str:
    """'' for an energy minimum, else which kind of spurious root (module docstring).

    Inside the ellipse range ``|rho1| < 2 K L / (K + k2)`` (which contains [0, L]) the
    verdict follows from the branch signs alone (docs/class2.md): ``delta2 = -delta1`` is the
    minimum for ``y >= 0``; ``delta2 = delta1`` is not stationary for ``y > 0`` and the
    maximum for ``y <= 0``; for ``y < 0`` the ``delta2 = -delta1`` root is not stationary;
    at ``c = 0`` (``y = L``) the two roots coincide.
    This is exact where the numeric test is not (near lambda1 = 0 or c = 0 the rounding of
    rho2 dominates dU/dbeta). Outside that range ``dU/dbeta = (y d - c k2 lambda1) / 2`` and
    ``d2U/dbeta2 = (c d + k2 lambda1 y) / 2`` decide.
    """
    if abs(rho1) * (K + k2) < 2.0 * K * L:
        if d2 == -d1 or (c == 0.0 and y > 0.0):   # c = 0: a double root, both signs agree
            return "" if y >= 0.0 else REASON_NOT_STATIONARY
        return REASON_NOT_STATIONARY if y > 0.0 else REASON_MAXIMUM
    if abs(y * d - c * k2 * lam1) > 0.5 * (abs(y * d) + abs(c * k2 * lam1)):
        return REASON_NOT_STATIONARY
    return REASON_MAXIMUM if c * d + k2 * lam1 * y < 0.0 else ""


def _branch(x: float, y: float, w: float, d1: int, L: float) -> tuple[float, float, float]:
    """``(rho1, c, y)`` of branch ``delta1`` (Eq. 13), rho1 snapped onto [0, L] when within
    :func:`snap_tolerance`; a snapped rho1 gets its own consistent ``c = x - rho1`` and
    ``y = +-sqrt(L^2 - c^2)`` (which moves y by only ~ c * snap / y)."""
    rho1 = x + d1 * w
    snapped = _snap(rho1, 0.0, L, snap_tolerance(w, L))
    if snapped == rho1:
        return rho1, -d1 * w, y
    c = x - snapped
    return snapped, c, math.copysign(math.sqrt(max(0.0, (L - c) * (L + c))), y)


def _candidate(x: float, y: float, yb: float, rho1: float, rho2: float, c: float, d1: int, d2: int,
               params: Class2Params, paper_range: bool) -> IKCandidate:
    """Verdict on one root; ``(x, y)`` is the target, ``yb`` the branch's (snapped) y."""
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    two_l = 2.0 * L
    tol = snap_tolerance(abs(c), L)   # det(dD/drho) ~ c: rho2 inherits the L / c too
    rho2 = _snap(rho2, 0.0, math.inf, tol)
    if two_l < rho1 + rho2 <= two_l + tol:
        rho2 = two_l - rho1
    s = rho1 + rho2
    in_domain = 0.0 <= rho1 <= L and rho2 >= 0.0 and s <= two_l
    reasons: list[str] = []
    if not in_domain:
        if not 0.0 <= rho1 <= L:
            reasons.append(REASON_RHO1)
        if rho2 < 0.0:
            reasons.append(REASON_RHO2)
        if s > two_l:
            reasons.append(REASON_SUM)
    beta = math.atan2(yb, c)
    lam_sq = (two_l - s) * (two_l + s)
    alpha = stiffness = dist = fk_res = math.nan
    if lam_sq >= -4.0 * tol * L:
        lam1 = math.sqrt(lam_sq) if lam_sq > 0.0 else 0.0
        alpha = math.atan2(lam1, s)
        d = K * rho2 - k2 * rho1
        e = k2 * lam1
        stiffness = 0.5 * (c * d + e * yb)
        spurious = _spurious_reason(yb, c, d, lam1, rho1, d1, d2, K, k2, L)
        if spurious:
            reasons.append(spurious)
        if in_domain:
            dist = nearest_singularity(rho1, rho2, params)[1]
            R = math.hypot(d, e)
            if R > 0.0:
                fk_res = math.hypot(rho1 + L * d / R - x, L * e / R - y)
    in_range = in_paper_range(beta) and 0.0 <= alpha <= 0.5 * math.pi
    if paper_range and not in_range:
        reasons.append(REASON_RANGE)
    return IKCandidate(
        rho1, rho2, beta, alpha, d1, d2, not reasons, "; ".join(reasons) if reasons else "", in_range,
        stiffness, dist, fk_res,
    )


def inverse_kinematics(
    x: float, y: float, params: Class2Params = PAPER_PARAMS, *, paper_range: bool = True
) -> IKResult:
    """Every real candidate of the paper's IK route for D = (x, y), each with its verdict.

    ``paper_range=True`` (default) makes candidates outside ``0 <= alpha, beta <= pi/2``
    invalid (the paper's restriction, Sect. 2); with ``False`` they stay valid and are only
    flagged by ``in_paper_range``. Candidates are listed in the order
    ``(delta1, delta2) = (-1, +1), (-1, -1), (+1, -1), (+1, +1)`` (genuine roots first); a
    root identical to an earlier one (at ``|y| = L``) is kept but marked invalid as a
    duplicate, so ``.valid`` lists distinct solutions. Raises :class:`DomainError` only for
    non-finite input; an unreachable target gives an empty or all-invalid result.
    """
    x = as_real("x", x)
    y = as_real("y", y)
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    tol = DOMAIN_TOL * L
    if L - tol <= abs(y) <= L + tol:
        y = math.copysign(L, y)   # the fold: c = sqrt(L^2 - y^2) would amplify rounding to sqrt(tol)
    candidates: list[IKCandidate] = []
    if abs(y) <= L:
        w = math.sqrt((L - y) * (L + y))
        for d1 in (-1, 1):
            rho1, c, yb = _branch(x, y, w, d1, L)
            xi2 = K * K * yb * yb + k2 * k2 * c * c
            q_sq = 4.0 * L * L * xi2 - (K + k2) ** 2 * rho1 * rho1 * yb * yb
            if q_sq < 0.0:
                continue
            mid = -k2 * rho1 * (k2 * c * c - K * yb * yb)
            spread = k2 * abs(c) * math.sqrt(q_sq)
            for d2 in (-d1, d1):
                rho2 = (mid + d2 * spread) / xi2
                cand = _candidate(x, y, yb, rho1, rho2, c, d1, d2, params, paper_range)
                if c == 0.0 and candidates:   # y = +-L: every root is the same double root
                    reason = REASON_DUPLICATE if cand.valid else f"{cand.reason}; {REASON_DUPLICATE}"
                    cand = cand._replace(valid=False, reason=reason)
                candidates.append(cand)
    n_valid = sum(c.valid for c in candidates)
    outside = 0.0 if n_valid else max(0.0, distance_to_full_workspace(x, y, L))
    message = _message(x, y, L, candidates, n_valid, outside, paper_range)
    return IKResult(x, y, paper_range, tuple(candidates), message, outside)


def _message(x: float, y: float, L: float, candidates: Sequence[IKCandidate], n_valid: int, outside: float,
             paper_range: bool) -> str:
    if n_valid:
        return f"{n_valid} valid solution{'s' if n_valid > 1 else ''} of {len(candidates)} candidates"
    where = f"D = ({x:g}, {y:g})"
    if abs(y) > L:
        return f"no real solution for {where}: |y| > L = {L:g} m (outside the workspace by {outside:.3g} m)"
    if outside > 0.0:
        return f"no valid solution for {where}: outside the workspace by {outside:.3g} m"
    if paper_range:
        return f"no valid solution for {where} within the paper's angle range"
    return f"no valid solution for {where}"


def nearest_solution(
    x: float, y: float, seed: Sequence[float], params: Class2Params = PAPER_PARAMS,
    *, paper_range: bool = True,
) -> IKCandidate:
    """The valid IK solution nearest ``seed = (rho1, rho2)`` [m] (Euclidean, actuator plane).

    Feeding each answer back as the next seed keeps a trajectory on one branch. With
    ``paper_range=True`` at most one solution is valid, so the seed matters only with
    ``paper_range=False`` (the ``delta1 = +1`` branch, beta > pi/2). Raises
    :class:`DomainError` (``distance`` = how far the target is outside the workspace)
    when no candidate is valid.
    """
    return inverse_kinematics(x, y, params, paper_range=paper_range).nearest(seed)
