"""The kernels of :mod:`.loops` written with numpy arrays: the same numbers to rounding, numpy alone.

Used where numba is not installed or not wanted (:mod:`.jit`). Every function works on a
batch of states at once (the leading axis ``B``), so its per-call cost of numpy on small
arrays is shared by the batch. Arguments and results are those of the loop kernels of the
same name, but that the right-hand side places its nodes and sums over its members with the
precomputed gathers of :class:`Sums` and :func:`place` takes the bodies' index arrays
(:class:`.body_arrays.BodyIndex`), each built once per topology (a right-hand side is about
25 numpy calls whatever the size, and about 65 more with moving bodies:
:mod:`.body_arrays`); the formulas are the same, in the same order where rounding could
tell.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.rotation import cross, hat
from tensegrity_core.sim.general.kernels import body_arrays
from tensegrity_core.sim.general.kernels.loops import SMALL_ANGLE
from tensegrity_core.sim.general.kernels.plan import Plan

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


class Sums(NamedTuple):
    """A plan's gathers and sums as constant index arrays, built once per topology.

    numpy has no fast scatter-add (``np.add.at`` and ``np.bincount`` cost several times a
    gather), scipy's sparse product costs ~5-10 us of Python dispatch per call (more than the
    whole sum on a few hundred members) and fancy-indexed assignment is several times slower
    than ``np.take`` with a precomputed index, the cheapest numpy call on small and large
    arrays alike. So every placement and every sum over members is a gather.

    A state's *sources* (:func:`sources`) are the flat array ``[y (2 n_dof) | drawn
    coordinates (3n) | 0 | body nodes' positions (3 n_on) | their velocities (3 n_on)]``:
    every node coordinate and velocity is one of its entries (a free coordinate its ``x`` or
    ``v``, a fixed one its drawn value and zero velocity). ``position_a``, ``position_b``,
    ``velocity_a``, ``velocity_b`` (3, m) index the members' ends there, component-major
    (``[k, i]``: axis ``k`` of member ``i``), so ``h = x_b - x_a`` is two gathers and a
    subtraction; ``node_position``, ``node_velocity`` (n, 3) index every node.

    A state's *contributions* (:func:`contributions`) are the flat array ``[external (3n,
    node-major) | +t u (3m, component-major) | -t u (3m) | 0]``: a tensile member ``i`` pulls
    its node ``a_i`` along ``+u_i`` and its node ``b_i`` along ``-u_i``. ``free_table``
    (d, n_free) lists per free coordinate the contributions it sums (its external force,
    then its members in member order, padded with the final zero), ``on_table`` (d, n_on, 3)
    those of the body nodes' coordinates. A sum over the first axis of a gather adds the rows
    one after the other, the loops' order: the nodal forces are the loops' for the same
    member forces. ``constant`` (3n + 1,) is the drawn coordinates and the zero of the
    sources; ``bodies`` the moving bodies' :class:`~.body_arrays.BodyIndex`."""

    position_a: IntArray
    position_b: IntArray
    velocity_a: IntArray
    velocity_b: IntArray
    node_position: IntArray
    node_velocity: IntArray
    free_table: IntArray
    on_table: IntArray
    constant: FloatArray
    bodies: body_arrays.BodyIndex


