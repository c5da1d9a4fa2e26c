"""Form-finding: find a stable equilibrium of a structure with given rest lengths and loads.

``form_find(structure, method=...)`` dispatches to a registry (scipy's ``METHODS`` idea):

- ``"newton"`` -- the paper's method (Sect. 5.1): Newton steps with the exact tangent
  stiffness, shifted only where it is not positive definite (:mod:`.linalg`; Eq. 81 with a
  fixed ``u`` as an option) and a line search on the total potential energy over ``x in
  [0, 1]`` (Eqs. 83-84). Linear algebra is dense (the paper's: full eigenvalues of ``K_T``
  every step) for small problems and sparse (Cholesky attempts) above ``DENSE_LIMIT``
  degrees of freedom, or as chosen with ``linear_solver``.
- ``"dynamic_relaxation"`` -- explicit pseudo-dynamics with kinetic damping (see
  :mod:`.relaxation`).

Every method judges convergence on the *relative* residual of :mod:`.convergence` (the net
force on each free node over the forces that meet there, rigid bodies' forces and moments
likewise; default tolerance ``DEFAULT_TOLERANCE``) and then checks stability
(:mod:`.stability`): the smallest eigenvalue of ``K_T`` with the zero-energy rigid-body
motions of an unsupported structure excluded, against its rounding level. A saddle is left
along its unstable mode and the search continues (``max_escapes`` times); an equilibrium
that stays unstable or neutral is a failure, not a result.
"""

from __future__ import annotations

import inspect
import numbers
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.excerpt import excerpt
from tensegrity_core.general.configuration import Configuration, transformation_matrix
from tensegrity_core.general.convergence import DEFAULT_TOLERANCE, Balance, balance
from tensegrity_core.general.formfind_result import (
    DENSE_LIMIT,
    STATUS_MESSAGES,
    FormFindResult,
    FormFindStatus,
    IterationInfo,
    diverged,
    make_result,
    structure_size,
)
from tensegrity_core.general.linalg import (
    NoDefiniteShift,
    ShiftedStep,
    moving_coordinates,
    null_space_of_rows,
    one_blas_thread,
    shifted_step_dense,
    shifted_step_sparse,
)
from tensegrity_core.general.linesearch import energy_noise, line_search
from tensegrity_core.general.relaxation import dynamic_relaxation
from tensegrity_core.general.stability import lowest_mode
from tensegrity_core.general.statics import (
    as_configuration,
    member_lengths,
    potential_energy,
)
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema import number_reason

FloatArray = NDArray[np.float64]
#: What the callback receives; returning ``True`` stops form-finding.
Callback = Callable[[IterationInfo], object]

__all__ = ["DENSE_LIMIT", "DEFAULT_TOLERANCE", "STATUS_MESSAGES", "FormFindResult", "FormFindStatus", "IterationInfo",
           "METHODS", "capped_step", "default_tolerance", "form_find", "line_search", "newton", "unbalanced_load"]


def default_tolerance(structure: Structure) -> float:
    """The default tolerance on the relative residual (dimensionless, ``DEFAULT_TOLERANCE``
    for every structure: it is relative to the forces at each node; :mod:`.convergence`)."""
    return DEFAULT_TOLERANCE


def form_find(structure: Structure, *, method: str = "newton", x0: Configuration | FloatArray | None = None,
              tol: float | None = None, max_iter: int | None = None, callback: Callback | None = None,
              strict: bool = False, **options: Any) -> FormFindResult:
    """Find a stable equilibrium of ``structure``.

    ``x0`` the start: ``None`` (the structure's reference coordinates), an (n, 3) array
    [m] or a :class:`Configuration` (e.g. ``previous_result.configuration``). ``tol`` bounds
    the relative residual (dimensionless, default ``DEFAULT_TOLERANCE``; every node's net
    force below ``tol`` times the forces that meet there, or within their rounding level:
    :mod:`.convergence`). ``callback(info)`` runs after every iteration with an
    :class:`IterationInfo`; returning ``True`` stops. On failure the result has
    ``success=False`` and says why; with ``strict=True`` a
    :class:`~tensegrity_core.errors.ConvergenceError` carrying the result is raised
    instead. Method options: see :func:`newton` and
    :func:`~tensegrity_core.general.relaxation.dynamic_relaxation`.
    """
    key = str(method).lower().replace("-", "_")
    key = METHOD_ALIASES.get(key, key)
    if key not in METHODS:
        raise StructureError(f"unknown form-finding method {method!r}; choose one of "
                             f"{', '.join(sorted(METHODS))}")
    if tol is None:
        tol = default_tolerance(structure)
    tol, why = number_reason(tol, unit="", lo=0.0, lo_open=True)
    if why:
        raise StructureError(f"tol (relative residual) {why}", entry=("tol",))
    if max_iter is not None and not _is_count(max_iter):
        raise StructureError(f"max_iter must be an integer >= 0, got {excerpt(max_iter)}", entry=("max_iter",))
    known = set(inspect.signature(METHODS[key]).parameters) - {"structure", "config", "tol", "max_iter", "callback"}
    unknown = sorted(set(options) - known)
    if unknown:
        raise StructureError(f"unknown option {unknown[0]!r} of form-finding method {key!r}; its options: "
                             f"{', '.join(sorted(known))}", entry=(unknown[0],))
    config = as_configuration(structure, x0)
    unbalanced = unbalanced_load(structure)
    if unbalanced is not None:
        result = make_result(structure, config, FormFindStatus.DIVERGED, 0, [], key, tol=float(tol), dense=False,
                             check_stability=False, reason=unbalanced.message)
    else:
        result = METHODS[key](structure, config, tol=float(tol), max_iter=max_iter, callback=callback, **options)
    if strict and not result.success:
        raise ConvergenceError(f"form-finding of {structure.name or 'the structure'} failed: "
                               f"{result.message}", result=result)
    return result


