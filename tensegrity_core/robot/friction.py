"""Coulomb friction of end caps on the floor: a stick-slip anchor, updated once per step.

Each cap in contact has an **anchor**: the point of the floor its contact point stuck to.
The tangential offset of the contact point from its anchor, ``s`` [m] (in the floor
plane), is a small elastic displacement (the compliance of the cap's rubber and the
ground); the friction force on the cap is ``F_t = -k_t s - c_t v_t`` while it sticks, with
tangential stiffness ``k_t`` [N/m], damping ``c_t`` [N s/m] and ``v_t`` the contact point's
tangential velocity [m/s]. The spring may hold at most ``mu F_n``: beyond it the cap slips
and the anchor is dragged along, so that ``k_t |s| = mu_k F_n``.

**One step** (:func:`friction_step`, fixed step ``dt``; a return mapping, backward Euler):
the trial offset ``s* = s_n + v_t dt``. A sticking cap stays stuck while
``k_t |s*| <= mu_s F_n``; a slipping one sticks again once ``k_t |s*| <= mu_k F_n``.
Otherwise it slips: ``s = s* mu_k F_n / (k_t |s*|)`` and ``F_t = -k_t s`` (no damper while
sliding), i.e. kinetic friction ``mu_k F_n`` against the direction of ``s*``. A cap out of
contact (``F_n = 0``) has no anchor (``s = 0``).

**Energy never rises.** Over a step the contact point moves ``dx = v_t dt`` and the force
``-k_t s_{n+1}`` does work ``W = -k_t s_{n+1} . dx`` on the cap while the anchor's spring
energy changes by ``dE = k_t (|s_{n+1}|^2 - |s_n|^2) / 2``.
Sticking (``s_{n+1} = s_n + dx``): ``W + dE = -k_t |dx|^2 / 2 <= 0``.
Slipping (``s_{n+1} = b s*``, ``b < 1``, ``s_n = s* - dx``):
``W + dE = k_t (1 - b) s*.dx - k_t (1 - b^2)|s*|^2 / 2 - k_t |dx|^2 / 2``, at most
``-k_t b (1 - b) |s*|^2 <= 0`` (the maximum over ``|dx|``, at ``|dx| = (1 - b)|s*|``).
Losing contact or a smaller ``F_n`` only shortens ``s``. The damper adds
``-c_t |v_t|^2 dt``. So friction never adds energy, whatever the step.

**Why this model** (docs/robots.md compares it with Drake's regularised Stribeck law): it
holds a cap still under a tangential load below ``mu_s F_n`` (a prestressed robot at rest
pushes its caps outwards; a regularised law lets them creep at ``~ v_s F_t / (mu F_n)``
forever), it distinguishes static and kinetic friction, and its stiffness ``k_t`` is a
chosen number, not ``mu F_n / v_s`` with a tiny stiction speed ``v_s``, so a fixed 1 kHz
step resolves it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def tangential(vectors: ArrayLike, normal: ArrayLike) -> FloatArray:
    """The components of ``vectors`` (n, 3) in the floor plane of unit ``normal`` (3,)."""
    v = np.asarray(vectors, dtype=float)
    n = np.asarray(normal, dtype=float)
    out: FloatArray = v - (v @ n)[..., None] * n
    return out


def friction_step(s: ArrayLike, v_t: ArrayLike, F_n: ArrayLike, dt: float, k_t: ArrayLike, c_t: ArrayLike,
                  mu_s: ArrayLike, mu_k: ArrayLike, slipping: ArrayLike
                  ) -> tuple[FloatArray, FloatArray, BoolArray]:
    """One step of the anchors (module docstring): ``(s (n, 3) [m], F_t (n, 3) [N],
    slipping (n,))`` after ``dt`` [s] from offsets ``s`` with tangential contact-point
    velocities ``v_t`` [m/s], normal forces ``F_n`` [N] and last step's ``slipping`` flags."""
    S = np.asarray(s, dtype=float)
    V = np.asarray(v_t, dtype=float)
    Fn = np.asarray(F_n, dtype=float)
    kt = np.asarray(k_t, dtype=float)
    trial = S + V * dt
    size = np.sqrt(np.sum(trial * trial, axis=-1))
    was = np.asarray(slipping, dtype=bool)
    hold = np.where(was, np.asarray(mu_k, dtype=float), np.asarray(mu_s, dtype=float)) * Fn
    touching = Fn > 0.0
    sticks = touching & (kt * size <= hold)
    scale = np.divide(np.asarray(mu_k, dtype=float) * Fn, kt * size, out=np.zeros_like(size), where=size > 0)
    new = np.where(sticks[..., None], trial, np.where(touching[..., None], scale[..., None] * trial, 0.0))
    force = -kt[..., None] * new - np.where(sticks, np.asarray(c_t, dtype=float), 0.0)[..., None] * V
    return new, force, touching & ~sticks


def friction_step_jacobian(s: ArrayLike, v_t: ArrayLike, F_n: ArrayLike, dt: float, k_t: ArrayLike,
                           c_t: ArrayLike, mu_s: ArrayLike, mu_k: ArrayLike, slipping: ArrayLike) -> FloatArray:
    """``dF_t / dv_t`` (n, 3, 3) [N s/m] of :func:`friction_step` at fixed ``s`` and ``F_n``:
    ``-(k_t dt + c_t) 1`` sticking; sliding ``-k_t b dt (1 - e e^T)`` with ``e = s*/|s*|``,
    ``b = mu_k F_n / (k_t |s*|)``; zero out of contact."""
    S = np.asarray(s, dtype=float)
    V = np.asarray(v_t, dtype=float)
    kt = np.asarray(k_t, dtype=float) * np.ones(S.shape[:-1])
    new, _, slip = friction_step(S, V, F_n, dt, k_t, c_t, mu_s, mu_k, slipping)
    trial = S + V * dt
    size = np.sqrt(np.sum(trial * trial, axis=-1))
    touching = np.asarray(F_n, dtype=float) > 0.0
    e = np.divide(trial, size[..., None], out=np.zeros_like(trial), where=size[..., None] > 0)
    P = np.eye(3) - np.einsum("...i,...j->...ij", e, e)
    b = np.divide(np.sqrt(np.sum(new * new, axis=-1)), size, out=np.zeros_like(size), where=size > 0)
    stick_d = -(kt * dt + np.asarray(c_t, dtype=float))[..., None, None] * np.eye(3)
    slip_d = -(kt * b * dt)[..., None, None] * P
    out: FloatArray = np.where((touching & ~slip)[..., None, None], stick_d,
                               np.where(slip[..., None, None], slip_d, 0.0))
    return out


def anchor_energy(s: ArrayLike, k_t: ArrayLike) -> FloatArray:
    """Elastic energy ``k_t |s|^2 / 2`` [J] of each anchor."""
    S = np.asarray(s, dtype=float)
    out: FloatArray = 0.5 * np.asarray(k_t, dtype=float) * np.sum(S * S, axis=-1)
    return out
