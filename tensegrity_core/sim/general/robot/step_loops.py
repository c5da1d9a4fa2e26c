"""A robot's fixed step with its switches located inside it, compiled by numba (:mod:`tensegrity_core.sim.general.kernels.jit`).

A robot's forces switch on and off inside a step: a cap touches the floor or leaves it
(penetration ``delta`` through 0), a cable goes taut or slack (``l - l0`` through 0, its
rest length ``l0`` constant in the step). Across such a switch the right-hand side has a kink
(the floor's and an undamped cable's force start from 0 with a slope) or a jump (a damped
cable's ``c ldot``), and the classical RK4 across it is no longer fourth order: its stages
weigh the force like Simpson's rule, which misses the area of a ramp starting at ``theta h``
into the step by ``h^2 theta (1 - 3 theta) / 6`` of its slope (``theta <= 1/2``; mirrored
above), up to ``h^2 / 24`` too little at ``theta = 1/2``. A cap meeting a floor of stiffness
``k`` at the speed ``v`` then gains up to ``k v^2 h^2 / 24`` [J] of spurious work, ``(h
omega)^2 / 12`` of its kinetic energy (``omega^2 = k / m``): about 2 % of a 6-bar cap's at
1 ms (docs/design/robots.md, "Switches inside a step").

So each step is integrated in **smooth pieces**. Each switch keeps the mode it has at the
step's start (:data:`.loops.ON`, :data:`.loops.OFF`: the force law continued through 0),
RK4 takes the step, and the guards (penetrations, ``l - l0``) at its end are compared with
the modes. Where one crossed, the earliest crossing is found on the cubic Hermite polynomial
of its guard through both ends' values and rates (:func:`crossing`), RK4 goes there, the
switch flips, and the rest of the step is taken the same way (at most
:data:`MAX_PIECES` pieces a step; a guard that crosses and returns inside one piece is not
seen). A step without a switch costs what it did: the guards come from its first stage's
placement and from the placement its end's sampled update needs. A piece redone up to a
crossing starts from the state and under the modes of the piece it redoes (a step's first
piece evaluates its first stage by the signs its modes are then set from: the same forces),
so it takes that piece's first-stage derivative: a crossing costs seven evaluations, not eight.

:mod:`.arrays` ``run_steps`` computes the same numbers with numpy (tested against each other).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.jit import jit
from tensegrity_core.sim.general.kernels.loops import copy_vector, place
from tensegrity_core.sim.general.robot.loops import BY_SIGN, OFF, ON, derivative, evaluate, sampled_update

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: At most this many smooth pieces per step (the rest of a step after them is one piece).
MAX_PIECES = 8
#: Sample points of a guard's cubic on a piece before bisecting the first sign change.
SCAN = 16
#: Bisections of a crossing's bracket (its time to 2^-48 of the piece).
BISECTIONS = 48


def _crossing(q0: float, d0: float, q1: float, d1: float) -> float:
    """The first ``x`` in (0, 1] where the cubic Hermite polynomial of a guard over a piece
    (values ``q0 >= 0``, ``q1 < 0`` at its ends, slopes ``d0``, ``d1`` per piece) falls below
    0: the first of :data:`SCAN` equal parts where it does, bisected :data:`BISECTIONS` times;
    the bracket's upper end (where the polynomial is below 0, or 1). Plain Python arithmetic:
    compiled for :func:`first_crossing`, called as it is by the numpy twin."""
    b, c, e = d0, 3.0 * (q1 - q0) - 2.0 * d0 - d1, 2.0 * (q0 - q1) + d0 + d1      # q0 + x (b + x (c + x e))
    lo, hi = 0.0, 1.0
    for j in range(1, SCAN + 1):
        x = j / SCAN
        if q0 + x * (b + x * (c + x * e)) < 0.0:
            lo, hi = (j - 1) / SCAN, x
            break
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        if q0 + mid * (b + mid * (c + mid * e)) < 0.0:
            hi = mid
        else:
            lo = mid
    return hi


crossing = jit(_crossing)


@jit
def guards(cap_node: IntArray, cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray,
           cable_a: IntArray, cable_b: IntArray, l0: FloatArray, X: FloatArray, V: FloatArray, g: FloatArray,
           rate: FloatArray) -> None:
    """The switches' guards ``g`` and their rates ``rate`` (ncap + c) at node positions ``X``
    [m] and velocities ``V`` [m/s]: per cap its penetration ``delta`` [m] and ``-n . v``, per
    cable ``l - l0`` [m] and ``ldot`` (computed as the forces compute them)."""
    n0, n1, n2 = floor_normal[0], floor_normal[1], floor_normal[2]
    ncap = cap_node.shape[0]
    for c in range(ncap):
        node = cap_node[c]
        g[c] = cap_radius[c] - ((X[node, 0] - floor_point[0]) * n0 + (X[node, 1] - floor_point[1]) * n1
                                + (X[node, 2] - floor_point[2]) * n2)
        rate[c] = -(V[node, 0] * n0 + V[node, 1] * n1 + V[node, 2] * n2)
    for i in range(cable_a.shape[0]):
        a, b = cable_a[i], cable_b[i]
        h0, h1, h2 = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
        length = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        u0, u1, u2 = 0.0, 0.0, 0.0
        if length > 0.0:
            u0, u1, u2 = h0 / length, h1 / length, h2 / length
        g[ncap + i] = length - l0[i]
        rate[ncap + i] = u0 * (V[b, 0] - V[a, 0]) + u1 * (V[b, 1] - V[a, 1]) + u2 * (V[b, 2] - V[a, 2])


@jit
def first_crossing(switch: FloatArray, g0: FloatArray, rate0: FloatArray, g1: FloatArray, rate1: FloatArray,
                   H: float) -> tuple[int, float]:
    """``(i, x)``: the switch whose guard leaves its mode's side first over a piece of ``H``
    [s] (``g0``, ``rate0`` at its start, ``g1``, ``rate1`` at its end), and where (the fraction
    ``x`` of the piece, :func:`crossing`); ``(-1, 1)`` if none does. A guard a rounding short
    of its mode's side at the piece's start (one just flipped at its crossing) starts at 0."""
    which, best = -1, 1.0
    for i in range(switch.shape[0]):
        side = 1.0 if switch[i] == ON else -1.0
        if side * g1[i] < 0.0:
            x = crossing(max(side * g0[i], 0.0), side * rate0[i] * H, side * g1[i], side * rate1[i] * H)
            if which < 0 or x < best:
                which, best = i, x
    return which, best


@jit
def run_steps(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
              on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
              body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
              body_inv_inertia_cm: FloatArray, external: FloatArray, cable_a: IntArray, cable_b: IntArray,
              cable_k: FloatArray, cable_c: FloatArray, cable_t_max: FloatArray, cable_l0: FloatArray,
              cable_motor: IntArray, motor_cable: IntArray, motor_lo: FloatArray, motor_hi: FloatArray,
              motor_tau: FloatArray, motor_speed: FloatArray, cap_node: IntArray, cap_body: IntArray,
              cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray, floor_params: FloatArray,
              y: FloatArray, R_ref: FloatArray, h: float, aims: FloatArray, modes: IntArray,
              y_end: FloatArray, out: FloatArray, X_out: FloatArray, V_out: FloatArray, R_out: FloatArray,
              F_out: FloatArray, l0_out: FloatArray, lengths_out: FloatArray, rates_out: FloatArray,
              tensions_out: FloatArray, depth_out: FloatArray, normal_out: FloatArray, friction_out: FloatArray,
              couple_out: FloatArray) -> None:
    """``len(aims)`` fixed steps of ``h`` [s] from ``y`` (changed in place, with the charts
    ``R_ref``): per step the classical RK4 in smooth pieces (module docstring; the sampled
    entries constant), then :func:`.loops.sampled_update` with that step's motor commands
    ``aims[s]`` in the motors' ``modes`` (rest length [m], reel speed [m/s], tension [N]).
    ``y_end``: the last step's RK4 result before its update (the end of the step in the step's
    own charts, for interpolation). ``out`` .. ``couple_out``: the final ``y`` in the final
    charts evaluated by :func:`.loops.evaluate` (a batch of one), what an observation of the
    step's end needs."""
    N = y.shape[0]
    n, nb, m, ncap = base.shape[0], body_dof.shape[0], cable_a.shape[0], cap_node.shape[0]
    n_dof = free_node.shape[0] + 6 * nb
    X, V, F = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    R, r = np.empty((nb, 3, 3)), np.empty((on_node.shape[0], 3))
    wrench, moments = np.empty((nb, 6)), np.empty((ncap, 3))
    l0, lengths, rates_, tensions = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    depth, normal, friction, couple = np.empty(ncap), np.empty(ncap), np.empty((ncap, 3)), np.empty((ncap, 3))
    K = np.empty((4, N))
    z, z0, y1 = np.empty(N), np.empty(N), np.empty(N)
    switch = np.empty(ncap + m)
    g0, rate0, g1, rate1 = np.empty(ncap + m), np.empty(ncap + m), np.empty(ncap + m), np.empty(ncap + m)
    for s in range(aims.shape[0]):
        copy_vector(y, z0)
        left = h                              # what is left of the step [s]
        H = h                                 # the piece being taken [s]: what is left, or up to a crossing
        pieces, which, to_crossing = 0, -1, False
        switch[:] = BY_SIGN                   # the first stage by sign: the modes are its guards' signs
        while True:
            # one RK4 piece of ``H`` from z0 (its first stage's guards into g0, rate0); redone up
            # to a crossing, its first stage is the one in K[0]: the same state, charts and modes
            for stage in range(1 if to_crossing else 0, 4):
                if stage == 0:
                    copy_vector(z0, z)
                else:
                    c = 0.5 * H if stage < 3 else H
                    for i in range(N):
                        z[i] = z0[i] + c * K[stage - 1, i]
                derivative(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof,
                           body_mass, body_first_moment, body_inertia, body_inv_inertia_cm, external, cable_a,
                           cable_b, cable_k, cable_c, cable_t_max, cable_l0, cable_motor, motor_cable, motor_lo,
                           motor_hi, motor_tau, motor_speed, cap_node, cap_body, cap_radius, floor_normal,
                           floor_point, floor_params, switch, z, R_ref, K[stage], X, V, R, r, F, wrench, moments,
                           l0, lengths, rates_, tensions, depth, normal, friction, couple)
                if stage == 0:
                    guards(cap_node, cap_radius, floor_normal, floor_point, cable_a, cable_b, l0, X, V, g0, rate0)
                    for i in range(ncap + m):
                        if switch[i] == BY_SIGN:
                            switch[i] = ON if g0[i] > 0.0 else OFF
            for i in range(N):
                y1[i] = z0[i] + H / 6.0 * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i])
            if to_crossing:
                # at the crossing under the same modes: the switch flips, the rest is the next piece
                copy_vector(y1, z0)
                left = left - H
                H = left
                switch[which] = OFF if switch[which] == ON else ON
                to_crossing = False
                continue
            place(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, y1[:2 * n_dof], R_ref, X, V,
                  R, r)
            guards(cap_node, cap_radius, floor_normal, floor_point, cable_a, cable_b, l0, X, V, g1, rate1)
            which, x = first_crossing(switch, g0, rate0, g1, rate1, left)
            if which < 0 or pieces >= MAX_PIECES:
                break
            pieces += 1
            H = x * left                      # the step is redone up to the crossing: another piece
            to_crossing = True
        copy_vector(y1, y)
        copy_vector(y, y_end)
        sampled_update(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, cable_a, cable_b, cable_k,
                       cable_t_max, motor_cable, motor_lo, motor_hi, motor_tau, motor_speed, cap_node, cap_body,
                       cap_radius, floor_normal, floor_point, floor_params, y, R_ref, h, aims[s], modes, X, V, R, r)
    evaluate(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
             body_first_moment, body_inertia, body_inv_inertia_cm, external, cable_a, cable_b, cable_k, cable_c,
             cable_t_max, cable_l0, cable_motor, motor_cable, motor_lo, motor_hi, motor_tau, motor_speed, cap_node,
             cap_body, cap_radius, floor_normal, floor_point, floor_params, y.reshape((1, N)),
             R_ref.reshape((1, nb, 3, 3)), out, X_out, V_out, R_out, F_out, l0_out, lengths_out, rates_out,
             tensions_out, depth_out, normal_out, friction_out, couple_out)
