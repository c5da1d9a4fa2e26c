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
from tensegrity_core.class2.singularities.distances import SINGULAR_MEANINGS, nearest_singularity
from tensegrity_core.errors import DomainError

#: Relative tolerance (times L) within which a length on a domain limit is snapped onto
#: it, a target with ``y`` that close below 0 onto the X axis, and a target with ``|y|``
#: that close to L onto the fold ``|y| = L`` (there
#: ``c = sqrt(L^2 - y^2)`` turns a rounding error of y into sqrt of it in rho1). The
#: snapped answer reproduces the target to within this tolerance: rho1 by the target's
#: distance from the limit's circle (:func:`rho1_snap_bound`), rho2 with an allowance for
#: the rounding of the target amplified by ``d rho1 / d y = y / c`` (:func:`snap_tolerance`).
DOMAIN_TOL: Final = 1e-12
#: The machine epsilon of float64, the unit of a rounding.
EPS: Final = float(np.finfo(float).eps)


def rho1_snap_bound(w: float, L: float) -> float:
    """Largest overshoot [m] of ``rho1 = x -+ w`` beyond 0 or L that is put on the limit.

    ``w = sqrt(L^2 - y^2)``. A branch length ``rho1 = lim +- s`` puts the target at
    ``hypot(x - lim, y) = sqrt(L^2 +- 2 w s + s^2)`` from ``(lim, 0)``, so the target lies
    within ``t = DOMAIN_TOL L`` of the circle that D traces with ``rho1 = lim`` when
    ``2 w s + s^2 <= 2 L t``: ``s <= sqrt(w^2 + 2 L t) - w``, written without cancellation.
    On the fold (``w = 0``) that is ``sqrt(2 DOMAIN_TOL) L``: a target within ``t`` of the
    corner ``rho1 = L, beta = pi/2`` is reached although its rho1 is ``~1e-6 L`` off.
    """
    t = DOMAIN_TOL * L
    return 2.0 * L * t / (math.sqrt(w * w + 2.0 * L * t) + w)


def merge_radius(L: float) -> float:
    """Distance [m] in the actuator plane within which two roots are one configuration.

    Two roots of one target coincide only on the fold ``|y| = L`` (beta = pi/2, the
    ``beta_half_pi`` singular set, where ``det(dD/drho) = 0``). There the branches
    ``delta1 = -+1`` are ``rho1 = x -+ w`` with ``w = sqrt(L^2 - y^2)``: D depends
    quadratically on the distance from the fold, so a target resolved to ``DOMAIN_TOL L`` (the
    fold snap) resolves the branch separation ``2 w`` only to ``sqrt(2 DOMAIN_TOL) L``
    (``2 w = 2 sqrt(2 L (L - y))``). Distinct equilibria of a target off the fold are at least
    ``2 w - rho1_snap_bound(w) >= 2.2e-6 L`` apart in rho1, more than this radius.
    """
    return math.sqrt(2.0 * DOMAIN_TOL) * L


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
    singular_set : name of that set (:data:`~tensegrity_core.class2.singularities.distances.SINGULAR_SETS`;
        '' outside the configuration domain).
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
    singular_set: str
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


def on_sum_limit(rho1: float, two_l: float) -> float:
    """The largest rho2 [m] with ``rho1 + rho2 <= 2L`` in floating point: ``2L - rho1``
    rounded can make the rounded sum exceed 2L by an ulp."""
    rho2 = two_l - rho1
    while rho1 + rho2 > two_l:
        rho2 = math.nextafter(rho2, -math.inf)
    return rho2


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
    verdict follows from the signs alone (docs/class2.md): ``delta2 = sign(c)`` (``= -delta1``
    unless rho1 was snapped onto a limit) is the minimum for ``y >= 0``; the other root is not
    stationary for ``y > 0`` and the maximum for ``y <= 0``; for ``y < 0`` the
    ``delta2 = sign(c)`` root is not stationary; at ``c = 0`` (``y = L``) the two roots coincide.
    This is exact where the numeric test is not (near lambda1 = 0 or c = 0 the rounding of
    rho2 dominates dU/dbeta). Outside that range ``dU/dbeta = (y d - c k2 lambda1) / 2`` and
    ``d2U/dbeta2 = (c d + k2 lambda1 y) / 2`` decide.
    """
    if abs(rho1) * (K + k2) < 2.0 * K * L:
        sign_c = -d1 if c == 0.0 else (1 if c > 0.0 else -1)   # = -delta1 unless rho1 was snapped
        if d2 == sign_c or (c == 0.0 and y > 0.0):   # c = 0: a double root, both signs agree
            return "" if y >= 0.0 else REASON_NOT_STATIONARY
        return REASON_NOT_STATIONARY if y > 0.0 else REASON_MAXIMUM
    if abs(y * d - c * k2 * lam1) > 0.5 * (abs(y * d) + abs(c * k2 * lam1)):
        return REASON_NOT_STATIONARY
    return REASON_MAXIMUM if c * d + k2 * lam1 * y < 0.0 else ""


def _branch(x: float, y: float, w: float, d1: int, L: float) -> tuple[float, float, float]:
    """``(rho1, c, y)`` of branch ``delta1`` (Eq. 13), rho1 put on 0 or L when beyond it by at
    most :func:`rho1_snap_bound`; a snapped rho1 gets the point of its circle nearest the
    target, ``(c, y) = L (x - rho1, y) / hypot(x - rho1, y)`` (which moves D by at most
    ``DOMAIN_TOL L``). The sign of that c, not ``delta1``, then tells the roots apart."""
    rho1 = x + d1 * w
    snapped = _snap(rho1, 0.0, L, rho1_snap_bound(w, L))
    if snapped == rho1:
        return rho1, -d1 * w, y
    r = math.hypot(x - snapped, y)
    return snapped, L * (x - snapped) / r, L * y / r


def fk_residual(x: float, y: float, rho1: float, rho2: float, params: Class2Params) -> float:
    """``|FK(rho1, rho2) - (x, y)|`` [m] by the closed form (``rho1 + rho2 <= 2L``); NaN where
    beta is indeterminate (``R = 0``)."""
    L, k2 = params.L, params.k2
    s = rho1 + rho2
    d = (2.0 * params.k3 + k2) * rho2 - k2 * rho1
    e = k2 * math.sqrt(max(0.0, (2.0 * L - s) * (2.0 * L + s)))
    R = math.hypot(d, e)
    if R == 0.0:
        return math.nan
    return math.hypot(rho1 + L * d / R - x, L * e / R - y)


def _candidate(x: float, y: float, yb: float, rho1: float, rho2: float, c: float, d1: int, d2: int,
               params: Class2Params, paper_range: bool) -> IKCandidate:
    """Verdict on one root; ``(x, y)`` is the target, ``yb`` the branch's (snapped) y."""
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    two_l = 2.0 * L
    tol = snap_tolerance(abs(c), L)   # det(dD/drho) ~ c: rho2 inherits the L / c too
    # rho2 onto 0 only if FK then reproduces the branch's target: dD/drho2 grows like
    # (2 k3 + k2) / k2, so a length within tol of 0 can put D far from it. (Onto the sum limit
    # lambda1 = 0 the map is a square root: the target's y sets lambda1, the move is ~y.)
    snapped = _snap(rho2, 0.0, math.inf, tol)
    if snapped == rho2 or fk_residual(rho1 + c, yb, rho1, snapped, params) <= tol:
        rho2 = snapped
    if two_l < rho1 + rho2 <= two_l + tol:
        rho2 = on_sum_limit(rho1, two_l)
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
    singular_set = ""
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
            singular_set, dist = nearest_singularity(rho1, rho2, params)
            fk_res = fk_residual(x, y, rho1, rho2, params)
    in_range = in_paper_range(beta) and 0.0 <= alpha <= 0.5 * math.pi
    if paper_range and not in_range:
        reasons.append(REASON_RANGE)
    return IKCandidate(
        rho1, rho2, beta, alpha, d1, d2, not reasons, "; ".join(reasons) if reasons else "", in_range,
        stiffness, dist, singular_set, fk_res,
    )


