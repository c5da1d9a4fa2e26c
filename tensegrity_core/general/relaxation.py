"""Dynamic relaxation with kinetic damping (Barnes), in the same minimal coordinates.

Pseudo-dynamics ``M dv/dt = P(U)`` integrated explicitly with time step ``dt = 1``:
``v <- v + P / M`` (``P / (2 M)`` from rest: the half step of the leapfrog scheme),
``U <- U (+) v`` (rotations through the exponential map). Fictitious
masses make the explicit scheme stable: ``M_i = mass_factor * sum_j |K_ij| / 2`` (the
Gershgorin bound of the largest eigenvalue of ``K_T``), refreshed every ``mass_update``
steps. ``K_T`` there counts slack strings with their elastic stiffness ``EA/l0``: a slack
string may tauten within a step, and a node held only by slack strings would otherwise get
no mass at all (a loaded one then flew off to overflow in one step). Kinetic damping: when the kinetic energy stops growing, the velocities are reset
to zero (the structure is near a minimum of the potential along its path). Each step
costs one force evaluation, so steps are cheap but many; it needs no factorization and
serves as the second method of the benchmark. Convergence is judged as Newton's
(:mod:`.convergence`); the full measure is only evaluated when the largest out-of-balance
force is below what convergence needs at the scales of the last mass update (x2), or for
the callback: at tens of thousands of cheap steps it would otherwise double their cost.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.convergence import FLOOR_FACTOR, balance
from tensegrity_core.general.formfind_result import (
    DENSE_LIMIT,
    FormFindResult,
    FormFindStatus,
    IterationInfo,
    diverged,
    make_result,
    structure_size,
)
from tensegrity_core.general.statics import generalized_force, potential_energy
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure, StructureError


def dynamic_relaxation(structure: Structure, config: Configuration, *, tol: float, max_iter: int | None = None,
                       callback: Callable[[IterationInfo], object] | None = None, mass_factor: float = 1.0,
                       mass_update: int = 50, check_stability: bool = True) -> FormFindResult:
    """Form-finding by dynamic relaxation; see the module docstring and
    :func:`tensegrity_core.general.formfind.form_find`. ``history`` holds one entry per
    kinetic-energy peak (velocity reset), ``callback`` runs every step."""
    if not (np.isfinite(mass_factor) and mass_factor >= 1.0):
        raise StructureError(f"mass_factor must be >= 1 for a stable explicit scheme, got {mass_factor!r}")
    max_iter = 100_000 if max_iter is None else int(max_iter)
    dense = structure.layout.n_dof <= DENSE_LIMIT
    history: list[dict[str, Any]] = []
    v = np.zeros(structure.layout.n_dof)
    kinetic = 0.0
    M: NDArray[np.float64] | None = None
    status, it = FormFindStatus.MAX_ITERATIONS, 0
    size = structure_size(structure)
    necessary = np.inf     # |P|_inf above this: not converged (no need for the full measure)
    while True:
        P = generalized_force(structure, config)
        if diverged(config, size):
            status = FormFindStatus.DIVERGED
            break
        if not np.all(np.isfinite(P)):
            status = FormFindStatus.NON_FINITE
            break
        refresh = M is None or it % mass_update == 0
        bal = None
        if refresh or callback is not None or np.abs(P).max(initial=0.0) <= necessary:
            bal = balance(structure, config)
            if bal.converged(tol):
                status = FormFindStatus.STABLE
                break
        if it >= max_iter:
            break
        if refresh:
            assert bal is not None
            necessary = 2.0 * (tol * bal.scale.max(initial=0.0) + FLOOR_FACTOR * bal.floor.max(initial=0.0))
            K = tangent_stiffness(structure, config, sparse=True, slack_elastic=True)
            rows = np.asarray(abs(K).sum(axis=1)).ravel()
            M = 0.5 * mass_factor * np.maximum(rows, 1e-12 * max(rows.max(initial=0.0), 1e-300))
        assert M is not None
        at_rest = kinetic == 0.0
        v_new = 0.5 * P / M if at_rest else v + P / M
        k_new = 0.5 * float(np.sum(M * v_new * v_new))
        it += 1
        if not at_rest and k_new < kinetic:
            v, kinetic, step = np.zeros_like(v), 0.0, 0.0
            bal = bal or balance(structure, config)
            history.append(asdict(IterationInfo(it, bal.residual, potential_energy(structure, config.coords),
                                                0.0, 0.0, residual_norm=bal.residual_norm)))
        else:
            v, kinetic = v_new, max(k_new, np.finfo(float).tiny)
            config = config.retract(v)
            step = float(np.linalg.norm(v))
        if callback is not None:
            assert bal is not None
            info = IterationInfo(it, bal.residual, float("nan"), 1.0, step, residual_norm=bal.residual_norm)
            if callback(info) is True:
                status = FormFindStatus.CALLBACK
                break
    return make_result(structure, config, status, it, history, "dynamic_relaxation", tol=tol, dense=dense,
                       check_stability=check_stability)
