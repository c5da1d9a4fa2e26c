"""Form-finding: find a stable equilibrium of a structure with given rest lengths and loads.

``form_find(structure, method=...)`` dispatches to a registry (scipy's ``METHODS`` idea):

- ``"newton"`` -- the paper's method (Sect. 5.1): Newton steps with the exact tangent
  stiffness shifted to positive definite (Eq. 81) and a line search on the total potential
  energy over ``x in [0, 1]`` (Eqs. 83-84). Linear algebra is dense (the paper's: full
  eigenvalues of ``K_T`` every step) for small problems and sparse (Cholesky attempts with
  increasing shift) above ``DENSE_LIMIT`` degrees of freedom, or as chosen with
  ``linear_solver``.
- ``"dynamic_relaxation"`` -- explicit pseudo-dynamics with kinetic damping (see
  :mod:`.relaxation`).

Every method judges convergence on the *physical* residual (net force on each free
coordinate, net force and moment on each rigid body; see
:class:`~tensegrity_core.general.statics.OutOfBalance`) and then checks stability: the
smallest eigenvalue of ``K_T`` with the zero-energy rigid-body motions of an unsupported
structure excluded. A saddle is left along its unstable mode and the search continues
(``max_escapes`` times); an equilibrium that stays unstable or neutral is a failure, not a
result.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np
import scipy.linalg as la
from scipy.linalg import qr
from scipy.optimize import brentq, minimize_scalar

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.general.configuration import Configuration
from tensegrity_core.general.linalg import (
    NEUTRAL_TOL,
    lowest_mode,
    shifted_step_dense,
    shifted_step_sparse,
    zero_energy_rigid_modes,
)
from tensegrity_core.general.statics import (
    as_configuration,
    forces_from_lengths,
    generalized_force,
    member_lengths,
    out_of_balance,
    potential_energy,
)
from tensegrity_core.general.stiffness import tangent_stiffness
from tensegrity_core.general.structure import Structure, StructureError

#: Up to this many degrees of freedom ``linear_solver="auto"`` uses dense linear algebra.
DENSE_LIMIT = 300

STATUS = {
    0: "converged to a stable equilibrium",
    1: "maximum number of iterations reached",
    2: "line search found no lower potential energy along the step",
    3: "converged to an unstable equilibrium",
    4: "converged to an equilibrium with an unstiffened mechanism (zero stiffness)",
    5: "stopped by the callback",
    6: "the iteration produced non-finite values",
    7: "diverged: the potential energy falls without bound (no equilibrium, e.g. unbalanced "
       "loads on a structure free to move)",
}


def diverged(config: Configuration, size: float) -> bool:
    """Whether a node has moved farther than 1e6 structure sizes from the origin of the
    drawing (the sign of a potential unbounded below)."""
    return bool(np.abs(config.coords).max() > 1e6 * size)


@dataclass
class IterationInfo:
    """What the callback receives after every iteration.

    ``residual`` [N] (see :class:`OutOfBalance`), ``energy`` [J], ``step_length`` the line
    search factor ``x`` of Eq. 83, ``step_norm`` the Euclidean norm of ``x dU``, ``shift``
    the identity shift added to the Jacobi-scaled ``K_T`` (Eq. 81), ``min_eigenvalue`` the
    smallest scaled eigenvalue when the method computed it (dense Newton) else ``None``.
    """

    iteration: int
    residual: float
    energy: float
    step_length: float
    step_norm: float
    shift: float | None = None
    min_eigenvalue: float | None = None


@dataclass
class FormFindResult:
    """Outcome of form-finding (scipy ``OptimizeResult`` style).

    ``nodes`` (n, 3) [m], ``member_forces`` (m,) [N, tension +], ``member_lengths`` (m,) [m],
    in the order of the description. ``residual`` [N] the physical out-of-balance measure,
    ``force_residual`` [N] and ``moment_residual`` [N m] its parts; ``min_eigenvalue`` the
    smallest eigenvalue of ``K_T`` (units of ``U``) excluding ``rigid_body_modes``
    zero-energy rigid motions; ``stable`` from the sign of the Jacobi-scaled one;
    ``configuration`` restarts form-finding (``form_find(..., x0=result.configuration)``).
    """

    success: bool
    status: int
    message: str
    nodes: np.ndarray
    member_forces: np.ndarray
    member_lengths: np.ndarray
    iterations: int
    residual: float
    min_eigenvalue: float
    stable: bool
    history: list = field(default_factory=list)
    method: str = ""
    force_residual: float = float("nan")
    moment_residual: float = float("nan")
    energy: float = float("nan")
    rigid_body_modes: int = 0
    configuration: Configuration | None = field(default=None, repr=False)
    structure: Structure | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """Plain data for YAML/JSON: nodes and members by name, in description order."""
        s = self.structure
        slack = s.is_string & (self.member_lengths < s.rest_lengths)
        return {
            "structure": s.name,
            "success": bool(self.success),
            "status": int(self.status),
            "message": self.message,
            "method": self.method,
            "iterations": int(self.iterations),
            "residual": float(self.residual),
            "force_residual": float(self.force_residual),
            "moment_residual": float(self.moment_residual),
            "energy": float(self.energy),
            "min_eigenvalue": float(self.min_eigenvalue),
            "stable": bool(self.stable),
            "rigid_body_modes": int(self.rigid_body_modes),
            "nodes": {n: [float(v) for v in xyz] for n, xyz in zip(s.node_names, self.nodes)},
            "members": {
                name: {"force": float(t), "length": float(l), "rest_length": float(l0),
                       "force_density": float(t / l), "slack": bool(sl)}
                for name, t, l, l0, sl in zip(s.member_names, self.member_forces,
                                              self.member_lengths, s.rest_lengths, slack)
            },
        }


def structure_size(structure: Structure) -> float:
    """Largest extent of the drawing [m] (1 for a single point)."""
    return float(np.ptp(structure.nodes, axis=0).max()) or 1.0


def default_tolerance(structure: Structure) -> float:
    """Default residual tolerance [N]: ``1e-10`` times the largest axial stiffness EA."""
    return 1e-10 * float(structure.EA.max())


def form_find(structure: Structure, *, method: str = "newton", x0=None, tol: float | None = None,
              max_iter: int | None = None, callback: Callable[[IterationInfo], object] | None = None,
              strict: bool = False, **options) -> FormFindResult:
    """Find a stable equilibrium of ``structure``.

    ``x0`` the start: ``None`` (the structure's reference coordinates), an (n, 3) array
    [m] or a :class:`Configuration` (e.g. ``previous_result.configuration``). ``tol`` [N]
    bounds the physical residual (default :func:`default_tolerance`). ``callback(info)``
    runs after every iteration with an :class:`IterationInfo`; returning ``True`` stops.
    On failure the result has ``success=False`` and says why; with ``strict=True`` a
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
    if not (np.isfinite(tol) and tol > 0):
        raise StructureError(f"tol must be a positive number of newtons, got {tol!r}")
    if max_iter is not None and int(max_iter) < 0:
        raise StructureError(f"max_iter must be >= 0, got {max_iter!r}")
    config = as_configuration(structure, x0)
    unbalanced = unbalanced_load(structure)
    if unbalanced is not None:
        result = _result(structure, config, 7, 0, [], key, False, False, reason=unbalanced.message)
    else:
            result = METHODS[key](structure, config, tol=float(tol), max_iter=max_iter,
                              callback=callback, **options)
    if strict and not result.success:
        raise ConvergenceError(f"form-finding of {structure.name or 'the structure'} failed: "
                               f"{result.message}", result=result)
    return result


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
    free = la.null_space(blocked) if blocked.size else np.eye(3)
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
def newton(structure: Structure, config: Configuration, *, tol: float, max_iter: int | None,
           callback=None, linear_solver: str = "auto", shift: float = 1e-10,
           max_step: float = 1.0, max_escapes: int = 3, check_stability: bool = True,
           slack_stiffness: bool = True) -> FormFindResult:
    """Shifted Newton with an energy line search (the paper's Sect. 5.1).

    ``shift`` is ``u`` of Eq. 81, applied to the Jacobi-scaled ``K_T`` (unit diagonal), so
    it is dimensionless: the paper's ``u = 0.1`` on raw matrices with entries ~1e7 N/m is
    about 1e-8 relative; the default 1e-10 keeps the convergence along soft
    prestress-stiffened modes quadratic for practical purposes. ``linear_solver``: ``"dense"`` (full eigenvalues each step, the
    paper's), ``"sparse"`` (Cholesky attempts with increasing shift) or ``"auto"``.
    ``max_step`` caps the first-order node displacement of a Newton step at that many
    structure sizes before the line search (a guard against near-singular directions; the
    paper's [0, 1] interval alone does not bound the step). ``max_escapes`` saddles are left
    along their unstable mode before an unstable result is reported. ``slack_stiffness``
    keeps the elastic stiffness of slack strings in the Newton matrix (not in the energy, the
    forces or the stability check) while the set of slack strings is still changing: without
    it every slack string leaves a mechanism in ``K_T``, the shift of Eq. 81 grows to the
    size of the negative curvature and the steps shrink to ~1e-4 of their length while the
    strings re-tension one by one (a C-shaped spine of 100 vertebrae spent 110 of its 164
    iterations there). Once the slack set is settled the exact ``K_T`` is used again, so
    convergence onto an equilibrium with slack strings stays quadratic.
    """
    if linear_solver not in ("auto", "dense", "sparse"):
        raise StructureError(f"linear_solver must be 'auto', 'dense' or 'sparse', got {linear_solver!r}")
    if not (np.isfinite(shift) and shift > 0):
        raise StructureError(f"shift must be a positive number, got {shift!r}")
    if not (np.isfinite(max_step) and max_step > 0):
        raise StructureError(f"max_step must be a positive number of structure sizes, got {max_step!r}")
    max_iter = 200 if max_iter is None else int(max_iter)
    dense = linear_solver == "dense" or (linear_solver == "auto" and structure.layout.n_dof <= DENSE_LIMIT)
    history: list[dict] = []
    it, escapes = 0, 0
    label = f"newton ({'dense' if dense else 'sparse'})"
    while True:
        config, it, status = _newton_iterations(structure, config, tol, max_iter, it, callback,
                                                dense, shift, max_step, history, slack_stiffness)
        if status != 0 or not check_stability:
            return _result(structure, config, status, it, history, label, dense, check_stability)
        low = lowest_mode(tangent_stiffness(structure, config, sparse=not dense), config, dense=dense)
        if low.scaled >= -NEUTRAL_TOL or escapes >= max_escapes:
            return _result(structure, config, 0, it, history, label, dense, True, low)
        escapes += 1
        config = _escape_saddle(structure, config, low.vector)


def _moving_coordinates(config: Configuration) -> np.ndarray:
    """Indices of ``U`` that Newton moves: all but one coordinate per zero-energy rigid-body
    motion of an unsupported structure (chosen by pivoted QR, so the rest is transversal to
    those motions). Off equilibrium ``K_T`` is not singular along rigid motions, only nearly
    so and possibly negative; left in, they swamp the shifted Newton step."""
    n = config.structure.layout.n_dof
    Z = zero_energy_rigid_modes(config)
    if Z.shape[1] == 0:
        return np.arange(n)
    _, _, piv = qr(Z.T, pivoting=True, mode="economic")
    return np.setdiff1d(np.arange(n), piv[:Z.shape[1]])


def capped_step(structure: Structure, dU: np.ndarray, limit: float) -> np.ndarray:
    """``dU`` scaled down so that no node moves (to first order) more than ``limit`` [m]:
    a free coordinate by ``|dU_i|``, a body node by at most ``|dc| + radius |dtheta|``."""
    lay = structure.layout
    bound = float(np.abs(dU[:lay.n_free]).max(initial=0.0))
    if lay.body_dof.size:
        d = dU[lay.body_dof[:, None] + np.arange(6)[None, :]]
        bound = max(bound, float((np.linalg.norm(d[:, :3], axis=1)
                                  + lay.body_radii * np.linalg.norm(d[:, 3:], axis=1)).max()))
    return dU * (limit / bound) if bound > limit else dU


def _newton_iterations(structure, config, tol, max_iter, it, callback, dense, u, max_step, history,
                       slack_stiffness=True):
    """Iterate until the residual is below ``tol``; returns (config, iterations, status)."""
    V = potential_energy(structure, config.coords)
    size = structure_size(structure)
    slack_before = None
    while True:
        ob = out_of_balance(structure, config)
        if diverged(config, size):
            return config, it, 7
        if not np.isfinite(ob.residual) or not np.isfinite(V):
            return config, it, 6
        if ob.residual <= tol:
            return config, it, 0
        if it >= max_iter:
            return config, it, 1
        slack = structure.is_string & (member_lengths(structure, config.coords) < structure.rest_lengths)
        changing = slack_before is None or not np.array_equal(slack, slack_before)
        slack_before = slack
        K = tangent_stiffness(structure, config, sparse=not dense,
                              slack_elastic=slack_stiffness and changing and bool(slack.any()))
        keep = _moving_coordinates(config)
        P = ob.generalized[keep]
        Kk = K[np.ix_(keep, keep)] if dense else K[keep][:, keep]
        step = shifted_step_dense(Kk, P, u) if dense else shifted_step_sparse(Kk, P, u)
        dU = np.zeros(structure.layout.n_dof)
        dU[keep] = step.dU
        dU = capped_step(structure, dU, max_step * size)
        x, V_new, config_new = line_search(structure, config, dU, V, ob.generalized)
        if x == 0.0:
            return config, it, 2
        it += 1
        config, V = config_new, V_new
        info = IterationInfo(it, float(out_of_balance(structure, config).residual), V, x,
                             float(x * np.linalg.norm(dU)), step.shift, step.min_eigenvalue)
        history.append(asdict(info))
        if callback is not None and callback(info) is True:
            return config, it, 5


def line_search(structure: Structure, config: Configuration, dU, V0: float, P0):
    """Bounded line search of Eqs. 83-84: ``x`` minimising ``V(U + x dU)`` on ``[0, 1]``.

    The full step is taken when the potential has not risen and its slope there is
    non-negative-descent or small (``|phi'(1)| <= 0.01 |phi'(0)|``, the Newton regime, so
    convergence stays quadratic); otherwise the slope ``phi'(x) = -P(x) . dU`` (computed
    from forces, free of the round-off of energy differences) is driven to zero by Brent's
    method when it changes sign on ``[0, 1]``, and ``V`` itself is minimised by bounded
    Brent (MATLAB's ``fminbnd``) when it does not. Returns ``(x, V(x), configuration)``;
    ``x = 0`` when no decrease was found.
    """
    slope0 = -float(np.dot(P0, dU))
    noise = 1e-12 * max(abs(V0), 1e-300)
    cache: dict[float, tuple[float, Configuration]] = {}

    def phi(x: float) -> float:
        if x not in cache:
            c = config.retract(x * dU)
            v = potential_energy(structure, c.coords)
            cache[x] = (v if np.isfinite(v) else np.inf, c)
        return cache[x][0]

    def slope(x: float) -> float:
        phi(x)
        P = generalized_force(structure, cache[x][1])
        return -float(np.dot(P, dU))

    if slope0 >= 0:            # not a descent direction (cannot happen with a PD shift)
        return 0.0, V0, config
    V1 = phi(1.0)
    if np.isfinite(V1):
        s1 = slope(1.0)
        if np.isfinite(s1) and V1 <= V0 + noise and (s1 <= 0 or abs(s1) <= 0.01 * abs(slope0)):
            return 1.0, V1, cache[1.0][1]
        if np.isfinite(s1) and s1 > 0:
            x = brentq(slope, 0.0, 1.0, xtol=1e-10, rtol=1e-6, maxiter=100)
            if phi(x) < V0:
                return x, cache[x][0], cache[x][1]
    res = minimize_scalar(phi, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-8})
    x = float(res.x)
    if phi(x) < V0:
        return x, cache[x][0], cache[x][1]
    x = 1.0
    for _ in range(60):
        x *= 0.5
        if phi(x) < V0:
            return x, cache[x][0], cache[x][1]
    return 0.0, V0, config