def _is_count(value: object) -> bool:
    """An integer >= 0 (a boolean is not one)."""
    return type(value) is not bool and isinstance(value, numbers.Integral) and int(value) >= 0


@dataclass
class UnbalancedLoad:
    """A net external force along a translation that no support resists: ``force`` [N] is
    the resultant of all dead loads and weights projected on the free translations
    ``directions`` (k, 3 orthonormal rows); along them ``V`` falls without bound."""

    force: np.ndarray
    directions: np.ndarray
    total_load: float

    @property
    def message(self) -> str:
        f = self.force
        free = {1: "the one free translation", 2: "the plane of free translations",
                3: "the free translations (no support at all)"}[len(self.directions)]
        return (f"no equilibrium exists: the external loads and weights have a net force of "
                f"[{f[0]:.6g}, {f[1]:.6g}, {f[2]:.6g}] N ({np.linalg.norm(f):.6g} N) in {free} of "
                f"the structure, which nothing balances (the potential energy falls without bound "
                f"along it); support the structure in that direction or balance the loads")


def unbalanced_load(structure: Structure, *, rtol: float = 1e-9) -> UnbalancedLoad | None:
    """The net load along the rigid translations the supports leave free, if it is not zero.

    A translation ``d`` that no pinned coordinate or fixed body stops stays allowed at any
    distance, and the potential changes along it by ``-F . d`` (``F`` the resultant of the
    dead loads and all weights): a structure with ``F . d != 0`` has no equilibrium at all,
    whatever the members. Rotations are not tested: a dead-load moment turns the structure
    until the loads line up, which is an equilibrium. ``None`` when balanced to within
    ``rtol`` of the total load magnitude (rounding of loads meant to cancel).
    """
    lay = structure.layout
    blocked = np.eye(3)[np.nonzero(lay.fixed_mask)[1]]
    free = null_space_of_rows(blocked) if blocked.size else np.eye(3)
    if free.shape[1] == 0:
        return None
    f = structure.external_forces
    w = lay.body_masses[:, None] * structure.gravity[None, :] if lay.body_masses.size else np.zeros((0, 3))
    total = float(np.linalg.norm(f, axis=1).sum() + np.linalg.norm(w, axis=1).sum())
    F = f.sum(axis=0) + w.sum(axis=0)
    F_free = free @ (free.T @ F)
    if total == 0.0 or np.linalg.norm(F_free) <= rtol * total:
        return None
    return UnbalancedLoad(F_free, free.T, total)


# --------------------------------------------------------------------------- Newton
@dataclass
class _Iteration:
    """Newton's settings and running state across saddle escapes."""

    tol: float
    max_iter: int
    callback: Callback | None
    dense: bool
    shift: float | None
    max_step: float
    slack_stiffness: bool
    history: list[dict[str, Any]]
    iterations: int = 0


