"""Force effects of the class-2 mechanism as independent pieces.

Every effect maps the *kinematic context* of one state to its contribution ``Q`` to the
generalised force (``M qddot + C = sum Q``; units N, N, N m for ``q = (rho1, rho2, beta)``),
and gives its potential energy (conservative effects) and its derivatives ``dQ/dq``,
``dQ/dqdot`` for the integrator's Jacobian. The simulator composes only the effects a scene
lists; an unlisted effect is never called.

Kinematics (see :mod:`tensegrity_core.class2.geometry`): ``s = rho1 + rho2``,
``lambda1 = sqrt(4L^2 - s^2)``, ``lambda2 = sqrt(L^2 - rho1^2)``, ``e1 = s/lambda1 =
-dlambda1/drho_i``, ``g2 = rho1/lambda2 = -dlambda2/drho1``. Nodes::

    A = (0, 0)   B = (rho1, 0)   C = (s, 0)   D = (rho1 + L cos b, L sin b)
    E = (s/2, lambda1/2)          F = (0, lambda2)

Springs (zero free length) CD k3/c3, DE k2/c2, EF k1/c1, BE k4/c4 with node-difference
vectors ``d_j`` and Jacobians ``J_j = dd_j/dq``: springs give ``Q = -sum k_j J_j^T d_j``,
dampers ``Q = -sum c_j (d_j . J_j qdot) / |d_j|^2 J_j^T d_j`` (the damper force along the
spring is ``c_j dL_j/dt``). Gravity acts on the struts' centres (mass ``m`` each); loads are
dead forces on nodes, ``Q = sum_n J_n^T F_n``. Only in-plane components act: the
mechanism's supports take the rest.
"""

from __future__ import annotations

import math

import numpy as np

from tensegrity_core.class2.params import Class2Params
from tensegrity_core.errors import DomainError, SingularityError

#: Regularisation of the damper direction at zero spring length (relative to L), as in
#: :mod:`tensegrity_core.class2.dynamics`.
ZERO_LENGTH_REL = 1e-12
#: The kinematic context refuses states with lambda1 or lambda2 below this (relative to L).
LAMBDA_MIN_REL = 1e-4


def context(L: float, y) -> tuple:
    """Kinematic context of state ``y = (rho1, rho2, beta, rho1dot, rho2dot, betadot, ...)``.

    Returns ``(r1, r2, sb, cb, v1, v2, vb, s, lam1, lam2, e1, g2)`` (plain floats). Raises
    :class:`SingularityError` when lambda1 or lambda2 is below ``1e-4 L`` and
    :class:`DomainError` when the configuration does not exist.
    """
    r1, r2, b, v1, v2, vb = y[0], y[1], y[2], y[3], y[4], y[5]
    s = r1 + r2
    lam1_sq = (2.0 * L - s) * (2.0 * L + s)
    lam2_sq = (L - r1) * (L + r1)
    limit_sq = (LAMBDA_MIN_REL * L) ** 2
    if not (lam1_sq >= limit_sq and lam2_sq >= limit_sq):
        _refuse(L, r1, r2, lam1_sq, lam2_sq, limit_sq)
    lam1 = math.sqrt(lam1_sq)
    lam2 = math.sqrt(lam2_sq)
    return (r1, r2, math.sin(b), math.cos(b), v1, v2, vb, s, lam1, lam2, s / lam1, r1 / lam2)


def _refuse(L, r1, r2, lam1_sq, lam2_sq, limit_sq):
    for kind, lam_sq, what in (("lambda1", lam1_sq, f"|rho1 + rho2| = {abs(r1 + r2):.9g} m against 2L = {2 * L:g} m"),
                               ("lambda2", lam2_sq, f"|rho1| = {abs(r1):.9g} m against L = {L:g} m")):
        if lam_sq >= limit_sq:
            continue
        if lam_sq >= 0.0:
            raise SingularityError(f"{kind} = {math.sqrt(lam_sq):.3g} m is below {math.sqrt(limit_sq):.3g} m "
                                   f"({what}): singular configuration", kind=kind, distance=math.sqrt(lam_sq),
                                   limit=math.sqrt(limit_sq))
        if lam_sq < 0.0:
            raise DomainError(f"configuration does not exist ({what})", distance=math.sqrt(-lam_sq))
    raise DomainError(f"state is not finite: rho1 = {r1!r}, rho2 = {r2!r}")


