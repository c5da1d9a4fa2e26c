"""References from timed trajectories of the actuator lengths (JointTrajectory semantics).

``actuator_reference(names, times, positions, velocities, accelerations, start=...)``
validates a trajectory of ``rho1, rho2`` and interpolates it as ros2_controllers'
joint_trajectory_controller does: positions only -> linear, with velocities -> cubic
Hermite, with accelerations too -> quintic (``scipy.interpolate.BPoly.from_derivatives``,
which is exactly that family). The first segment starts from the measured lengths (and,
for cubic and quintic, rates) at time 0 unless the first point is at time 0. After the
last point the reference rests there (zero rates, holding forces), whatever rate the
last point gives.

beta is not actuated and the trajectory does not say where it should be: the reference
takes its equilibrium ``beta*(rho)`` for the reference lengths, with
``beta' = grad(beta*) . rho'`` and ``beta'' = grad(beta*) . rho'' + (d grad(beta*)/dt) . rho'``;
the feedforward comes from the actuated rows of the equations of motion along that
state. It is not an exact trajectory of the dynamics while the lengths move (beta lags
its equilibrium), so the feedback trades a little length error for a beta that stays near
``beta*``; at rest the reference is exact.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Final, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2 import damping_matrix, mass_matrix, potential_gradient, velocity_terms
from tensegrity_core.class2.control.errors import (
    INVALID_GOAL,
    INVALID_JOINTS,
    OUTSIDE_WORKSPACE,
    SINGULAR_PATH,
    PlanningError,
)
from tensegrity_core.class2.control.flat import grid
from tensegrity_core.class2.control.planner import SINGULAR_MARGIN
from tensegrity_core.class2.control.reference import Reference
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.names import ACTUATED_JOINTS
from tensegrity_core.class2.params import Class2Params
from tensegrity_core.class2.singularities.distances import nearest_singularity, singularity_distance_array

#: Bounds on what a trajectory may hold (input from outside is bounded).
MAX_POINTS: Final = 100_000
MAX_DURATION: Final = 3600.0

#: Rows of two values per trajectory point (positions, velocities or accelerations), as received.
Rows: TypeAlias = Sequence[Sequence[float]]


def _array(name: str, value: Rows | None, n: int, joints: Sequence[str]) -> NDArray[np.float64] | None:
    """``value`` as an (n, 2) finite array (columns: ``joints``), or None when empty (no rows, or
    only empty rows: trajectory_msgs leaves a point's velocities empty when it has none)."""
    if value is None or len(value) == 0 or all(len(row) == 0 for row in value):
        return None
    if len(value) != n:
        raise PlanningError(f"{name}: {len(value)} rows for {n} points (give all points or none)")
    for i, row in enumerate(value):
        if len(row) != 2:
            raise PlanningError(f"{name}[{i}]: {len(row)} values for the 2 joints")
    try:
        arr = np.array([[float(v) for v in row] for row in value])
    except (TypeError, ValueError) as err:
        raise PlanningError(f"{name}: not numbers ({err})") from None
    if not np.all(np.isfinite(arr)):
        i, j = np.argwhere(~np.isfinite(arr))[0]
        raise PlanningError(f"{name}[{i}]: {joints[j]} is not finite ({float(arr[i, j]):g})")
    return arr


def joint_order(joint_names: Iterable[str]) -> list[int]:
    """Column of each of :data:`~tensegrity_core.class2.names.ACTUATED_JOINTS` in a trajectory naming the
    joints ``joint_names``."""
    names = list(joint_names)
    unknown = [n for n in names if n not in ACTUATED_JOINTS]
    if unknown:
        raise PlanningError(f"unknown joint(s) {', '.join(map(repr, unknown))}; the joints are rho1, rho2",
                            code=INVALID_JOINTS)
    if len(set(names)) != len(names):
        raise PlanningError(f"a joint is named twice in {names}", code=INVALID_JOINTS)
    if len(names) != 2:
        raise PlanningError(f"the trajectory must name both joints rho1, rho2, got {names}", code=INVALID_JOINTS)
    return [names.index(j) for j in ACTUATED_JOINTS]


def actuator_reference(names: Iterable[str], times: Sequence[float], positions: Rows, velocities: Rows | None = None,
                       accelerations: Rows | None = None, *, start_rho: ArrayLike,
                       start_rate: ArrayLike = (0.0, 0.0), params: Class2Params,
                       singular_margin: float = SINGULAR_MARGIN, force_budget: float = math.inf,
                       step: float = 0.002) -> Reference:
    """The reference of a trajectory (see the module docstring); raises :class:`PlanningError`.

    ``times`` [s] from the start, strictly increasing, >= 0; ``positions`` (n, 2) [m] in the
    order of ``names``; ``velocities`` [m/s], ``accelerations`` [m/s^2] likewise or empty;
    ``start_rho`` [m], ``start_rate`` [m/s] the measured state at the start (rho1, rho2).
    """
    names = list(names)
    cols = joint_order(names)
    n = len(times)
    if n == 0:
        raise PlanningError("the trajectory has no points")
    if n > MAX_POINTS:
        raise PlanningError(f"the trajectory has {n} points; at most {MAX_POINTS} are accepted")
    t = np.array([float(v) for v in times])
    if not np.all(np.isfinite(t)):
        raise PlanningError(f"time_from_start[{int(np.argmax(~np.isfinite(t)))}] is not finite")
    if t[0] < 0.0:
        raise PlanningError(f"time_from_start[0] = {t[0]:g} s is negative")
    if np.any(np.diff(t) <= 0.0):
        i = int(np.argmax(np.diff(t) <= 0.0)) + 1
        raise PlanningError(f"time_from_start must increase strictly: point {i} at {t[i]:g} s does not "
                            f"follow point {i - 1} at {t[i - 1]:g} s")
    if t[-1] > MAX_DURATION:
        raise PlanningError(f"the trajectory lasts {t[-1]:g} s; at most {MAX_DURATION:g} s are accepted")
    p = _array("positions", positions, n, names)
    if p is None:
        raise PlanningError("every point needs positions for rho1 and rho2")
    v = _array("velocities", velocities, n, names)
    a = _array("accelerations", accelerations, n, names)
    if a is not None and v is None:
        raise PlanningError("accelerations need velocities too")
    p = p[:, cols]
    v, a = (None if x is None else x[:, cols] for x in (v, a))
    _check_points(p, params)

    knots, derivs = [t], [p] + [x for x in (v, a) if x is not None]
    if t[0] > 0.0:
        s0 = [np.asarray(start_rho, dtype=float), np.asarray(start_rate, dtype=float), np.zeros(2)]
        knots = [np.concatenate([[0.0], t])]
        derivs = [np.vstack([s0[k], d]) for k, d in enumerate(derivs)]
    T = knots[0]
    if len(T) == 1:            # one point at time 0: rest there
        T = np.array([0.0, step])
        derivs = [np.vstack([d, d]) for d in derivs[:1]]
    # imported here: a controller that only holds never plans (its start is cheaper by the import)
    from scipy.interpolate import BPoly

    values = np.stack(derivs, 1)                     # (knots, orders, 2)
    poly = BPoly.from_derivatives(T, values)
    tg = grid(float(T[-1]), step)
    rho, rhod, rhodd = poly(tg), poly.derivative(1)(tg), poly.derivative(2)(tg)
    return _reference(tg, rho, rhod, rhodd, params, singular_margin, force_budget)


def _check_points(p: NDArray[np.float64], params: Class2Params) -> None:
    L = params.L
    for i, (r1, r2) in enumerate(p):
        if r1 < 0.0 or r2 < 0.0 or r1 >= L or r1 + r2 >= 2.0 * L:
            raise PlanningError(f"point {i}: rho = ({r1:g}, {r2:g}) m is outside the mechanism's domain "
                                f"(0 <= rho1 < L = {L:g} m, rho2 >= 0, rho1 + rho2 < 2L)", code=OUTSIDE_WORKSPACE)


def _beta_gradient(rho1: NDArray[np.float64], rho2: NDArray[np.float64], params: Class2Params) -> NDArray[np.float64]:
    """``d beta*/d rho`` (N, 2) on the paper's branch (implicit function theorem on
    ``dU/dbeta = 0``, as :func:`~tensegrity_core.class2.dbeta_drho`, vectorised)."""
    L, k2 = params.L, params.k2
    K = 2.0 * params.k3 + k2
    s = rho1 + rho2
    lam1 = np.sqrt((2.0 * L - s) * (2.0 * L + s))
    d, e = K * rho2 - k2 * rho1, k2 * lam1
    R = np.hypot(d, e)
    sb, cb = e / R, d / R
    b_i = k2 * s / lam1
    return np.stack([(k2 * sb - b_i * cb) / R, (-K * sb - b_i * cb) / R], -1)


def _reference(t: NDArray[np.float64], rho: NDArray[np.float64], rhod: NDArray[np.float64],
               rhodd: NDArray[np.float64], params: Class2Params, singular_margin: float,
               force_budget: float) -> Reference:
    L, k2, K = params.L, params.k2, 2.0 * params.k3 + params.k2
    r1, r2 = rho[:, 0], rho[:, 1]
    outside = (r1 < 0.0) | (r2 < 0.0) | (r1 >= L) | (r1 + r2 >= 2.0 * L)
    if np.any(outside):
        i = int(np.argmax(outside))
        raise PlanningError(f"the interpolated trajectory leaves the mechanism's domain at t = {t[i]:.3f} s "
                            f"(rho = ({r1[i]:.4f}, {r2[i]:.4f}) m)", code=OUTSIDE_WORKSPACE)
    dist = singularity_distance_array(r1, r2, params)
    near = dist < singular_margin
    if np.any(near):
        i = int(np.argmax(near))
        name, _ = nearest_singularity(float(r1[i]), float(r2[i]), params)
        raise PlanningError(f"the trajectory passes within {dist[i]:.3g} L of the singular set {name} at "
                            f"t = {t[i]:.3f} s (rho = ({r1[i]:.4f}, {r2[i]:.4f}) m; the margin is "
                            f"{singular_margin:g} L)", code=SINGULAR_PATH)
    if np.any(K * r2 < k2 * r1):
        i = int(np.argmax(K * r2 < k2 * r1))
        raise PlanningError(f"the trajectory leaves the paper's range (beta > pi/2) at t = {t[i]:.3f} s",
                            code=SINGULAR_PATH)
    beta = equilibrium_beta(r1, r2, params)
    g = _beta_gradient(r1, r2, params)
    bd = np.einsum("ni,ni->n", g, rhod)
    bdd = np.einsum("ni,ni->n", g, rhodd) + np.einsum("ni,ni->n", np.gradient(g, t, axis=0), rhod)
    q = np.column_stack([r1, r2, beta])
    qd = np.column_stack([rhod, bd])
    qdd = np.column_stack([rhodd, bdd])
    rows = (np.einsum("nij,nj->ni", mass_matrix(q, params), qdd) + velocity_terms(q, qd, params)
            + np.einsum("nij,nj->ni", damping_matrix(q, params), qd) + potential_gradient(q, params))
    force = -rows[:, :2]
    qd[-1], force[-1] = 0.0, -potential_gradient(q[-1], params)[:2]   # after the last point: rest there
    peak = float(np.max(np.abs(force)))
    if peak > force_budget:
        i = int(np.argmax(np.max(np.abs(force), 1)))
        raise PlanningError(f"the trajectory needs feedforward forces up to {peak:.3g} N (at t = {t[i]:.3f} s), "
                            f"over the budget of {force_budget:g} N: slow it down", code=INVALID_GOAL)
    return Reference(t[1] - t[0], q, qd, force, params, kind="actuator")
