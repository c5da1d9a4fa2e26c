"""The robot kernels of :mod:`.loops` written with numpy arrays: the same numbers to rounding, numpy alone.

Used where numba is not installed or not wanted (``TENSEGRITY_KERNELS=numpy``). Each
function takes a batch of states (leading axis ``B``) as the general array kernels do
(:mod:`tensegrity_core.sim.general.kernels.arrays`, whose ``place`` it calls, and
:mod:`~tensegrity_core.sim.general.kernels.body_arrays` for the moving bodies' wrenches and
Newton-Euler); :func:`run_steps` loops over the steps in Python. Arguments and results are
those of the loop kernels of the same name, but that :func:`derivatives`,
:func:`sampled_update` and :func:`run_steps` take the bodies' index arrays ``bodies``
(:class:`~tensegrity_core.sim.general.kernels.body_arrays.BodyIndex`) and
:func:`derivatives`, :func:`guards` and :func:`run_steps` the cables' ``cables``
(:class:`CableIndex`), each built once per plan (built there if not given).

A step evaluates one state at a time, where a numpy call's dispatch (~1 us), not its
arithmetic, is the cost: each quantity is as few calls as the formulas allow.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.rotation import cross
from tensegrity_core.robot import motor
from tensegrity_core.robot.contact import resisting_couple
from tensegrity_core.robot.friction import stage_force
from tensegrity_core.sim.general.kernels import arrays as general
from tensegrity_core.sim.general.kernels import body_arrays
from tensegrity_core.sim.general.robot.loops import BY_SIGN, NO_ANCHOR, OFF, ON, RECHART_ANGLE, SLIPPING, STICKING
from tensegrity_core.sim.general.robot.step_loops import MAX_PIECES, SCAN, _crossing

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a . b`` over the last axis, summed in the loop kernels' order."""
    out: FloatArray = a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]
    return out


def rest_lengths(cable_l0: FloatArray, cable_motor: IntArray, y: FloatArray, start: int) -> FloatArray:
    """(B, c) rest lengths [m]: drawn, or the motors' states."""
    out: FloatArray = np.where(cable_motor >= 0, y[:, start + cable_motor], cable_l0)   # -1: no motor
    return out


class CableIndex(NamedTuple):
    """A robot's cables as index arrays into node arrays ``(B, n, 3)`` flattened, built once
    per plan (:func:`cable_index`): ``ends`` (2, 3, c) the entries of each cable's nodes ``a``
    and ``b``, component-major (``[e, k, i]``: axis ``k`` of cable ``i``'s end ``e``), so that
    ``h = x_b - x_a`` is two gathers and a subtraction and its length a sum over its middle
    axis (the components added in turn, as the loops add them); ``pulls`` (3, 2c) the entries
    that ``+t u`` on ``a`` and then ``-t u`` on ``b`` add to."""

    ends: IntArray
    pulls: IntArray


def cable_index(cable_a: IntArray, cable_b: IntArray) -> CableIndex:
    """The :class:`CableIndex` of cables from nodes ``cable_a`` to ``cable_b``."""
    ends = np.stack([3 * np.asarray(cable_a, dtype=np.int64), 3 * np.asarray(cable_b, dtype=np.int64)])[:, None] \
        + np.arange(3)[:, None]
    return CableIndex(ends=ends, pulls=np.concatenate([ends[0], ends[1]], axis=1))


