"""Incremental form-finding along a rest-length path, with limit-point detection.

``rest_length_path(structure, rest_lengths_of, parameters)`` form-finds at each parameter
value, starting from the previous equilibrium, and accepts a step only if it stays on the
same branch: the new equilibrium must be stable and its largest node displacement from the
previous one must not exceed ``jump_factor`` times the first-order prediction
``|G dU/dp| dp`` of the tangent (``dU/dp = K_T^-1 dP/dp``, ``dP/dp = A_r diag(EA l / l0^2)
dl0/dp`` for taut members), and the smallest eigenvalue of ``K_T``, extrapolated linearly
from the last two accepted points, must stay positive over the step (else a critical
point lies inside it: a limit point, or a bifurcation where the branch turns unstable
and the solver would land on another one). A rejected step is halved; when the step falls below
``min_step`` the branch has ended at a limit (or bifurcation) point between the last
accepted parameter and the next one, and the path stops there with a message instead of
returning the collapsed or snapped-through shape the solver may have reached.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.configuration import transformation_matrix
from tensegrity_core.general.formfind import FormFindResult, form_find
from tensegrity_core.general.linalg import shifted_step_sparse
from tensegrity_core.general.statics import equilibrium_matrix, member_lengths
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure, StructureError


@dataclass
class PathResult:
    """Equilibria along the path.

    ``parameters`` the accepted parameter values (always including those of the input that
    were reached), ``results`` the form-finding result at each; ``completed`` whether the
    last input parameter was reached; ``limit_point`` ``(p_last_stable, p_no_branch)``
    bracketing the end of the branch, or ``None``; ``message``.
    """

    parameters: list[float] = field(default_factory=list)
    results: list[FormFindResult] = field(default_factory=list)
    completed: bool = False
    limit_point: tuple[float, float] | None = None
    message: str = ""

    @property
    def member_forces(self) -> NDArray[np.float64]:
        """(steps, m) member forces [N] along the path."""
        return np.array([r.member_forces for r in self.results])


def tangent_displacement(structure: Structure, result: FormFindResult, dl0_dp: NDArray[np.float64]) -> float:
    """Largest first-order node displacement per unit parameter, ``max |G dU/dp|`` [m]
    at the equilibrium of a successful ``result``."""
    config = result.configuration
    if config is None:
        raise StructureError(f"no equilibrium to linearise about: {result.message}")
    lengths = member_lengths(structure, config.coords)
    taut = ~(structure.is_string & (lengths < structure.rest_lengths))
    dt_dp = np.where(taut, -structure.EA * lengths / structure.rest_lengths**2, 0.0) * dl0_dp
    dP = -(equilibrium_matrix(structure, config, sparse=True) @ dt_dp)
    K = tangent_stiffness(structure, config, sparse=True)
    dU = shifted_step_sparse(K, dP, 1e-10).dU
    return float(np.abs(transformation_matrix(config) @ dU).max())


def rest_length_path(structure: Structure, rest_lengths_of: Callable[[float], NDArray[np.float64]],
                     parameters: Iterable[float], *, min_step: float | None = None, jump_factor: float = 4.0,
                     **form_find_options: Any) -> PathResult:
    """Follow the stable equilibrium branch as ``rest_lengths_of(p)`` (m,) [m] changes with
    ``p`` over ``parameters`` (monotonic sequence). ``min_step`` defaults to 1e-3 of the
    first parameter step. Extra keyword arguments go to :func:`form_find`."""
    params = [float(p) for p in parameters]
    if len(params) < 1:
        raise StructureError("parameters must contain at least one value")
    steps = np.diff(params)
    if steps.size and not (np.all(steps > 0) or np.all(steps < 0)):
        raise StructureError("parameters must be strictly monotonic")
    min_step = abs(float(min_step)) if min_step is not None else (1e-3 * abs(steps[0]) if steps.size else 0.0)
    current = structure.with_rest_lengths(rest_lengths_of(params[0]))
    first = form_find(current, **form_find_options)
    out = PathResult()
    if not first.success:
        out.message = f"no stable equilibrium at the first parameter {params[0]:g}: {first.message}"
        return out
    out.parameters.append(params[0])
    out.results.append(first)
    p, res = params[0], first
    lams = [(p, first.min_eigenvalue)]
    for target in params[1:]:
        while p != target:
            dp = target - p
            accepted = False
            while abs(dp) >= min_step:
                trial_p = p + dp
                if len(out.results) >= 2 and _eigenvalue_crosses(lams, trial_p):
                    dp *= 0.5
                    continue
                trial = structure.with_rest_lengths(rest_lengths_of(trial_p))
                dl0 = (trial.rest_lengths - current.rest_lengths) / dp
                predicted = tangent_displacement(current, res, dl0) * abs(dp)
                attempt = form_find(trial, x0=res.configuration, **form_find_options)
                moved = float(np.abs(attempt.nodes - res.nodes).max())
                scale = float(np.ptp(res.nodes, axis=0).max())
                if attempt.success and moved <= jump_factor * predicted + 1e-9 * scale:
                    p, res, current, accepted = trial_p, attempt, trial, True
                    lams.append((p, res.min_eigenvalue))
                    break
                dp *= 0.5
            if not accepted:
                out.limit_point = (p, p + dp * 2)
                out.message = (f"the stable branch ends at a critical point between {p:g} and "
                               f"{p + 2 * dp:g} (smallest eigenvalue of K_T -> 0: a limit point or a "
                               f"bifurcation); going on would leave the branch (snap-through, collapse "
                               f"or symmetry breaking), so the path stops at {p:g}")
                return out
            if p == target and out.parameters[-1] != p:
                out.parameters.append(p)
                out.results.append(res)
    out.completed = True
    out.message = f"reached {params[-1]:g} on one stable branch ({len(out.results)} steps)"
    return out



def _eigenvalue_crosses(lams: list[tuple[float, float]], p: float) -> bool:
    """Whether the smallest eigenvalue, extrapolated linearly from the last two accepted
    points, reaches zero by parameter ``p``."""
    (p0, l0), (p1, l1) = lams[-2], lams[-1]
    if p1 == p0:
        return False
    return l1 + (l1 - l0) / (p1 - p0) * (p - p1) <= 0.0