def context_array(L: float, q, qdot) -> tuple:
    """:func:`context` for arrays of states (no domain checks; callers pass valid states)."""
    q = np.asarray(q, dtype=float)
    qdot = np.asarray(qdot, dtype=float)
    r1, r2, b = q[..., 0], q[..., 1], q[..., 2]
    s = r1 + r2
    lam1 = np.sqrt((2.0 * L - s) * (2.0 * L + s))
    lam2 = np.sqrt((L - r1) * (L + r1))
    return (r1, r2, np.sin(b), np.cos(b), qdot[..., 0], qdot[..., 1], qdot[..., 2], s, lam1, lam2,
            s / lam1, r1 / lam2)


def spring_vectors(L: float, k) -> tuple:
    """Node-difference vectors ``(dx, dy)`` of the springs CD, DE, EF, BE for context ``k``
    (floats or arrays). EF's y component is written free of cancellation."""
    r1, r2, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
    h = 0.5 * (r2 - r1)
    return ((L * cb - r2, L * sb),
            (h - L * cb, 0.5 * lam1 - L * sb),
            (-0.5 * s, (r2 - r1) * (3.0 * r1 + r2) / (4.0 * lam2 + 2.0 * lam1)),
            (h, 0.5 * lam1))


def spring_rates(L: float, k) -> tuple:
    """Time derivatives ``(dx', dy')`` of the spring vectors, in :func:`spring_vectors` order."""
    _, _, sb, cb, v1, v2, vb, _, _, _, e1, g2 = k
    sd = v1 + v2
    hd = 0.5 * (v2 - v1)
    return ((-v2 - L * sb * vb, L * cb * vb),
            (hd + L * sb * vb, -0.5 * e1 * sd - L * cb * vb),
            (-0.5 * sd, 0.5 * e1 * sd - g2 * v1),
            (hd, -0.5 * e1 * sd))


def map_spring_forces(L: float, k, F) -> tuple:
    """``sum_j J_j^T F_j`` for per-spring vectors ``F = ((Fx, Fy) x 4)`` in CD, DE, EF, BE order."""
    _, _, sb, cb, _, _, _, _, _, _, e1, g2 = k
    (x3, y3), (x4, y4), (x7, y7), (x8, y8) = F
    x48 = x4 + x8
    y48 = y4 + y8
    q1 = -0.5 * (x48 + e1 * y48) - 0.5 * x7 + (0.5 * e1 - g2) * y7
    q2 = -x3 + 0.5 * (x48 - e1 * y48) + 0.5 * (-x7 + e1 * y7)
    q3 = L * (-sb * x3 + cb * y3 + sb * x4 - cb * y4)
    return q1, q2, q3


def spring_second_derivatives(L: float, q) -> np.ndarray:
    """Second derivatives of the spring vectors' components, shape (4, 2, 3, 3), at one ``q``."""
    r1, r2, b = float(q[0]), float(q[1]), float(q[2])
    s = r1 + r2
    lam1 = math.sqrt((2 * L - s) * (2 * L + s))
    lam2 = math.sqrt((L - r1) * (L + r1))
    eta1 = -4.0 * L * L / lam1**3          # d2 lambda1 / ds2
    eta2 = -L * L / lam2**3                # d2 lambda2 / drho1^2
    D = np.zeros((4, 2, 3, 3))
    D[0, 0, 2, 2] = -L * math.cos(b)
    D[0, 1, 2, 2] = -L * math.sin(b)
    D[1, 0, 2, 2] = L * math.cos(b)
    D[1, 1, :2, :2] = 0.5 * eta1
    D[1, 1, 2, 2] = L * math.sin(b)
    D[2, 1, :2, :2] = -0.5 * eta1
    D[2, 1, 0, 0] += eta2
    D[3, 1, :2, :2] = 0.5 * eta1
    return D