def inverse_kinematics(
    x: float, y: float, params: Class2Params = PAPER_PARAMS, *, paper_range: bool = True
) -> IKResult:
    """Every real candidate of the paper's IK route for D = (x, y), each with its verdict.

    ``paper_range=True`` (default) makes candidates outside ``0 <= alpha, beta <= pi/2``
    invalid (the paper's restriction, Sect. 2); with ``False`` they stay valid and are only
    flagged by ``in_paper_range``. Candidates are listed in the order
    ``(delta1, delta2) = (-1, +1), (-1, -1), (+1, -1), (+1, +1)`` (genuine roots first).
    ``.valid`` lists distinct configurations: a root within :func:`merge_radius`
    (``sqrt(2 DOMAIN_TOL) L``, the resolution of the branches at the fold) of an earlier
    valid one is the same configuration; it is kept but marked invalid as a duplicate. That
    happens only on the fold ``|y| = L``, the singular point where the branches meet.
    Targets within ``DOMAIN_TOL L`` of the workspace's boundary are put on it
    (:func:`rho1_snap_bound`); ``fk_residual`` reports the move. Raises :class:`DomainError` only for
    non-finite input; an unreachable target gives an empty or all-invalid result.
    """
    x = as_real("x", x)
    y = as_real("y", y)
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    tol = DOMAIN_TOL * L
    if L - tol <= abs(y) <= L + tol:
        y = math.copysign(L, y)   # the fold: c = sqrt(L^2 - y^2) would amplify rounding to sqrt(tol)
    elif -tol <= y < 0.0:
        y = 0.0                   # the X axis, W's lower edge (lambda1 = 0): below it no equilibrium
    candidates: list[IKCandidate] = []
    merge = merge_radius(L)
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
                if any(o.valid and math.hypot(o.rho1 - cand.rho1, o.rho2 - cand.rho2) <= merge for o in candidates):
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
        found = f"{n_valid} valid solution{'s' if n_valid > 1 else ''} of {len(candidates)} candidates"
        return found + "".join(_on_singular_set(c, L) for c in candidates if c.valid)
    where = f"D = ({x:g}, {y:g}) m"
    if abs(y) > L:
        return f"no real solution for {where}: |y| > L = {L:g} m (outside the workspace by {outside:.3g} m)"
    if outside > 0.0:
        return f"no valid solution for {where}: outside the workspace by {outside:.3g} m"
    if paper_range:
        return f"no valid solution for {where} within the paper's angle range"
    return f"no valid solution for {where}"


def _on_singular_set(c: IKCandidate, L: float) -> str:
    """The note for a valid solution on a singular set (within the IK's resolution,
    :func:`merge_radius`): an equilibrium, but a singular one (what is singular depends on
    the set), so a controller keeping a margin from the singular sets
    (``tensegrity_controller``'s ``singular_margin``) refuses to hold D there; '' elsewhere."""
    if not c.singularity_distance * L <= merge_radius(L):
        return ""
    return (f"; rho = ({c.rho1:.6g}, {c.rho2:.6g}) m lies on the singular set {c.singular_set} "
            f"({SINGULAR_MEANINGS[c.singular_set]}): an equilibrium, refused as a target by a "
            f"controller keeping a margin from singular sets")


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
