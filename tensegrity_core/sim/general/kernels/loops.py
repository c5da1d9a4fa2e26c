"""Explicit-loop kernels of a general model, compiled by numba (see :mod:`.jit`).

Each kernel is one fused loop over members, nodes or bodies with scalar arithmetic: numba
turns it into machine code without temporaries (measured on the spine, 72 members: about
5x faster than numba's compilation of the same computation written with numpy arrays, 30x
faster than numpy itself). :mod:`.arrays` computes the same with numpy arrays; the two are
tested against each other to rounding.

Arguments are the :class:`~.plan.Plan` arrays spelled out (numba caches kernels whose
arguments are plain arrays; a named tuple of them defeats its cache) and, per call, a batch
of ``B`` states ``y`` (B, 2 n_dof), their rotation charts ``R_ref`` (B, nb, 3, 3) and rest
lengths ``l0`` (B, m) [m]. The pipeline of one evaluation, each stage a kernel:

1. :func:`place`: node positions ``X`` and velocities ``V`` (n, 3), body rotations ``R`` and
   arms ``r = R p`` of the body nodes;
2. force effects, each adding its nodal forces to ``F`` (n, 3): the constant external forces
   (dead loads, weights), :func:`member_forces` (axial springs and taut dampers). A new
   effect (contacts, cables driven by motors) is one more kernel of this shape, called in
   :func:`evaluate`;
3. :func:`accelerate`: generalised forces (:func:`nodal_wrenches`), rigid-body Newton-Euler
   and the state's rate (:func:`rates`). An effect that applies moments as well as nodal
   forces (friction at a cap's contact point) adds them to the wrenches between the two.

Rigid body (module docstring of :mod:`tensegrity_core.sim.general.model`): with ``s`` the
first moment and ``I_c`` the inertia about ``c`` (world frame), ``F`` and ``M`` the force
and moment about ``c`` of the nodal forces, ``F' = F - w x (w x s)`` and
``M' = M - w x (I_c w)``, Newton-Euler ``[[m I, -hat(s)], [hat(s), I_c]] [a_c; dw] = [F'; M']``
is solved by eliminating ``a_c``: ``dw = I_cm^-1 (M' - s x F' / m)`` with ``I_cm = I_c +
hat(s)^2 / m`` the inertia about the centre of mass (``R I_cm,body^-1 R^T``: inverted once,
in the plan), then ``a_c = (F' + s x dw) / m``.

Longer than 500 lines because the kernels call one another (the Jacobian and the
integration stages call the right-hand side's): numba's on-disk cache of a kernel is renewed
only when the kernel's own file changes, so a callee in another file could change while its
callers' cached machine code keeps the old one (numba's documentation, "Cache Notes").
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.jit import jit

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Below this angle [rad] the rotation formulas use their Taylor series.
SMALL_ANGLE = 1e-4


@jit
def copy_vector(src: FloatArray, out: FloatArray) -> None:
    """``out[i] = src[i]`` for every ``i`` of ``src``. The kernels copy arrays with loops, not
    slice assignment (``out[:] = src``): numba compiles a slice assignment's shape check with
    its error message, whose string formatting is linked into every kernel that calls it, up
    to ~1 s of compile time each (docs/design/performance.md, the set-up's numba warm-up)."""
    for i in range(src.shape[0]):
        out[i] = src[i]


@jit
def copy_matrix(src: FloatArray, out: FloatArray) -> None:
    """``out[i, j] = src[i, j]`` for every ``(i, j)`` of ``src`` (as :func:`copy_vector`)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            out[i, j] = src[i, j]


@jit
def rotate(t0: float, t1: float, t2: float, R_ref: FloatArray, R: FloatArray) -> None:
    """``R = exp(hat(theta)) R_ref`` (Rodrigues; series below :data:`SMALL_ANGLE`)."""
    a2 = t0 * t0 + t1 * t1 + t2 * t2
    if a2 < SMALL_ANGLE * SMALL_ANGLE:
        s = 1.0 - a2 / 6.0 + a2 * a2 / 120.0
        c = 0.5 - a2 / 24.0 + a2 * a2 / 720.0
    else:
        a = math.sqrt(a2)
        s = math.sin(a) / a
        c = (1.0 - math.cos(a)) / a2
    # exp(hat(t)) = I + s hat(t) + c (t t^T - |t|^2 I)
    e00 = 1.0 + c * (t0 * t0 - a2)
    e01 = -s * t2 + c * t0 * t1
    e02 = s * t1 + c * t0 * t2
    e10 = s * t2 + c * t1 * t0
    e11 = 1.0 + c * (t1 * t1 - a2)
    e12 = -s * t0 + c * t1 * t2
    e20 = -s * t1 + c * t2 * t0
    e21 = s * t0 + c * t2 * t1
    e22 = 1.0 + c * (t2 * t2 - a2)
    for j in range(3):
        r0, r1, r2 = R_ref[0, j], R_ref[1, j], R_ref[2, j]
        R[0, j] = e00 * r0 + e01 * r1 + e02 * r2
        R[1, j] = e10 * r0 + e11 * r1 + e12 * r2
        R[2, j] = e20 * r0 + e21 * r1 + e22 * r2


@jit
def chart_rate_coefficient(a2: float) -> float:
    """``k(a)`` of ``J_l(theta)^-1 = I - hat(theta)/2 + k hat(theta)^2``, ``a = |theta|``:
    ``1/a^2 - (1 + cos a) / (2 a sin a)`` (series ``1/12 + a^2/720`` below :data:`SMALL_ANGLE`)."""
    if a2 < SMALL_ANGLE * SMALL_ANGLE:
        return 1.0 / 12.0 + a2 / 720.0
    a = math.sqrt(a2)
    return 1.0 / a2 - (1.0 + math.cos(a)) / (2.0 * a * math.sin(a))


@jit
def place(base: FloatArray, free_node: IntArray, free_axis: IntArray, on_node: IntArray, on_body: IntArray,
          on_offset: FloatArray, body_dof: IntArray, y: FloatArray, R_ref: FloatArray,
          X: FloatArray, V: FloatArray, R: FloatArray, r: FloatArray) -> None:
    """Node positions ``X`` and velocities ``V`` (n, 3), rotations ``R`` (nb, 3, 3) and arms
    ``r`` (n_on, 3) [m] of one state ``y`` in the charts ``R_ref``."""
    n_dof = y.shape[0] // 2
    copy_matrix(base, X)
    V[:, :] = 0.0
    for j in range(free_node.shape[0]):
        X[free_node[j], free_axis[j]] = y[j]
        V[free_node[j], free_axis[j]] = y[n_dof + j]
    for b in range(body_dof.shape[0]):
        d = body_dof[b]
        rotate(y[d + 3], y[d + 4], y[d + 5], R_ref[b], R[b])
    for k in range(on_node.shape[0]):
        b = on_body[k]
        d = body_dof[b]
        p0, p1, p2 = on_offset[k, 0], on_offset[k, 1], on_offset[k, 2]
        r0 = R[b, 0, 0] * p0 + R[b, 0, 1] * p1 + R[b, 0, 2] * p2
        r1 = R[b, 1, 0] * p0 + R[b, 1, 1] * p1 + R[b, 1, 2] * p2
        r2 = R[b, 2, 0] * p0 + R[b, 2, 1] * p1 + R[b, 2, 2] * p2
        r[k, 0], r[k, 1], r[k, 2] = r0, r1, r2
        node = on_node[k]
        X[node, 0] = y[d] + r0
        X[node, 1] = y[d + 1] + r1
        X[node, 2] = y[d + 2] + r2
        w0, w1, w2 = y[n_dof + d + 3], y[n_dof + d + 4], y[n_dof + d + 5]
        V[node, 0] = y[n_dof + d] + w1 * r2 - w2 * r1
        V[node, 1] = y[n_dof + d + 1] + w2 * r0 - w0 * r2
        V[node, 2] = y[n_dof + d + 2] + w0 * r1 - w1 * r0


@jit
def string_gaps(base: FloatArray, free_node: IntArray, free_axis: IntArray, on_node: IntArray, on_body: IntArray,
                on_offset: FloatArray, body_dof: IntArray, member_a: IntArray, member_b: IntArray, strings: IntArray,
                y: FloatArray, R_ref: FloatArray, l0: FloatArray, X: FloatArray, V: FloatArray, R: FloatArray,
                r: FloatArray, gap: FloatArray, rate: FloatArray) -> None:
    """Per string ``strings[j]`` of one state ``y``: ``gap[j] = l - l0`` [m] and ``rate[j] =
    dl/dt`` [m/s] (the strings' slack/taut event functions); ``X``, ``V``, ``R``, ``r`` are
    :func:`place`'s work arrays."""
    place(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, y, R_ref, X, V, R, r)
    for j in range(strings.shape[0]):
        i = strings[j]
        a, b = member_a[i], member_b[i]
        h0, h1, h2 = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
        length = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        gap[j] = length - l0[i]
        rate[j] = (h0 * (V[b, 0] - V[a, 0]) + h1 * (V[b, 1] - V[a, 1]) + h2 * (V[b, 2] - V[a, 2])) / length


@jit
def member_forces(member_a: IntArray, member_b: IntArray, EA: FloatArray, damping: FloatArray,
                  is_string: BoolArray, l0: FloatArray, X: FloatArray, V: FloatArray, F: FloatArray,
                  lengths: FloatArray, forces: FloatArray) -> None:
    """Axial springs ``t = EA (l - l0)/l0`` and dampers ``c dl/dt``, both only while the member
    is taut (a string shorter than its rest length is slack and carries nothing): adds
    ``+t u`` to node ``a`` and ``-t u`` to node ``b`` of ``F``; writes ``lengths`` [m] and
    ``forces`` [N] (positive = tensile)."""
    for i in range(member_a.shape[0]):
        a, b = member_a[i], member_b[i]
        h0, h1, h2 = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
        length = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        lengths[i] = length
        if is_string[i] and length < l0[i]:
            forces[i] = 0.0
            continue
        u0, u1, u2 = h0 / length, h1 / length, h2 / length
        rate = u0 * (V[b, 0] - V[a, 0]) + u1 * (V[b, 1] - V[a, 1]) + u2 * (V[b, 2] - V[a, 2])
        t = EA[i] * (length - l0[i]) / l0[i] + damping[i] * rate
        forces[i] = t
        F[a, 0] += t * u0
        F[a, 1] += t * u1
        F[a, 2] += t * u2
        F[b, 0] -= t * u0
        F[b, 1] -= t * u1
        F[b, 2] -= t * u2


@jit
def nodal_wrenches(on_node: IntArray, on_body: IntArray, r: FloatArray, F: FloatArray, wrench: FloatArray) -> None:
    """``wrench`` (nb, 6): per moving body the force and the moment about ``c`` of the nodal
    forces ``F`` on its nodes (arms ``r``)."""
    wrench[:, :] = 0.0
    for k in range(on_node.shape[0]):
        b = on_body[k]
        f0, f1, f2 = F[on_node[k], 0], F[on_node[k], 1], F[on_node[k], 2]
        r0, r1, r2 = r[k, 0], r[k, 1], r[k, 2]
        wrench[b, 0] += f0
        wrench[b, 1] += f1
        wrench[b, 2] += f2
        wrench[b, 3] += r1 * f2 - r2 * f1
        wrench[b, 4] += r2 * f0 - r0 * f2
        wrench[b, 5] += r0 * f1 - r1 * f0


@jit
def accelerate(free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray, on_node: IntArray,
               on_body: IntArray, body_dof: IntArray, body_mass: FloatArray, body_first_moment: FloatArray,
               body_inertia: FloatArray, body_inv_inertia_cm: FloatArray, y: FloatArray, R: FloatArray,
               r: FloatArray, F: FloatArray, wrench: FloatArray, out: FloatArray) -> None:
    """``out = dy/dt`` of state ``y`` from the nodal forces ``F``: the bodies' wrenches
    (:func:`nodal_wrenches`, into ``wrench``), then :func:`rates`."""
    nodal_wrenches(on_node, on_body, r, F, wrench)
    rates(free_node, free_axis, free_inv_mass, body_dof, body_mass, body_first_moment, body_inertia,
          body_inv_inertia_cm, y, R, F, wrench, out)


@jit
def rates(free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray, body_dof: IntArray,
          body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
          body_inv_inertia_cm: FloatArray, y: FloatArray, R: FloatArray, F: FloatArray, wrench: FloatArray,
          out: FloatArray) -> None:
    """``out = dy/dt`` of state ``y`` (2 n_dof,) from the nodal forces ``F`` on the free
    coordinates (``F / m``) and the bodies' ``wrench`` (nb, 6) about ``c``: Newton-Euler
    (module docstring) and the rotation vectors' rate ``J_l(theta)^-1 w``."""
    n_dof = y.shape[0] // 2
    for j in range(free_node.shape[0]):
        out[j] = y[n_dof + j]
        out[n_dof + j] = F[free_node[j], free_axis[j]] * free_inv_mass[j]
    for b in range(body_dof.shape[0]):
        d = body_dof[b]
        m = body_mass[b]
        Rb = R[b]
        sb = body_first_moment[b]
        s0 = Rb[0, 0] * sb[0] + Rb[0, 1] * sb[1] + Rb[0, 2] * sb[2]
        s1 = Rb[1, 0] * sb[0] + Rb[1, 1] * sb[1] + Rb[1, 2] * sb[2]
        s2 = Rb[2, 0] * sb[0] + Rb[2, 1] * sb[1] + Rb[2, 2] * sb[2]
        w0, w1, w2 = y[n_dof + d + 3], y[n_dof + d + 4], y[n_dof + d + 5]
        # I_c w = R I_body R^T w
        q0 = Rb[0, 0] * w0 + Rb[1, 0] * w1 + Rb[2, 0] * w2
        q1 = Rb[0, 1] * w0 + Rb[1, 1] * w1 + Rb[2, 1] * w2
        q2 = Rb[0, 2] * w0 + Rb[1, 2] * w1 + Rb[2, 2] * w2
        Ib = body_inertia[b]
        p0 = Ib[0, 0] * q0 + Ib[0, 1] * q1 + Ib[0, 2] * q2
        p1 = Ib[1, 0] * q0 + Ib[1, 1] * q1 + Ib[1, 2] * q2
        p2 = Ib[2, 0] * q0 + Ib[2, 1] * q1 + Ib[2, 2] * q2
        L0 = Rb[0, 0] * p0 + Rb[0, 1] * p1 + Rb[0, 2] * p2
        L1 = Rb[1, 0] * p0 + Rb[1, 1] * p1 + Rb[1, 2] * p2
        L2 = Rb[2, 0] * p0 + Rb[2, 1] * p1 + Rb[2, 2] * p2
        # F' = F - w x (w x s), M' = M - w x (I_c w)
        c0, c1, c2 = w1 * s2 - w2 * s1, w2 * s0 - w0 * s2, w0 * s1 - w1 * s0
        F0 = wrench[b, 0] - (w1 * c2 - w2 * c1)
        F1 = wrench[b, 1] - (w2 * c0 - w0 * c2)
        F2 = wrench[b, 2] - (w0 * c1 - w1 * c0)
        M0 = wrench[b, 3] - (w1 * L2 - w2 * L1)
        M1 = wrench[b, 4] - (w2 * L0 - w0 * L2)
        M2 = wrench[b, 5] - (w0 * L1 - w1 * L0)
        # dw = R I_cm^-1 R^T (M' - s x F' / m)
        g0 = M0 - (s1 * F2 - s2 * F1) / m
        g1 = M1 - (s2 * F0 - s0 * F2) / m
        g2 = M2 - (s0 * F1 - s1 * F0) / m
        q0 = Rb[0, 0] * g0 + Rb[1, 0] * g1 + Rb[2, 0] * g2
        q1 = Rb[0, 1] * g0 + Rb[1, 1] * g1 + Rb[2, 1] * g2
        q2 = Rb[0, 2] * g0 + Rb[1, 2] * g1 + Rb[2, 2] * g2
        Jb = body_inv_inertia_cm[b]
        p0 = Jb[0, 0] * q0 + Jb[0, 1] * q1 + Jb[0, 2] * q2
        p1 = Jb[1, 0] * q0 + Jb[1, 1] * q1 + Jb[1, 2] * q2
        p2 = Jb[2, 0] * q0 + Jb[2, 1] * q1 + Jb[2, 2] * q2
        dw0 = Rb[0, 0] * p0 + Rb[0, 1] * p1 + Rb[0, 2] * p2
        dw1 = Rb[1, 0] * p0 + Rb[1, 1] * p1 + Rb[1, 2] * p2
        dw2 = Rb[2, 0] * p0 + Rb[2, 1] * p1 + Rb[2, 2] * p2
        # a_c = (F' + s x dw) / m
        out[n_dof + d] = (F0 + s1 * dw2 - s2 * dw1) / m
        out[n_dof + d + 1] = (F1 + s2 * dw0 - s0 * dw2) / m
        out[n_dof + d + 2] = (F2 + s0 * dw1 - s1 * dw0) / m
        out[n_dof + d + 3] = dw0
        out[n_dof + d + 4] = dw1
        out[n_dof + d + 5] = dw2
        # dc/dt = v_c; dtheta/dt = J_l^-1 w = w - theta x w / 2 + k theta x (theta x w)
        t0, t1, t2 = y[d + 3], y[d + 4], y[d + 5]
        kc = chart_rate_coefficient(t0 * t0 + t1 * t1 + t2 * t2)
        x0, x1, x2 = t1 * w2 - t2 * w1, t2 * w0 - t0 * w2, t0 * w1 - t1 * w0
        out[d] = y[n_dof + d]
        out[d + 1] = y[n_dof + d + 1]
        out[d + 2] = y[n_dof + d + 2]
        out[d + 3] = w0 - 0.5 * x0 + kc * (t1 * x2 - t2 * x1)
        out[d + 4] = w1 - 0.5 * x1 + kc * (t2 * x0 - t0 * x2)
        out[d + 5] = w2 - 0.5 * x2 + kc * (t0 * x1 - t1 * x0)


@jit
def derivative(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
               on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
               body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
               body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
               damping: FloatArray, is_string: BoolArray, external: FloatArray,
               y: FloatArray, R_ref: FloatArray, l0: FloatArray, out: FloatArray,
               X: FloatArray, V: FloatArray, F: FloatArray, R: FloatArray, r: FloatArray, wrench: FloatArray,
               lengths: FloatArray, forces: FloatArray) -> None:
    """``out = dy/dt`` of one state: the plan's arrays, then ``y`` (2 n_dof,), ``R_ref``
    (nb, 3, 3), ``l0`` (m,), ``out``, and work arrays that keep the placement (``X``, ``V``,
    ``R``, ``r``), the nodal forces ``F``, the body wrenches and the member state afterwards."""
    place(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, y, R_ref, X, V, R, r)
    copy_matrix(external, F)
    member_forces(member_a, member_b, EA, damping, is_string, l0, X, V, F, lengths, forces)
    accelerate(free_node, free_axis, free_inv_mass, on_node, on_body, body_dof, body_mass, body_first_moment,
               body_inertia, body_inv_inertia_cm, y, R, r, F, wrench, out)


@jit
def rate(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
         on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
         body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
         body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
         damping: FloatArray, is_string: BoolArray, external: FloatArray,
         y: FloatArray, R_ref: FloatArray, l0: FloatArray) -> FloatArray:
    """:func:`derivative` of one state, returning ``dy/dt`` (the work arrays allocated here:
    the cheapest call from Python, e.g. for scipy's solvers)."""
    n, nb, m = base.shape[0], body_dof.shape[0], member_a.shape[0]
    out = np.empty(y.shape[0])
    derivative(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
               body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping, is_string,
               external, y, R_ref, l0, out, np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
               np.empty((nb, 3, 3)), np.empty((on_node.shape[0], 3)), np.empty((nb, 6)), np.empty(m),
               np.empty(m))
    return out


@jit
def derivatives(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
                on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
                body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
                body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
                damping: FloatArray, is_string: BoolArray, external: FloatArray,
                y: FloatArray, R_ref: FloatArray, l0: FloatArray, out: FloatArray,
                X: FloatArray, V: FloatArray, R: FloatArray, lengths: FloatArray, forces: FloatArray) -> None:
    """:func:`derivative` of a batch: ``y`` (B, 2 n_dof), ``R_ref`` (B, nb, 3, 3), ``l0``
    (B, m), ``out`` (B, 2 n_dof); kept per state: ``X``, ``V`` (B, n, 3), ``R`` (B, nb, 3, 3),
    ``lengths``, ``forces`` (B, m)."""
    F = np.empty((base.shape[0], 3))
    r = np.empty((on_node.shape[0], 3))
    wrench = np.empty((body_dof.shape[0], 6))
    for k in range(y.shape[0]):
        derivative(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
                   body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping,
                   is_string, external, y[k], R_ref[k], l0[k], out[k], X[k], V[k], F, R[k], r, wrench,
                   lengths[k], forces[k])


# -- Jacobian --------------------------------------------------------------------------------------
@jit
def chart_jacobians(t0: float, t1: float, t2: float, Jl: FloatArray, Jl_inv: FloatArray) -> None:
    """The left Jacobian of SO(3) ``J_l(theta)`` (``w = J_l dtheta/dt``) and its inverse, 3 x 3."""
    a2 = t0 * t0 + t1 * t1 + t2 * t2
    if a2 < SMALL_ANGLE * SMALL_ANGLE:
        c1 = 0.5 - a2 / 24.0
        c2 = 1.0 / 6.0 - a2 / 120.0
    else:
        a = math.sqrt(a2)
        c1 = (1.0 - math.cos(a)) / a2
        c2 = (a - math.sin(a)) / (a2 * a)
    k = chart_rate_coefficient(a2)
    t = (t0, t1, t2)
    K = ((0.0, -t2, t1), (t2, 0.0, -t0), (-t1, t0, 0.0))
    for i in range(3):
        for j in range(3):
            K2 = t[i] * t[j] - (a2 if i == j else 0.0)
            eye = 1.0 if i == j else 0.0
            Jl[i, j] = eye + c1 * K[i][j] + c2 * K2
            Jl_inv[i, j] = eye - 0.5 * K[i][j] + k * K2


@jit
def hat_into(v0: float, v1: float, v2: float, out: FloatArray) -> None:
    """``out = hat(v)`` (3 x 3): ``hat(v) b = v x b``."""
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -v2, v1
    out[1, 0], out[1, 1], out[1, 2] = v2, 0.0, -v0
    out[2, 0], out[2, 1], out[2, 2] = -v1, v0, 0.0


@jit
def multiply(A: FloatArray, B: FloatArray, out: FloatArray) -> None:
    """``out = A B`` for small matrices (explicit loops: numba's BLAS path costs compile time
    and call overhead on 3 x 3 and 6 x 6)."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc


@jit
def multiply_transposed(A: FloatArray, B: FloatArray, out: FloatArray) -> None:
    """``out = A^T B`` for small matrices."""
    for i in range(A.shape[1]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[0]):
                acc += A[k, i] * B[k, j]
            out[i, j] = acc


@jit
def rotate_tensor(R: FloatArray, T: FloatArray, out: FloatArray, work: FloatArray) -> None:
    """``out = R T R^T`` (3 x 3)."""
    multiply(R, T, work)
    for i in range(3):
        for j in range(3):
            out[i, j] = work[i, 0] * R[j, 0] + work[i, 1] * R[j, 1] + work[i, 2] * R[j, 2]


@jit
def group_matrices(free_inv_mass: FloatArray, body_dof: IntArray, body_mass: FloatArray,
                   body_first_moment: FloatArray, body_inertia: FloatArray, body_inv_inertia_cm: FloatArray,
                   group_dofs: IntArray, group_size: IntArray, group_body: IntArray, y: FloatArray, R: FloatArray,
                   M_inv: FloatArray, chart: FloatArray, T: FloatArray, gyro: FloatArray) -> None:
    """Per group (G, 6, 6, zero padded): the inverse mass ``M_inv``, ``chart`` = ``d(x
    increment)/dx`` = blockdiag(I, J_l), ``T`` = ``d(dx/dt)/dv`` = blockdiag(I, J_l^-1) and the
    derivative ``gyro`` of the velocity terms ``[w x (w x s); w x (I_c w)]`` by ``v``.
    A body's ``M^-1`` (Newton-Euler eliminated as in :func:`accelerate`, ``W = I_cm^-1``,
    ``S = hat(s)``) is ``[[I/m - S W S/m^2, S W/m], [-W S/m, W]]``."""
    n_dof = y.shape[0] // 2
    M_inv[:] = 0.0
    chart[:] = 0.0
    T[:] = 0.0
    gyro[:] = 0.0
    S, W, Ic, Hw = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    SW, WS, SWS, work = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    Jl, Jl_inv = np.empty((3, 3)), np.empty((3, 3))
    for g in range(group_size.shape[0]):
        b = group_body[g]
        if b < 0:
            for k in range(group_size[g]):
                M_inv[g, k, k] = free_inv_mass[group_dofs[g, k]]
                chart[g, k, k] = 1.0
                T[g, k, k] = 1.0
            continue
        d = body_dof[b]
        m = body_mass[b]
        Rb = R[b]
        sb = body_first_moment[b]
        s0 = Rb[0, 0] * sb[0] + Rb[0, 1] * sb[1] + Rb[0, 2] * sb[2]
        s1 = Rb[1, 0] * sb[0] + Rb[1, 1] * sb[1] + Rb[1, 2] * sb[2]
        s2 = Rb[2, 0] * sb[0] + Rb[2, 1] * sb[1] + Rb[2, 2] * sb[2]
        rotate_tensor(Rb, body_inv_inertia_cm[b], W, work)
        rotate_tensor(Rb, body_inertia[b], Ic, work)
        hat_into(s0, s1, s2, S)
        multiply(S, W, SW)
        multiply(W, S, WS)
        multiply(SW, S, SWS)
        w0, w1, w2 = y[n_dof + d + 3], y[n_dof + d + 4], y[n_dof + d + 5]
        hat_into(w0, w1, w2, Hw)
        chart_jacobians(y[d + 3], y[d + 4], y[d + 5], Jl, Jl_inv)
        # gyro: [:3, 3:] = -hat(w x s) - hat(w) hat(s); [3:, 3:] = hat(w) I_c - hat(I_c w)
        multiply(Hw, S, work)
        c0, c1, c2 = w1 * s2 - w2 * s1, w2 * s0 - w0 * s2, w0 * s1 - w1 * s0
        hat_into(c0, c1, c2, S)                               # S now holds hat(w x s)
        for i in range(3):
            for j in range(3):
                gyro[g, i, 3 + j] = -S[i, j] - work[i, j]
        L0 = Ic[0, 0] * w0 + Ic[0, 1] * w1 + Ic[0, 2] * w2
        L1 = Ic[1, 0] * w0 + Ic[1, 1] * w1 + Ic[1, 2] * w2
        L2 = Ic[2, 0] * w0 + Ic[2, 1] * w1 + Ic[2, 2] * w2
        multiply(Hw, Ic, work)
        hat_into(L0, L1, L2, S)                               # S now holds hat(I_c w)
        for i in range(3):
            chart[g, i, i] = 1.0
            T[g, i, i] = 1.0
            for j in range(3):
                gyro[g, 3 + i, 3 + j] = work[i, j] - S[i, j]
                M_inv[g, i, j] = (1.0 / m if i == j else 0.0) - SWS[i, j] / (m * m)
                M_inv[g, i, 3 + j] = SW[i, j] / m
                M_inv[g, 3 + i, j] = -WS[i, j] / m
                M_inv[g, 3 + i, 3 + j] = W[i, j]
                chart[g, 3 + i, 3 + j] = Jl[i, j]
                T[g, 3 + i, 3 + j] = Jl_inv[i, j]


@jit
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
    """The Jacobian's blocks (:mod:`.pattern`) of one state: ``T`` (G, 6, 6), and per block
    (nk, 6, 6) ``position = -M^-1 K_T C`` and ``velocity = -M^-1 (D + G)``. ``K_T`` is the
    statics' exact tangent stiffness of the members' elastic forces and the external forces
    (material and geometric parts, and the moments' rotation terms ``S(g, r)`` of
    :mod:`tensegrity_core.general.stiffness`), ``D`` the taut dampers' ``c u u^T``."""
    n = base.shape[0]
    G = group_size.shape[0]
    X, V = np.empty((n, 3)), np.empty((n, 3))
    R = np.empty((body_dof.shape[0], 3, 3))
    r = np.empty((on_node.shape[0], 3))
    place(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, y, R_ref, X, V, R, r)
    arm = np.zeros((n, 3))
    for k in range(on_node.shape[0]):
        copy_vector(r[k], arm[on_node[k]])
    f_el = external.copy()
    K = np.zeros(position.shape)
    D = np.zeros(position.shape)
    Ga, Gb = np.zeros((3, 6)), np.zeros((3, 6))
    kGa, kGb, dGa, dGb = np.empty((3, 6)), np.empty((3, 6)), np.empty((3, 6)), np.empty((3, 6))
    kmat, dmat = np.empty((3, 3)), np.empty((3, 3))
    block, block2 = np.empty((6, 6)), np.empty((6, 6))
    for i in range(member_a.shape[0]):
        a, b = member_a[i], member_b[i]
        h0, h1, h2 = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
        length = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        if is_string[i] and length < l0[i]:
            continue
        u = (h0 / length, h1 / length, h2 / length)
        t = EA[i] * (length - l0[i]) / l0[i]
        for p in range(3):
            f_el[a, p] += t * u[p]
            f_el[b, p] -= t * u[p]
        blocks = member_blocks[i]
        if blocks[0] < 0 and blocks[3] < 0:
            continue
        k_axial, geometric, c = EA[i] / l0[i], t / length, damping[i]
        for p in range(3):
            for q in range(3):
                uu = u[p] * u[q]
                kmat[p, q] = k_axial * uu + geometric * ((1.0 if p == q else 0.0) - uu)
                dmat[p, q] = c * uu
        for end in range(2):
            node = a if end == 0 else b
            G_ = Ga if end == 0 else Gb
            g = node_group[node]
            if g >= 0 and group_body[g] >= 0:        # [I, -hat(r)]
                G_[:, :] = 0.0
                G_[0, 0] = G_[1, 1] = G_[2, 2] = 1.0
                r0, r1, r2 = arm[node, 0], arm[node, 1], arm[node, 2]
                G_[0, 4], G_[0, 5] = r2, -r1
                G_[1, 3], G_[1, 5] = -r2, r0
                G_[2, 3], G_[2, 4] = r1, -r0
            else:
                copy_matrix(node_selection[node], G_)
        multiply(kmat, Ga, kGa)
        multiply(kmat, Gb, kGb)
        multiply(dmat, Ga, dGa)
        multiply(dmat, Gb, dGb)
        for slot in range(4):
            blk = blocks[slot]
            if blk < 0:
                continue
            left = Ga if slot < 2 else Gb
            sign = 1.0 if slot == 0 or slot == 3 else -1.0
            multiply_transposed(left, kGa if slot % 2 == 0 else kGb, block)
            multiply_transposed(left, dGa if slot % 2 == 0 else dGb, block2)
            for p in range(6):
                for q in range(6):
                    K[blk, p, q] += sign * block[p, q]
                    D[blk, p, q] += sign * block2[p, q]
    for k in range(on_node.shape[0]):            # moments' rotation terms S(g, r), g = -f
        j = on_node[k]
        blk = diagonal_block[node_group[j]]
        g0, g1, g2 = -f_el[j, 0], -f_el[j, 1], -f_el[j, 2]
        gv = (g0, g1, g2)
        rv = (r[k, 0], r[k, 1], r[k, 2])
        gr = g0 * rv[0] + g1 * rv[1] + g2 * rv[2]
        for p in range(3):
            for q in range(3):
                K[blk, 3 + p, 3 + q] += 0.5 * (gv[p] * rv[q] + rv[p] * gv[q]) - (gr if p == q else 0.0)
    M_inv, chart, gyro = np.empty((G, 6, 6)), np.empty((G, 6, 6)), np.empty((G, 6, 6))
    group_matrices(free_inv_mass, body_dof, body_mass, body_first_moment, body_inertia, body_inv_inertia_cm,
                   group_dofs, group_size, group_body, y, R, M_inv, chart, T, gyro)
    for k in range(block_rows.shape[0]):
        p, q = block_rows[k], block_cols[k]
        multiply(M_inv[p], K[k], block)
        multiply(block, chart[q], block2)
        if p == q:
            for i in range(6):
                for j in range(6):
                    D[k, i, j] += gyro[p, i, j]
        multiply(M_inv[p], D[k], block)
        for i in range(6):
            for j in range(6):
                position[k, i, j] = -block2[i, j]
                velocity[k, i, j] = -block[i, j]


# -- integration stages ------------------------------------------------------------------------------
@jit
def rk_stages(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
              on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
              body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
              body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
              damping: FloatArray, is_string: BoolArray, external: FloatArray,
              y: FloatArray, h: float, R_ref: FloatArray, l0: FloatArray, A: FloatArray,
              first: int | np.int64, last: int | np.int64, K: FloatArray) -> None:
    """Stages ``first .. last - 1`` of an explicit Runge-Kutta tableau ``A``:
    ``K[s] = f(y + h sum_j A[s, j] K[j])`` with the rest lengths ``l0[s]`` (one row per stage).
    Kernels pass ``first`` and ``last`` as ``np.int64``, as a call from Python does: numba
    compiles a kernel again for every literal integer argument (``1``, ``5``) it is called with."""
    N = y.shape[0]
    n = base.shape[0]
    X, V, F = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    R, r = np.empty((body_dof.shape[0], 3, 3)), np.empty((on_node.shape[0], 3))
    wrench = np.empty((body_dof.shape[0], 6))
    lengths, forces = np.empty(member_a.shape[0]), np.empty(member_a.shape[0])
    z = np.empty(N)
    for s in range(first, last):
        for i in range(N):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            z[i] = y[i] + h * acc
        derivative(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
                   body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping,
                   is_string, external, z, R_ref, l0[s], K[s], X, V, F, R, r, wrench, lengths, forces)


@jit
def embedded_error(y: FloatArray, y_new: FloatArray, K: FloatArray, E5: FloatArray, E3: FloatArray, h: float,
                   rtol: float, atol: float) -> float:
    """DOP853's error norm (Hairer, Norsett & Wanner, Solving ODEs I, Sect. II.10): with the
    scaled 5th- and 3rd-order estimates ``e5 = sum_j E5_j K_j / sc``, ``e3`` likewise,
    ``sc = atol + rtol max(|y|, |y_new|)``: ``|h| |e5|^2 / sqrt(N (|e5|^2 + 0.01 |e3|^2))``."""
    N = y.shape[0]
    s5 = 0.0
    s3 = 0.0
    for i in range(N):
        sc = atol + rtol * max(abs(y[i]), abs(y_new[i]))
        e5 = 0.0
        e3 = 0.0
        for j in range(E5.shape[0]):
            e5 += E5[j] * K[j, i]
            e3 += E3[j] * K[j, i]
        s5 += (e5 / sc) ** 2
        s3 += (e3 / sc) ** 2
    if s5 == 0.0:
        return 0.0
    return abs(h) * s5 / math.sqrt(N * (s5 + 0.01 * s3))


@jit
def combine(y: FloatArray, h: float, weights: FloatArray, K: FloatArray, out: FloatArray) -> None:
    """``out = y + h sum_j weights_j K_j`` (summed as :func:`rk_stages` sums a stage)."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(weights.shape[0]):
            acc += weights[j] * K[j, i]
        out[i] = y[i] + h * acc


@jit
def dop853_attempt(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
                   on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
                   body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
                   body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
                   damping: FloatArray, is_string: BoolArray, external: FloatArray,
                   y: FloatArray, h: float, R_ref: FloatArray, l0: FloatArray, A: FloatArray, E5: FloatArray,
                   E3: FloatArray, rtol: float, atol: float, K: FloatArray, y_new: FloatArray) -> float:
    """One DOP853 step attempt in one call: stages 1-12 into ``K`` (``K[0]`` given: the rate
    at ``y``; row 12 the rate at ``y_new``), ``y_new``, and the error norm (:func:`embedded_error`)."""
    n_stages = E5.shape[0] - 1                              # 12
    rk_stages(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
              body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping, is_string,
              external, y, h, R_ref, l0, A, np.int64(1), n_stages + 1, K)
    combine(y, h, A[n_stages, :n_stages], K, y_new)
    return embedded_error(y, y_new, K, E5, E3, h, rtol, atol)


@jit
def dop853_dense(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
                 on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
                 body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
                 body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
                 damping: FloatArray, is_string: BoolArray, external: FloatArray,
                 y: FloatArray, y_new: FloatArray, h: float, R_ref: FloatArray, l0: FloatArray, A: FloatArray,
                 D: FloatArray, K: FloatArray, F: FloatArray) -> None:
    """DOP853's dense output of an accepted step of ``h`` [s] from ``y`` to ``y_new`` with
    stages ``K`` (rows 0-12): its three extra stages into ``K`` (rows 13-15) and the
    interpolant's coefficients ``F`` (7, N) (Hairer's DOP853, as scipy lays them out:
    :func:`dop853_value` evaluates them)."""
    extra = K.shape[0] - 3                                  # 13: the first extra stage (row 12: the end's rate)
    rk_stages(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
              body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping, is_string,
              external, y, h, R_ref, l0, A, extra, K.shape[0], K)
    for i in range(y.shape[0]):
        dy = y_new[i] - y[i]
        F[0, i] = dy
        F[1, i] = h * K[0, i] - dy
        F[2, i] = 2.0 * dy - h * (K[extra - 1, i] + K[0, i])
        for row in range(D.shape[0]):
            acc = 0.0
            for j in range(K.shape[0]):
                acc += D[row, j] * K[j, i]
            F[3 + row, i] = h * acc


@jit
def dop853_value(F: FloatArray, y_start: FloatArray, x: float, out: FloatArray) -> None:
    """``out``: DOP853's interpolant of coefficients ``F`` from ``y_start`` at the fraction
    ``x`` of its step (summed in scipy's ``Dop853DenseOutput`` order)."""
    last = F.shape[0] - 1
    for i in range(y_start.shape[0]):
        v = 0.0
        for k in range(F.shape[0]):
            v += F[last - k, i]
            v *= x if k % 2 == 0 else 1.0 - x
        out[i] = v + y_start[i]


@jit
def hermite_value(y_start: FloatArray, f_start: FloatArray, y_end: FloatArray, f_end: FloatArray, h: float,
                  x: float, out: FloatArray) -> None:
    """``out``: the cubic Hermite interpolant of a step of ``h`` [s] between both ends' states
    and rates at the fraction ``x`` of the step (as
    :class:`tensegrity_core.sim.integrators.HermiteDense` sums it)."""
    for i in range(y_start.shape[0]):
        a, b = h * f_start[i], h * f_end[i]
        dy = y_end[i] - y_start[i]
        out[i] = y_start[i] + x * (a + x * ((3.0 * dy - 2.0 * a - b) + x * (a + b - 2.0 * dy)))


# -- many steps in one call ----------------------------------------------------------------------
@jit
def quiet_step(g0: FloatArray, r0: FloatArray, g1: FloatArray, r1: FloatArray, moving: BoolArray, h: float) -> bool:
    """Whether no string can cross zero in a step of ``h`` [s] whose gaps are ``g0``, ``g1``
    [m] and rates ``r0``, ``r1`` [m/s] at its ends: the screen of
    :func:`tensegrity_core.sim.event_location.candidates` (every component strictly on one
    side at both ends and, by the Hermite bound ``4/27 h (|r0| + |r1|)``, unable to reach zero
    in between; ``moving`` strings, whose rates are unknown there, by their ends alone), with
    a margin of 1e-9 of the bound: a step it lets through is one the stepper would find quiet."""
    bound = (4.0 / 27.0) * h
    for j in range(g0.shape[0]):
        if not g0[j] * g1[j] > 0.0:
            return False
        if not moving[j] and min(abs(g0[j]), abs(g1[j])) < bound * (abs(r0[j]) + abs(r1[j])) * (1.0 + 1e-9):
            return False
    return True


@jit
def chart_due(body_dof: IntArray, y: FloatArray, angle: float) -> bool:
    """Whether a body's rotation vector in ``y`` is near or past ``angle`` [rad] (within 1e-9
    of it: the model's re-charting test decides)."""
    limit = (angle * (1.0 - 1e-9)) ** 2
    for b in range(body_dof.shape[0]):
        d = body_dof[b]
        if y[d + 3] * y[d + 3] + y[d + 4] * y[d + 4] + y[d + 5] * y[d + 5] > limit:
            return True
    return False


@jit
def covered(samples: FloatArray, sample: int, t_end: float) -> int:
    """The index after the last of ``samples`` from ``sample`` on at or before ``t_end`` [s]."""
    end = sample
    while end < samples.shape[0] and samples[end] <= t_end:
        end += 1
    return end


@jit
def exactly_at_end(samples: FloatArray, sample: int, end: int, t_end: float) -> bool:
    """Whether a step ending at ``t_end`` covers one sample only, at its very end: then the
    step's end state is the sample (as the stepper samples one time it advanced to), else
    every sample comes from the dense output (as the stepper interpolates several at once)."""
    return end == sample + 1 and samples[sample] == t_end


@jit
def rk4_run(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
            on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
            body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
            body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
            damping: FloatArray, is_string: BoolArray, external: FloatArray,
            strings: IntArray, moving: BoolArray, rechart_angle: float,
            t: float, y: FloatArray, f: FloatArray, h_fixed: float, t_bound: float, horizon: float,
            R_ref: FloatArray, l0: FloatArray, A: FloatArray, weights: FloatArray, K: FloatArray,
            y_new: FloatArray, samples: FloatArray, sample: int, Y: FloatArray) -> tuple[int, float, float, int]:
    """Classical RK4 steps of ``h_fixed`` [s] from ``(t, y)`` with rate ``f`` (rest lengths
    ``l0`` (5, m), constant), each shortened only to land on ``t_bound`` as
    :class:`tensegrity_core.sim.integrators.RK4` steps, until a step ends at or past
    ``horizon`` or ``t_bound``, or may hold a string's slack/taut event (:func:`quiet_step`)
    or a re-charting (:func:`chart_due`). Returns ``(steps, t_start, t_end, sample)`` of the
    last step: its start state and rate are left in ``y`` and ``f`` (overwritten), its end
    state in ``y_new`` and its end rate in ``K[4]``. The states at the times ``samples``
    [s] (increasing) from index ``sample`` on that the steps before the last one cover go
    into the rows of ``Y`` (:func:`hermite_value`, or a step's end state where
    :func:`exactly_at_end`); ``sample`` returned: the first time left."""
    n, nb, ns = base.shape[0], body_dof.shape[0], strings.shape[0]
    X, V, R, r = np.empty((n, 3)), np.empty((n, 3)), np.empty((nb, 3, 3)), np.empty((on_node.shape[0], 3))
    g0, r0, g1, r1 = np.empty(ns), np.empty(ns), np.empty(ns), np.empty(ns)
    string_gaps(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, member_a, member_b, strings, y,
                R_ref, l0[0], X, V, R, r, g0, r0)
    steps = 0
    while True:
        left = t_bound - t
        h = left if left < h_fixed * (1.0 + 1e-9) else h_fixed
        copy_vector(f, K[0])
        rk_stages(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
                  body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping, is_string,
                  external, y, h, R_ref, l0, A, np.int64(1), np.int64(5), K)
        combine(y, h, weights, K, y_new)
        t_new = t_bound if h == left else t + h
        steps += 1
        string_gaps(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, member_a, member_b, strings,
                    y_new, R_ref, l0[0], X, V, R, r, g1, r1)
        if t_new >= horizon or t_new >= t_bound or not quiet_step(g0, r0, g1, r1, moving, t_new - t) \
                or chart_due(body_dof, y_new, rechart_angle):
            return steps, t, t_new, sample
        end = covered(samples, sample, t_new)
        if exactly_at_end(samples, sample, end, t_new):
            copy_vector(y_new, Y[sample])
        else:
            for j in range(sample, end):
                hermite_value(y, f, y_new, K[4], t_new - t, (samples[j] - t) / (t_new - t), Y[j])
        sample = end
        t = t_new
        copy_vector(y_new, y)
        copy_vector(K[4], f)
        copy_vector(g1, g0)
        copy_vector(r1, r0)


@jit
def dop853_run(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
               on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
               body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
               body_inv_inertia_cm: FloatArray, member_a: IntArray, member_b: IntArray, EA: FloatArray,
               damping: FloatArray, is_string: BoolArray, external: FloatArray,
               strings: IntArray, moving: BoolArray, rechart_angle: float,
               t: float, y: FloatArray, t_bound: float, horizon: float, h_abs: float, max_step: float,
               rtol: float, atol: float, R_ref: FloatArray, l0: FloatArray, A: FloatArray, E5: FloatArray,
               E3: FloatArray, safety: float, min_factor: float, max_factor: float, D: FloatArray, K: FloatArray,
               y_new: FloatArray, F: FloatArray, samples: FloatArray, sample: int,
               Y: FloatArray) -> tuple[bool, int, int, float, float, float, int, int]:
    """Adaptive DOP853 steps from ``(t, y)`` with rate ``K[0]`` (rest lengths ``l0`` (16, m),
    constant), each chosen, attempted and accepted exactly as
    :class:`tensegrity_core.sim.integrators.DOP853` does (proposal ``h_abs`` [s], bounded by
    ``max_step``; controller ``safety``, ``min_factor``, ``max_factor``), until a step ends at
    or past ``horizon`` or ``t_bound``, or may hold a string's event or a re-charting (as
    :func:`rk4_run`). Returns ``(failed, steps, attempts, t_start, t_end, h_abs, sample,
    dense)``: the last step's start state is left in ``y``, its stages in ``K`` (row 12: the
    rate at its end ``y_new``), and the next step's proposal ``h_abs``; ``failed``: a step
    fell below the rounding of ``t``, and the state reached at ``t_end`` is in ``y``. The
    states at ``samples`` go into ``Y`` as in :func:`rk4_run`, from the steps' dense output
    (:func:`dop853_dense`, into ``F``; ``dense``: how many were built, 3 evaluations each)."""
    n, nb, ns = base.shape[0], body_dof.shape[0], strings.shape[0]
    X, V, R, r = np.empty((n, 3)), np.empty((n, 3)), np.empty((nb, 3, 3)), np.empty((on_node.shape[0], 3))
    g0, r0, g1, r1 = np.empty(ns), np.empty(ns), np.empty(ns), np.empty(ns)
    string_gaps(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, member_a, member_b, strings, y,
                R_ref, l0[0], X, V, R, r, g0, r0)
    n_stages = E5.shape[0] - 1                              # 12
    steps, attempts, dense = 0, 0, 0
    while True:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        rejected = False
        while True:
            h = min(h_abs, max_step)
            if h < min_step:
                return True, steps, attempts, t, t, h_abs, sample, dense
            t_new = t + h
            if t_new - t_bound > 0:
                t_new = t_bound
            h = t_new - t
            error = dop853_attempt(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof,
                                   body_mass, body_first_moment, body_inertia, body_inv_inertia_cm, member_a,
                                   member_b, EA, damping, is_string, external, y, h, R_ref, l0, A, E5, E3, rtol,
                                   atol, K, y_new)
            attempts += 1
            if error < 1.0:
                factor = max_factor if error == 0.0 else min(max_factor, safety * error ** (-1.0 / 8.0))
                h_abs = h * (min(1.0, factor) if rejected else factor)
                break
            h_abs = h * max(min_factor, safety * error ** (-1.0 / 8.0))
            rejected = True
        steps += 1
        t_start = t
        string_gaps(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, member_a, member_b, strings,
                    y_new, R_ref, l0[0], X, V, R, r, g1, r1)
        if t_new >= horizon or t_new >= t_bound or not quiet_step(g0, r0, g1, r1, moving, t_new - t) \
                or chart_due(body_dof, y_new, rechart_angle):
            return False, steps, attempts, t_start, t_new, h_abs, sample, dense
        end = covered(samples, sample, t_new)
        if exactly_at_end(samples, sample, end, t_new):
            copy_vector(y_new, Y[sample])
        elif end > sample:
            dop853_dense(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
                         body_first_moment, body_inertia, body_inv_inertia_cm, member_a, member_b, EA, damping,
                         is_string, external, y, y_new, h, R_ref, l0, A, D, K, F)
            dense += 1
            for j in range(sample, end):
                dop853_value(F, y, (samples[j] - t) / h, Y[j])
        sample = end
        t = t_new
        copy_vector(y_new, y)
        copy_vector(K[n_stages], K[0])
        copy_vector(g1, g0)
        copy_vector(r1, r0)