def _escape_saddle(structure: Structure, config: Configuration, v: np.ndarray) -> Configuration:
    """Leave a saddle along its unstable mode ``v``: minimise ``V`` over both directions,
    with the largest node displacement up to 10% of the structure's size."""
    from tensegrity_core.general.configuration import transformation_matrix

    disp = np.abs(transformation_matrix(config) @ v).max()
    size = float(np.ptp(config.coords, axis=0).max()) or 1.0
    smax = 0.1 * size / max(disp, 1e-300)
    best_v, best = potential_energy(structure, config.coords), config
    for sign in (1.0, -1.0):
        f = lambda s: potential_energy(structure, config.retract(sign * s * v).coords)  # noqa: E731
        r = minimize_scalar(f, bounds=(0.0, smax), method="bounded", options={"xatol": 1e-6 * smax})
        if r.fun < best_v:
            best_v, best = r.fun, config.retract(sign * float(r.x) * v)
    return best


def _result(structure, config, status, it, history, method, dense, checked, low=None,
            reason: str | None = None) -> FormFindResult:
    """Build the result: forces, lengths, residual and stability (computed if not given; a
    converged but unstable or neutral equilibrium becomes status 3 or 4)."""
    ob = out_of_balance(structure, config)
    lengths = member_lengths(structure, config.coords)
    if low is None and checked and status == 0:
        low = lowest_mode(tangent_stiffness(structure, config, sparse=not dense), config, dense=dense)
    stable = bool(low is not None and low.scaled > NEUTRAL_TOL)
    if status == 0 and checked and not stable:
        status = 4 if low.scaled >= -NEUTRAL_TOL else 3
    message = STATUS[status]
    if status == 0 and not checked:
        message = "converged (stability not checked)"
    if status in (3, 4):
        message += f" (smallest scaled eigenvalue {low.scaled:.3g})"
    if reason is not None:
        message = reason
    elif status in (6, 7):
        message += f" after {it} iterations"
    if status == 1:
        message += f" ({it}); residual {ob.residual:.3g} N"
    if status == 2:
        message += f" after {it} iterations; residual {ob.residual:.3g} N"
        message += rounding_floor_note(structure, config.coords, ob.residual)
    return FormFindResult(
        success=status == 0, status=status, message=message, nodes=config.coords.copy(),
        member_forces=forces_from_lengths(structure, lengths), member_lengths=lengths,
        iterations=it, residual=ob.residual,
        min_eigenvalue=low.value if low is not None else float("nan"), stable=stable,
        history=history, method=method, force_residual=ob.force_residual,
        moment_residual=ob.moment_residual, energy=potential_energy(structure, config.coords),
        rigid_body_modes=low.rigid_body_modes if low is not None else 0,
        configuration=config, structure=structure)


