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
``tests/sim/test_class2_effects.py`` checks these against a least-squares solution of all
24 Newton-Euler equations (which also checks the Lagrangian equations of motion).

:func:`member_values` and :func:`node_coordinates` are written with arithmetic only,
so the same formulas run on floats (one observation, a few microseconds) and on arrays (the
samples of a run); :func:`member_forces`, :func:`node_positions` and
:func:`node_accelerations` are their array forms.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.dynamics.kinematics import Kinematics, kinematics_array
from tensegrity_core.class2.dynamics.limits import ZERO_LENGTH_REL
from tensegrity_core.class2.dynamics.springs import dampings, spring_tensions, stiffnesses
from tensegrity_core.class2.params import Class2Params

FloatArray = NDArray[np.float64]
#: A quantity of one state (a float) or of many (an array): the formulas are arithmetic only.
Value = float | FloatArray
#: Quantities in a fixed order (nodes' coordinates, members), each a :data:`Value`.
Values = tuple[Value, ...]


def _where(cond: bool | NDArray[np.bool_], a: Value, b: Value) -> Value:
    """``a`` where ``cond`` holds, else ``b`` (floats or arrays)."""
    if isinstance(cond, np.ndarray):
        return np.where(cond, a, b)
    return a if cond else b


def node_coordinates(L: float, k: Kinematics[Any]) -> Values:
    """``(Bx, Cx, Dx, Dy, Ex, Ey, Fy)`` [m] from a kinematic context (floats or arrays);
    ``A`` is the origin and ``By = Cy = Fx = 0``."""
    r1, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
    return r1, s, r1 + L * cb, L * sb, 0.5 * s, 0.5 * lam1, lam2


def node_acceleration_values(L: float, k: Kinematics[Any], qdd: tuple[Value, Value, Value]) -> Values:
    """``(aBx, aCx, aDx, aDy, aEx, aEy, aFy)`` [m/s^2]: ``J qddot + qdot^T H qdot`` for
    accelerations ``qdd = (a1, a2, ab)`` (floats or arrays); ``A`` is fixed and
    ``aBy = aCy = aFx = 0``."""
    _, _, sb, cb, v1, v2, vb, _, lam1, lam2, e1, g2 = k
    a1, a2, ab = qdd
    sdd, sd = a1 + a2, v1 + v2
    return (a1, sdd, a1 - L * sb * ab - L * cb * vb * vb, L * cb * ab - L * sb * vb * vb, 0.5 * sdd,
            -0.5 * e1 * sdd - 2.0 * L * L * sd * sd / lam1**3,     # d2 lambda1/ds2 = -4L^2/lambda1^3
            -g2 * a1 - L * L * v1 * v1 / lam2**3)                   # d2 lambda2/drho1^2 = -L^2/lambda2^3


def node_positions(L: float, k: Kinematics[Any]) -> FloatArray:
    """(N, 6, 2) node positions from an array context."""
    Bx, Cx, Dx, Dy, Ex, Ey, Fy = node_coordinates(L, k)
    z = np.zeros(np.shape(Bx))
    return np.stack([np.stack([z, z], -1), np.stack([Bx, z], -1), np.stack([Cx, z], -1), np.stack([Dx, Dy], -1),
                     np.stack([Ex, Ey], -1), np.stack([z, Fy], -1)], -2)


def node_accelerations(L: float, k: Kinematics[Any], qdd: FloatArray) -> FloatArray:
    """(N, 6, 2) node accelerations for accelerations ``qdd`` (N, 3)."""
    aB, aC, aDx, aDy, aEx, aEy, aFy = node_acceleration_values(L, k, (qdd[:, 0], qdd[:, 1], qdd[:, 2]))
    z = np.zeros(np.shape(aB))
    return np.stack([np.stack([z, z], -1), np.stack([aB, z], -1), np.stack([aC, z], -1), np.stack([aDx, aDy], -1),
                     np.stack([aEx, aEy], -1), np.stack([z, aFy], -1)], -2)