def newton(structure: Structure, config: Configuration, *, tol: float, max_iter: int | None,
           callback: Callback | None = None, linear_solver: str = "auto", shift: float | None = None,
           max_step: float = 1.0, max_escapes: int = 3, check_stability: bool = True,
           slack_stiffness: bool = True) -> FormFindResult:
    """Newton's method with an energy line search (the paper's Sect. 5.1).

    ``shift``: ``None`` (default) shifts the Jacobi-scaled ``K_T`` by its rounding level when
    it is positive definite (Newton's own step: quadratic convergence however soft the
    structure) and, when it is not, enough to lift its most negative eigenvalue to between
    ``|lambda_min|`` and ``19 |lambda_min|`` (:mod:`.linalg`); such a step along negative
    curvature may be extended by the line search up to ``max_step``. A number ``u`` is the
    paper's Eq. 81 on the scaled matrix, ``u`` always and ``u + |lambda_min|`` when
    indefinite (the paper's ``u = 0.1`` on raw entries ~1e7 N/m is about 1e-8 relative; a
    fixed ``u`` makes convergence linear along modes softer than ``u``). Steps the line
    search would cut go through the watchdog of :func:`_newton_iterations`.
    ``linear_solver``: ``"dense"`` (full eigenvalues each step, the paper's; BLAS on one
    thread meanwhile, :func:`~.linalg.one_blas_thread`), ``"sparse"`` (Cholesky attempts)
    or ``"auto"``. ``max_step`` caps the first-order node displacement
    of a Newton step at that many structure sizes before the line search (a guard against
    near-singular directions; the paper's [0, 1] interval alone does not bound the step).
    ``max_escapes`` saddles are left along their unstable mode before an unstable result is
    reported. ``slack_stiffness`` keeps the elastic stiffness of slack strings in the Newton
    matrix (not in the energy, the forces or the stability check) while the set of slack
    strings is still changing: without it every slack string leaves a mechanism in
    ``K_T``, the shift grows to the size of the negative curvature and the steps shrink to
    ~1e-4 of their length while the strings re-tension one by one (a C-shaped spine of 100
    vertebrae spent 110 of its 164 iterations there). Once the slack set is settled the
    exact ``K_T`` is used again, so convergence onto an equilibrium with slack strings stays
    quadratic.
    """
    if linear_solver not in ("auto", "dense", "sparse"):
        raise StructureError(f"linear_solver must be 'auto', 'dense' or 'sparse', got {linear_solver!r}")
    if shift is not None and not (np.isfinite(shift) and shift > 0):
        raise StructureError(f"shift must be None or a positive number, got {shift!r}")
    if not (np.isfinite(max_step) and max_step > 0):
        raise StructureError(f"max_step must be a positive number of structure sizes, got {max_step!r}")
    dense = linear_solver == "dense" or (linear_solver == "auto" and structure.layout.n_dof <= DENSE_LIMIT)
    state = _Iteration(tol, 200 if max_iter is None else int(max_iter), callback, dense, shift, max_step,
                       slack_stiffness, [])
    escapes = 0
    timings = {"iterations": 0.0, "stability": 0.0}
    label = f"newton ({'dense' if dense else 'sparse'})"
    with one_blas_thread() if dense else nullcontext():
        while True:
            started = time.perf_counter()
            config, status = _newton_iterations(structure, config, state)
            timings["iterations"] += time.perf_counter() - started
            if status not in (FormFindStatus.STABLE, FormFindStatus.LINE_SEARCH_STALLED) or not check_stability:
                return make_result(structure, config, status, state.iterations, state.history, label, tol=tol,
                                   dense=dense, check_stability=check_stability, timings=timings)
            started = time.perf_counter()
            low = lowest_mode(tangent_stiffness(structure, config, sparse=not dense), config, dense=dense)
            timings["stability"] += time.perf_counter() - started
            # a line search stalls where the energy is flat: along an unstiffened mechanism, or on
            # a saddle; such a stall is reported as what it is (UNSTIFFENED or UNSTABLE), or left (a saddle)
            if status == FormFindStatus.LINE_SEARCH_STALLED and low.verdict == "stable":
                return make_result(structure, config, status, state.iterations, state.history, label, tol=tol, dense=dense,
                                   check_stability=True, low=low, timings=timings)
            if low.verdict != "unstable" or escapes >= max_escapes:
                return make_result(structure, config, FormFindStatus.STABLE, state.iterations, state.history, label,
                                   tol=tol, dense=dense, check_stability=True, low=low, timings=timings,
                                   stalled=status == FormFindStatus.LINE_SEARCH_STALLED)
            escapes += 1
            config = _escape_saddle(structure, config, low.vector)


def step_reach(structure: Structure, dU: FloatArray) -> float:
    """The largest first-order node displacement of the increment ``dU`` [m]: a free
    coordinate by ``|dU_i|``, a body node by at most ``|dc| + radius |dtheta|``."""
    lay = structure.layout
    bound = float(np.abs(dU[:lay.n_free]).max(initial=0.0))
    if lay.body_dof.size:
        d = dU[lay.body_dof[:, None] + np.arange(6)[None, :]]
        bound = max(bound, float((np.linalg.norm(d[:, :3], axis=1)
                                  + lay.body_radii * np.linalg.norm(d[:, 3:], axis=1)).max()))
    return bound