def rounding_floor_note(structure: Structure, coords: np.ndarray, residual: float) -> str:
    """Why a residual cannot fall further: a member of axial stiffness ``EA/l0`` turns the
    rounding of its end coordinates (``eps |x|``) into a force error ``EA/l0 eps |x|`` [N].
    Very short (nearly coincident nodes) or very stiff members raise that floor above the
    tolerance. Returns '' when the residual is well above the floor."""
    reach = np.abs(coords).max(axis=1)
    floors = (structure.EA / structure.rest_lengths) * np.finfo(float).eps * np.maximum(
        reach[structure.members[:, 0]], reach[structure.members[:, 1]])
    i = int(np.argmax(floors))
    k, floor = structure.EA / structure.rest_lengths, float(floors[i])
    if residual > 10.0 * floor:
        return ""
    return (f"; that is the rounding floor of member {structure.member_names[i]!r} (EA/l0 = {k[i]:.3g} N/m "
            f"times eps times the coordinates: {floor:.3g} N; rest length {structure.rest_lengths[i]:.3g} m = "
            f"{structure.rest_lengths[i] / structure_size(structure):.3g} of the structure size): raise tol "
            f"above it or make the member longer or softer")


def _dynamic_relaxation(structure, config, **kw):
    from tensegrity_core.general.relaxation import dynamic_relaxation
    return dynamic_relaxation(structure, config, **kw)


METHODS: dict[str, Callable[..., FormFindResult]] = {
    "newton": newton,
    "dynamic_relaxation": _dynamic_relaxation,
}
METHOD_ALIASES = {"dr": "dynamic_relaxation", "relaxation": "dynamic_relaxation"}