def _cable_geometry(cables: CableIndex, X: FloatArray, V: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(lengths [m], rates [m/s], unit vectors (3, c) from a to b)`` of the cables of one
    state's or a batch's nodes ``X``, ``V`` (..., n, 3) (a cable of length 0: slack, rate 0)."""
    lead = X.shape[:-2]
    Xf, Vf = X.reshape(lead + (-1,)), V.reshape(lead + (-1,))
    axis = len(lead)
    h = Xf.take(cables.ends[1], axis=axis)
    h -= Xf.take(cables.ends[0], axis=axis)
    length = np.sqrt(np.add.reduce(h * h, axis=axis))
    u = h
    u /= np.where(length > 0.0, length, np.inf)[..., None, :]            # l = 0: u = 0
    dv = Vf.take(cables.ends[1], axis=axis)
    dv -= Vf.take(cables.ends[0], axis=axis)
    dv *= u
    return length, np.add.reduce(dv, axis=axis), u


def cable_forces(cable_a: IntArray, cable_b: IntArray, cable_k: FloatArray, cable_c: FloatArray,
                 cable_t_max: FloatArray, l0: FloatArray, X: FloatArray, V: FloatArray,
                 switch: FloatArray, cables: CableIndex | None = None
                 ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`.loops.cable_forces` of a batch: ``(nodal forces (B, n, 3), lengths, rates,
    tensions)``; ``switch`` (c,) the cables' modes (:data:`.loops.BY_SIGN`, ``OFF``, ``ON``);
    ``cables`` their :class:`CableIndex` (built here if not given)."""
    if cables is None:
        cables = cable_index(cable_a, cable_b)
    B, n = X.shape[:2]
    length, rate, u = _cable_geometry(cables, X, V)
    taut = np.where(switch == BY_SIGN, length > l0, switch == ON)
    t = np.where(taut, np.minimum(np.maximum(cable_k * (length - l0) + cable_c * rate, 0.0), cable_t_max),
                 0.0)
    ft = u
    ft *= t[:, None]
    entries = cables.pulls if B == 1 else np.arange(0, 3 * B * n, 3 * n)[:, None, None] + cables.pulls
    F = np.bincount(entries.ravel(), weights=np.concatenate([ft, -ft], axis=2).ravel(), minlength=3 * B * n)
    return np.asarray(F, dtype=np.float64).reshape(B, n, 3), length, rate, t


def contact_velocity(cap_node: IntArray, cap_body: IntArray, cap_radius: FloatArray, floor_normal: FloatArray,
                     body_dof: IntArray, y: FloatArray, n_dof: int, V: FloatArray) -> FloatArray:
    """(B, ncap, 3) velocities [m/s] of the caps' contact points: ``v + w x (-r n)``."""
    v = V[:, cap_node]
    on = cap_body >= 0
    if on.any():
        cols = n_dof + body_dof[cap_body[on]][:, None] + 3 + np.arange(3)
        v[:, on] -= cap_radius[on][:, None] * cross(y[:, cols], floor_normal)
    return v


def floor_forces(cap_node: IntArray, cap_body: IntArray, cap_radius: FloatArray, floor_normal: FloatArray,
                 floor_point: FloatArray, floor_params: FloatArray, body_dof: IntArray, y: FloatArray, n_dof: int,
                 anchors: int, X: FloatArray, V: FloatArray, switch: FloatArray
                 ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """:func:`.loops.floor_forces` of a batch: ``(nodal forces (B, n, 3), moments (B, ncap, 3),
    depth, normal (B, ncap), friction (B, ncap, 3), resisting couples (B, ncap, 3), the
    offsets' rates (B, ncap, 3))``; the moments include the couples. ``switch`` (ncap,) the
    caps' modes (:data:`.loops.BY_SIGN`, ``OFF``, ``ON``)."""
    k, d, kt, ct = floor_params[0], floor_params[1], floor_params[4], floor_params[5]
    nvec = floor_normal
    ncap = len(cap_node)
    B = len(y)
    if not ncap:                       # no floor: nothing of it (a spine), without its ~40 calls
        none = np.zeros((B, 0))
        return np.zeros_like(X), none[..., None], none, none, none[..., None], none[..., None], none[..., None]
    P = X[:, cap_node]
    delta = cap_radius - _dot(P - floor_point, nvec)
    rate = -_dot(V[:, cap_node], nvec)
    fn = np.where(np.where(switch == BY_SIGN, delta > 0.0, switch == ON), k * delta * np.maximum(0.0, 1.0 + d * rate),
                  0.0)
    pressing = np.maximum(fn, 0.0)
    state = y[:, anchors + 3 * ncap:anchors + 4 * ncap]
    s = y[:, anchors:anchors + 3 * ncap].reshape(B, ncap, 3)
    s = s - _dot(s, nvec)[..., None] * nvec
    v = contact_velocity(cap_node, cap_body, cap_radius, nvec, body_dof, y, n_dof, V)
    v -= _dot(v, nvec)[..., None] * nvec
    anchored = (state != NO_ANCHOR)[..., None]
    f = np.where(anchored, stage_force(s, v, pressing, kt, ct, floor_params[2], floor_params[3], state == SLIPPING),
                 0.0)
    moments = -cap_radius[:, None] * cross(nvec, f)
    on = cap_body >= 0
    couple = np.zeros_like(f)
    if on.any():
        w = y[:, n_dof + body_dof[cap_body[on]][:, None] + 3 + np.arange(3)]
        couple[:, on] = resisting_couple(w, pressing[:, on], nvec, floor_params[6],
                                         floor_params[7])
    total = fn[..., None] * nvec + f
    F = general.scatter(cap_node, total, X.shape[1])
    return F, moments + couple, delta, fn, f, couple, np.where(anchored, v, 0.0)


def derivatives(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
                on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
                body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
                body_inv_inertia_cm: FloatArray, external: FloatArray, cable_a: IntArray, cable_b: IntArray,
                cable_k: FloatArray, cable_c: FloatArray, cable_t_max: FloatArray, cable_l0: FloatArray,
                cable_motor: IntArray, motor_cable: IntArray, motor_lo: FloatArray, motor_hi: FloatArray,
                motor_tau: FloatArray, motor_speed: FloatArray, cap_node: IntArray, cap_body: IntArray,
                cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray, floor_params: FloatArray,
                y: FloatArray, R_ref: FloatArray, out: FloatArray, X: FloatArray, V: FloatArray, R: FloatArray,
                F: FloatArray, l0: FloatArray, lengths: FloatArray, rates_: FloatArray, tensions: FloatArray,
                depth: FloatArray, normal: FloatArray, friction: FloatArray, couple: FloatArray, *,
                bodies: body_arrays.BodyIndex | None = None, switch: FloatArray | None = None,
                cables: CableIndex | None = None) -> None:
    """:func:`.loops.evaluate`: ``out = dy/dt`` of a batch, keeping every effect's state per
    state; ``switch`` (ncap + c): the modes of :func:`.loops.derivative` (default: all by sign)."""
    if switch is None:
        switch = np.full(len(cap_node) + len(cable_a), BY_SIGN)
    n_free, nb = len(free_node), len(body_dof)
    n_dof = n_free + 6 * nb
    if bodies is None:
        bodies = body_arrays.body_index(on_body, on_offset, body_dof, n_dof)
    moving = general.place(base, free_node, free_axis, on_node, bodies, y[:, :2 * n_dof], R_ref, X, V, R)
    l0[...] = rest_lengths(cable_l0, cable_motor, y, 2 * n_dof)
    Fc, lengths[...], rates_[...], tensions[...] = cable_forces(cable_a, cable_b, cable_k, cable_c, cable_t_max,
                                                               l0, X, V, switch[len(cap_node):], cables)
    a0 = 2 * n_dof + len(motor_cable)
    Ff, moments, depth[...], normal[...], friction[...], couple[...], sliding = floor_forces(
        cap_node, cap_body, cap_radius, floor_normal, floor_point, floor_params, body_dof, y, n_dof,
        a0, X, V, switch[:len(cap_node)])
    F[...] = external + Fc + Ff
    out[:, :n_free] = y[:, n_dof:n_dof + n_free]
    out[:, n_dof:n_dof + n_free] = F[:, free_node, free_axis] * free_inv_mass
    if moving is not None:
        wrench = body_arrays.wrenches(bodies, moving, F[:, on_node])
        on = cap_body >= 0
        if on.any():
            wrench[:, :, 1] += general.scatter(cap_body[on], moments[:, on], nb)
        body_arrays.accelerate(bodies, body_mass, body_first_moment, body_inertia, body_inv_inertia_cm, moving, R,
                               wrench, out)
    out[:, 2 * n_dof:] = 0.0
    out[:, a0:a0 + 3 * len(cap_node)] = sliding.reshape(len(y), -1)


evaluate = derivatives


def motor_step(l0: FloatArray, aim: FloatArray, tau: FloatArray, speed: FloatArray, dt: float) -> FloatArray:
    """:func:`.loops.motor_step` over arrays."""
    e0 = aim - l0
    mag = np.abs(e0)
    knee = np.where(tau > 0.0, speed * np.where(tau > 0.0, tau, 1.0), 0.0)    # not inf * 0: a NaN and a warning
    finite = np.isfinite(speed)
    slew_time = np.where((mag > knee) & finite, (mag - knee) / np.where(finite, speed, 1.0), 0.0)
    slewing = dt < slew_time
    decay = np.exp(-(dt - slew_time) / np.where(tau > 0.0, tau, 1.0))
    left = np.where(slewing, np.maximum(mag - np.where(finite, speed, 0.0) * dt, 0.0),
                    np.where(tau > 0.0, np.minimum(mag, knee) * decay, 0.0))
    out: FloatArray = np.where(e0 != 0.0, aim - np.copysign(left, e0), aim)
    return out


def sampled_update(base: FloatArray, free_node: IntArray, free_axis: IntArray, on_node: IntArray,
                   on_body: IntArray, on_offset: FloatArray, body_dof: IntArray, cable_a: IntArray,
                   cable_b: IntArray, cable_k: FloatArray, cable_t_max: FloatArray, motor_cable: IntArray,
                   motor_lo: FloatArray, motor_hi: FloatArray, motor_tau: FloatArray, motor_speed: FloatArray,
                   cap_node: IntArray, cap_body: IntArray, cap_radius: FloatArray, floor_normal: FloatArray,
                   floor_point: FloatArray, floor_params: FloatArray, y: FloatArray, R_ref: FloatArray, h: float,
                   aim: FloatArray, mode: IntArray, *, bodies: body_arrays.BodyIndex | None = None) -> None:
    """:func:`.loops.sampled_update` of one state ``y`` (N,) and its charts ``R_ref`` (nb, 3, 3), in place."""
    n_dof = len(free_node) + 6 * len(body_dof)
    n, nb = len(base), len(body_dof)
    if bodies is None:
        bodies = body_arrays.body_index(on_body, on_offset, body_dof, n_dof)
    X, V, R = np.empty((1, n, 3)), np.empty((1, n, 3)), np.empty((1, nb, 3, 3))
    general.place(base, free_node, free_axis, on_node, bodies, y[None, :2 * n_dof], R_ref[None], X, V, R)
    m0 = 2 * n_dof
    na = len(motor_cable)
    if na:
        t_max = cable_t_max[motor_cable]
        hvec = X[0, cable_b[motor_cable]] - X[0, cable_a[motor_cable]]
        length = np.sqrt(_dot(hvec, hvec))
        k = cable_k[motor_cable]
        lagged = motor_step(y[m0:m0 + na], motor.target(mode, aim, length, k, motor_lo, motor_hi, t_max), motor_tau,
                            motor_speed, h)
        l0 = np.where(mode == motor.REEL_SPEED, motor.reel(y[m0:m0 + na], aim, motor_speed, motor_lo, motor_hi, h),
                      lagged)
        limited = np.isfinite(t_max)
        pay = np.minimum(length - np.where(limited, t_max, 0.0) / k, motor_hi)
        y[m0:m0 + na] = np.where(limited, np.maximum(l0, pay), l0)
    ncap = len(cap_node)
    if ncap:
        k, d, mu_s, mu_k, kt = floor_params[:5]
        nvec = floor_normal
        a0 = m0 + na
        P = X[0, cap_node]
        delta = cap_radius - _dot(P - floor_point, np.broadcast_to(nvec, P.shape))
        fn = np.where(delta > 0.0, k * delta * np.maximum(0.0, 1.0 + d * -_dot(V[0, cap_node],
                                                                             np.broadcast_to(nvec, P.shape))), 0.0)
        offset = y[a0:a0 + 3 * ncap].reshape(ncap, 3)
        state = y[a0 + 3 * ncap:a0 + 4 * ncap]
        s = offset - _dot(offset, np.broadcast_to(nvec, offset.shape))[:, None] * nvec
        size = np.sqrt(_dot(s, s))
        hold = np.where(state == SLIPPING, mu_k, mu_s) * fn
        touching = (fn > 0.0) & (kt > 0.0)
        new = touching & (state == NO_ANCHOR)
        sticks = touching & ~new & (kt * size <= hold)
        slips = touching & ~new & ~sticks
        mag = mu_k * fn / np.where(slips, kt * size, 1.0)
        offset[...] = np.where(slips[:, None], mag[:, None] * s, np.where((~touching | new)[:, None], 0.0, offset))
        state[...] = np.where(~touching, NO_ANCHOR, np.where(slips, SLIPPING, STICKING))
    if nb:
        cols = body_dof[:, None] + 3 + np.arange(3)
        theta = y[cols]
        big = _dot(theta, theta) > RECHART_ANGLE * RECHART_ANGLE
        if big.any():
            R_ref[big] = R[0, big]
            y[cols[big]] = 0.0


def guards(cap_node: IntArray, cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray,
           cable_a: IntArray, cable_b: IntArray, l0: FloatArray, X: FloatArray, V: FloatArray,
           cables: CableIndex | None = None) -> tuple[FloatArray, FloatArray]:
    """:func:`.step_loops.guards` of one state (``l0`` (c,), ``X``, ``V`` (n, 3)): ``(g, rate)``
    (ncap + c); ``cables`` the cables' :class:`CableIndex` (built here if not given)."""
    if cables is None:
        cables = cable_index(cable_a, cable_b)
    P = X[cap_node]
    delta = cap_radius - _dot(P - floor_point, floor_normal)
    ddot = -_dot(V[cap_node], floor_normal)
    length, rate, _ = _cable_geometry(cables, X, V)
    return np.concatenate([delta, length - l0]), np.concatenate([ddot, rate])


def first_crossing(switch: FloatArray, g0: FloatArray, rate0: FloatArray, g1: FloatArray, rate1: FloatArray,
                   H: float) -> tuple[int, float]:
    """:func:`.step_loops.first_crossing`: its crossings by the same scalar code, in the same
    order, but only of the guards that can be first. Each crossing ``x`` lies above the start
    of the first of the :data:`.step_loops.SCAN` parts where its cubic is below 0 and at most
    at that part's end, so a guard whose first such part starts at or after another's ends
    crosses strictly later: the parts are found for every guard at once (the cubics at the
    parts' ends, the scalar code's arithmetic), and only the guards whose part starts before
    the earliest end are bisected."""
    side = np.where(switch == ON, 1.0, -1.0)
    crossed = np.flatnonzero(side * g1 < 0.0)
    if not len(crossed):
        return -1, 1.0
    sign = side[crossed]
    q0, q1 = np.maximum(sign * g0[crossed], 0.0), sign * g1[crossed]
    d0, d1 = sign * rate0[crossed] * H, sign * rate1[crossed] * H
    b, c, e = d0, 3.0 * (q1 - q0) - 2.0 * d0 - d1, 2.0 * (q0 - q1) + d0 + d1
    x = np.arange(1, SCAN + 1)[:, None] / SCAN
    below = q0 + x * (b + x * (c + x * e)) < 0.0                            # (SCAN, crossed)
    part = np.where(below.any(axis=0), below.argmax(axis=0), -1)            # -1: none (bisected from 0 to 1)
    start, end = np.where(part >= 0, part / SCAN, 0.0), np.where(part >= 0, (part + 1) / SCAN, 1.0)
    which, best = -1, 1.0
    for j in np.flatnonzero(start < end.min()).tolist():
        i = int(crossed[j])
        x_i = _crossing(float(q0[j]), float(d0[j]), float(q1[j]), float(d1[j]))
        if which < 0 or x_i < best:
            which, best = i, x_i
    return which, best


def run_steps(base: FloatArray, free_node: IntArray, free_axis: IntArray, free_inv_mass: FloatArray,
              on_node: IntArray, on_body: IntArray, on_offset: FloatArray, body_dof: IntArray,
              body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
              body_inv_inertia_cm: FloatArray, external: FloatArray, cable_a: IntArray, cable_b: IntArray,
              cable_k: FloatArray, cable_c: FloatArray, cable_t_max: FloatArray, cable_l0: FloatArray,
              cable_motor: IntArray, motor_cable: IntArray, motor_lo: FloatArray, motor_hi: FloatArray,
              motor_tau: FloatArray, motor_speed: FloatArray, cap_node: IntArray, cap_body: IntArray,
              cap_radius: FloatArray, floor_normal: FloatArray, floor_point: FloatArray, floor_params: FloatArray,
              y: FloatArray, R_ref: FloatArray, h: float, aims: FloatArray, modes: IntArray,
              y_end: FloatArray, *end: FloatArray, bodies: body_arrays.BodyIndex | None = None,
              cables: CableIndex | None = None) -> None:
    """:func:`.step_loops.run_steps` (the steps and their smooth pieces in a Python loop, each
    stage a batch of one; ``end``: the final state's evaluation arrays, ``out`` .. ``couple_out``)."""
    plan = (base, free_node, free_axis, free_inv_mass, on_node, on_body, on_offset, body_dof, body_mass,
            body_first_moment, body_inertia, body_inv_inertia_cm, external, cable_a, cable_b, cable_k, cable_c,
            cable_t_max, cable_l0, cable_motor, motor_cable, motor_lo, motor_hi, motor_tau, motor_speed, cap_node,
            cap_body, cap_radius, floor_normal, floor_point, floor_params)
    n, nb, m, ncap = len(base), len(body_dof), len(cable_a), len(cap_node)
    n_dof = len(free_node) + 6 * nb
    work = (np.empty((1, n, 3)), np.empty((1, n, 3)), np.empty((1, nb, 3, 3)), np.empty((1, n, 3)), np.empty((1, m)),
            np.empty((1, m)),
            np.empty((1, m)), np.empty((1, m)), np.empty((1, ncap)), np.empty((1, ncap)), np.empty((1, ncap, 3)),
            np.empty((1, ncap, 3)))
    X, V, R, l0 = work[0], work[1], work[2], work[4]
    K = np.empty((4, 1, len(y)))
    if bodies is None:
        bodies = body_arrays.body_index(on_body, on_offset, body_dof, n_dof)
    if cables is None:
        cables = cable_index(cable_a, cable_b)
    guard_args = (cap_node, cap_radius, floor_normal, floor_point, cable_a, cable_b)

    def piece(z0: FloatArray, H: float, switch: FloatArray, first: bool,
              again: bool = False) -> tuple[FloatArray, FloatArray, FloatArray]:
        """RK4 over ``H`` [s] from ``z0`` under ``switch`` (set from the first stage's guards
        where ``first``): ``(end, guards, rates)`` of its first stage. ``again``: the piece
        redone up to a crossing, whose first stage is the one in ``K[0]`` (no guards)."""
        g0 = rate0 = np.empty(0)
        for stage in range(1 if again else 0, 4):
            c = 0.0 if stage == 0 else (0.5 * H if stage < 3 else H)
            z = z0[None] if stage == 0 else z0[None] + c * K[stage - 1]
            derivatives(*plan, z, R_ref[None], K[stage], *work, bodies=bodies, switch=switch, cables=cables)
            if stage == 0:
                g0, rate0 = guards(*guard_args, l0[0], X[0], V[0], cables)
                if first:
                    switch[...] = np.where(g0 > 0.0, ON, OFF)
        end: FloatArray = z0 + H / 6.0 * (K[0, 0] + 2.0 * K[1, 0] + 2.0 * K[2, 0] + K[3, 0])
        return end, g0, rate0

    for s in range(len(aims)):
        z0, left, pieces = y.copy(), h, 0
        switch = np.full(ncap + m, BY_SIGN)
        while True:
            y1, g0, rate0 = piece(z0, left, switch, pieces == 0)
            general.place(base, free_node, free_axis, on_node, bodies, y1[None, :2 * n_dof], R_ref[None], X, V, R)
            g1, rate1 = guards(*guard_args, l0[0], X[0], V[0], cables)
            which, x = first_crossing(switch, g0, rate0, g1, rate1, left)
            if which < 0 or pieces >= MAX_PIECES:
                break
            pieces += 1
            z0, _, _ = piece(z0, x * left, switch, False, again=True)
            left = left - x * left
            switch[which] = OFF if switch[which] == ON else ON
        y[...] = y1
        y_end[...] = y
        sampled_update(base, free_node, free_axis, on_node, on_body, on_offset, body_dof, cable_a, cable_b, cable_k,
                       cable_t_max, motor_cable, motor_lo, motor_hi, motor_tau, motor_speed, cap_node, cap_body,
                       cap_radius, floor_normal, floor_point, floor_params, y, R_ref, h, aims[s], modes,
                       bodies=bodies)
    derivatives(*plan, y[None], R_ref[None], *end, bodies=bodies, cables=cables)
