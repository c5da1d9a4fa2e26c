"""The cable element: one tension-only law for statics and dynamics, passive or motor-driven.

A cable of stiffness ``k`` [N/m], damping ``c`` [N s/m] and rest length ``l0`` [m] between
two points ``l`` [m] apart, lengthening at ``ldot`` [m/s], carries the tension [N]
(positive: it pulls its ends together)::

    T = clip(k (l - l0) + c ldot, 0, T_max)   while taut (l > l0)
    T = 0                                      while slack (l <= l0)

- **Tension only.** A slack cable carries nothing, spring or damper; a taut one never
  pushes: the clamp at 0 cuts the damper when it would push (a taut cable shortening faster
  than ``k (l - l0) / c``). This is where MuJoCo's tendons differ: their damping acts on
  slack tendons too, and pushes.
- **At the slack/taut transition** the spring force is continuous (0 at ``l = l0``) and the
  damper switches on with the tautness: a cable snapping taut at ``ldot > 0`` takes
  ``c ldot`` at once, as a real damped cable does. ``l = l0`` counts as slack for the force
  and as taut for the stiffness (``dT/dl = k``, the stiffness it has when pulled; the
  statics' convention).
- **Energy.** With ``V = k max(0, l - l0)^2 / 2`` stored and ``l0`` fixed, the cable's
  power into the structure is ``-T ldot``, so ``dV/dt - T ldot = (k (l - l0)^+ - T) ldot``:
  ``-c ldot^2`` while the law is unclamped, ``k (l - l0) ldot < 0`` when the clamp at 0 cuts
  the damper (then ``ldot < -k (l - l0)/c < 0``), and ``(k (l - l0) - T_max) ldot <= 0`` at
  the tension limit (reached only while lengthening, since the motor pays out to keep
  ``k (l - l0) <= T_max``; :mod:`.motor`). A passive cable never adds energy.
- **Actuated cables** are the same element with ``l0`` the motor's state (:mod:`.motor`)
  and ``T_max`` its tension limit; passive ones have ``T_max = inf``.

**Shared with the statics.** At rest (``ldot = 0``) ``T = k (l - l0)^+``; a structure
string of axial stiffness ``EA = k l0`` has ``t = EA (l - l0)/l0`` = the same, so the
form-finding, stiffness and stability of :mod:`tensegrity_core.general` run on this element
through :func:`statics_EA` (``tensegrity_core.robot.statics``), and "which rest lengths
hold this shape" and "what the robot does when its motors reach them" share one model.

Every function is vectorised over cables (arrays of one shape; plain array code, no
objects), so the dynamics' kernels can take it as it is.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def statics_EA(stiffness: ArrayLike, rest_length: ArrayLike) -> FloatArray:
    """The axial stiffness ``EA = k l0`` [N] of the statics' string that is this cable at
    rest (``t = EA (l - l0)/l0 = k (l - l0)``)."""
    out: FloatArray = np.asarray(stiffness, dtype=float) * np.asarray(rest_length, dtype=float)
    return out


def tension(l: ArrayLike, ldot: ArrayLike, l0: ArrayLike, k: ArrayLike, c: ArrayLike,
            t_max: ArrayLike = np.inf) -> FloatArray:
    """Cable tensions [N] (module docstring): lengths ``l`` [m], rates ``ldot`` [m/s], rest
    lengths ``l0`` [m], stiffness ``k`` [N/m], damping ``c`` [N s/m], limit ``t_max`` [N]."""
    L = np.asarray(l, dtype=float)
    L0 = np.asarray(l0, dtype=float)
    raw = np.asarray(k, dtype=float) * (L - L0) + np.asarray(c, dtype=float) * np.asarray(ldot, dtype=float)
    out: FloatArray = np.where(L > L0, np.clip(raw, 0.0, t_max), 0.0)
    return out


def tension_derivatives(l: ArrayLike, ldot: ArrayLike, l0: ArrayLike, k: ArrayLike, c: ArrayLike,
                        t_max: ArrayLike = np.inf) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(dT/dl [N/m], dT/dldot [N s/m], dT/dl0 [N/m])`` where :func:`tension` is smooth
    (zero where it is clamped or slack; ``k`` at ``l = l0`` with ``ldot >= 0``, the
    right-hand derivative)."""
    L = np.asarray(l, dtype=float)
    L0 = np.asarray(l0, dtype=float)
    K = np.asarray(k, dtype=float)
    C = np.asarray(c, dtype=float)
    raw = K * (L - L0) + C * np.asarray(ldot, dtype=float)
    active = (L >= L0) & (raw >= 0.0) & (raw < t_max)
    dl: FloatArray = np.where(active, K, 0.0)
    dv: FloatArray = np.where(active, C, 0.0)
    return dl, dv, -dl


