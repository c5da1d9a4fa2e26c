"""Equilibria of the quasi-static class-2 model, and the pieces of the path through them.

With massless struts the configuration at time ``t`` is a stable minimum of the total
potential ``Pi(., t)`` (:mod:`.potential`): ``G = dPi/dq = 0`` on the coordinates not held
(``F``, by the contact mode) and ``K_FF = d2Pi/dq2`` positive definite. :class:`Equilibria`
answers the questions the path follower (:mod:`.path`) and its event locator
(:mod:`.path_events`) ask, for one set of input laws:

- :meth:`Equilibria.minimise`: a stable minimum at fixed ``t`` reached by projected Newton
  with a line search (a held actuator whose contact force would pull is let go);
- :meth:`Equilibria.equilibrium_at`: Newton on ``G_F = 0`` at fixed ``t``;
- :meth:`Equilibria.tangent`, :meth:`Equilibria.correct`, :meth:`Equilibria.at`: the
  pseudo-arclength continuation in the scaled variables ``z = (q_F / L, t / T)`` (tangent
  from the bordered system, Newton corrector on ``G_F = 0`` plus the arclength condition).

Points are :class:`PathPoint`: a configuration with ``G, K, Gt`` evaluated there.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from tensegrity_core.class2.dynamics.limits import SINGULAR_GUARD_REL
from tensegrity_core.sim.class2.path_samples import MODE_FREE
from tensegrity_core.sim.class2.potential import TotalPotential
from tensegrity_core.sim.class2.small_dense import positive_definite, solve_bordered, solve_symmetric
from tensegrity_core.sim.errors import SimulationError

#: The corrector stops once its scaled step is below this: Newton converges quadratically
#: there (the next step would be ~1e-12), and the path's points only need to be that good
#: (samples off stationary segments are polished into exact equilibria).
CORRECT_TOL = 1e-6
#: Near a minimum the potential's decrease falls below its rounding and the line search
#: cannot judge a step: a Newton step shorter than this (relative to L) is taken as it is.
NEWTON_ZONE = 1e-6


class PathPoint(NamedTuple):
    """A configuration ``q`` (list of 3) at time ``t`` [s] with ``G, K, Gt`` of
    :meth:`~tensegrity_core.sim.class2.potential.TotalPotential.evaluate` there."""

    q: list[float]
    t: float
    G: list[float]
    K: list[list[float]]
    Gt: list[float]


def bits_of(held: Iterable[int]) -> int:
    """The contact mode (bit i: actuator i held) of a set of held actuators."""
    return sum(1 << i for i in held)


@dataclass(frozen=True)
class PathSettings:
    """The scales and tolerances of a quasi-static path: strut length ``L`` [m], duration
    ``T`` [s] (the scales of ``z``), whether the fold limit holds, the force tolerance
    ``tol`` of an equilibrium and ``release_tol`` of a release [N], and the largest
    continuation step ``ds_max`` (scaled arc length)."""

    L: float
    T: float
    fold: bool
    tol: float
    release_tol: float
    ds_max: float


@dataclass
class PathCounts:
    """Work done along a path: accepted continuation steps and Newton iterations."""

    steps: int = 0
    newton: int = 0


def _stepped(q: Sequence[float], t: float, G: Sequence[float], K: list[list[float]], Gt: list[float],
             dq: Sequence[float], dt: float) -> PathPoint:
    """The point ``(q + dq, t + dt)`` after a last, converged Newton step from ``(q, t)`` where
    ``G, K, Gt`` were evaluated: ``G`` updated to first order (its error is of the step's
    square, i.e. rounding once the step is small), ``K`` and ``Gt`` kept (off by the step)."""
    return PathPoint([x + d for x, d in zip(q, dq)], t + dt,
                 [g + Kr[0] * dq[0] + Kr[1] * dq[1] + Kr[2] * dq[2] + gt * dt for g, Kr, gt in zip(G, K, Gt)],
                 K, Gt)


class Equilibria:
    """Equilibria and path pieces of ``potential`` (a
    :class:`~tensegrity_core.sim.class2.potential.TotalPotential`: the effects and one set of
    input laws) with the path's ``settings``; Newton iterations are counted in ``counts``."""

    def __init__(self, potential: TotalPotential, settings: PathSettings, counts: PathCounts):
        self.potential = potential
        self.settings = settings
        self.counts = counts
        self.L, self.T, self.fold = settings.L, settings.T, settings.fold
        self.tol, self.release_tol = settings.tol, settings.release_tol

    def with_potential(self, potential: TotalPotential) -> Equilibria:
        """The same path under other input laws (a new command), counting into the same counts."""
        return Equilibria(potential, self.settings, self.counts)

    def point(self, q: list[float], t: float) -> PathPoint:
        return PathPoint(q, t, *self.potential.evaluate(q, t))

    def regular(self, q: Sequence[float]) -> bool:
        """Whether the formulas hold at ``q`` (lambda1, lambda2 above ``SINGULAR_GUARD_REL L``)."""
        L = self.L
        s = q[0] + q[1]
        lim = (SINGULAR_GUARD_REL * L) ** 2
        return (2 * L - s) * (2 * L + s) > lim and (L - q[0]) * (L + q[0]) > lim

    def in_domain(self, q: Sequence[float]) -> bool:
        """Regular, and the actuator lengths >= 0 when the fold limit holds."""
        return self.regular(q) and (not self.fold or min(q[0], q[1]) >= 0.0)

    def z(self, q: Sequence[float], t: float, free: Sequence[int]) -> list[float]:
        return [q[a] / self.L for a in free] + [t / self.T]

    def q_t(self, z: Sequence[float], template: Sequence[float], free: Sequence[int]) -> tuple[list[float], float]:
        q = list(template)
        for j, a in enumerate(free):
            q[a] = z[j] * self.L
        return q, z[-1] * self.T

    # -- equilibria at fixed t --------------------------------------------------------------------
    def minimise(self, q: Iterable[float], t: float, bits: int, max_iter: int = 500) -> tuple[list[float], int]:
        """A stable local minimum of ``Pi(., t)`` reached from ``q`` (projected Newton with a
        backtracking line search; scaled steepest descent where ``K`` is not positive definite;
        a held actuator whose contact force would be tensile is let go). At the minimum the
        last Newton step is taken too, so the result is an equilibrium to rounding."""
        q = list(q)
        held = {i for i in (0, 1) if bits >> i & 1}
        potential = self.potential
        pi_q = None                    # Pi(q, t) when known
        for _ in range(max_iter):
            G, K, _ = potential.evaluate(q, t)
            self.counts.newton += 1
            free = MODE_FREE[bits_of(held)]
            pd = positive_definite(K, free)
            if pd:
                d = solve_symmetric(K, free, [-G[a] for a in free])
                if max(map(abs, (G[a] for a in free))) <= 10 * self.tol:
                    # a minimum with these actuators held: let go of the most tensile stop, if any
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        last = list(q)
                        for j, a in enumerate(free):
                            last[a] += d[j]
                        return (last if self.in_domain(last) else q), bits_of(held)
                    held.discard(min(pulling, key=lambda i: G[i]))
                    continue
            else:
                scale = max(max(abs(K[a][a]) for a in free), 1e-12)
                d = [-G[a] / scale for a in free]
                if max(abs(x) for x in d) < 1e-6 * self.L:
                    # (nearly) an unstable equilibrium: leave it along the most negative curvature
                    w, V = np.linalg.eigh(np.array([[K[a][b] for b in free] for a in free]))
                    sign = 1.0 if sum(G[a] * V[j, 0] for j, a in enumerate(free)) <= 0 else -1.0
                    d = [sign * 1e-2 * self.L * V[j, 0] for j in range(len(free))]
            step = [0.0, 0.0, 0.0]
            for j, a in enumerate(free):
                step[a] = d[j]
            big = max(map(abs, step))
            if big > 0.1 * self.L:
                step = [x * 0.1 * self.L / big for x in step]
            a_max, hit = 1.0, None
            if self.fold:
                for i in (0, 1):
                    if i not in held and step[i] < 0 and q[i] + step[i] < 0:
                        alpha = -q[i] / step[i]
                        if alpha < a_max:
                            a_max, hit = alpha, i
            if pd and hit is None and big <= NEWTON_ZONE * self.L:
                trial = [x + s for x, s in zip(q, step)]
                if self.in_domain(trial):
                    q, pi_q = trial, None
                    continue
            if pi_q is None:
                pi_q = potential.value(q, t)
            slope = sum(g * s for g, s in zip(G, step))
            alpha = a_max
            while alpha > 1e-14:
                trial = [x + alpha * s for x, s in zip(q, step)]
                if hit is not None and alpha == a_max:
                    trial[hit] = 0.0
                if self.in_domain(trial):
                    pi_trial = potential.value(trial, t)
                    if pi_trial <= pi_q + 1e-4 * alpha * slope:
                        break
                alpha *= 0.5
            else:
                if pd:     # no decrease left within rounding: converged as far as it goes
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        return q, bits_of(held)
                    held.discard(min(pulling, key=lambda i: G[i]))
                    continue
                break
            q, pi_q = trial, pi_trial
            if hit is not None and alpha == a_max:
                held.add(hit)
        raise SimulationError(f"t = {t:.9g} s: no stable equilibrium found from q = {np.array2string(np.array(q), precision=6)} "
                              f"(the springs cannot balance the actuator forces there)", t=t)

    def equilibrium_at(self, q: Iterable[float], t: float, bits: int) -> PathPoint | None:
        """Newton on ``G_F = 0`` at fixed ``t`` from ``q``: the :class:`PathPoint`, or ``None``
        when it leaves the domain, meets a singular stiffness or does not converge."""
        free = MODE_FREE[bits]
        q = list(q)
        for _ in range(40):
            if not self.regular(q):
                return None
            G, K, Gt = self.potential.evaluate(q, t)
            self.counts.newton += 1
            try:
                d = solve_symmetric(K, free, [-G[a] for a in free])
            except ZeroDivisionError:
                return None
            dq = [0.0, 0.0, 0.0]
            for j, a in enumerate(free):
                dq[a] = d[j]
            if max(abs(x) for x in d) <= 1e-13 * self.L:
                p = _stepped(q, t, G, K, Gt, dq, 0.0)
                return p if self.regular(p.q) else None
            q = [x + y for x, y in zip(q, dq)]
        return None

    # -- pseudo-arclength continuation in z = (q_free / L, t / T) ---------------------------------
    def tangent(self, p: PathPoint, bits: int, previous: Sequence[float] | None = None) -> list[float]:
        """Unit tangent ``dz/ds`` (n_free + 1) at ``p``: the null vector of
        ``[K_FF L, dG_F/dt T]`` from the bordered system with the previous tangent (forward in
        time at a start). Raises :class:`ZeroDivisionError` where it is not unique."""
        free = MODE_FREE[bits]
        n = len(free)
        prev = previous if previous is not None else [0.0] * n + [1.0]
        L, T = self.L, self.T
        d = solve_bordered(p.K, free, [p.Gt[a] for a in free], [x / L for x in prev[:n]], prev[n] / T, [0.0] * n, 1.0)
        v = [d[j] / L for j in range(n)] + [d[n] / T]
        norm = math.sqrt(sum(x * x for x in v))
        return [x / norm for x in v]

    def correct(self, q: Iterable[float], t: float, bits: int, z_pred: Sequence[float], v: Sequence[float],
                max_iter: int = 12, tol: float = CORRECT_TOL) -> PathPoint | None:
        """Newton on ``G_F = 0``, ``v . (z - z_pred) = 0`` until the scaled step is below
        ``tol``; the :class:`PathPoint` reached (see :func:`_stepped`), or ``None``."""
        free = MODE_FREE[bits]
        n = len(free)
        L, T = self.L, self.T
        evaluate = self.potential.evaluate
        w, wt = [x / L for x in v[:n]], v[n] / T
        q = list(q)
        for _ in range(max_iter):
            if not self.regular(q):
                return None
            G, K, Gt = evaluate(q, t)
            self.counts.newton += 1
            c = v[n] * (t / T - z_pred[n])
            for j, a in enumerate(free):
                c += v[j] * (q[a] / L - z_pred[j])
            try:         # in (dq, dt): [K_FF, dG_F/dt; v_F / L, v_t / T] (dq, dt) = -(G_F, c)
                step = solve_bordered(K, free, [Gt[a] for a in free], w, wt, [-G[a] for a in free], -c)
            except ZeroDivisionError:
                return None
            dq = [0.0, 0.0, 0.0]
            for j, a in enumerate(free):
                dq[a] = step[j]
            dt = step[n]
            if max(max(map(abs, step[:n])) / L, abs(dt) / T) <= tol:
                p = _stepped(q, t, G, K, Gt, dq, dt)
                return p if self.regular(p.q) else None
            q = [x + d for x, d in zip(q, dq)]
            t += dt
        return None

    def at(self, z0: Sequence[float], v0: Sequence[float], h: float, template: Sequence[float], bits: int,
           tol: float = CORRECT_TOL, max_iter: int = 12) -> tuple[PathPoint | None, list[float]]:
        """The corrected point ``h`` along tangent ``v0`` from ``z0`` (``None`` if the corrector
        fails), with the prediction."""
        free = MODE_FREE[bits]
        zp = [a + h * b for a, b in zip(z0, v0)]
        q, t = self.q_t(zp, template, free)
        return self.correct(q, t, bits, zp, v0, max_iter=max_iter, tol=tol), zp