def sums(base: FloatArray, free_node: IntArray, free_axis: IntArray, on_node: IntArray, on_body: IntArray,
         on_offset: FloatArray, body_dof: IntArray, member_a: IntArray, member_b: IntArray) -> Sums:
    """The :class:`Sums` of nodes drawn at ``base`` (n, 3) [m], free coordinates ``(free_node,
    free_axis)``, body nodes ``on_node`` on the moving bodies ``on_body`` (of ``len(body_dof)``)
    at the offsets ``on_offset`` (n_on, 3) [m] and members ``(member_a, member_b)``."""
    n, m, n_free, n_on, three = len(base), len(member_a), len(free_node), len(on_node), np.arange(3)
    n_dof = n_free + 6 * len(body_dof)
    zero = 2 * n_dof + 3 * n                       # the sources' zero
    position = 2 * n_dof + 3 * np.arange(n)[:, None] + three
    velocity = np.full((n, 3), zero)
    position[free_node, free_axis] = np.arange(n_free)
    velocity[free_node, free_axis] = n_dof + np.arange(n_free)
    position[on_node] = zero + 1 + 3 * np.arange(n_on)[:, None] + three
    velocity[on_node] = zero + 1 + 3 * n_on + 3 * np.arange(n_on)[:, None] + three
    # contributions per node in member order: (node, member, offset of its +t u or -t u)
    node = np.concatenate([member_a, member_b]).astype(np.int64)
    member = np.concatenate([np.arange(m), np.arange(m)])
    offset = 3 * n + np.concatenate([np.arange(m), 3 * m + np.arange(m)])
    order = np.lexsort((member, node))
    node, offset = node[order], offset[order]
    degree = np.bincount(node, minlength=n)
    slot = np.arange(len(node)) - np.repeat(np.cumsum(degree) - degree, degree)
    table = np.full((1 + int(degree.max(initial=0)), n, 3), 3 * n + 6 * m, dtype=np.int64)
    table[0] = 3 * np.arange(n)[:, None] + three                  # the external force first
    table[1 + slot, node] = offset[:, None] + m * three
    a, b = np.asarray(member_a), np.asarray(member_b)
    return Sums(position_a=np.ascontiguousarray(position[a].T), position_b=np.ascontiguousarray(position[b].T),
                velocity_a=np.ascontiguousarray(velocity[a].T), velocity_b=np.ascontiguousarray(velocity[b].T),
                node_position=position, node_velocity=velocity,
                free_table=np.ascontiguousarray(table[:, free_node, free_axis]),
                on_table=np.ascontiguousarray(table[:, on_node]),
                constant=np.append(np.asarray(base, dtype=float).ravel(), 0.0),
                bodies=body_arrays.body_index(on_body, on_offset, body_dof, n_dof))


def plan_sums(plan: Plan) -> Sums:
    """The :class:`Sums` of ``plan``'s topology."""
    return sums(plan.base, plan.free_node, plan.free_axis, plan.on_node, plan.on_body, plan.on_offset,
                plan.body_dof, plan.member_a, plan.member_b)


def sources(sums: Sums, y: FloatArray, body_nodes: FloatArray | None) -> FloatArray:
    """The sources (B, 2 n_dof + 3n + 1 + 6 n_on) of :class:`Sums` of states ``y`` (B, 2 n_dof)
    whose body nodes are at ``body_nodes`` (B, 2, n_on, 3) (positions [m], then velocities
    [m/s]; None: no body node)."""
    B = len(y)
    tail = [] if body_nodes is None else [body_nodes.reshape(B, -1)]
    if B == 1:
        one: FloatArray = np.concatenate([y, sums.constant[None]] + tail, axis=1)
        return one
    src = np.empty((B, y.shape[1] + len(sums.constant) + sum(t.shape[1] for t in tail)))
    np.concatenate([y, np.broadcast_to(sums.constant, (B, len(sums.constant)))] + tail, axis=1, out=src)
    return src


def gather_sum(values: FloatArray, table: IntArray) -> FloatArray:
    """``sum_k values[:, table[k]]`` for values (B, c) and a table (d, ...): (B, ...), the rows
    added in the table's order."""
    out: FloatArray = np.add.reduce(values.take(table, axis=1), axis=1)
    return out


def scatter(index: IntArray, values: FloatArray, n: int) -> FloatArray:
    """``out[:, j] = sum of values[:, i] with index[i] == j`` for values (B, k, 3) -> (B, n, 3): one
    ``bincount`` over every entry, each sum in the order of ``i``."""
    B = len(values)
    flat = (np.arange(0, 3 * B * n, 3 * n)[:, None] + 3 * index)[..., None] + np.arange(3)   # (B, k, 3) entries
    out = np.asarray(np.bincount(flat.ravel(), weights=values.ravel(), minlength=3 * B * n), dtype=np.float64)
    return out.reshape(B, n, 3)


def place(base: FloatArray, free_node: IntArray, free_axis: IntArray, on_node: IntArray,
          bodies: body_arrays.BodyIndex, y: FloatArray, R_ref: FloatArray, X: FloatArray, V: FloatArray,
          R: FloatArray) -> body_arrays.Moving | None:
    """Fills the nodes' positions ``X`` [m] and velocities ``V`` [m/s] (B, n, 3) and the
    bodies' rotations ``R`` (B, nb, 3, 3) of states ``y`` (B, 2 n_dof) in the charts
    ``R_ref``; returns the moving bodies placed (:func:`.body_arrays.place`; None: none)."""
    n_dof = y.shape[1] // 2
    n_free = len(free_node)
    X[...] = base
    V[...] = 0.0
    X[:, free_node, free_axis] = y[:, :n_free]
    V[:, free_node, free_axis] = y[:, n_dof:n_dof + n_free]
    if not bodies.vectors.shape[1]:
        return None
    nodes = np.empty((len(y), 2, len(on_node), 3))
    moving = body_arrays.place(bodies, y, R_ref, R, nodes)
    X[:, on_node], V[:, on_node] = nodes[:, 0], nodes[:, 1]
    return moving