def capped_step(structure: Structure, dU: FloatArray, limit: float) -> FloatArray:
    """``dU`` scaled down so that no node moves (to first order) more than ``limit`` [m]."""
    bound = step_reach(structure, dU)
    return dU * (limit / bound) if bound > limit else dU


@dataclass
class _Watchdog:
    """The iterate before a relaxed step, and its Newton direction, to go back to."""

    config: Configuration
    energy: float
    balance: Balance
    direction: FloatArray


def _direction(structure: Structure, step: ShiftedStep, keep: NDArray[np.int64], limit: float) -> FloatArray:
    """The step in all of ``U`` (held coordinates 0), capped at ``limit`` [m] of node motion."""
    dU = np.zeros(structure.layout.n_dof)
    dU[keep] = step.dU
    return capped_step(structure, dU, limit)


def _negative_curvature_search(structure: Structure, config: Configuration, step: ShiftedStep,
                               keep: NDArray[np.int64], limit: float, V: float,
                               P: FloatArray) -> tuple[float, float, Configuration, FloatArray]:
    """On an indefinite matrix: the line search along the reflected step (extended up to
    ``limit``) and along the step with the smallest definite shift (mostly along the negative
    curvature, capped at ``limit``), whichever ends lower. The first suits a negative
    curvature that is local (a tall tower near its equilibrium, where the second's long step
    is cut to ~1e-6: 6 iterations at 9,000 and 36,000 members, the second alone needs 13 and
    20 or more), the second one that persists (strings going slack on a coiling spine, a
    pendulum falling over: a C spine of 60 vertebrae 29 iterations, the first alone 34,
    Eq. 81 with ``u = 1e-10`` before 37). Returns ``(x, V, configuration, direction)``."""
    best: tuple[float, float, Configuration, FloatArray] | None = None
    for candidate in (step, step.alternative):
        if candidate is None:
            continue
        dU = _direction(structure, candidate, keep, limit)
        reach = step_reach(structure, dU)
        x_max = limit / reach if reach > 0 else 1.0
        x, V_new, config_new = line_search(structure, config, dU, V, P, x_max=x_max)
        if best is None or V_new < best[1]:
            best = (x, V_new, config_new, dU)
    assert best is not None
    return best


def _newton_iterations(structure: Structure, config: Configuration,
                       state: _Iteration) -> tuple[Configuration, FormFindStatus]:
    """Iterate until converged; returns (config, status) and counts ``state.iterations``.

    Watchdog (Chamberlain, Powell, Lemarechal & Pedersen 1982; Nocedal & Wright, Sect. 15.6):
    when the line search would cut a Newton step, the full step is taken anyway ("relaxed"),
    and kept if the next full Newton step brings the energy below where the relaxed step
    started; else the iteration goes back there and does the line search, and no step is
    relaxed again until one is accepted in full. Bars much stiffer than the strings make
    the energy rise along a good full step (moving a bar's end across the bar lengthens it
    to second order, times its stiffness: the Maratos effect of constrained optimisation):
    the line search alone cut every other step to ~0.6 and needed 2-4x the iterations of a
    plain full-step Newton (26 against 8 on a prism tower with bars 1e6 times stiffer than
    its strings; with the watchdog 8). The energy rises only in a relaxed step, and the next
    iterate is below where it started.
    """
    V = potential_energy(structure, config.coords)
    size = structure_size(structure)
    slack_before: NDArray[np.bool_] | None = None
    bal = balance(structure, config)
    watch: _Watchdog | None = None
    relax = True
    while True:
        if diverged(config, size):
            return config, FormFindStatus.DIVERGED
        if not np.isfinite(bal.residual_norm) or not np.isfinite(V):
            return config, FormFindStatus.NON_FINITE
        if bal.converged(state.tol):
            return config, FormFindStatus.STABLE
        if state.iterations >= state.max_iter:
            return config, FormFindStatus.MAX_ITERATIONS
        slack = structure.is_string & (member_lengths(structure, config.coords) < structure.rest_lengths)
        changing = slack_before is None or not np.array_equal(slack, slack_before)
        slack_before = slack
        K = tangent_stiffness(structure, config, sparse=not state.dense,
                              slack_elastic=state.slack_stiffness and changing and bool(slack.any()))
        keep = moving_coordinates(config)
        P = bal.physical.generalized[keep]
        if len(keep) == K.shape[0]:
            Kk = K
        else:
            Kk = K[np.ix_(keep, keep)] if state.dense else K[keep][:, keep]
        try:
            step = shifted_step_dense(Kk, P, state.shift) if state.dense else shifted_step_sparse(Kk, P, state.shift)
        except NoDefiniteShift:
            return config, FormFindStatus.NON_FINITE
        dU = _direction(structure, step, keep, state.max_step * size)
        if watch is not None:               # the second step of a relaxed pair
            relaxed = config.retract(dU)
            x, V_new, config_new = 1.0, potential_energy(structure, relaxed.coords), relaxed
            if not V_new <= watch.energy + energy_noise(watch.energy):          # no net decrease: go back
                config, V, bal, dU = watch.config, watch.energy, watch.balance, watch.direction
                x, V_new, config_new = line_search(structure, config, dU, V, bal.physical.generalized)
                relax = False
            watch = None
        elif step.indefinite:
            x, V_new, config_new, dU = _negative_curvature_search(structure, config, step, keep, state.max_step * size,
                                                                  V, bal.physical.generalized)
        else:
            x, V_new, config_new = line_search(structure, config, dU, V, bal.physical.generalized)
            relax = relax or x == 1.0
            if relax and 0.0 < x < 1.0:
                relaxed = config.retract(dU)
                V_relaxed = potential_energy(structure, relaxed.coords)
                if np.isfinite(V_relaxed):
                    watch = _Watchdog(config, V, bal, dU)
                    x, V_new, config_new = 1.0, V_relaxed, relaxed
        trial_balance = None
        if x == 0.0:
            x, V_new, config_new, trial_balance = _below_energy_rounding(structure, config, dU, V, bal)
            if x == 0.0:
                return config, FormFindStatus.LINE_SEARCH_STALLED
        state.iterations += 1
        config, V = config_new, V_new
        bal = trial_balance if trial_balance is not None else balance(structure, config)
        info = IterationInfo(state.iterations, bal.residual, V, x, float(x * np.linalg.norm(dU)), step.shift,
                             step.min_eigenvalue, bal.residual_norm)
        state.history.append(asdict(info))
        if state.callback is not None and state.callback(info) is True:
            return config, FormFindStatus.CALLBACK


