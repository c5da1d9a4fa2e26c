"""Equilibria at given times from the pieces of a quasi-static class-2 path.

The path follower (:mod:`.path`) stores its path as :class:`Segment` s: cubic
Hermite pieces in the scaled arc length between accepted equilibria. An observed state at
time ``t`` starts from the segment's interpolant at ``t`` (the cubic ``tau(u) = t / T`` is
inverted for the segment parameter ``u``) and is polished by Newton at fixed ``t`` into an
exact equilibrium; the rate is the path's ``dq/dt = -K_FF^-1 dG_F/dt``. Segments where the
path stands still (a held fold, constant forces) give their end point, an exact equilibrium
already, without Newton.

:func:`equilibria` does this for all the samples of a run: on a stationary segment every
sample is its end point with zero rate (only the actuator and contact forces follow the
input laws in time, evaluated together); off them it interpolates and polishes one sample
at a time when they are few (:data:`FEW`: numpy's per-call overhead costs more than the
work below that), else vectorised (one pass per Newton iteration over the samples not yet
converged). :func:`state_at` and :func:`polish_one` do it for one sample (the ROS node's
observations). The paths agree to rounding (tested).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple, NoReturn, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.sim.class2.small_dense import solve_symmetric
from tensegrity_core.sim.errors import SimulationError

if TYPE_CHECKING:
    from tensegrity_core.sim.class2.potential import TotalPotential

FloatArray = NDArray[np.float64]
#: A float (one sample) or an array (many): the formulas are arithmetic only.
Value = TypeVar("Value", float, FloatArray)

#: Coordinates not held, per contact mode (bit i set: actuator i held at zero length).
MODE_FREE = {0: (0, 1, 2), 1: (1, 2), 2: (0, 2), 3: (2,)}
#: ``FREE_MASK[bits][a]``: coordinate ``a`` is free in mode ``bits``.
FREE_MASK = np.array([[a in MODE_FREE[bits] for a in range(3)] for bits in range(4)])
#: Newton iterations at most when polishing a sample.
POLISH_ITER = 6
#: A polishing step below this (relative to L) ends the iteration: Newton converges
#: quadratically, the error left is of its square, i.e. rounding.
POLISH_TOL = 1e-8
#: Polishing steps larger than this (relative to L) are not taken (K nearly singular there).
POLISH_LIMIT = 0.05
#: Newton iterations on the segment parameter ``u`` (vectorised inversion of ``tau(u)``).
INVERT_ITER = 8
#: Up to this many samples off stationary segments are interpolated and polished one by one.
FEW = 16


class Segment(NamedTuple):
    """A piece of the path in scaled coordinates ``z = (q_free / L, t / T)`` between
    ``(t0, z0)`` and ``(t1, z1)`` with unit tangents ``v0, v1`` and arc length ``ds``; ``q1``
    the end configuration (held coordinates included) and ``bits`` the contact mode. A
    segment with ``t1 == t0`` is a single point. ``stationary``: the path stands still on it
    (every state is ``q1``, the rate zero); :meth:`of` works it out."""

    t0: float
    t1: float
    q1: list[float]
    z0: list[float]
    z1: list[float]
    v0: list[float]
    v1: list[float]
    ds: float
    bits: int
    stationary: bool

    @classmethod
    def of(cls, t0: float, t1: float, q1: list[float], z0: list[float], z1: list[float], v0: list[float],
           v1: list[float], ds: float, bits: int) -> Segment:
        still = t1 > t0 and z0[:-1] == z1[:-1] and not any(v0[:-1]) and not any(v1[:-1])
        return cls(t0, t1, q1, z0, z1, v0, v1, ds, bits, still)

    def full(self, L: float) -> tuple[list[float], list[float], list[float], list[float]]:
        """``(Z0, Z1, V0, V1)``: ends and tangents over all of ``(q / L, t / T)`` as
        4-vectors (held coordinates constant), tangents scaled by ``ds``."""
        free = MODE_FREE[self.bits]
        Z0, Z1, V0, V1 = [x / L for x in self.q1] + [0.0], [x / L for x in self.q1] + [0.0], [0.0] * 4, [0.0] * 4
        for j, a in enumerate(free + (3,)):
            Z0[a], Z1[a] = self.z0[j], self.z1[j]
            V0[a], V1[a] = self.ds * self.v0[j], self.ds * self.v1[j]
        return Z0, Z1, V0, V1


#: Samples at some times of one segment: ``(times (k,), segment)``.
Block = tuple[FloatArray, Segment]


def _hermite_weights(u: Value) -> tuple[Value, Value, Value, Value]:
    u2 = u * u
    u3 = u2 * u
    return 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2


def _time_cubic(c0: Value, c1: Value, c2: Value, c3: Value) -> tuple[Value, Value]:
    """``(a2, a3)`` of ``tau(u) = c0 + c1 u + a2 u^2 + a3 u^3``, the Hermite cubic with end
    values ``c0, c2`` and end slopes ``c1, c3`` (floats or arrays)."""
    return -3.0 * c0 - 2.0 * c1 + 3.0 * c2 - c3, 2.0 * c0 + c1 - 2.0 * c2 + c3


def state_at(seg: Segment, t: float, L: float, T: float) -> list[float]:
    """The segment's interpolant at time ``t`` [s] (``q`` as a list; ``q1`` at and past its
    end, and on a single point)."""
    if seg.stationary or t >= seg.t1 or seg.t1 <= seg.t0:
        return list(seg.q1)
    z0, z1, v0, v1, ds = seg.z0, seg.z1, seg.v0, seg.v1, seg.ds
    c0, c1, c2, c3 = z0[-1], ds * v0[-1], z1[-1], ds * v1[-1]
    a2, a3 = _time_cubic(c0, c1, c2, c3)
    tau = t / T
    lo, hi = 0.0, 1.0
    u = (t - seg.t0) / (seg.t1 - seg.t0)
    for _ in range(60):                      # safeguarded Newton on tau(u) = t / T
        f = ((a3 * u + a2) * u + c1) * u + c0 - tau
        if f < 0:
            lo = u
        else:
            hi = u
        if abs(f) <= 1e-15 * max(1.0, abs(tau)) or hi - lo < 1e-15:
            break
        df = (3.0 * a3 * u + 2.0 * a2) * u + c1
        nxt = u - f / df if df > 0 else 0.5 * (lo + hi)
        u = nxt if lo < nxt < hi else 0.5 * (lo + hi)
    h00, h10, h01, h11 = _hermite_weights(u)
    q = list(seg.q1)
    for j, a in enumerate(MODE_FREE[seg.bits]):
        q[a] = (h00 * z0[j] + h10 * ds * v0[j] + h01 * z1[j] + h11 * ds * v1[j]) * L
    return q


def equilibria(potential: TotalPotential, blocks: Sequence[Block], L: float,
               T: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int_]]:
    """The equilibria at the times of ``blocks`` ``[(times (k,), Segment), ...]`` (each time
    inside its segment): ``(t, q, dq/dt, contact forces, actuator forces, bits)``, arrays
    over the N samples ((N,), (N, 3), (N, 3), (N, 2), (N, 2), (N,)).

    ``potential`` a :class:`~tensegrity_core.sim.class2.potential.TotalPotential`."""
    counts = [len(b[0]) for b in blocks]
    segs = [b[1] for b in blocks]
    n = sum(counts)
    t = np.concatenate([np.asarray(b[0], dtype=float) for b in blocks]) if blocks else np.zeros(0)
    which = np.repeat(np.arange(len(blocks)), counts)
    bits = np.array([s.bits for s in segs], dtype=int).reshape(-1)[which]
    q = np.array([s.q1 for s in segs], dtype=float).reshape(-1, 3)[which]
    qd, lam, u = np.zeros((n, 3)), np.zeros((n, 2)), np.zeros((n, 2))
    still = np.array([s.stationary for s in segs], dtype=bool).reshape(-1)[which]
    rows = np.flatnonzero(still)
    if rows.size:
        # q = q1 and dq/dt = 0; u(t, q1) from the laws, contact forces u_i - Q_i with the
        # springs' (and loads') force Q of the segment's configuration
        for a, law in enumerate(potential.laws):
            u[rows, a] = law.arrays(t[rows], q[rows, a])[0]
        Q = np.zeros((len(segs), 2))
        known = {}                                  # Q = u - G depends on q only
        for b, seg in enumerate(segs):
            if seg.stationary:
                key = tuple(seg.q1)
                if key not in known:
                    G, _, _ = potential.evaluate(seg.q1, seg.t1)
                    known[key] = [law.value_at(seg.t1, seg.q1[a]) - G[a] for a, law in enumerate(potential.laws)]
                Q[b] = known[key]
        held = ~FREE_MASK[bits[rows], :2]
        lam[rows] = np.where(held, u[rows] - Q[which[rows]], 0.0)
    rows = np.flatnonzero(~still)
    if len(rows) <= FEW:
        for r in rows:
            seg, tr = segs[which[r]], float(t[r])
            q[r], qd[r], lam[r], u[r] = polish_one(potential, tr, state_at(seg, tr, L, T), seg.bits, True, L)
    else:
        q[rows] = _interpolate(segs, which[rows], t[rows], L, T)
        q[rows], qd[rows], lam[rows], u[rows] = polish(potential, t[rows], q[rows], bits[rows], L)
    return t, q, qd, lam, u, bits


def _interpolate(segs: Sequence[Segment], which: NDArray[np.intp], t: FloatArray, L: float,
                 T: float) -> FloatArray:
    """:func:`state_at` vectorised over samples at times ``t`` on moving segments
    ``segs[which]``."""
    Z0, Z1, V0, V1 = (np.array(parts, dtype=float)[which] for parts in zip(*(s.full(L) for s in segs)))
    t0, t1 = np.array([s.t0 for s in segs])[which], np.array([s.t1 for s in segs])[which]
    tau = np.minimum(t, t1) / T
    c0, c1, c2, c3 = Z0[:, 3], V0[:, 3], Z1[:, 3], V1[:, 3]
    a2, a3 = _time_cubic(c0, c1, c2, c3)
    # tau(u) increases on a segment: safeguarded Newton from the linear estimate
    lo, hi = np.zeros(len(t)), np.ones(len(t))
    with np.errstate(all="ignore"):
        u = np.clip((tau - c0) / (c2 - c0), 0.0, 1.0)
        for _ in range(INVERT_ITER):
            f = ((a3 * u + a2) * u + c1) * u + c0 - tau
            lo = np.where(f < 0, u, lo)
            hi = np.where(f < 0, hi, u)
            df = (3.0 * a3 * u + 2.0 * a2) * u + c1
            nxt = u - f / df
            u = np.where((df > 0) & (nxt > lo) & (nxt < hi), nxt, 0.5 * (lo + hi))
    h00, h10, h01, h11 = _hermite_weights(u)
    Z = h00[:, None] * Z0 + h10[:, None] * V0 + h01[:, None] * Z1 + h11[:, None] * V1
    free = FREE_MASK[np.array([s.bits for s in segs], dtype=int)[which]]
    q1 = np.array([s.q1 for s in segs], dtype=float).reshape(-1, 3)[which]
    end = ((t >= t1) | (t1 <= t0))[:, None]          # at or past the end, or a single point
    return np.where(free & ~end, Z[:, :3] * L, q1)


def masked_solve(K: Sequence[float | FloatArray], b: FloatArray, bits: NDArray[np.int_]) -> FloatArray:
    """Solve ``K_FF x_F = b_F`` per sample for the free coordinates ``F`` of each sample's
    mode (``K`` the unique entries ``(K11, K12, K13, K22, K23, K33)`` of symmetric 3 x 3
    matrices, arrays (N,); ``b`` (N, 3); ``bits`` (N,)), ``x = 0`` on the held ones: the held
    rows and columns are replaced by the identity's, and the 3 x 3 systems solved by the
    symmetric adjugate (numpy's batched LU costs several times more for 3 x 3). A singular
    ``K_FF`` gives non-finite entries."""
    K11, K12, K13, K22, K23, K33 = K
    free = FREE_MASK[bits]
    f0, f1, f2 = free.T
    a, d, f = np.where(f0, K11, 1.0), np.where(f1, K22, 1.0), np.where(f2, K33, 1.0)
    bb, c, e = np.where(f0 & f1, K12, 0.0), np.where(f0 & f2, K13, 0.0), np.where(f1 & f2, K23, 0.0)
    r0, r1, r2 = np.where(free, b, 0.0).T
    A00, A01, A02 = d * f - e * e, c * e - bb * f, bb * e - c * d
    A11, A12, A22 = a * f - c * c, bb * c - a * e, a * d - bb * bb
    inv = 1.0 / (a * A00 + bb * A01 + c * A02)
    x = np.empty((len(a), 3))
    x[:, 0] = (A00 * r0 + A01 * r1 + A02 * r2) * inv
    x[:, 1] = (A01 * r0 + A11 * r1 + A12 * r2) * inv
    x[:, 2] = (A02 * r0 + A12 * r1 + A22 * r2) * inv
    return x


def polish(potential: TotalPotential, t: FloatArray, q: ArrayLike, bits: NDArray[np.int_],
           L: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Newton at fixed ``t`` from the states ``q`` (N, 3) in contact modes ``bits``,
    vectorised over the samples not yet converged; returns ``(q, dq/dt, contact forces
    (N, 2), actuator forces (N, 2))``."""
    q = np.array(q, dtype=float)
    active = np.arange(len(t))
    for _ in range(POLISH_ITER):
        if active.size == 0:
            break
        G, K, _, _ = potential.evaluate_array(t[active], q[active])
        with np.errstate(all="ignore"):
            d = masked_solve(K, -G, bits[active])
        ok = np.all(np.isfinite(d) & (np.abs(d) < POLISH_LIMIT * L), axis=1)
        q[active[ok]] += d[ok]
        active = active[ok & (np.abs(d).max(axis=1) > POLISH_TOL * L)]
    G, K, Gt, u = potential.evaluate_array(t, q)
    with np.errstate(all="ignore"):
        qd = masked_solve(K, -Gt, bits)
    bad = ~np.all(np.isfinite(qd), axis=1)
    if bad.any():
        _undefined_rate(float(t[bad][0]), q[bad][0])
    lam = np.where(FREE_MASK[bits, :2], 0.0, G[:, :2])
    return q, qd, lam, u


def _undefined_rate(t: float, q: ArrayLike) -> NoReturn:
    raise SimulationError(f"t = {t:.9g} s: the equilibrium path's rate dq/dt is undefined at q = "
                          f"{np.array2string(np.asarray(q), precision=6)} (the stiffness d2Pi/dq2 is singular "
                          f"there: a limit or branch point at a sample time)", t=t)


def polish_one(potential: TotalPotential, t: float, q: Sequence[float], bits: int, moving: bool,
               L: float) -> tuple[list[float], list[float], list[float], list[float]]:
    """:func:`polish` for one sample (Newton only if ``moving``): ``(q, dq/dt, contact
    forces, actuator forces)`` as lists."""
    q = list(q)
    free = MODE_FREE[bits]
    evaluate = potential.evaluate
    for _ in range(POLISH_ITER if moving else 0):
        G, K, _ = evaluate(q, t)
        try:
            d = solve_symmetric(K, free, [-G[a] for a in free])
        except ZeroDivisionError:
            break
        size = max(map(abs, d))
        if not size < POLISH_LIMIT * L:            # too far, or not finite
            break
        for j, a in enumerate(free):
            q[a] += d[j]
        if size <= POLISH_TOL * L:
            break
    G, K, Gt = evaluate(q, t)
    qd = [0.0, 0.0, 0.0]
    try:
        rate = solve_symmetric(K, free, [-Gt[a] for a in free])
    except ZeroDivisionError:
        _undefined_rate(t, q)
    for j, a in enumerate(free):
        qd[a] = rate[j]
    l1, l2 = potential.laws
    u = [l1.value_at(t, q[0]), l2.value_at(t, q[1])]
    return q, qd, [0.0 if 0 in free else G[0], 0.0 if 1 in free else G[1]], u