def member_forces(sums: Sums, EA: FloatArray, damping: FloatArray, is_string: BoolArray, l0: FloatArray,
                  src: FloatArray, lengths: FloatArray, forces: FloatArray, pulls: FloatArray,
                  member_rates: FloatArray | None = None) -> None:
    """:func:`.loops.member_forces` of a batch of states given by their sources ``src``
    (:func:`sources`): fills ``lengths`` [m], ``forces`` [N] (B, m), ``pulls`` (B, 3, m) [N],
    the force ``t u`` of each member on its node ``a`` (component-major), and
    ``member_rates`` (B, m), if given, with the lengthening rates [m/s]. The loops' formulas
    in the loops' order."""
    h = src.take(sums.position_b, axis=1)             # (B, 3, m)
    h -= src.take(sums.position_a, axis=1)
    np.add.reduce(h * h, axis=1, out=lengths)         # the components added in turn, as the loops do
    np.sqrt(lengths, out=lengths)
    u = h
    u /= lengths[:, None]
    t = np.subtract(lengths, l0, out=forces)
    t *= EA
    t /= l0
    damped = np.count_nonzero(damping) > 0
    if member_rates is not None or damped:
        dv = src.take(sums.velocity_b, axis=1)
        dv -= src.take(sums.velocity_a, axis=1)
        dv *= u
        rate = np.add.reduce(dv, axis=1, out=member_rates)
        if damped:
            t += damping * rate
    if np.count_nonzero(is_string):
        t[is_string & (lengths < l0)] = 0.0
    np.multiply(u, t[:, None], out=pulls)


def contributions(external: FloatArray, B: int, m: int) -> tuple[FloatArray, FloatArray]:
    """The flat contributions (B, 3n + 6m + 1) of :class:`Sums` for ``B`` states of ``m``
    members, with the external nodal forces ``external`` (n, 3) [N] and the final zero in
    place, and the view (B, 3, m) where :func:`member_forces` writes the members' pulls;
    :func:`pull_back` then writes their opposites."""
    n3 = external.size
    c = np.empty((B, n3 + 6 * m + 1))
    c[:, :n3] = external.reshape(-1)
    c[:, -1] = 0.0
    pulls: FloatArray = c[:, n3:n3 + 3 * m].reshape(B, 3, m)
    return c, pulls


def pull_back(c: FloatArray, m: int) -> None:
    """Writes the opposites of the pulls into the contributions ``c`` (:func:`contributions`)."""
    np.negative(c[:, -1 - 6 * m:-1 - 3 * m], out=c[:, -1 - 3 * m:-1])


def rate(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
         on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
         body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
         body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
         damping: FloatArray, is_string: BoolArray, external: FloatArray,
         y: FloatArray, R_ref: FloatArray, l0: FloatArray, sums: Sums) -> FloatArray:
    """:func:`.loops.rate`: ``dy/dt`` of one state (``sums``: the plan's :class:`Sums`)."""
    nb, m = body_dof.shape[0], member_a.shape[0]
    out = np.empty((1, y.shape[0]))
    derivatives(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
                body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping, is_string,
                external, y[None], R_ref[None], l0[None], out, None, None, np.empty((1, nb, 3, 3)), np.empty((1, m)),
                np.empty((1, m)), sums)
    ydot: FloatArray = out[0]
    return ydot


