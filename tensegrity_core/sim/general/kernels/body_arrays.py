"""The moving rigid bodies' terms of the numpy right-hand sides: one numpy call per quantity.

Used by the general model's (:mod:`.arrays`) and the robot's
(:mod:`tensegrity_core.sim.general.robot.arrays`) numpy kernels and the numpy Jacobian.

Below a few hundred bodies a numpy evaluation costs its number of calls (about 0.5-2 us of
dispatch each), not their arithmetic. So every quantity is one call over all bodies and
all states of a batch (leading axes ``(B, nb)``, or ``(B, n_on)`` per body node), with
index arrays built once per topology (:class:`BodyIndex`):

- the gathers ``[theta | w | v_c]`` of every body and the skew matrices ``[hat(w) |
  hat(theta) | .]`` of every body are one ``take`` each from ``y`` (a skew matrix is its
  vector's entries gathered and multiplied by a constant pattern of signs and zeros);
- every cross product is a product with a skew matrix (``a x b = hat(a) b``), so several
  crosses with the same left factor are one ``np.matmul`` over stacked columns;
- ``exp(hat(theta)) = I + s hat(theta) + c hat(theta)^2`` and the chart's rate ``J_l^-1 w =
  w - hat(theta) w / 2 + k hat(theta)^2 w`` are each one product of the coefficients ``[s,
  c]``, ``[-1/2, k]`` with the stacked ``[hat(theta) | hat(theta)^2]``;
- the body nodes' arms ``r = R p`` and their velocities' parts ``w x r = (hat(w) R) p``
  are one product of ``[R | hat(w) R]`` with each body's offsets ``[p_1 .. p_d]`` as
  columns, then gathered per node (one small product per body: numpy's ``matmul`` calls
  BLAS once per matrix of a stack, ~40 ns each, so a product per node cost five times that
  on a spine);
- the wrenches ``sum_k [f_k | r_k x f_k]`` per body are one gather and one sum over a
  table of each body's nodes (in node order, padded with a zero row: the loops' order);
- Newton-Euler and the charts' rates, from :data:`COMPONENT_MAJOR_BODIES` bodies, are
  written component-major (each component of all bodies one contiguous row: a 3 x 3
  product by a vector one product and one sum over all bodies), since ``np.matmul`` over a
  stack calls BLAS once per matrix (~40 ns each); below it as stacked products, fewer calls.

The formulas are those of :mod:`.loops`, grouped as products of small matrices: the
numbers agree with the compiled kernels to rounding (a product of 3 x 3 matrices adds its
terms in its own order, ``hat(theta)^2`` is a product where the loops write ``theta
theta^T - |theta|^2 I``). Each state's numbers are computed independently of the batch.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels.loops import SMALL_ANGLE

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: ``hat(v)`` (3, 3) as indices into ``v`` (3,) and the signs that multiply them (0 on the
#: diagonal): ``hat(v) = v[HAT] * HAT_SIGN``.
HAT = np.array([[0, 2, 1], [2, 0, 0], [1, 0, 0]])
HAT_SIGN = np.array([[0.0, -1.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 1.0, 0.0]])
#: ``a x b = (a[CROSS_A] * b[CROSS_B])[:3] - (...)[3:]``, the loops' terms ``a1 b2 - a2 b1`` ...
CROSS_A = np.array([1, 2, 0, 2, 0, 1])
CROSS_B = np.array([2, 0, 1, 1, 2, 0])
#: The small-angle series of ``[s, c, k]`` (:func:`.loops.rotate`,
#: :func:`.loops.chart_rate_coefficient`): ``SERIES_0 + a2 / SERIES_1 + a2^2 / SERIES_2``.
SERIES_0 = np.array([1.0, 0.5, 1.0 / 12.0])
SERIES_1 = np.array([-6.0, -24.0, 720.0])
SERIES_2 = np.array([120.0, 720.0, np.inf])
EYE = np.eye(3).ravel()
#: From this many moving bodies :func:`accelerate` runs component-major (about 50 calls
#: whose cost grows with the bodies at numpy's streaming speed), below it as products of
#: stacked matrices (about 30 calls of BLAS once per matrix): measured per RK4 step of the
#: generated spines (docs/design/performance.md), 8 bodies 456 against 521 us, 35 a tie,
#: 143 1,334 against 1,180 us, 575 4,264 against 3,384 us.
COMPONENT_MAJOR_BODIES = 36


class BodyIndex(NamedTuple):
    """A model's moving bodies as index arrays into a batch of states ``y`` (B, 2 n_dof).

    The stacked quantities lead with their slot, so that for one state each slot is a
    contiguous block (numpy's products are several times slower into or from strided views).
    ``vectors`` (3, nb, 3): the columns of ``[theta | w | v_c]`` of every body; ``hats`` (3,
    nb, 3, 3) with ``signs`` (3, 1, 3, 3): ``y.take(hats) * signs`` is ``[hat(w) | hat(theta)
    | 0]``; ``on_body`` (n_on,) each body node's body; ``offsets`` (nb, 3, d) [m] per body its
    nodes' offsets in its reference frame as columns (in node order, padded with zeros) and
    ``slots`` (n_on, 3) each body node's column of them, as entries of them flattened (nb 3
    d); ``crosses`` (2, 2, n_on, 3) the entries of the arms and of the forces (n_on, 3)
    flattened whose products give each node's ``r x f`` as ``[r1 f2, r2 f0, r0 f1] - [r2 f1,
    r0 f2, r1 f0]``; ``centres`` (2, n_on, 3) the columns of its body's
    ``[c | v_c]``; ``table`` (d, nb) per body its nodes' rows, padded with ``n_on`` (a zero
    row); ``rates`` (nb, 4, 3) the columns of ``dy/dt`` that hold ``[dc/dt | dtheta/dt |
    dv_c/dt | dw/dt]``."""

    vectors: IntArray
    hats: IntArray
    signs: FloatArray
    on_body: IntArray
    offsets: FloatArray
    slots: IntArray
    crosses: IntArray
    centres: IntArray
    table: IntArray
    rates: IntArray


def body_index(on_body: IntArray, on_offset: FloatArray, body_dof: IntArray, n_dof: int) -> BodyIndex:
    """The :class:`BodyIndex` of body nodes on the moving bodies ``on_body`` at the offsets
    ``on_offset`` (n_on, 3) [m], the bodies' coordinates starting at ``body_dof`` in states of
    ``n_dof`` coordinates."""
    three, nb, n_on = np.arange(3), len(body_dof), len(on_body)
    d = np.asarray(body_dof, dtype=np.int64)[:, None]
    theta, w, v = d + 3 + three, n_dof + d + 3 + three, n_dof + d + three
    vectors = np.stack([theta, w, v])
    hats = np.stack([w[:, HAT], theta[:, HAT], theta[:, HAT]])
    signs = np.stack([HAT_SIGN, HAT_SIGN, np.zeros((3, 3))])[:, None]
    on_body = np.asarray(on_body, dtype=np.int64)
    degree = np.bincount(on_body, minlength=nb)
    table = np.full((int(degree.max(initial=0)), nb), n_on, dtype=np.int64)
    order = np.argsort(on_body, kind="stable")
    slot = np.arange(n_on) - np.repeat(np.cumsum(degree) - degree, degree)
    table[slot, on_body[order]] = order
    column = np.empty(n_on, dtype=np.int64)
    column[order] = slot
    offsets = np.zeros((nb, 3, len(table)))
    offsets[on_body, :, column] = np.asarray(on_offset, dtype=float).reshape(n_on, 3)
    slots = (on_body[:, None] * 3 + three) * len(table) + column[:, None]
    crosses = 3 * np.arange(n_on)[:, None] + np.stack([CROSS_A, CROSS_B]).reshape(2, 2, 1, 3)
    return BodyIndex(vectors=vectors, hats=hats, signs=signs, on_body=on_body, offsets=offsets, slots=slots,
                     crosses=crosses,
                     centres=np.stack([d[on_body] + three, n_dof + d[on_body] + three]),
                     table=table, rates=np.stack([d + three, theta, v, w], axis=1))


def coefficients(a2: FloatArray) -> FloatArray:
    """(..., 4) ``[-1/2, s, c, k]`` of rotation vectors with ``|theta|^2 = a2`` (...):
    ``exp(hat(theta)) = I + s hat(theta) + c hat(theta)^2`` and ``J_l^-1 = I - hat(theta)/2 +
    k hat(theta)^2`` (so ``[..., 1:3]`` and ``[..., ::3]`` are each product's pair), the
    formulas of :func:`.loops.rotate` and :func:`.loops.chart_rate_coefficient`, their series
    below :data:`SMALL_ANGLE` (each branch computed only where some angle takes it)."""
    out = np.empty(a2.shape + (4,))
    out[..., 0] = -0.5
    small = a2 < SMALL_ANGLE * SMALL_ANGLE
    n_small = np.count_nonzero(small)
    if n_small < small.size:
        _trigonometric(np.where(small, 1.0, a2) if n_small else a2, out)
    if n_small:
        series = out[..., 1:] if n_small == small.size else np.empty(out[..., 1:].shape)
        a2 = a2[..., None]
        np.divide(a2, SERIES_1, series)
        series += SERIES_0
        series += a2 * a2 / SERIES_2
        if n_small < small.size:
            np.copyto(out[..., 1:], series, where=small[..., None])
    return out


def _trigonometric(a2: FloatArray, out: FloatArray) -> None:
    """``out[..., 1:] = [sin a / a, (1 - cos a) / a^2, 1/a^2 - (1 + cos a) / (2 a sin a)]``
    for ``a2 = a^2 > 0``."""
    a = np.sqrt(a2)
    sin, cos = np.sin(a), np.cos(a)
    np.divide(sin, a, out[..., 1])
    c = np.subtract(1.0, cos, out[..., 2])
    c /= a2
    k = out[..., 3]
    a *= 2.0
    a *= sin
    cos += 1.0
    np.divide(cos, a, k)
    np.subtract(np.divide(1.0, a2), k, k)


class Moving(NamedTuple):
    """The moving bodies of a batch placed (:func:`place`): ``vectors`` (B, 3, nb, 3) ``[theta
    | w | v_c]``; ``hats`` (B, 3, nb, 3, 3) ``[hat(w) | hat(theta) | hat(theta)^2]``;
    ``coefficients`` (B, nb, 4) of :func:`coefficients`; ``arms`` (B, 2, n_on, 3) of the
    body nodes ``[r | w x r]`` [m, m/s]."""

    vectors: FloatArray
    hats: FloatArray
    coefficients: FloatArray
    arms: FloatArray


def place(index: BodyIndex, y: FloatArray, R_ref: FloatArray, R: FloatArray, nodes: FloatArray) -> Moving:
    """Fills the bodies' rotations ``R`` (B, nb, 3, 3) of states ``y`` (B, 2 n_dof) in the
    charts ``R_ref`` and their nodes' ``nodes`` (B, 2, n_on, 3): positions [m], then
    velocities [m/s]."""
    B, nb = len(y), index.vectors.shape[1]
    vectors = y.take(index.vectors, axis=1)
    hats = y.take(index.hats, axis=1)
    hats *= index.signs
    theta_hat = hats[:, 1]
    np.matmul(theta_hat, theta_hat, hats[:, 2])
    theta = vectors[:, 0]
    coef = coefficients(np.vecdot(theta, theta))
    E = np.matmul(coef[:, :, None, 1:3], hats[:, 1:].reshape(B, 2, nb, 9).swapaxes(1, 2))
    E += EYE
    frames = np.empty((B, 2, nb, 3, 3))                                # [R | hat(w) R]
    np.matmul(E.reshape(B, nb, 3, 3), R_ref, frames[:, 0])
    np.matmul(hats[:, 0], frames[:, 0], frames[:, 1])
    R[...] = frames[:, 0]
    columns = np.matmul(frames, index.offsets)                         # (B, 2, nb, 3, d): [R | hat(w) R] p
    arms = columns.reshape(B, 2, -1).take(index.slots, axis=2)
    np.add(y.take(index.centres, axis=1), arms, nodes)
    return Moving(vectors, hats, coef, arms)


def wrenches(index: BodyIndex, moving: Moving, f: FloatArray) -> FloatArray:
    """(B, nb, 2, 3) per body the force [N] and the moment about ``c`` [N m] of the forces
    ``f`` (B, n_on, 3) on its nodes, summed in node order."""
    B, n_on = f.shape[:2]
    rows = np.empty((B, 2, n_on + 1, 3))                               # [f | r x f], a zero row each
    rows[:, :, n_on] = 0.0
    rows[:, 0, :n_on] = f
    terms = moving.arms[:, 0].reshape(B, -1).take(index.crosses[0], axis=1)
    terms *= f.reshape(B, -1).take(index.crosses[1], axis=1)
    np.subtract(terms[:, 0], terms[:, 1], rows[:, 1, :n_on])
    out: FloatArray = np.add.reduce(rows.take(index.table, axis=2), axis=2).swapaxes(1, 2)
    return out


def accelerate(index: BodyIndex, body_mass: FloatArray, body_first_moment: FloatArray, body_inertia: FloatArray,
               body_inv_inertia_cm: FloatArray, moving: Moving, R: FloatArray, wrench: FloatArray,
               out: FloatArray) -> None:
    """The moving bodies' part of ``out = dy/dt`` (B, 2 n_dof): Newton-Euler of ``wrench``
    (B, nb, 2, 3) [N, N m] about ``c`` (:func:`.loops.rates`) and the charts' rates; from
    :data:`COMPONENT_MAJOR_BODIES` bodies component-major (:func:`_accelerate_components`),
    below it as products of stacked 3 x 3 matrices (:func:`_accelerate_stacked`)."""
    terms = _accelerate_components if len(body_mass) >= COMPONENT_MAJOR_BODIES else _accelerate_stacked
    terms(index, body_mass, body_first_moment, body_inertia, body_inv_inertia_cm, moving, R, wrench, out)


def _accelerate_stacked(index: BodyIndex, body_mass: FloatArray, body_first_moment: FloatArray,
                        body_inertia: FloatArray, body_inv_inertia_cm: FloatArray, moving: Moving, R: FloatArray,
                        wrench: FloatArray, out: FloatArray) -> None:
    """:func:`accelerate` as products of stacked 3 x 3 matrices (``np.matmul``: one BLAS call
    per matrix of a stack, ~30 calls whatever the number of bodies)."""
    B, nb = R.shape[:2]
    hw = moving.hats[:, 0]
    w = moving.vectors[:, 1, :, :, None]
    m = body_mass[:, None, None]
    Rt = R.swapaxes(2, 3)
    s = np.matmul(R, body_first_moment[:, :, None])
    cL = np.empty((B, nb, 3, 2))                                       # [w x s | L = I_c w] columns
    np.matmul(hw, s, cL[..., :1])
    np.matmul(R, np.matmul(body_inertia, np.matmul(Rt, w)), cL[..., 1:])
    primed = np.subtract(wrench.swapaxes(2, 3), np.matmul(hw, cL))    # [F' | M']: w x (w x s), w x L
    F, M = primed[..., :1], primed[..., 1:]
    hs = s[..., 0].take(HAT, axis=2)
    hs *= HAT_SIGN
    g = np.matmul(hs, F)
    g /= m
    np.subtract(M, g, g)
    rates = np.empty((B, nb, 4, 3))                                    # [dc/dt | dtheta/dt | a_c | dw/dt]
    rates[:, :, 0] = moving.vectors[:, 2]
    dw = rates[:, :, 3, :, None]
    np.matmul(R, np.matmul(body_inv_inertia_cm, np.matmul(Rt, g)), dw)
    acceleration = np.matmul(hs, dw)
    acceleration += F
    np.divide(acceleration, m, rates[:, :, 2, :, None])
    turned = np.matmul(moving.hats[:, 1:], w[:, None])                # [theta x w | theta x (theta x w)]
    chart = np.matmul(moving.coefficients[:, :, None, ::3], turned[..., 0].swapaxes(1, 2))
    np.add(moving.vectors[:, 1], chart[:, :, 0], rates[:, :, 1])
    out[:, index.rates] = rates


def _accelerate_components(index: BodyIndex, body_mass: FloatArray, body_first_moment: FloatArray,
                           body_inertia: FloatArray, body_inv_inertia_cm: FloatArray, moving: Moving, R: FloatArray,
                           wrench: FloatArray, out: FloatArray) -> None:
    """:func:`accelerate` component-major: every vector (B, 3, nb) and matrix (B, 3, 3, nb)
    holds a component of all bodies in one contiguous row, so a product of a 3 x 3 matrix and a vector is one product
    over the matrices' entries and one sum (:func:`_times`), a cross product two gathers, a
    product and a subtraction (:func:`_cross`): the sums in the loops' order, a few calls
    whatever the number of bodies (``np.matmul`` over stacks of 3 x 3 matrices calls BLAS once
    per matrix, ~40 ns each)."""
    B = len(R)
    m = body_mass
    Rc = np.ascontiguousarray(R.transpose(0, 2, 3, 1))                 # (B, 3, 3, nb)
    w = np.ascontiguousarray(moving.vectors[:, 1].swapaxes(1, 2))      # (B, 3, nb)
    theta = np.ascontiguousarray(moving.vectors[:, 0].swapaxes(1, 2))
    s = _times(Rc, body_first_moment.T)                                # R s_body
    turned = np.empty((B, 2, 3, len(m)))                               # [w x s | L = R I R^T w]
    _cross(w, s, turned[:, 0])
    _times(Rc, _times(body_inertia.transpose(1, 2, 0), _times(Rc, w, True)), out=turned[:, 1])
    primed = np.subtract(wrench.transpose(0, 2, 3, 1), _cross(w[:, None], turned))   # [F' | M']
    F, M = primed[:, 0], primed[:, 1]
    g = _cross(s, F)
    g /= m
    np.subtract(M, g, g)                                               # M' - s x F' / m
    rates = np.empty((B, 4, 3, len(m)))                                # [dc/dt | dtheta/dt | a_c | dw/dt]
    rates[:, 0] = moving.vectors[:, 2].swapaxes(1, 2)
    dw = rates[:, 3]
    _times(Rc, _times(body_inv_inertia_cm.transpose(1, 2, 0), _times(Rc, g, True)), out=dw)
    acceleration = _cross(s, dw)
    acceleration += F
    np.divide(acceleration, m, rates[:, 2])
    x = _cross(theta, w)                                               # theta x w
    chart = _cross(theta, x)
    chart *= moving.coefficients[:, None, :, 3]
    x *= 0.5
    np.subtract(w, x, rates[:, 1])
    rates[:, 1] += chart                                               # w - theta x w / 2 + k theta x (theta x w)
    out[:, index.rates.transpose(1, 2, 0)] = rates


def _times(M: FloatArray, v: FloatArray, transposed: bool = False, out: FloatArray | None = None) -> FloatArray:
    """Component-major ``M v`` (or ``M^T v``) of matrices ``M`` (..., 3, 3, nb) and vectors
    ``v`` (..., 3, nb): each component ``sum_k M_ik v_k`` added left to right, as the loops."""
    terms = np.multiply(M, v[..., :, None, :] if transposed else v[..., None, :, :])   # M_ki v_k / M_ik v_k
    product: FloatArray = np.add.reduce(terms, axis=-3 if transposed else -2, out=out)
    return product


def _cross(a: FloatArray, b: FloatArray, out: FloatArray | None = None) -> FloatArray:
    """Component-major ``a x b`` of vectors (..., 3, nb): ``[a1 b2, a2 b0, a0 b1] - [a2 b1,
    a0 b2, a1 b0]``, the loops' terms."""
    terms = np.multiply(a.take(CROSS_A, -2), b.take(CROSS_B, -2))
    return np.subtract(terms[..., :3, :], terms[..., 3:, :], out)