def spring_jacobians(L: float, q) -> np.ndarray:
    """``J_j = dd_j/dq``, shape (4, 2, 3), at one ``q``."""
    k = context(L, (q[0], q[1], q[2], 0.0, 0.0, 0.0))
    _, _, sb, cb, _, _, _, _, _, _, e1, g2 = k
    return np.array([
        [[0.0, -1.0, -L * sb], [0.0, 0.0, L * cb]],
        [[-0.5, 0.5, L * sb], [-0.5 * e1, -0.5 * e1, -L * cb]],
        [[-0.5, -0.5, 0.0], [0.5 * e1 - g2, 0.5 * e1, 0.0]],
        [[-0.5, 0.5, 0.0], [-0.5 * e1, -0.5 * e1, 0.0]],
    ])


# --------------------------------------------------------------------------------- effects
class Springs:
    """Linear zero-free-length springs: ``Q = -dU/dq``, ``U = 1/2 sum k_j |d_j|^2``."""

    name = "springs"

    def __init__(self, params: Class2Params):
        self.params = params
        self.L = params.L
        self.k = (params.k3, params.k2, params.k1, params.k4)

    def force(self, k) -> tuple:
        L = self.L
        (x3, y3), (x4, y4), (x7, y7), (x8, y8) = spring_vectors(L, k)
        k3, k2, k1, k4 = self.k
        q1, q2, q3 = map_spring_forces(L, k, ((k3 * x3, k3 * y3), (k2 * x4, k2 * y4), (k1 * x7, k1 * y7),
                                              (k4 * x8, k4 * y8)))
        return -q1, -q2, -q3

    def energy(self, k):
        d = spring_vectors(self.L, k)
        return 0.5 * sum(kj * (dx * dx + dy * dy) for kj, (dx, dy) in zip(self.k, d))

    def stiffness(self, k) -> tuple:
        """Unique entries ``(K11, K12, K13, K22, K23, K33)`` of ``d2U/dq2`` (floats or arrays).

        ``d2U/dq2 = sum k_j (J_j^T J_j + sum_a d_ja d2d_ja/dq2)``, with ``eta1 = -4L^2/lambda1^3``
        and ``eta2 = -L^2/lambda2^3`` the second derivatives of lambda1 (in s) and lambda2."""
        r1, r2, sb, cb, _, _, _, s, lam1, lam2, e1, g2 = k
        L = self.L
        k3, k2, k1, k4 = self.k
        eta1 = -4.0 * L * L / lam1**3
        eta2 = -L * L / lam2**3
        e1sq = e1 * e1
        sym = 0.25 + 0.25 * e1sq               # (J^T J)_11 = (J^T J)_22 of DE and BE; _12 is sym - 0.5
        ey = 0.5 * e1 - g2
        dy7 = (r2 - r1) * (3.0 * r1 + r2) / (4.0 * lam2 + 2.0 * lam1)
        # the curvature terms sum_a d_ja d2d_ja/dq2 of DE, EF and BE, alike in K11, K12, K22
        curv = eta1 * ((0.5 * k2) * (0.5 * lam1 - L * sb) - (0.5 * k1) * dy7 + (0.25 * k4) * lam1)
        k24sym = (k2 + k4) * sym
        K11 = k24sym + k1 * (0.25 + ey * ey + eta2 * dy7) + curv
        K12 = k24sym - 0.5 * (k2 + k4) + k1 * (0.25 + 0.5 * ey * e1) + curv
        K22 = k3 + k24sym + k1 * (0.25 + 0.25 * e1sq) + curv
        K13 = (0.5 * k2 * L) * (e1 * cb - sb)
        K23 = (k3 * L) * sb + (0.5 * k2 * L) * (e1 * cb + sb)
        K33 = (k3 * L) * r2 * cb + (k2 * L) * (0.5 * (r2 - r1) * cb + 0.5 * lam1 * sb)
        return K11, K12, K13, K22, K23, K33

    def jacobian(self, q, qdot):
        return _minus_matrix(self.stiffness(context(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0)))), np.zeros((3, 3))


