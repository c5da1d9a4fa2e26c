"""Where the class-2 coordinates are trusted: the thresholds, and the checks that refuse a state.

The coordinates ``q = (rho1, rho2, beta)`` break down where ``lambda1 = sqrt(4L^2 - s^2)``
(``s = rho1 + rho2``: struts AE and CE flat) or ``lambda2 = sqrt(L^2 - rho1^2)`` (strut BF
flat) vanishes: the mass matrix grows like ``1/lambda^2`` there. Three thresholds, all
relative to the strut length ``L``, each defined here once:

- :data:`LAMBDA_MIN_REL` (1e-4): below it the equations of motion refuse to answer
  (:class:`~tensegrity_core.errors.SingularityError`). Rounding ``s`` leaves a relative
  error of about ``1e-15 (L/lambda)^2`` in ``M``, i.e. ``1e-7`` at this limit.
- :data:`SINGULAR_GUARD_REL` (1e-3): where the scene simulators stop a run (the dynamic
  back end's ``singular`` event, the quasi-static path's regular region). An order above
  the refusal, so that an integrator's trial stages just past the event still evaluate.
- :data:`ZERO_LENGTH_REL` (1e-12): the damper direction of a spring of zero length is
  undefined; the damper term uses ``|d|^2 + (ZERO_LENGTH_REL L)^2`` in its denominator,
  which changes nothing measurable for ``|d| > 1e-9 L`` and keeps the force continuous.

A configuration with ``lambda^2 < 0`` does not exist
(:class:`~tensegrity_core.errors.DomainError`).
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.errors import DomainError, ParameterError, SingularityError

#: The equations refuse states with lambda1 or lambda2 below this (relative to L).
LAMBDA_MIN_REL: Final = 1e-4
#: The scene simulators stop where lambda1 or lambda2 falls to this (relative to L).
SINGULAR_GUARD_REL: Final = 1e-3
#: Regularisation of the damper direction at zero spring length (relative to L).
ZERO_LENGTH_REL: Final = 1e-12


def check_lambda_min(lambda_min: object) -> float:
    """``lambda_min`` as a float, or :class:`ParameterError` unless it is a number in (0, 1)."""
    if isinstance(lambda_min, bool) or not isinstance(lambda_min, (int, float)) or not 0.0 < lambda_min < 1.0:
        raise ParameterError(f"lambda_min must be a number in (0, 1) (relative to L), got {lambda_min!r}")
    return float(lambda_min)


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
    return (f"configuration does not exist: |rho1| = {abs(rho1):.9g} m exceeds L = {L:g} m "
            f"(node F cannot reach the Y axis)")


def refuse(kind: str, lam_sq: float, limit: float, rho1: float, rho2: float, L: float) -> None:
    """Raise the error for ``lambda^2 = lam_sq`` below ``limit^2`` (a float that failed the
    check): :class:`SingularityError` near the set, :class:`DomainError` beyond it or for a
    state that is not finite."""
    if lam_sq >= 0.0:
        lam = math.sqrt(lam_sq)
        raise SingularityError(_singular_message(kind, lam, limit, rho1, rho2, L), kind=kind, distance=lam,
                               limit=limit)
    if lam_sq < 0.0:
        raise DomainError(_absent_message(kind, rho1, rho2, L), distance=math.sqrt(-lam_sq))
    raise DomainError(f"state is not finite: rho1 = {rho1!r}, rho2 = {rho2!r}")


def refuse_pair(lam1_sq: float, lam2_sq: float, limit: float, rho1: float, rho2: float, L: float) -> None:
    """Raise the error of the first of ``lambda1^2, lambda2^2`` (floats) that fails the check."""
    limit_sq = limit * limit
    if not lam1_sq >= limit_sq:
        refuse("lambda1", lam1_sq, limit, rho1, rho2, L)
    refuse("lambda2", lam2_sq, limit, rho1, rho2, L)


def checked_lambda(kind: str, lam_sq: NDArray[np.float64], limit: float, rho1: ArrayLike, rho2: ArrayLike,
                   L: float) -> NDArray[np.float64]:
    """``sqrt(lam_sq)`` for arrays of states; the error of the first offending state otherwise
    (its index appended to the message)."""
    ok = lam_sq >= limit * limit
    if not np.all(ok):
        idx = np.unravel_index(np.argmin(np.where(ok, 1, 0)), np.shape(lam_sq)) if np.ndim(lam_sq) else ()
        where = f" (state {tuple(int(i) for i in idx)})" if idx else ""
        r1 = float(np.broadcast_to(rho1, np.shape(lam_sq))[idx])
        r2 = float(np.broadcast_to(rho2, np.shape(lam_sq))[idx])
        try:
            refuse(kind, float(lam_sq[idx]), limit, r1, r2, L)
        except (SingularityError, DomainError) as err:
            err.args = (str(err) + where,)
            raise
    return np.sqrt(lam_sq)
