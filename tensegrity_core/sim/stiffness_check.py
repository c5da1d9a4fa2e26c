"""Does a scene's integration method fit its stiffness? An estimate before the run.

An explicit Runge-Kutta method (RK23, RK45, DOP853) is stable only while ``h lambda`` lies in
its stability region for every eigenvalue ``lambda`` of the Jacobian ``d(dy/dt)/dy``: a mode
that decays at the rate ``sigma = -Re(lambda)`` forces steps ``h <= r / sigma`` however little
it moves (``r`` the region's extent along the negative real axis), so over a run of
``duration`` the method needs at least ``duration sigma / r`` steps. The compliant drive's
elongation decays at ``k_a / c_d`` (1e7 1/s for ``k_a = 1e6 N/m``, ``c_d = 0.1 N s/m``): DOP853
then needs ~8e6 steps for 5 s where Radau, whose steps follow the motion, needs ~900.

:func:`check_integrator` evaluates the Jacobian at the initial state (eigenvalues: dense for
small systems, the few of largest magnitude for large sparse ones) and says so when an
explicit method would need more than :data:`MAX_EXPLICIT_STEPS` steps for that reason alone.
``r`` is computed from scipy's own Butcher tableaux (the stability function
``R(z) = 1 + z b^T (I - z A)^-1 1`` of the propagated solution): 2.51 for RK23, 3.31 for
RK45, 6.39 for DOP853. Implicit methods (Radau, BDF, LSODA's stiff mode) have no such
limit. The estimate holds at the initial state only: a stiffness that appears later (a
string going taut) is not seen.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.integrate import DOP853, RK23, RK45, OdeSolver
from scipy.sparse.linalg import ArpackNoConvergence, eigs

#: Explicit methods and their scipy classes (the stepper's names).
EXPLICIT: dict[str, type[OdeSolver]] = {"RK23": RK23, "RK45": RK45, "DOP853": DOP853}
#: Steps forced by stability alone above which an explicit method is said not to fit.
MAX_EXPLICIT_STEPS = 1e5
#: Systems up to this size get all their eigenvalues (dense); larger ones the largest few.
DENSE_LIMIT = 400


class StiffnessWarning(UserWarning):
    """A scene's explicit integration method does not fit its stiffness (see :func:`check_integrator`)."""


@dataclass(frozen=True)
class IntegratorFit:
    """The estimate: ``decay_rate`` the fastest decay rate at the initial state [1/s];
    ``explicit_steps`` the steps an explicit method's stability needs over the run (0 for an
    implicit method); ``message`` the warning, empty when the method fits."""

    method: str
    decay_rate: float
    explicit_steps: float
    message: str

    @property
    def fits(self) -> bool:
        return not self.message


@cache
def real_stability_limit(method: str) -> float:
    """How far the stability region of the explicit ``method`` reaches along the negative real
    axis: the largest ``x`` with ``|R(-x')| <= 1`` for all ``0 < x' <= x`` (bisection)."""
    cls = EXPLICIT[method]
    n = cls.n_stages
    A = np.zeros((n, n))
    given = np.asarray(cls.A, dtype=float)
    A[:, :min(n, given.shape[1])] = given[:n, :n]
    b = np.asarray(cls.B, dtype=float)[:n]

    def stable(x: float) -> bool:
        z = -x
        return abs(1.0 + z * float(b @ np.linalg.solve(np.eye(n) - z * A, np.ones(n)))) <= 1.0

    step = 0.01
    x = step
    while stable(x + step):          # the first instability on a fine grid ...
        x += step
    lo, hi = x, x + step             # ... then bisection
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def fastest_decay(jacobian: Any) -> float:
    """The largest ``-Re(lambda)`` over the eigenvalues of ``jacobian`` (dense or sparse) [1/s]."""
    n = jacobian.shape[0]
    if n <= DENSE_LIMIT:
        J = jacobian.toarray() if sp.issparse(jacobian) else np.asarray(jacobian, dtype=float)
        values = np.linalg.eigvals(J)
    else:
        try:
            values = eigs(sp.csc_matrix(jacobian), k=min(6, n - 2), which="LM", tol=1e-3,
                          return_eigenvectors=False)
        except ArpackNoConvergence as err:
            values = err.eigenvalues
    return max(0.0, float(-np.min(np.real(values)))) if len(values) else 0.0


def check_integrator(method: str, jacobian: Any, duration: float) -> IntegratorFit:
    """Whether ``method`` fits a system whose Jacobian at the initial state is ``jacobian``,
    for a run of ``duration`` [s]."""
    sigma = fastest_decay(jacobian)
    if method not in EXPLICIT:
        return IntegratorFit(method, sigma, 0.0, "")
    limit = real_stability_limit(method)
    steps = duration * sigma / limit if math.isfinite(duration) else math.inf
    message = ""
    if steps > MAX_EXPLICIT_STEPS:
        message = (f"integrator.method {method} is explicit and this scene is stiff: its fastest mode decays at "
                   f"{sigma:.3g} 1/s at the initial state, which keeps {method}'s steps below "
                   f"{limit / sigma:.3g} s, about {steps:.2g} steps for {duration:g} s however slowly it moves; "
                   f"an implicit method takes the steps the motion needs: use Radau, BDF or LSODA (or method: auto)")
    return IntegratorFit(method, sigma, steps, message)


def warn_if_stiff(model: Any, state: Any, duration: float) -> IntegratorFit | None:
    """:func:`check_integrator` for a dynamic model's state (``model.equations(state).jac``):
    a :class:`StiffnessWarning` when the method does not fit; None for models without
    equations (quasi-static) or a Jacobian."""
    equations = getattr(model, "equations", None)
    if equations is None:
        return None
    system = equations(state)
    if system.jac is None:
        return None
    fit = check_integrator(model.method, system.jac(state.t, state.y), duration)
    if fit.message:
        warnings.warn(fit.message, StiffnessWarning, stacklevel=3)
    return fit