def _below_energy_rounding(structure: Structure, config: Configuration, dU: FloatArray, V: float,
                           bal: Balance) -> tuple[float, float, Configuration, Balance | None]:
    """The full step ``dU`` where the line search found no decrease because the energy cannot
    see one: the step's first-order change of energy ``|P . dU|`` [J] is below the energy's
    rounding (:func:`~.linesearch.energy_noise`), so ``V`` and its slope at the step's end
    are rounding and their signs a coin toss of the machine's arithmetic (a 6-bar one Newton
    step from converged: ``P . dU`` = 5e-21 J against 8e-10 J of rounding, the slope at the
    end +1e-22 J on one orientation of a symmetric support and -1e-23 J on another). The
    forces are not rounding there: the step is taken when it lowers the residual norm.
    Returns ``(x, V(x), configuration, its balance)``, ``x = 0`` (and no balance) when not."""
    if abs(float(np.dot(bal.physical.generalized, dU))) > energy_noise(V):
        return 0.0, V, config, None
    trial = config.retract(dU)
    V_trial = potential_energy(structure, trial.coords)
    after = balance(structure, trial)
    if not (np.isfinite(V_trial) and V_trial <= V + energy_noise(V) and after.residual_norm < bal.residual_norm):
        return 0.0, V, config, None
    return 1.0, V_trial, trial, after


def _escape_saddle(structure: Structure, config: Configuration, v: FloatArray) -> Configuration:
    """Leave a saddle along its unstable mode ``v``: minimise ``V`` over both directions,
    with the largest node displacement up to 10% of the structure's size."""
    disp = np.abs(transformation_matrix(config) @ v).max()
    size = float(np.ptp(config.coords, axis=0).max()) or 1.0
    smax = 0.1 * size / max(disp, 1e-300)
    best_v, best = potential_energy(structure, config.coords), config
    for sign in (1.0, -1.0):
        def along(step: float, sign: float = sign) -> float:
            return potential_energy(structure, config.retract(sign * step * v).coords)

        r = minimize_scalar(along, bounds=(0.0, smax), method="bounded", options={"xatol": 1e-6 * smax})
        if r.fun < best_v:
            best_v, best = r.fun, config.retract(sign * float(r.x) * v)
    return best


METHODS: dict[str, Callable[..., FormFindResult]] = {
    "newton": newton,
    "dynamic_relaxation": dynamic_relaxation,
}
METHOD_ALIASES = {"dr": "dynamic_relaxation", "relaxation": "dynamic_relaxation"}