class Damping:
    """Linear dampers along the springs: force ``c_j dL_j/dt`` (dissipated power ``sum c_j Ldot_j^2``)."""

    name = "damping"

    def __init__(self, params: Class2Params):
        self.L = params.L
        self.c = (params.c3, params.c2, params.c1, params.c4)
        self.eps2 = (ZERO_LENGTH_REL * params.L) ** 2

    def force(self, k) -> tuple:
        L = self.L
        d = spring_vectors(L, k)
        dd = spring_rates(L, k)
        F = []
        for cj, (dx, dy), (ux, uy) in zip(self.c, d, dd):
            phi = cj * (dx * ux + dy * uy) / (dx * dx + dy * dy + self.eps2)
            F.append((phi * dx, phi * dy))
        q1, q2, q3 = map_spring_forces(L, k, F)
        return -q1, -q2, -q3

    def jacobian(self, q, qdot):
        """``(dQ/dq, dQ/dqdot)``: ``Q = -H(q) qdot`` with ``H = sum c_j g_j g_j^T / n_j``,
        ``g_j = J_j^T d_j``, ``n_j = |d_j|^2 + eps^2``; ``G_j = J_j^T J_j + sum_a d_ja D_ja``::

            d(H qdot)/dq = sum c_j [(g_j (G_j qdot)^T + w_j G_j) / n_j - 2 w_j g_j g_j^T / n_j^2],
            w_j = g_j . qdot.
        """
        q = np.asarray(q, dtype=float)
        qdot = np.asarray(qdot, dtype=float)
        k = context(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0))
        d = np.array(spring_vectors(self.L, k))                       # (4, 2)
        J = spring_jacobians(self.L, q)                                # (4, 2, 3)
        D = spring_second_derivatives(self.L, q)                       # (4, 2, 3, 3)
        g = np.einsum("jac,ja->jc", J, d)
        G = np.einsum("jac,jae->jce", J, J) + np.einsum("ja,jace->jce", d, D)
        c = np.array(self.c)
        n = np.sum(d * d, axis=1) + self.eps2
        w = g @ qdot
        Gq = np.einsum("jce,e->jc", G, qdot)
        H = np.einsum("j,jc,je->ce", c / n, g, g)
        dHq = (np.einsum("j,jc,je->ce", c / n, g, Gq) + np.einsum("j,jce->ce", c * w / n, G)
               - 2.0 * np.einsum("j,jc,je->ce", c * w / n**2, g, g))
        return -dHq, -H


