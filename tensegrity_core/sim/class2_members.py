"""Member forces of the class-2 mechanism in motion (or at rest), by Newton-Euler on the struts.

Springs carry ``k_j L_j`` (plus ``c_j dL_j/dt`` with damping), actuators the transmitted
force minus the fold-limit contact force. The struts are rigid rods with mass, so their
end forces are not axial in motion. They follow from d'Alembert's principle: with ``P_sa``
the force node ``a`` exerts on strut ``s`` (ends ``a, b``, centre ``c``)::

    P_sa + P_sb = m (a_c - g)                        (strut s, 2 equations)
    r_a x P_sa + r_b x P_sb = I alpha_s              (about its centre, I = m L^2/12)
    sum_members t_j u_nj + F_n + R_n - sum_struts P_sn = 0    (massless node n, 2 equations)

with ``u_nj`` the unit vector from node ``n`` along member ``j``, ``F_n`` the dead loads and
``R_n`` the support reactions (A: x, y; B, C: y; F: x). Actuators act along +X (their
signed length is ``rho_i``), also at zero length. That is 24 equations for 21 unknowns;
the three extra ones hold exactly when the state satisfies the Lagrangian equations of
motion, so the least-squares residual checks the equations of motion independently. The
reported strut force is the axial force at mid-span, ``(-P_sa.u + P_sb.u)/2`` with
``u = (b - a)/L`` (tension +), which is exact for the linear variation along a uniform rod.
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.class2.geometry import MEMBERS, NODE_NAMES
from tensegrity_core.sim.class2_effects import context_array, spring_rates, spring_vectors

#: The struts (member index, end node a, end node b) in MEMBERS order.
STRUTS = tuple((i, *m.nodes) for i, m in enumerate(MEMBERS) if m.kind == "strut")
#: Member indices of the springs in CD, DE, EF, BE order (the order of class2_effects).
SPRING_ORDER = tuple(next(i for i, m in enumerate(MEMBERS) if m.name == n) for n in ("CD", "DE", "EF", "BE"))
ACTUATORS = (0, 1)
_REACTIONS = ((0, 0), (0, 1), (1, 1), (2, 1), (5, 0))   # (node, axis)


def node_positions(L: float, k) -> np.ndarray:
    """(N, 6, 2) node positions from an array context."""
    r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
    z = np.zeros_like(r1)
    return np.stack([np.stack([z, z], -1), np.stack([r1, z], -1), np.stack([s, z], -1),
                     np.stack([r1 + L * cb, L * sb], -1), np.stack([0.5 * s, 0.5 * lam1], -1),
                     np.stack([z, lam2], -1)], -2)


def node_accelerations(L: float, k, qdd) -> np.ndarray:
    """(N, 6, 2) node accelerations ``J qddot + qdot^T H qdot`` for accelerations ``qdd`` (N, 3)."""
    r1, _, sb, cb, v1, v2, vb, _, lam1, lam2, e1, g2 = k
    a1, a2, ab = qdd[:, 0], qdd[:, 1], qdd[:, 2]
    eta1 = -4.0 * L * L / lam1**3
    eta2 = -L * L / lam2**3
    sdd, sd = a1 + a2, v1 + v2
    z = np.zeros_like(a1)
    return np.stack([
        np.stack([z, z], -1),
        np.stack([a1, z], -1),
        np.stack([sdd, z], -1),
        np.stack([a1 - L * sb * ab - L * cb * vb**2, L * cb * ab - L * sb * vb**2], -1),
        np.stack([0.5 * sdd, -0.5 * e1 * sdd + 0.5 * eta1 * sd**2], -1),
        np.stack([z, -g2 * a1 + eta2 * v1**2], -1),
    ], -2)


def member_lengths(L: float, q) -> np.ndarray:
    """(N, 10) member lengths [m] in MEMBERS order."""
    P = node_positions(L, context_array(L, q, np.zeros_like(q)))
    a = np.array([m.nodes[0] for m in MEMBERS])
    b = np.array([m.nodes[1] for m in MEMBERS])
    return np.linalg.norm(P[:, b] - P[:, a], axis=-1)


def member_forces(params, q, qdot, qdd, actuator_forces, *, springs: bool, damping: bool,
                  gravity=None, loads=None, inertia: bool = True) -> tuple:
    """Tension-positive forces (N, 10) [N] of all members and the residual (N,) [N] of the
    d'Alembert system (zero when the state satisfies the equations of motion).

    ``q, qdot, qdd`` (N, 3); ``actuator_forces`` (N, 2) the actuators' member forces (transmitted
    force minus contact force); ``gravity`` an in-plane vector (2,) or None; ``loads`` (6, 2)
    or None; ``inertia`` False for massless struts (quasi-static: accelerations ignored)."""
    L, m = params.L, params.m
    q = np.atleast_2d(np.asarray(q, dtype=float))
    qdot = np.atleast_2d(np.asarray(qdot, dtype=float))
    qdd = np.atleast_2d(np.asarray(qdd, dtype=float))
    N = len(q)
    k = context_array(L, q, qdot)
    P = node_positions(L, k)
    t = np.zeros((N, 10))
    t[:, 0:2] = actuator_forces
    if springs or damping:
        d = np.array(spring_vectors(L, k))                  # (4, 2, N)
        lengths = np.sqrt(np.sum(d * d, axis=1))            # (4, N)
        if springs:
            kk = np.array([params.k3, params.k2, params.k1, params.k4])
            t[:, SPRING_ORDER] += (kk[:, None] * lengths).T
        if damping:
            dd = np.array(spring_rates(L, k))
            cc = np.array([params.c3, params.c2, params.c1, params.c4])
            rate = np.sum(d * dd, axis=1) / np.maximum(lengths, 1e-300)
            t[:, SPRING_ORDER] += (cc[:, None] * rate).T
    if inertia:
        acc = node_accelerations(L, k, qdd)
        mass = m
    else:
        acc = np.zeros_like(P)
        mass = m if gravity is not None else 0.0
    g = np.zeros(2) if gravity is None else np.asarray(gravity, dtype=float)[:2]
    A = np.zeros((N, 24, 21))
    rhs = np.zeros((N, 24))
    inertia_rot = m * L * L / 12.0 if inertia else 0.0
    for s_i, (member, a, b) in enumerate(STRUTS):
        col = 4 * s_i
        row = 3 * s_i
        ra = P[:, a] - 0.5 * (P[:, a] + P[:, b])
        rb = -ra
        ac = 0.5 * (acc[:, a] + acc[:, b])
        rvec = P[:, b] - P[:, a]
        rel = acc[:, b] - acc[:, a]
        alpha = (rvec[:, 0] * rel[:, 1] - rvec[:, 1] * rel[:, 0]) / (L * L)
        A[:, row, col] = A[:, row, col + 2] = 1.0
        A[:, row + 1, col + 1] = A[:, row + 1, col + 3] = 1.0
        rhs[:, row:row + 2] = mass * (ac - g)
        A[:, row + 2, col] = -ra[:, 1]
        A[:, row + 2, col + 1] = ra[:, 0]
        A[:, row + 2, col + 2] = -rb[:, 1]
        A[:, row + 2, col + 3] = rb[:, 0]
        rhs[:, row + 2] = inertia_rot * alpha
        for end, node in ((0, a), (1, b)):
            A[:, 12 + 2 * node, col + 2 * end] = -1.0
            A[:, 12 + 2 * node + 1, col + 2 * end + 1] = -1.0
    for j, (node, axis) in enumerate(_REACTIONS):
        A[:, 12 + 2 * node + axis, 16 + j] = 1.0
    for i, mem in enumerate(MEMBERS):
        if mem.kind == "strut":
            continue
        a, b = mem.nodes
        if mem.kind == "actuator":
            # a prismatic actuator along +X: its signed length is rho_i, so its line of action
            # stays +X even at (and, in the unconstrained model, beyond) zero length
            u = np.broadcast_to(np.array([1.0, 0.0]), P[:, a].shape)
        else:
            u = P[:, b] - P[:, a]
            u = u / np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-300)
        # tension pulls node a toward b and node b toward a; moved to the right-hand side
        rhs[:, 12 + 2 * a:12 + 2 * a + 2] -= t[:, i:i + 1] * u
        rhs[:, 12 + 2 * b:12 + 2 * b + 2] += t[:, i:i + 1] * u
    if loads is not None:
        rhs[:, 12:] -= np.asarray(loads, dtype=float).reshape(1, 12)
    x = np.linalg.pinv(A) @ rhs[..., None]
    residual = np.linalg.norm(A @ x - rhs[..., None], axis=(-2, -1))
    x = x[..., 0]
    for s_i, (member, a, b) in enumerate(STRUTS):
        u = (P[:, b] - P[:, a]) / L
        col = 4 * s_i
        t[:, member] = 0.5 * (-np.sum(x[:, col:col + 2] * u, -1) + np.sum(x[:, col + 2:col + 4] * u, -1))
    return t, residual


def node_names() -> tuple:
    return NODE_NAMES
