"""Member forces of the class-2 mechanism in motion (or at rest), by Newton-Euler on the struts.

Springs carry ``k_j L_j`` (plus ``c_j dL_j/dt`` with damping), actuators the transmitted
force minus the fold-limit contact force. The struts are rigid rods with mass, so their
end forces are not axial in motion. With ``P_sa`` the force node ``a`` exerts on strut ``s``
(ends ``a, b``, centre ``c``, ``r_b = -r_a = (L/2) u``, ``u = (b - a)/L``)::

    P_sa + P_sb = m (a_c - g)                        (Newton)
    r_a x P_sa + r_b x P_sb = I alpha                (Euler about the centre, I = m L^2/12)
    =>  r_b x P_sb = tau := (I alpha + r_b x m (a_c - g)) / 2

and every node is massless (its forces balance). The far ends are leaves of the structure,
which gives the struts one at a time:

- BD: node D joins only springs CD, DE (and loads): ``P_BD,D`` = their force on D;
- BF: node F joins spring EF and the X reaction ``R``: ``P_BF,F = F_EF + R e_x`` with ``R``
  from the moment equation (``r_F x e_x = -lambda2/2 != 0``);
- AE, CE: both end at E with springs DE, EF, BE: ``P_sE = N_s u_s + (2 tau_s / L) n_s``
  (``n_s`` the left normal of ``u_s``); E's balance gives a 2 x 2 system for the axial
  parts ``N_AE, N_CE`` with determinant ``u_AE x u_CE``, which vanishes at the full fold
  ``rho1 + rho2 = 0``: there AE and CE are collinear and their forces are not determined
  (they grow like 1/(rho1 + rho2) near it); the minimum-norm split (equal halves) is reported.

The reported strut force is the axial force at mid-span, ``N = P_sb . u - m (a_c - g) . u / 2``
(tension +; exact for the linear variation of the axial force along a uniform rod).
``tests/sim/test_class2_members.py`` checks these against a least-squares solution of all
24 Newton-Euler equations (which also checks the Lagrangian equations of motion).
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.class2.geometry import MEMBERS
from tensegrity_core.sim.class2_effects import ZERO_LENGTH_REL, context_array, spring_rates, spring_vectors

#: Member indices of the springs in CD, DE, EF, BE order (the order of class2_effects).
SPRING_ORDER = tuple(next(i for i, m in enumerate(MEMBERS) if m.name == n) for n in ("CD", "DE", "EF", "BE"))


def node_positions(L: float, k) -> np.ndarray:
    """(N, 6, 2) node positions from an array context."""
    r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
    P = np.zeros((np.size(r1), 6, 2))
    P[:, 1, 0] = r1
    P[:, 2, 0] = s
    P[:, 3, 0] = r1 + L * cb
    P[:, 3, 1] = L * sb
    P[:, 4, 0] = 0.5 * s
    P[:, 4, 1] = 0.5 * lam1
    P[:, 5, 1] = lam2
    return P


def node_accelerations(L: float, k, qdd) -> np.ndarray:
    """(N, 6, 2) node accelerations ``J qddot + qdot^T H qdot`` for accelerations ``qdd`` (N, 3)."""
    r1, _, sb, cb, v1, v2, vb, _, lam1, lam2, e1, g2 = k
    a1, a2, ab = qdd[:, 0], qdd[:, 1], qdd[:, 2]
    sdd, sd = a1 + a2, v1 + v2
    acc = np.zeros((len(a1), 6, 2))
    acc[:, 1, 0] = a1
    acc[:, 2, 0] = sdd
    acc[:, 3, 0] = a1 - L * sb * ab - L * cb * vb**2
    acc[:, 3, 1] = L * cb * ab - L * sb * vb**2
    acc[:, 4, 0] = 0.5 * sdd
    acc[:, 4, 1] = -0.5 * e1 * sdd + 0.5 * (-4.0 * L * L / lam1**3) * sd**2     # d2 lambda1/ds2 = -4L^2/lambda1^3
    acc[:, 5, 1] = -g2 * a1 + (-L * L / lam2**3) * v1**2                      # d2 lambda2/drho1^2 = -L^2/lambda2^3
    return acc


def member_forces(params, q, qdot, qdd, actuator_forces, *, springs: bool, damping: bool,
                  gravity=None, loads=None, inertia: bool = True) -> np.ndarray:
    """Tension-positive forces (N, 10) [N] of all members, MEMBERS order.

    ``q, qdot, qdd`` (N, 3); ``actuator_forces`` (N, 2) the actuators' member forces (transmitted
    force minus contact force); ``gravity`` a vector (>= 2 components, in-plane ones used) or
    None; ``loads`` (6, 2) or None; ``inertia`` False for massless struts (quasi-static)."""
    L, m = params.L, params.m
    q = np.atleast_2d(np.asarray(q, dtype=float))
    qdot = np.atleast_2d(np.asarray(qdot, dtype=float))
    qdd = np.atleast_2d(np.asarray(qdd, dtype=float))
    N = len(q)
    k = context_array(L, q, qdot)
    P = node_positions(L, k)
    t = np.zeros((N, 10))
    t[:, 0:2] = actuator_forces
    # spring force vectors phi_j d_j (j in CD, DE, EF, BE order), tension + along d_j
    d = np.array(spring_vectors(L, k))                         # (4, 2, N)
    phi = np.zeros((4, N))
    length = np.sqrt(np.sum(d * d, axis=1))
    if springs:
        phi += np.array([params.k3, params.k2, params.k1, params.k4])[:, None]
    if damping:
        dd = np.array(spring_rates(L, k))
        c = np.array([params.c3, params.c2, params.c1, params.c4])[:, None]
        phi += c * np.sum(d * dd, axis=1) / (length**2 + (ZERO_LENGTH_REL * L) ** 2)
    t[:, SPRING_ORDER] = (phi * length).T
    f = np.transpose(phi[:, None, :] * d, (2, 0, 1))           # (N, 4, 2)
    F_D = -f[:, 0] + f[:, 1]                                   # CD ends at D, DE starts at D
    F_E = -f[:, 1] + f[:, 2] - f[:, 3]                         # DE, BE end at E, EF starts at E
    F_F = -f[:, 2]                                             # EF ends at F
    if loads is not None:
        loads = np.asarray(loads, dtype=float)
        F_D, F_E, F_F = F_D + loads[3], F_E + loads[4], F_F + loads[5]
    acc = node_accelerations(L, k, qdd) if inertia else np.zeros_like(P)
    g = np.zeros(2) if gravity is None else np.asarray(gravity, dtype=float)[:2]
    mass = m if (inertia or gravity is not None) else 0.0
    I_rot = m * L * L / 12.0 if inertia else 0.0

    def strut(a, b):
        u = (P[:, b] - P[:, a]) / L
        rel = acc[:, b] - acc[:, a]
        alpha = (u[:, 0] * rel[:, 1] - u[:, 1] * rel[:, 0]) / L
        w = mass * (0.5 * (acc[:, a] + acc[:, b]) - g)          # m (a_c - g)
        tau = 0.5 * (I_rot * alpha + 0.5 * L * (u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]))
        return u, w, tau

    def mid(Pb, u, w):
        return np.sum(Pb * u, -1) - 0.5 * np.sum(w * u, -1)

    A_, B_, C_, D_, E_, F_ = range(6)
    u, w, _ = strut(B_, D_)
    t[:, 8] = mid(F_D, u, w)                                   # BD
    u, w, tau = strut(B_, F_)
    r_cross_F = 0.5 * L * (u[:, 0] * F_F[:, 1] - u[:, 1] * F_F[:, 0])
    R = (tau - r_cross_F) / (-0.5 * L * u[:, 1])
    t[:, 5] = mid(F_F + R[:, None] * np.array([1.0, 0.0]), u, w)   # BF
    u1, w1, tau1 = strut(A_, E_)
    u2, w2, tau2 = strut(C_, E_)
    n1 = np.stack([-u1[:, 1], u1[:, 0]], -1)
    n2 = np.stack([-u2[:, 1], u2[:, 0]], -1)
    W = F_E - (2.0 / L) * (tau1[:, None] * n1 + tau2[:, None] * n2)
    det = u1[:, 0] * u2[:, 1] - u1[:, 1] * u2[:, 0]
    safe = np.abs(det) > 1e-300
    den = np.where(safe, det, 1.0)
    N1 = np.where(safe, (W[:, 0] * u2[:, 1] - W[:, 1] * u2[:, 0]) / den, 0.5 * np.sum(W * u1, -1))
    N2 = np.where(safe, (u1[:, 0] * W[:, 1] - u1[:, 1] * W[:, 0]) / den, 0.5 * np.sum(W * u1, -1))
    t[:, 4] = N1 - 0.5 * np.sum(w1 * u1, -1)                   # AE
    t[:, 9] = N2 - 0.5 * np.sum(w2 * u2, -1)                   # CE
    return t
