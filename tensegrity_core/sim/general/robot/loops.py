"""Explicit-loop kernels of a robot's dynamics, compiled by numba (:mod:`tensegrity_core.sim.general.kernels.jit`).

The robot's effects are kernels of the general kernels' shape (:mod:`tensegrity_core.sim.general.kernels.loops`),
called between its ``place`` and ``rates``; :mod:`.arrays` computes the same numbers with
numpy (tested against each other). Arguments are the :class:`~.plan.RobotPlan` arrays
spelled out, then per call the state ``y`` (:class:`~.plan.RobotPlan` ``n_state``), the
rotation charts ``R_ref`` (nb, 3, 3) and work or output arrays.

**State** ``y = (x, v, l0, offsets, contact)``: the general coordinates and rates
(``2 n_dof``), the motors' rest lengths [m], per cap the tangential offset [m] (3) of its
contact's material point from its friction anchor, and its contact state (0: no anchor,
1: sticking, 2: slipping). The offsets are integrated with the motion (their rate is the
material point's tangential velocity); the rest lengths and contact states are
**sampled**: constant during a step and updated once at its end by
:func:`sampled_update`, which also re-maps the offsets (a slip);
:func:`.step_loops.run_steps` integrates whole fixed steps (classical RK4 in smooth pieces
between the caps' and cables' switches), updating after each, as a 1 kHz robot loop does
(MuJoCo likewise integrates its actuators' states once per step).

One evaluation (:func:`derivative`):

1. ``place``: node positions, velocities, body rotations and arms (general kernel);
2. weights (``external``), :func:`cable_forces` (the tension-only cable element of
   :mod:`tensegrity_core.robot.cable`), :func:`floor_forces` (Hunt-Crossley normal force of
   :mod:`tensegrity_core.robot.contact` and the friction anchor's force of
   :mod:`tensegrity_core.robot.friction`, the return map of the stage's offset (at most
   ``mu F_n`` at every stage), acting at the contact point: a force on the cap
   and a moment about its centre; the rolling and spin resistance couple of
   :mod:`tensegrity_core.robot.contact`);
3. ``nodal_wrenches``, the caps' friction moments added, ``rates`` (general kernels).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.robot.contact import SPIN_TOLERANCE
from tensegrity_core.robot.motor import REEL_SPEED, TENSION
from tensegrity_core.sim.general.kernels.jit import jit
from tensegrity_core.sim.general.kernels.loops import copy_matrix, nodal_wrenches, place, rates, rotate

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Contact states of a cap (the last entries of the state vector).
NO_ANCHOR, STICKING, SLIPPING = 0.0, 1.0, 2.0
#: A switch's mode in an evaluation (per cap: in contact; per cable: taut): by the sign of its
#: guard (penetration, ``l - l0``), or held off or on through a smooth piece of a step.
BY_SIGN, OFF, ON = -1.0, 0.0, 1.0
#: Re-anchor a body's rotation chart when its rotation vector exceeds this angle [rad]
#: (as the general dynamics do).
RECHART_ANGLE = 1.0


@jit
def rest_lengths(cable_l0: FloatArray, cable_motor: IntArray, y: FloatArray, start: int, l0: FloatArray) -> None:
    """``l0`` (c,) [m]: each cable's drawn rest length, or its motor's state ``y[start + slot]``."""
    for i in range(cable_l0.shape[0]):
        slot = cable_motor[i]
        l0[i] = cable_l0[i] if slot < 0 else y[start + slot]


@jit
def cable_forces(cable_a: IntArray, cable_b: IntArray, cable_k: FloatArray, cable_c: FloatArray,
                 cable_t_max: FloatArray, l0: FloatArray, X: FloatArray, V: FloatArray, F: FloatArray,
                 lengths: FloatArray, rates_: FloatArray, tensions: FloatArray, switch: FloatArray,
                 first: int) -> None:
    """Tensions ``T = clip(k (l - l0) + c ldot, 0, T_max)`` of taut cables (``l > l0``; 0
    while slack) added as ``+T u`` to end ``a`` and ``-T u`` to end ``b`` of ``F``; writes
    ``lengths`` [m], ``rates_`` [m/s] and ``tensions`` [N]. A cable whose ends meet (``l = 0``,
    two rods' caps passing through each other) is slack, with rate 0. ``switch[first + i]``
    (:data:`BY_SIGN`, :data:`OFF`, :data:`ON`): whether cable ``i`` is taut by the sign of
    ``l - l0`` or held slack or taut (a step's smooth piece, :mod:`.step_loops`)."""
    for i in range(cable_a.shape[0]):
        a, b = cable_a[i], cable_b[i]
        h0, h1, h2 = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
        length = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        u0, u1, u2 = 0.0, 0.0, 0.0                  # ends at one point: slack (l0 > 0), no direction
        if length > 0.0:
            u0, u1, u2 = h0 / length, h1 / length, h2 / length
        rate = u0 * (V[b, 0] - V[a, 0]) + u1 * (V[b, 1] - V[a, 1]) + u2 * (V[b, 2] - V[a, 2])
        lengths[i] = length
        rates_[i] = rate
        t = 0.0
        mode = switch[first + i]
        if (length > l0[i]) if mode == BY_SIGN else mode == ON:
            t = min(max(cable_k[i] * (length - l0[i]) + cable_c[i] * rate, 0.0), cable_t_max[i])
        tensions[i] = t
        F[a, 0] += t * u0
        F[a, 1] += t * u1
        F[a, 2] += t * u2
        F[b, 0] -= t * u0
        F[b, 1] -= t * u1
        F[b, 2] -= t * u2


@jit
def cap_contact(X: FloatArray, V: FloatArray, node: int, radius: float, floor_point: FloatArray, n0: float, n1: float,
                n2: float, k: float, d: float, mode: float) -> tuple[float, float]:
    """``(delta, F_n)`` of a cap of ``radius`` [m] centred at ``node``: its penetration
    ``delta`` [m] into the floor (through ``floor_point``, unit normal ``n``) and the normal
    force ``F_n = k delta max(0, 1 + d deltadot)`` [N] (0 out of contact). ``mode``
    (:data:`BY_SIGN`, :data:`OFF`, :data:`ON`): in contact where ``delta > 0``, or held out of
    or in contact (a step's smooth piece: ``F_n`` continued through ``delta = 0``)."""
    delta = radius - ((X[node, 0] - floor_point[0]) * n0 + (X[node, 1] - floor_point[1]) * n1
                      + (X[node, 2] - floor_point[2]) * n2)
    fn = 0.0
    if (delta > 0.0) if mode == BY_SIGN else mode == ON:
        fn = k * delta * max(0.0, 1.0 + d * -(V[node, 0] * n0 + V[node, 1] * n1 + V[node, 2] * n2))
    return delta, fn


@jit
def contact_point_velocity(V: FloatArray, node: int, body: int, body_dof: IntArray, y: FloatArray, n_dof: int,
                           radius: float, n0: float, n1: float, n2: float) -> tuple[float, float, float]:
    """Velocity [m/s] of the material point of a cap (centred at ``node``, on moving body
    ``body`` or -1) that touches the floor of unit normal ``n``: the centre's plus
    ``w x (-radius n)`` (``y``'s rates start at ``y[n_dof]``)."""
    v0, v1, v2 = V[node, 0], V[node, 1], V[node, 2]
    if body >= 0:
        dof = n_dof + body_dof[body] + 3
        w0, w1, w2 = y[dof], y[dof + 1], y[dof + 2]
        v0 -= radius * (w1 * n2 - w2 * n1)
        v1 -= radius * (w2 * n0 - w0 * n2)
        v2 -= radius * (w0 * n1 - w1 * n0)
    return v0, v1, v2


@jit
def anchor_force(s0: float, s1: float, s2: float, v0: float, v1: float, v2: float, fn: float, kt: float, ct: float,
                 mu_s: float, mu_k: float, sticking: bool) -> tuple[float, float, float]:
    """The friction force [N] of a cap at one evaluation
    (:func:`tensegrity_core.robot.friction.stage_force`): the return map of its trial offset
    ``s`` [m] with the step's hold (``mu_s F_n`` ``sticking``, else ``mu_k F_n``): sticking,
    ``-k_t s - beta c_t v`` (``v`` [m/s], ``beta`` in [0, 1] the largest keeping the force
    within the hold; no damper while slipping); beyond it ``mu_k F_n`` against ``s``."""
    size = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    hold = (mu_s if sticking else mu_k) * fn
    if kt * size <= hold and hold > 0.0:
        a0, a1, a2 = kt * s0, kt * s1, kt * s2
        b0, b1, b2 = 0.0, 0.0, 0.0
        if sticking:
            b0, b1, b2 = ct * v0, ct * v1, ct * v2
        b_size = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        beta = 0.0
        if b_size > 0.0:
            h0, h1, h2 = a0 / hold, a1 / hold, a2 / hold
            au = (h0 * b0 + h1 * b1 + h2 * b2) / b_size
            t = hold * (-au + math.sqrt(au * au + max(1.0 - (h0 * h0 + h1 * h1 + h2 * h2), 0.0)))
            beta = min(t / b_size, 1.0)
        return -a0 - beta * b0, -a1 - beta * b1, -a2 - beta * b2
    if size == 0.0:
        return 0.0, 0.0, 0.0
    slide = mu_k * fn
    return -slide * (s0 / size), -slide * (s1 / size), -slide * (s2 / size)


@jit
def floor_forces(cap_node: IntArray, cap_body: IntArray, cap_radius: FloatArray, floor_normal: FloatArray,
                 floor_point: FloatArray, floor_params: FloatArray, body_dof: IntArray, y: FloatArray,
                 n_dof: int, anchors: int, X: FloatArray, V: FloatArray, F: FloatArray, moments: FloatArray,
                 depth: FloatArray, normal: FloatArray, friction: FloatArray, couple: FloatArray,
                 out: FloatArray, switch: FloatArray) -> None:
    """Per cap: its penetration ``depth`` [m], the normal force ``F_n = k delta max(0, 1 + d
    deltadot)`` [N] (``normal``; 0 out of contact) along the floor's normal, and with an
    anchor the friction force (``friction``, (ncap, 3); :func:`anchor_force`: ``-k_t s -
    beta c_t v_t`` within the hold, ``mu_k F_n`` against ``s`` beyond it) of the anchor's
    tangential offset ``s`` (the state's entries from ``anchors``) and the tangential
    velocity ``v_t`` of the cap's material point at the contact; both added to the cap's
    node in ``F``, the friction's moment about the cap's centre plus the rolling and spin
    resistance ``couple`` [N m] (``couple``, (ncap, 3);
    :func:`tensegrity_core.robot.contact.resisting_couple`) into ``moments``. The offset's
    rate ``v_t`` (0 without an anchor) goes into ``out`` at the state's entries: the offset
    is the material point's tangential displacement since it was anchored, so the force's
    power is the rate of the anchor's potential (:mod:`tensegrity_core.robot.friction`; a
    cap rolls without storing energy). ``n_dof``: the rates start at ``y[n_dof]``."""
    k, d, mu_s, mu_k = floor_params[0], floor_params[1], floor_params[2], floor_params[3]
    kt, ct = floor_params[4], floor_params[5]
    b_roll, b_spin = floor_params[6], floor_params[7]
    n0, n1, n2 = floor_normal[0], floor_normal[1], floor_normal[2]
    ncap = cap_node.shape[0]
    for c in range(ncap):
        node = cap_node[c]
        r = cap_radius[c]
        delta, fn = cap_contact(X, V, node, r, floor_point, n0, n1, n2, k, d, switch[c])
        depth[c] = delta
        normal[c] = fn
        F[node, 0] += fn * n0
        F[node, 1] += fn * n1
        F[node, 2] += fn * n2
        state = y[anchors + 3 * ncap + c]
        f0, f1, f2 = 0.0, 0.0, 0.0
        a = anchors + 3 * c
        out[a], out[a + 1], out[a + 2] = 0.0, 0.0, 0.0
        if state != NO_ANCHOR:
            s0, s1, s2 = y[a], y[a + 1], y[a + 2]
            sn = s0 * n0 + s1 * n1 + s2 * n2
            s0, s1, s2 = s0 - sn * n0, s1 - sn * n1, s2 - sn * n2
            v0, v1, v2 = contact_point_velocity(V, node, cap_body[c], body_dof, y, n_dof, r, n0, n1, n2)
            vn = v0 * n0 + v1 * n1 + v2 * n2
            v0, v1, v2 = v0 - vn * n0, v1 - vn * n1, v2 - vn * n2
            out[a], out[a + 1], out[a + 2] = v0, v1, v2
            f0, f1, f2 = anchor_force(s0, s1, s2, v0, v1, v2, max(fn, 0.0), kt, ct, mu_s, mu_k, state == STICKING)
        friction[c, 0], friction[c, 1], friction[c, 2] = f0, f1, f2
        F[node, 0] += f0
        F[node, 1] += f1
        F[node, 2] += f2
        # moment about the cap's centre of the friction at the contact point: (-r n) x f
        moments[c, 0] = -r * (n1 * f2 - n2 * f1)
        moments[c, 1] = -r * (n2 * f0 - n0 * f2)
        moments[c, 2] = -r * (n0 * f1 - n1 * f0)
        m0, m1, m2 = 0.0, 0.0, 0.0
        body = cap_body[c]
        if fn > 0.0 and body >= 0 and (b_roll > 0.0 or b_spin > 0.0):
            dof = n_dof + body_dof[body] + 3
            w0, w1, w2 = y[dof], y[dof + 1], y[dof + 2]
            wn = w0 * n0 + w1 * n1 + w2 * n2
            w0, w1, w2 = w0 - wn * n0, w1 - wn * n1, w2 - wn * n2
            roll = -b_roll * fn / max(math.sqrt(w0 * w0 + w1 * w1 + w2 * w2), SPIN_TOLERANCE)
            spin = -b_spin * fn * wn / max(abs(wn), SPIN_TOLERANCE)
            m0, m1, m2 = roll * w0 + spin * n0, roll * w1 + spin * n1, roll * w2 + spin * n2
        couple[c, 0], couple[c, 1], couple[c, 2] = m0, m1, m2
        moments[c, 0] += m0
        moments[c, 1] += m1
        moments[c, 2] += m2


@jit
def derivative(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
               on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
               body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
               body_inv_inertia_cm: FloatArray, external: FloatArray, cable_a: IntArray, cable_b: IntArray,
               cable_k: FloatArray, cable_c: FloatArray, cable_t_max: FloatArray, cable_l0: FloatArray,
               cable_motor: IntArray, motor_cable: IntArray, motor_lo: FloatArray, motor_hi: FloatArray,
               motor_tau: FloatArray, motor_speed: FloatArray, cap_node: IntArray, cap_body: IntArray,
               cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray, floor_params: FloatArray,
               switch: FloatArray, y: FloatArray, R_ref: FloatArray, out: FloatArray, X: FloatArray, V: FloatArray,
               R: FloatArray, r: FloatArray, F: FloatArray, wrench: FloatArray, moments: FloatArray, l0: FloatArray,
               lengths: FloatArray, rates_: FloatArray, tensions: FloatArray, depth: FloatArray,
               normal: FloatArray, friction: FloatArray, couple: FloatArray) -> None:
    """``out = dy/dt`` of one state (module docstring): the plan's arrays, the switches' modes
    ``switch`` (ncap + c: the caps', then the cables'; :data:`BY_SIGN` in every evaluation but a
    step's smooth pieces, :mod:`.step_loops`), ``y``, ``R_ref``,
    ``out``, then work arrays that keep the placement, the forces and each effect's state
    afterwards (``l0`` the cables' rest lengths, ``lengths``, ``rates_``, ``tensions``;
    the caps' ``depth``, ``normal`` and ``friction`` forces and resisting ``couple``)."""
    n_dof = free_node.shape[0] + 6 * body_dof.shape[0]
    xv = y[:2 * n_dof]
    place(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, xv, R_ref, X, V, R, r)
    copy_matrix(external, F)
    out[2 * n_dof:] = 0.0
    rest_lengths(cable_l0, cable_motor, y, 2 * n_dof, l0)
    cable_forces(cable_a, cable_b, cable_k, cable_c, cable_t_max, l0, X, V, F, lengths, rates_, tensions, switch,
                 cap_node.shape[0])
    floor_forces(cap_node, cap_body, cap_radius, floor_normal, floor_point, floor_params, body_dof, y, n_dof,
                 2 * n_dof + motor_cable.shape[0], X, V, F, moments, depth, normal, friction, couple, out, switch)
    nodal_wrenches(on_node, on_body, r, F, wrench)
    for c in range(cap_node.shape[0]):
        b = cap_body[c]
        if b >= 0:
            wrench[b, 3] += moments[c, 0]
            wrench[b, 4] += moments[c, 1]
            wrench[b, 5] += moments[c, 2]
    rates(free_node, free_axis, free_inv_mass, body_dof, body_mass, body_first_moment, body_inertia,
          body_inv_inertia_cm, xv, R, F, wrench, out[:2 * n_dof])


@jit
def motor_step(l0: float, aim: float, tau: float, speed: float, dt: float) -> float:
    """The rest length [m] after ``dt`` [s] of ``dl0/dt = clip((aim - l0)/tau, -speed, speed)``
    towards a constant ``aim``, exactly (:func:`tensegrity_core.robot.motor.step`): a slew at
    ``speed`` down to an error of ``speed tau``, then the exponential; an ideal motor
    (``tau = 0``, ``speed = inf``) reaches ``aim``."""
    e0 = aim - l0
    mag = abs(e0)
    knee = speed * tau if tau > 0.0 else 0.0
    slew_time = (mag - knee) / speed if mag > knee and math.isfinite(speed) else 0.0
    if dt < slew_time:
        left = max(mag - speed * dt, 0.0)
    else:
        left = min(mag, knee) * math.exp(-(dt - slew_time) / tau) if tau > 0.0 else 0.0
    return aim - math.copysign(left, e0) if e0 != 0.0 else aim


@jit
def sampled_update(base: FloatArray, free_node: IntArray, free_axis: IntArray, on_node: IntArray,
                   on_body: IntArray, on_offset: FloatArray, body_dof: IntArray, cable_a: IntArray,
                   cable_b: IntArray, cable_k: FloatArray, cable_t_max: FloatArray, motor_cable: IntArray,
                   motor_lo: FloatArray, motor_hi: FloatArray, motor_tau: FloatArray, motor_speed: FloatArray,
                   cap_node: IntArray, cap_body: IntArray, cap_radius: FloatArray, floor_normal: FloatArray,
                   floor_point: FloatArray, floor_params: FloatArray, y: FloatArray, R_ref: FloatArray, h: float,
                   aim: FloatArray, mode: IntArray, X: FloatArray, V: FloatArray, R: FloatArray,
                   r: FloatArray) -> None:
    """The end of a fixed step of ``h`` [s] at state ``y`` (changed in place, with ``R_ref``):

    - **motors** (:mod:`tensegrity_core.robot.motor`): each motor's command ``aim`` is read in
      its ``mode``: a rest length [m] (clipped to the range) or a tension [N] (the rest
      length ``l - T / k`` at the cable's length ``l`` now, clipped) that the rest length
      moves towards by the motor's exact step, or a reel speed [m/s] that moves it by
      ``clip(u, -speed, speed) h`` within the range; then the spool pays out where the
      cable would pull harder than the tension limit: ``l0 >= l - T_max / k``, at most to
      the range's end;
    - **friction anchors** (return mapping): a cap out of contact (``F_n = 0``) loses its
      anchor (offset 0); a cap without one gets it where it touches (offset 0), sticking; one
      whose offset ``s`` holds (``k_t |s| <= mu F_n``, ``mu_s`` while sticking, ``mu_k``
      while slipping) sticks; otherwise it slips: the anchor is dragged along, leaving
      ``|s| = mu_k F_n / k_t`` along the offset (:mod:`tensegrity_core.robot.friction`:
      the force inside the next step is that offset's return map, so a steady slide feels
      ``mu_k F_n`` at every stage). Every change only lowers the anchor's stored energy;
    - **charts**: a body whose rotation vector exceeds :data:`RECHART_ANGLE` is re-anchored."""
    n_dof = free_node.shape[0] + 6 * body_dof.shape[0]
    xv = y[:2 * n_dof]
    place(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, xv, R_ref, X, V, R, r)
    m0 = 2 * n_dof
    for j in range(motor_cable.shape[0]):
        i = motor_cable[j]
        a, b = cable_a[i], cable_b[i]
        h0, h1, h2 = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
        length = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        if mode[j] == REEL_SPEED:
            l0 = min(max(y[m0 + j] + min(max(aim[j], -motor_speed[j]), motor_speed[j]) * h, motor_lo[j]),
                     motor_hi[j])
        else:
            u = aim[j]
            if mode[j] == TENSION:
                u = length - min(max(u, 0.0), cable_t_max[i]) / cable_k[i]
            l0 = motor_step(y[m0 + j], min(max(u, motor_lo[j]), motor_hi[j]), motor_tau[j], motor_speed[j], h)
        if math.isfinite(cable_t_max[i]):
            l0 = max(l0, min(length - cable_t_max[i] / cable_k[i], motor_hi[j]))
        y[m0 + j] = l0
    k, d, mu_s, mu_k, kt = floor_params[0], floor_params[1], floor_params[2], floor_params[3], floor_params[4]
    n0, n1, n2 = floor_normal[0], floor_normal[1], floor_normal[2]
    ncap = cap_node.shape[0]
    a0 = m0 + motor_cable.shape[0]
    for c in range(ncap):
        node = cap_node[c]
        rc = cap_radius[c]
        _, fn = cap_contact(X, V, node, rc, floor_point, n0, n1, n2, k, d, BY_SIGN)
        a = a0 + 3 * c
        st = a0 + 3 * ncap + c
        if not (fn > 0.0 and kt > 0.0):
            y[st] = NO_ANCHOR
            y[a], y[a + 1], y[a + 2] = 0.0, 0.0, 0.0
            continue
        if y[st] == NO_ANCHOR:
            y[st] = STICKING
            y[a], y[a + 1], y[a + 2] = 0.0, 0.0, 0.0
            continue
        s0, s1, s2 = y[a], y[a + 1], y[a + 2]
        sn = s0 * n0 + s1 * n1 + s2 * n2
        s0, s1, s2 = s0 - sn * n0, s1 - sn * n1, s2 - sn * n2
        size = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        hold = (mu_k if y[st] == SLIPPING else mu_s) * fn
        if kt * size <= hold:
            y[st] = STICKING
            continue
        mag = mu_k * fn / (kt * size)
        y[a], y[a + 1], y[a + 2] = mag * s0, mag * s1, mag * s2
        y[st] = SLIPPING
    for bb in range(body_dof.shape[0]):
        dd = body_dof[bb] + 3
        t0, t1, t2 = y[dd], y[dd + 1], y[dd + 2]
        if t0 * t0 + t1 * t1 + t2 * t2 > RECHART_ANGLE * RECHART_ANGLE:
            rotate(t0, t1, t2, R_ref[bb], R[bb])
            copy_matrix(R[bb], R_ref[bb])
            y[dd], y[dd + 1], y[dd + 2] = 0.0, 0.0, 0.0


@jit
def evaluate(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
             on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
             body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
             body_inv_inertia_cm: FloatArray, external: FloatArray, cable_a: IntArray, cable_b: IntArray,
             cable_k: FloatArray, cable_c: FloatArray, cable_t_max: FloatArray, cable_l0: FloatArray,
             cable_motor: IntArray, motor_cable: IntArray, motor_lo: FloatArray, motor_hi: FloatArray,
             motor_tau: FloatArray, motor_speed: FloatArray, cap_node: IntArray, cap_body: IntArray,
             cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray, floor_params: FloatArray,
             y: FloatArray, R_ref: FloatArray, out: FloatArray, X: FloatArray, V: FloatArray, R: FloatArray,
             F: FloatArray, l0: FloatArray, lengths: FloatArray, rates_: FloatArray, tensions: FloatArray,
             depth: FloatArray, normal: FloatArray, friction: FloatArray, couple: FloatArray) -> None:
    """:func:`derivative` of a batch: ``y`` (B, N), ``R_ref`` (B, nb, 3, 3), ``out`` (B, N);
    kept per state: ``X``, ``V``, the nodal forces ``F`` (B, n, 3), ``R`` (B, nb, 3, 3), ``l0``, ``lengths``,
    ``rates_``, ``tensions`` (B, c), ``depth``, ``normal`` (B, ncap), ``friction``, ``couple`` (B, ncap, 3)."""
    r = np.empty((on_node.shape[0], 3))
    wrench = np.empty((body_dof.shape[0], 6))
    moments = np.empty((cap_node.shape[0], 3))
    by_sign = np.full(cap_node.shape[0] + cable_a.shape[0], BY_SIGN)
    for k in range(y.shape[0]):
        derivative(base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
                   body_first_moment, body_inertia, body_inv_inertia_cm, external, cable_a, cable_b, cable_k, cable_c,
                   cable_t_max, cable_l0, cable_motor, motor_cable, motor_lo, motor_hi, motor_tau, motor_speed,
                   cap_node, cap_body, cap_radius, floor_normal, floor_point, floor_params, by_sign, y[k], R_ref[k], out[k],
                   X[k], V[k], R[k], r, F[k], wrench, moments, l0[k], lengths[k], rates_[k], tensions[k], depth[k],
                   normal[k], friction[k], couple[k])