class Gravity:
    """Weight of the four struts (mass ``m`` each, at their centres) in the field ``g`` [m/s^2].

    With ``X, Y`` the sums of the strut centres' coordinates, ``X = s + 1.5 rho1 + (L/2) cos b``,
    ``Y = (lambda1 + lambda2 + L sin b)/2``; ``V = -m (g_x X + g_y Y)``, ``Q = -dV/dq``.
    The z component acts against the supports of the horizontal mechanism and does no work.
    """

    name = "gravity"

    def __init__(self, params: Class2Params, vector):
        self.L = params.L
        self.m = params.m
        self.gx, self.gy = float(vector[0]), float(vector[1])

    def force(self, k) -> tuple:
        _, _, sb, cb, _, _, _, _, _, _, e1, g2 = k
        mgx, mgy, hl = self.m * self.gx, self.m * self.gy, 0.5 * self.L
        return (2.5 * mgx - 0.5 * (e1 + g2) * mgy, mgx - 0.5 * e1 * mgy, hl * (mgy * cb - mgx * sb))

    def energy(self, k):
        r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
        X = s + 1.5 * r1 + 0.5 * self.L * cb
        Y = 0.5 * (lam1 + lam2 + self.L * sb)
        return -self.m * (self.gx * X + self.gy * Y)

    def stiffness(self, k) -> tuple:
        """Unique entries of ``d2V/dq2`` (floats or arrays)."""
        _, _, sb, cb, _, _, _, _, lam1, lam2, _, _ = k
        L = self.L
        eta1 = -4.0 * L * L / lam1**3
        eta2 = -L * L / lam2**3
        mgx, mgy = self.m * self.gx, self.m * self.gy
        zero = 0.0 * lam1
        rho = -0.5 * mgy * eta1
        return rho - 0.5 * mgy * eta2, rho, zero, rho, zero, 0.5 * L * (mgx * cb + mgy * sb)

    def jacobian(self, q, qdot):
        return _minus_matrix(self.stiffness(context(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0)))), np.zeros((3, 3))


class Loads:
    """Dead forces ``F_n`` [N] on nodes (in-plane components act): ``Q = sum J_n^T F_n``,
    ``V = -sum F_n . P_n``."""

    name = "loads"

    def __init__(self, params: Class2Params, forces: dict):
        self.L = params.L
        F = np.zeros((6, 2))
        for node, vec in forces.items():
            F[node] += vec[:2]
        self.F = F
        (self.fbx, _), (self.fcx, _), (self.fdx, self.fdy), (self.fex, self.fey), (_, self.ffy) = F[1:].tolist()

    def force(self, k) -> tuple:
        _, _, sb, cb, _, _, _, _, _, _, e1, g2 = k
        L = self.L
        q1 = self.fbx + self.fcx + self.fdx + 0.5 * (self.fex - e1 * self.fey) - g2 * self.ffy
        q2 = self.fcx + 0.5 * (self.fex - e1 * self.fey)
        q3 = L * (cb * self.fdy - sb * self.fdx)
        return q1, q2, q3

    def energy(self, k):
        """``V = -sum F_n . P_n`` (floats or arrays); A is fixed and B, C, F have a zero coordinate."""
        r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
        L = self.L
        return -(self.fbx * r1 + self.fcx * s + self.fdx * (r1 + L * cb) + self.fdy * L * sb
                 + 0.5 * (self.fex * s + self.fey * lam1) + self.ffy * lam2)

    def stiffness(self, k) -> tuple:
        """Unique entries of ``d2V/dq2`` (floats or arrays)."""
        _, _, sb, cb, _, _, _, _, lam1, lam2, _, _ = k
        L = self.L
        zero = 0.0 * lam1
        rho = 0.5 * self.fey * 4.0 * L * L / lam1**3
        return rho + self.ffy * L * L / lam2**3, rho, zero, rho, zero, L * (cb * self.fdx + sb * self.fdy)

    def jacobian(self, q, qdot):
        return _minus_matrix(self.stiffness(context(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0)))), np.zeros((3, 3))


def stiffness_matrix(entries) -> np.ndarray:
    """Symmetric (..., 3, 3) matrix from unique entries ``(K11, K12, K13, K22, K23, K33)``."""
    K11, K12, K13, K22, K23, K33 = entries
    K = np.empty(np.broadcast_shapes(*(np.shape(e) for e in entries)) + (3, 3))
    K[..., 0, 0], K[..., 0, 1], K[..., 0, 2] = K11, K12, K13
    K[..., 1, 0], K[..., 1, 1], K[..., 1, 2] = K12, K22, K23
    K[..., 2, 0], K[..., 2, 1], K[..., 2, 2] = K13, K23, K33
    return K


def _minus_matrix(entries) -> np.ndarray:
    return -stiffness_matrix(entries)