def energy(l: ArrayLike, l0: ArrayLike, k: ArrayLike) -> FloatArray:
    """Elastic energy ``k max(0, l - l0)^2 / 2`` [J] stored in each cable."""
    stretch = np.maximum(np.asarray(l, dtype=float) - np.asarray(l0, dtype=float), 0.0)
    out: FloatArray = 0.5 * np.asarray(k, dtype=float) * stretch * stretch
    return out


def kinematics(xa: ArrayLike, xb: ArrayLike, va: ArrayLike, vb: ArrayLike
               ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(l (n,), ldot (n,), u (n, 3))`` of cables from points ``xa`` to ``xb`` ((n, 3) [m])
    moving at ``va``, ``vb`` [m/s]: length, its rate and the unit vector from a to b."""
    h = np.asarray(xb, dtype=float) - np.asarray(xa, dtype=float)
    L: FloatArray = np.sqrt(np.sum(h * h, axis=-1))
    u = h / L[..., None]
    rate: FloatArray = np.sum(u * (np.asarray(vb, dtype=float) - np.asarray(va, dtype=float)), axis=-1)
    return L, rate, u


def end_forces(xa: ArrayLike, xb: ArrayLike, va: ArrayLike, vb: ArrayLike, l0: ArrayLike, k: ArrayLike,
               c: ArrayLike, t_max: ArrayLike = np.inf) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(f_a (n, 3) [N], T (n,) [N], l (n,) [m], ldot (n,) [m/s])``: the force on end ``a``
    (``f_a = T u``, towards b; end ``b`` takes ``-f_a``) and the cables' state."""
    L, rate, u = kinematics(xa, xb, va, vb)
    T = tension(L, rate, l0, k, c, t_max)
    return T[..., None] * u, T, L, rate


def end_force_jacobians(xa: ArrayLike, xb: ArrayLike, va: ArrayLike, vb: ArrayLike, l0: ArrayLike,
                        k: ArrayLike, c: ArrayLike, t_max: ArrayLike = np.inf) -> tuple[FloatArray, FloatArray]:
    """``(K, D)``, each (n, 3, 3): ``K = d f_a / d x_b`` [N/m] and ``D = d f_a / d v_b``
    [N s/m]. By translation invariance ``d f_a / d x_a = -K`` and, with ``f_b = -f_a``,
    ``d f_b / d x_b = -K``, ``d f_b / d x_a = K``; likewise for ``D`` and the velocities.

    With ``u`` the unit vector a -> b, ``P = 1 - u u^T`` and ``v = v_b - v_a``:
    ``dl/dx_b = u``, ``du/dx_b = P / l``, ``d ldot / d x_b = P v / l``, ``d ldot/d v_b = u``,
    so ``K = u (T_l u + T_v P v / l)^T + T P / l`` and ``D = T_v u u^T`` (``T_l``, ``T_v``
    from :func:`tension_derivatives`)."""
    xa_, xb_ = np.asarray(xa, dtype=float), np.asarray(xb, dtype=float)
    v = np.asarray(vb, dtype=float) - np.asarray(va, dtype=float)
    L, rate, u = kinematics(xa_, xb_, va, vb)
    T = tension(L, rate, l0, k, c, t_max)
    T_l, T_v, _ = tension_derivatives(L, rate, l0, k, c, t_max)
    P = np.eye(3) - np.einsum("...i,...j->...ij", u, u)
    w = np.einsum("...ij,...j->...i", P, v) / L[..., None]
    row = T_l[..., None] * u + T_v[..., None] * w
    K: FloatArray = np.einsum("...i,...j->...ij", u, row) + (T / L)[..., None, None] * P
    D: FloatArray = T_v[..., None, None] * np.einsum("...i,...j->...ij", u, u)
    return K, D