def derivatives(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
                on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
                body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
                body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
                damping: FloatArray, is_string: BoolArray, external: FloatArray,
                y: FloatArray, R_ref: FloatArray, l0: FloatArray, out: FloatArray,
                X: FloatArray | None, V: FloatArray | None, R: FloatArray, lengths: FloatArray, forces: FloatArray,
                sums: Sums, member_rates: FloatArray | None = None,
                work: tuple[FloatArray, FloatArray] | None = None) -> None:
    """:func:`.loops.derivatives`: ``out = dy/dt`` of a batch of states, keeping ``X``, ``V``
    (None: not kept), ``R``, ``lengths`` and ``forces`` per state (``sums``: the plan's
    :class:`Sums`), and the members' lengthening rates [m/s] in ``member_rates`` (B, m) if
    given; ``work``: the contributions of :func:`contributions` for this plan and batch size
    to reuse (their external forces and zero stay in place), else allocated here."""
    B, n_dof, n_free = len(y), y.shape[1] // 2, len(free_node)
    nodes = np.empty((B, 2, len(on_node), 3)) if len(body_dof) else None
    moving = None if nodes is None else body_arrays.place(sums.bodies, y, R_ref, R, nodes)
    src = sources(sums, y, nodes)
    if X is not None:
        X[...] = src.take(sums.node_position, axis=1)
    if V is not None:
        V[...] = src.take(sums.node_velocity, axis=1)
    c, pulls = contributions(external, B, len(EA)) if work is None else work
    member_forces(sums, EA, damping, is_string, l0, src, lengths, forces, pulls, member_rates)
    pull_back(c, len(EA))
    out[:, :n_free] = y[:, n_dof:n_dof + n_free]
    np.multiply(gather_sum(c, sums.free_table), free_inv_mass, out=out[:, n_dof:n_dof + n_free])
    if moving is not None:
        wrench = body_arrays.wrenches(sums.bodies, moving, gather_sum(c, sums.on_table))
        body_arrays.accelerate(sums.bodies, body_mass, body_first_moment, body_inertia, body_inv_inertia_cm, moving,
                               R, wrench, out)


