"""Coulomb friction of end caps on the floor: a stick-slip anchor, updated once per step.

Each cap in contact has an **anchor**: the point of the floor its contact point stuck to.
The tangential offset of the contact point from its anchor, ``s`` [m] (in the floor
plane), is a small elastic displacement (the compliance of the cap's rubber and the
ground); the friction force on the cap is ``F_t = -k_t s - c_t v_t`` while it sticks, with
tangential stiffness ``k_t`` [N/m], damping ``c_t`` [N s/m] and ``v_t`` the contact point's
tangential velocity [m/s]. The force may be at most ``mu F_n``: beyond it the cap slips
and the anchor is dragged along, so that ``k_t |s| = mu_k F_n``.

**The force at any instant** (:func:`stage_force`; every evaluation of the equations of
motion inside a step, where the offset is the *trial* offset ``s* = s_n + int v_t dt`` of
the step's anchor): the return map of ``s*`` with the step's stick/slip rule. The hold is
``H = mu_s F_n`` for a cap that sticks at the step's start and ``mu_k F_n`` for one that
slips, with ``F_n`` the normal force at that instant.

- ``k_t |s*| <= H`` (the trial sticks; ``H > 0``): ``F_t = -k_t s* - beta c_t v_t`` with
  ``beta`` in ``[0, 1]`` the largest value that keeps ``|F_t| <= H``. The damper is part of
  the sticking force, so the bound covers it; with ``a = k_t s*`` (``|a| <= H``), ``b = c_t
  v_t = |b| u``, ``beta |b| = t`` is the positive root of ``|a + t u|^2 = H^2``: ``t =
  -(a.u) + sqrt((a.u)^2 + H^2 - |a|^2)``, and ``beta = min(t / |b|, 1)``. A slipping cap's
  trial has no damper (``beta = 0``), as in the step-end update.
- otherwise (the trial slips): ``F_t = -mu_k F_n s*/|s*|``, kinetic friction against the
  offset (0 where ``H = 0``: a disk of radius 0 holds nothing).

So ``|F_t| <= mu_s F_n`` wherever the cap sticks and ``|F_t| <= mu_k F_n`` wherever it slips,
at every evaluation; with ``mu_s = mu_k = 0`` the force is 0 at every evaluation (a cap
slides freely). A cap out of contact (``F_n = 0``) feels none.

**Energy never rises inside a step.** Write ``g = |s*|^2 / 2``; the spring part of the force
is ``-k_t phi(g) s*`` with ``phi = 1`` for ``k_t |s*| <= H`` and ``mu_k F_n / (k_t |s*|)``
beyond, a function of ``g`` alone at a given ``F_n``. Its power is ``-k_t phi(g) s*.v_t =
-k_t phi(g) dg/dt``, so its work over any path is ``-k_t (psi(g_1) - psi(g_0))`` with the
potential ``psi(g) = int_0^g phi``: ``|s*|^2 / 2`` inside the hold and ``H^2 / (2 k_t^2) +
(mu_k F_n / k_t)(|s*| - H / k_t)`` beyond (the spring is conservative in ``s*``; unloading
returns what loading stored). The damper's power ``-beta c_t |v_t|^2 <= 0``. At the step's
start ``|s_n| <= H / k_t`` (the last update left it there), so ``psi(g_0) = |s_n|^2 / 2``.

**One step** (:func:`friction_step`, fixed step ``dt``; the step-end update, a return
mapping): the trial offset ``s* = s_n + v_t dt``. A sticking cap stays stuck while
``k_t |s*| <= mu_s F_n``; a slipping one sticks again once ``k_t |s*| <= mu_k F_n``.
Otherwise it slips: ``s = s* mu_k F_n / (k_t |s*|)`` (on the kinetic disk). A cap out of
contact (``F_n = 0``) has no anchor (``s = 0``). The update leaves the stored energy
``k_t |s_{n+1}|^2 / 2 <= k_t psi(g_1)``: equal when it sticks; when it slips ``|s_{n+1}| =
mu_k F_n / k_t <= H / k_t`` while ``psi(g_1) >= H^2 / (2 k_t^2)``. With the work above,
work + stored energy change over a step ``<= 0``: **friction never adds energy, whatever
the step**. In a steady slide (``v_t`` along ``e = s_n / |s_n|``, ``|s_n| = mu_k F_n / k_t``)
every trial lies outside the disk, so every evaluation feels exactly ``mu_k F_n``.

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


def stage_force(s: ArrayLike, v_t: ArrayLike, F_n: ArrayLike, k_t: ArrayLike, c_t: ArrayLike, mu_s: ArrayLike,
                mu_k: ArrayLike, slipping: ArrayLike) -> FloatArray:
    """The friction force ``F_t`` (..., 3) [N] on a cap at one instant (module docstring):
    the return map of its trial offset ``s`` (..., 3) [m] from the step's anchor, with the
    contact point's tangential velocity ``v_t`` [m/s], normal force ``F_n`` [N] and the
    step's ``slipping`` flags; ``|F_t| <= mu_s F_n`` (``mu_k F_n`` where it slips)."""
    # each quantity one numpy call where it can be (the robot's numpy kernels call this at every
    # evaluation of a few caps, where a call's dispatch, not its arithmetic, is the cost)
    S = np.asarray(s, dtype=float)
    V = np.asarray(v_t, dtype=float)
    Fn = np.asarray(F_n, dtype=float)
    kt = np.asarray(k_t, dtype=float)
    was = np.asarray(slipping, dtype=bool)
    kinetic = np.asarray(mu_k, dtype=float)
    size = np.sqrt(np.add.reduce(S * S, axis=-1))
    hold = np.where(was, kinetic, np.asarray(mu_s, dtype=float)) * Fn
    sticks = (kt * size <= hold) & (hold > 0.0)
    a = kt[..., None] * S
    b = np.where(was, 0.0, np.asarray(c_t, dtype=float))[..., None] * V
    # beta |b| = t, the root of |a + t u|^2 = H^2 with u = b / |b|, in units of H (no H^2 to underflow)
    b_size = np.sqrt(np.add.reduce(b * b, axis=-1))
    moving = b_size > 0.0
    a_h = np.divide(a, np.where(sticks, hold, 1.0)[..., None])
    au = np.add.reduce(a_h * b, axis=-1) / np.where(moving, b_size, 1.0)
    t = hold * (np.sqrt(au * au + np.maximum(1.0 - np.add.reduce(a_h * a_h, axis=-1), 0.0)) - au)
    beta = np.where(moving, np.minimum(t / np.where(moving, b_size, 1.0), 1.0), 0.0)
    e = S / np.where(size > 0.0, size, 1.0)[..., None]
    out: FloatArray = np.where(sticks[..., None], -a - beta[..., None] * b, -(kinetic * Fn)[..., None] * e)
    return out


def friction_step(s: ArrayLike, v_t: ArrayLike, F_n: ArrayLike, dt: float, k_t: ArrayLike, c_t: ArrayLike,
                  mu_s: ArrayLike, mu_k: ArrayLike, slipping: ArrayLike
                  ) -> tuple[FloatArray, FloatArray, BoolArray]:
    """One step of the anchors (module docstring): ``(s (n, 3) [m], F_t (n, 3) [N],
    slipping (n,))`` after ``dt`` [s] from offsets ``s`` with tangential contact-point
    velocities ``v_t`` [m/s], normal forces ``F_n`` [N] and last step's ``slipping`` flags;
    ``F_t`` is :func:`stage_force` at the step's end trial."""
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
    force = np.where(touching[..., None], stage_force(trial, V, Fn, kt, c_t, mu_s, mu_k, was), 0.0)
    return new, force, touching & ~sticks


def anchor_energy(s: ArrayLike, k_t: ArrayLike) -> FloatArray:
    """Elastic energy ``k_t |s|^2 / 2`` [J] of each anchor."""
    S = np.asarray(s, dtype=float)
    out: FloatArray = 0.5 * np.asarray(k_t, dtype=float) * np.sum(S * S, axis=-1)
    return out