def member_values(params: Class2Params, k: Kinematics[Any], qdd: tuple[Value, Value, Value],
                  actuator_forces: tuple[Value, Value], *, springs: bool, damping: bool,
                  gravity: Sequence[float] | None = None, loads: ArrayLike | None = None,
                  inertia: bool = True) -> tuple[Values, Values]:
    """``(forces, lengths)``: tension-positive forces [N] and lengths [m] of the 10 members
    in MEMBERS order (tuples of floats or arrays).

    ``k`` a kinematic context, ``qdd = (a1, a2, ab)`` the accelerations, ``actuator_forces``
    ``(t1, t2)`` the actuators' member forces (transmitted force minus contact force);
    ``gravity`` a vector (>= 2 components, in-plane ones used) or None; ``loads`` (6, 2) or
    None; ``inertia`` False for massless struts (quasi-static)."""
    L, m = params.L, params.m
    x3, y3, x4, y4, x7, y7, x8, y8, p3, p4, p7, p8 = spring_tensions(      # CD, DE, EF, BE
        L, stiffnesses(params) if springs else (0.0,) * 4, dampings(params) if damping else None,
        (ZERO_LENGTH_REL * L) ** 2, k)
    sq = (x3 * x3 + y3 * y3, x4 * x4 + y4 * y4, x7 * x7 + y7 * y7, x8 * x8 + y8 * y8)
    # forces of the springs on the nodes D, E, F (tension + along CD, DE, EF, BE), plus loads
    FDx, FDy = p4 * x4 - p3 * x3, p4 * y4 - p3 * y3
    FEx, FEy = p7 * x7 - p4 * x4 - p8 * x8, p7 * y7 - p4 * y4 - p8 * y8
    FFx, FFy = -p7 * x7, -p7 * y7
    if loads is not None:
        (dx, dy), (ex, ey), (fx_, fy_) = np.asarray(loads, dtype=float)[3:].tolist()
        FDx, FDy, FEx, FEy, FFx, FFy = FDx + dx, FDy + dy, FEx + ex, FEy + ey, FFx + fx_, FFy + fy_
    Bx, Cx, Dx, Dy, Ex, Ey, Fy = node_coordinates(L, k)
    if inertia:
        aB, aC, aDx, aDy, aEx, aEy, aFy = node_acceleration_values(L, k, qdd)
    else:
        aB = aC = aDx = aDy = aEx = aEy = aFy = 0.0
    gx, gy = (0.0, 0.0) if gravity is None else (float(gravity[0]), float(gravity[1]))
    mass = m if (inertia or gravity is not None) else 0.0
    I_rot = m * L * L / 12.0 if inertia else 0.0

    def strut(ux: Value, uy: Value, aax: Value, aay: Value, abx: Value, aby: Value) -> tuple[Value, Value, Value]:
        """``(w = m (a_c - g), tau = r_b x P_b)`` of a strut along ``u`` with end accelerations
        (zeros for massless struts)."""
        if not mass:
            return 0.0, 0.0, 0.0
        wx, wy = mass * (0.5 * (aax + abx) - gx), mass * (0.5 * (aay + aby) - gy)
        alpha = (ux * (aby - aay) - uy * (abx - aax)) / L
        return wx, wy, 0.5 * (I_rot * alpha + 0.5 * L * (ux * wy - uy * wx))

    def mid_span(Fx: Value, Fy: Value, ux: Value, uy: Value, wx: Value, wy: Value) -> Value:
        """Axial force at mid-span from the end force ``F`` on the far end."""
        N = Fx * ux + Fy * uy
        return N - 0.5 * (wx * ux + wy * uy) if mass else N

    # BD: D joins only the springs CD, DE (and loads); u = (cos b, sin b)
    _, _, sb, cb, _, _, _, s, lam1, lam2, _, _ = k
    wx, wy, _ = strut(cb, sb, aB, 0.0, aDx, aDy)
    t_bd = mid_span(FDx, FDy, cb, sb, wx, wy)
    # BF: F joins the spring EF and the X reaction R, from the moment equation
    ux, uy = -Bx / L, Fy / L
    wx, wy, tau = strut(ux, uy, aB, 0.0, 0.0, aFy)
    R = (tau - 0.5 * L * (ux * FFy - uy * FFx)) / (-0.5 * L * uy)
    t_bf = mid_span(FFx + R, FFy, ux, uy, wx, wy)
    # AE, CE: E's balance, a 2 x 2 system in their axial parts
    u1x, u1y, u2x, u2y = Ex / L, Ey / L, (Ex - Cx) / L, Ey / L
    w1x, w1y, tau1 = strut(u1x, u1y, 0.0, 0.0, aEx, aEy)
    w2x, w2y, tau2 = strut(u2x, u2y, aC, 0.0, aEx, aEy)
    Wx, Wy = FEx, FEy
    if mass:
        Wx = Wx + (2.0 / L) * (tau1 * u1y + tau2 * u2y)
        Wy = Wy - (2.0 / L) * (tau1 * u1x + tau2 * u2x)
    det = u1x * u2y - u1y * u2x
    safe = (det > 1e-300) | (det < -1e-300)      # |det| > 1e-300, for a float and an array alike
    den = _where(safe, det, 1.0)
    split = 0.5 * (Wx * u1x + Wy * u1y)
    N1 = _where(safe, (Wx * u2y - Wy * u2x) / den, split)
    N2 = _where(safe, (u1x * Wy - u1y * Wx) / den, split)
    t_ae = N1 - 0.5 * (w1x * u1x + w1y * u1y) if mass else N1
    t_ce = N2 - 0.5 * (w2x * u2x + w2y * u2y) if mass else N2
    l3, l4, l7, l8 = (n ** 0.5 for n in sq)
    t1, t2 = actuator_forces
    r1, r2 = k[0], k[1]
    return ((t1, t2, p3 * l3, p4 * l4, t_ae, t_bf, p7 * l7, p8 * l8, t_bd, t_ce),
            (abs(r1), abs(r2), l3, l4, L, L, l7, l8, L, L))


def member_forces(params: Class2Params, q: ArrayLike, qdot: ArrayLike, qdd: ArrayLike, actuator_forces: ArrayLike, *,
                  springs: bool, damping: bool, gravity: Sequence[float] | None = None,
                  loads: ArrayLike | None = None, inertia: bool = True) -> FloatArray:
    """Tension-positive forces (N, 10) [N] of all members, MEMBERS order: the array form of
    :func:`member_values` for ``q, qdot, qdd`` (N, 3) and ``actuator_forces`` (N, 2)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    qdd = np.atleast_2d(np.asarray(qdd, dtype=float))
    actuator_forces = np.atleast_2d(np.asarray(actuator_forces, dtype=float))
    k = kinematics_array(params.L, q, np.atleast_2d(np.asarray(qdot, dtype=float)))
    forces, _ = member_values(params, k, (qdd[:, 0], qdd[:, 1], qdd[:, 2]),
                              (actuator_forces[:, 0], actuator_forces[:, 1]), springs=springs, damping=damping,
                              gravity=gravity, loads=loads, inertia=inertia)
    return np.stack(np.broadcast_arrays(*forces), -1)