# -- Jacobian --------------------------------------------------------------------------------------
def chart_jacobians(theta: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`.loops.chart_jacobians` of rotation vectors (k, 3): ``(J_l, J_l^-1)`` (k, 3, 3)."""
    a2 = np.sum(theta * theta, axis=-1)
    small = a2 < SMALL_ANGLE * SMALL_ANGLE
    safe = np.where(small, 1.0, a2)
    a = np.sqrt(safe)
    c1 = np.where(small, 0.5 - a2 / 24.0, (1.0 - np.cos(a)) / safe)
    c2 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (a - np.sin(a)) / (safe * a))
    k = body_arrays.coefficients(a2)[..., 3]
    K = hat(theta)
    K2 = theta[..., :, None] * theta[..., None, :] - a2[..., None, None] * np.eye(3)
    eye = np.eye(3)
    Jl = eye + c1[..., None, None] * K + c2[..., None, None] * K2
    Jl_inv = eye - 0.5 * K + k[..., None, None] * K2
    return Jl, Jl_inv


def group_matrices(free_inv_mass: FloatArray, body_dof: IntArray, body_mass: FloatArray,
                   body_first_moment: FloatArray, body_inertia: FloatArray, body_inv_inertia_cm: FloatArray,
                   group_dofs: IntArray, group_size: IntArray, group_body: IntArray, y: FloatArray, R: FloatArray,
                   M_inv: FloatArray, chart: FloatArray, T: FloatArray, gyro: FloatArray) -> None:
    """:func:`.loops.group_matrices` with numpy arrays."""
    n_dof = y.shape[0] // 2
    for out in (M_inv, chart, T, gyro):
        out[...] = 0.0
    free = group_body < 0
    six = np.arange(6)
    used = six[None, :] < group_size[:, None]
    g_free, k_free = np.nonzero(free[:, None] & used)
    M_inv[g_free, k_free, k_free] = free_inv_mass[group_dofs[g_free, k_free]]
    chart[g_free, k_free, k_free] = 1.0
    T[g_free, k_free, k_free] = 1.0
    gb = np.flatnonzero(~free)
    if not gb.size:
        return
    b = group_body[gb]
    Rb = R[b]
    Rt = np.swapaxes(Rb, 1, 2)
    m = body_mass[b][:, None, None]
    s = np.matmul(Rb, body_first_moment[b][..., None])[..., 0]
    W = Rb @ body_inv_inertia_cm[b] @ Rt
    Ic = Rb @ body_inertia[b] @ Rt
    S = hat(s)
    SW = S @ W
    M_inv[gb, :3, :3] = np.eye(3) / m - (SW @ S) / (m * m)
    M_inv[gb, :3, 3:] = SW / m
    M_inv[gb, 3:, :3] = -(W @ S) / m
    M_inv[gb, 3:, 3:] = W
    theta = y[body_dof[b][:, None] + 3 + np.arange(3)]
    Jl, Jl_inv = chart_jacobians(theta)
    three = np.arange(3)
    chart[gb[:, None], three, three] = 1.0
    T[gb[:, None], three, three] = 1.0
    chart[gb, 3:, 3:] = Jl
    T[gb, 3:, 3:] = Jl_inv
    w = y[n_dof + body_dof[b][:, None] + 3 + np.arange(3)]
    Hw = hat(w)
    gyro[gb, :3, 3:] = -hat(cross(w, s)) - Hw @ S
    gyro[gb, 3:, 3:] = Hw @ Ic - hat(np.matmul(Ic, w[..., None])[..., 0])


def jacobian_blocks(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
                    on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
                    body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
                    body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
                    damping: FloatArray, is_string: BoolArray, external: FloatArray,
                    group_dofs: IntArray, group_size: IntArray, group_body: IntArray, node_group: IntArray,
                    node_selection: FloatArray, member_blocks: IntArray, diagonal_block: IntArray,
                    block_rows: IntArray, block_cols: IntArray,
                    y: FloatArray, R_ref: FloatArray, l0: FloatArray,
                    T: FloatArray, position: FloatArray, velocity: FloatArray) -> None:
    """:func:`.loops.jacobian_blocks` with numpy arrays."""
    n = base.shape[0]
    X, V = np.empty((1, n, 3)), np.empty((1, n, 3))
    R = np.empty((1, len(body_dof), 3, 3))
    bodies = body_arrays.body_index(on_body, on_offset, body_dof, len(y) // 2)
    moving = place(base, free_node, free_axis, on_node, bodies, y[None], R_ref[None], X, V, R)
    r = np.zeros((0, 3)) if moving is None else moving.arms[0, 0]
    X, R = X[0], R[0]
    h = X[member_b] - X[member_a]
    length = np.sqrt(np.sum(h * h, axis=1))
    taut = ~(is_string & (length < l0))
    u = h / length[:, None]
    t = np.where(taut, EA * (length - l0) / l0, 0.0)
    ft = t[:, None] * u
    f_el = external + scatter(np.concatenate([member_a, member_b]), np.concatenate([ft, -ft])[None], n)[0]
    uu = u[:, :, None] * u[:, None, :]
    kmat = np.where(taut, EA / l0, 0.0)[:, None, None] * uu + (t / length)[:, None, None] * (np.eye(3) - uu)
    dmat = np.where(taut, damping, 0.0)[:, None, None] * uu
    Gn = node_selection.copy()
    Gn[on_node] = 0.0
    Gn[on_node, :, :3] = np.eye(3)
    Gn[on_node, :, 3:] = -hat(r)
    Ga, Gb = Gn[member_a], Gn[member_b]
    K = np.zeros(position.shape)
    D = np.zeros(position.shape)
    for slot, (left, right, sign) in enumerate(((Ga, Ga, 1.0), (Ga, Gb, -1.0), (Gb, Ga, -1.0), (Gb, Gb, 1.0))):
        keep = (member_blocks[:, slot] >= 0) & taut
        lt = np.swapaxes(left[keep], 1, 2)
        np.add.at(K, member_blocks[keep, slot], sign * (lt @ (kmat[keep] @ right[keep])))
        np.add.at(D, member_blocks[keep, slot], sign * (lt @ (dmat[keep] @ right[keep])))
    g = -f_el[on_node]
    gr = np.sum(g * r, axis=1)
    S = 0.5 * (g[:, :, None] * r[:, None, :] + r[:, :, None] * g[:, None, :]) - gr[:, None, None] * np.eye(3)
    K_rot = np.zeros((len(K), 3, 3))
    np.add.at(K_rot, diagonal_block[node_group[on_node]], S)
    K[:, 3:, 3:] += K_rot
    G = len(group_size)
    M_inv, chart, gyro = np.empty((G, 6, 6)), np.empty((G, 6, 6)), np.empty((G, 6, 6))
    group_matrices(free_inv_mass, body_dof, body_mass, body_first_moment, body_inertia, body_inv_inertia_cm,
                   group_dofs, group_size, group_body, y, R, M_inv, chart, T, gyro)
    position[...] = -(M_inv[block_rows] @ K @ chart[block_cols])
    own = (block_rows == block_cols)[:, None, None]
    velocity[...] = -(M_inv[block_rows] @ (D + np.where(own, gyro[block_rows], 0.0)))
