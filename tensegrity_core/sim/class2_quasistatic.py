"""The class-2 mechanism without inertia: the configuration tracks a stable equilibrium.

With massless struts the equations of motion ``M qddot + C = Q - (T, 0)`` reduce to the
force balance ``Q(q) = (f1, f2, 0)``. Every input law depends on time and on its own length
only, so at frozen ``t`` the actuator force is conservative, and the balance is the
stationarity of the total potential ``Pi(q, t)`` (:mod:`.class2_potential`). So with forces
as inputs the actuator lengths are *unknowns*: ``dPi/drho_i = 0`` says the actuator force
balances the springs' generalised force, ``dPi/dbeta = 0`` is the paper's Eq. (10) for the
angle. The quasi-static configuration is a local minimum of ``Pi(., t)`` followed
continuously in ``t``; with the fold limit the minimum is taken over ``rho_i >= 0`` and a held
actuator carries the contact force ``lambda_i = dPi/drho_i >= 0`` (KKT).

**Path following.** ``G = dPi/dq`` restricted to the coordinates not held (``F``) defines a
curve ``G_F(q, t) = 0``. It is followed by pseudo-arclength continuation in the scaled
variables ``z = (q/L, t/T)`` (``T`` the scene's duration): the tangent ``v`` spans the null
space of ``[K_FF L, dG_F/dt T]`` (``K = d2Pi/dq2``), the predictor is ``z + ds v`` plus the
curvature term from the tangents' change over the last step, and Newton corrects on
``G_F = 0`` plus ``v . (z - z_pred) = 0``. Unlike stepping in ``t``, this stays
regular where ``dq/dt`` is infinite -- which happens in the paper's scenario, where the
stable branch meets the fold with a vertical tangent. The step ``ds`` is controlled by the
predictor's error (:data:`PATH_TOL`). An accepted point must be a stable equilibrium
(``K_FF`` positive definite) reached forward in time.

**Events** along the path: an actuator reaching zero length (``fold``: held from then on), a
held actuator whose contact force falls to zero (``release``), an input law's breakpoint, and
a **limit point**: time would have to run backwards to stay on the branch, i.e. the
equilibrium stops existing because the forces exceed what the springs can resist. The
quasi-static model cannot continue there (the mechanism would snap; that needs inertia): the
run stops with a :class:`SimulationError`. An event inside a step is located by Newton on
the path's equations plus the event's own (``rho_i = 0``, ``lambda_i = -tol``, ``t = t_b``),
quadratically convergent from the chord's estimate. Where a branch meets the stop at a
*degenerate* contact (``lambda_i`` vanishes along the held branch too: the paper's full fold,
an equilibrium for every ``t``), that system is singular; the meeting point is then the
bifurcation of the held branch, where ``K_FF`` of the free mode is singular, found by the
secant method in ``t``. Limit points, and anything these two cannot settle, are bracketed by
regula falsi on the step length.

Observed samples come from :mod:`.class2_path_samples` (the segments' interpolants polished
into exact equilibria). If the initial state is not an equilibrium under the inputs at
``t = 0`` (e.g. the paper's start: the equilibrium angle for locked actuators, but zero
actuator force), the model starts from the minimum of ``Pi(., 0)`` reached by descent from
it (event ``jump``); a changed command does the same at its time.
"""

from __future__ import annotations

import math
import sys
from bisect import bisect_left, bisect_right
from typing import NamedTuple

import numpy as np

from tensegrity_core.sim import class2_path_samples as samples
from tensegrity_core.sim.backend import Commands
from tensegrity_core.sim.class2_model import build_force_effects
from tensegrity_core.sim.class2_observe import Class2Observer
from tensegrity_core.sim.class2_path_samples import MODE_FREE, Segment
from tensegrity_core.sim.class2_potential import TotalPotential
from tensegrity_core.sim.class2_sim import generalized_static_force, initial_configuration, runtime_laws
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.inputs import next_breakpoint
from tensegrity_core.sim.small_dense import (
    positive_definite,
    principal_det,
    solve_bordered,
    solve_small,
    solve_symmetric,
)

#: Predictor error allowed per continuation step (scaled variables). The path only needs to
#: stay on the branch and start each sample's polishing Newton close enough: the observed
#: samples are then equilibria to rounding, whatever this tolerance.
PATH_TOL = 1e-2
GROWTH = 4.0
#: An actuator within this distance of zero (relative to L) has reached the fold.
FOLD_EPS = 1e-12
#: A branch that ends (limit point) this close to an actuator's zero length (relative to L)
#: ends at the fold.
FOLD_NEAR = 1e-3
#: The corrector stops once its scaled step is below this: Newton converges quadratically
#: there (the next step would be ~1e-12), and the path's points only need to be that good
#: (samples are polished; a stationary path's corrector is exact at once).
CORRECT_TOL = 1e-6
#: Near a minimum the potential's decrease falls below its rounding and the line search
#: cannot judge a step: a Newton step shorter than this (relative to L) is taken as it is.
NEWTON_ZONE = 1e-6
#: Events bracketed by regula falsi are located to this fraction of the continuation step (a
#: step is at most a quarter of the run in scaled arc length).
LOCATE_TOL = 1e-7
#: Newton iterations per trial point when bracketing an event; a trial that needs more (the
#: stiffness nearly singular) counts as past the event.
LOCATE_ITER = 6
#: Newton iterations at most when solving for an event point, and the scaled step that ends
#: them (quadratic convergence: the error left is of its square, i.e. rounding).
EVENT_ITER = 12
EVENT_TOL = 1e-9
#: Secant iterations at most for a degenerate contact's bifurcation time, and their end
#: (relative to the duration).
BRANCH_ITER = 30
BRANCH_TOL = 1e-14
#: A path that cannot continue within this distance (relative to L) of lambda1 = 0 or
#: lambda2 = 0 has reached the singular configuration rather than a limit point.
SINGULAR_NEAR = 0.05


class Point(NamedTuple):
    """A configuration ``q`` (list of 3) at time ``t`` [s] with ``G, K, Gt`` of
    :meth:`TotalPotential.evaluate` there."""

    q: list
    t: float
    G: list
    K: list
    Gt: list


class Event(NamedTuple):
    """A located event: ``kind``, the point ``at`` (last state of the branch), the
    actuators it concerns, and the closing tangent and arc length of the last segment."""

    kind: str
    at: Point
    actuators: frozenset
    tangent: list
    ds: float


def _stepped(q, t: float, G, K, Gt, dq, dt: float) -> Point:
    """The point ``(q + dq, t + dt)`` after a last, converged Newton step from ``(q, t)`` where
    ``G, K, Gt`` were evaluated: ``G`` updated to first order (its error is of the step's
    square, i.e. rounding once the step is small), ``K`` and ``Gt`` kept (off by the step)."""
    return Point([x + d for x, d in zip(q, dq)], t + dt,
                 [g + Kr[0] * dq[0] + Kr[1] * dq[1] + Kr[2] * dq[2] + gt * dt for g, Kr, gt in zip(G, K, Gt)],
                 K, Gt)


def _after(t: float) -> float:
    """``t`` plus a few units of rounding: an event this close to a time counts as at it."""
    return t + 8 * sys.float_info.epsilon * max(1.0, abs(t))


def _bits(held) -> int:
    return sum(1 << i for i in held)


def _distance(a, b) -> float:
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


class Class2QuasiStatic(Commands):
    """Back end: the equilibrium path of a class-2 scene without inertia."""

    kind = "class2"
    quasi_static = True
    state_names = ("rho1", "rho2", "beta", "rho1_dot", "rho2_dot", "beta_dot")

    def __init__(self, scene):
        params = scene.model.params
        self.scene = scene
        self.params = params
        self.L = params.L
        self.T = scene.duration
        self.effects = build_force_effects(scene, params)
        q0, _ = initial_configuration(scene, self.effects)
        hold = generalized_static_force(self.effects, self.L, q0)[:2]
        self.laws = runtime_laws(scene, hold)
        self.potential = TotalPotential(self.effects, self.laws, self.L)
        self.observer = Class2Observer(scene, self.effects, inertia=False)
        self.actuator_names = tuple(scene.inputs)
        self.fold = "fold_limit" in scene.effects
        force_scale = max(params.k1, params.k2, params.k3, params.k4) * params.L
        self.tol = 1e-12 * force_scale
        # A contact force must be clearly tensile to release: at a degenerate contact
        # (lambda = 0, as at the paper's full fold) rounding must not make the stop chatter.
        self.release_tol = 1e-9 * force_scale
        self.ds_max = min(scene.integrator.max_step, scene.duration) / (4.0 * scene.duration)
        self.ds = self.ds_max / 16
        self.events: list = []
        self.n_steps = 0
        self.n_newton = 0
        self.t = 0.0
        q0 = [float(v) for v in q0]
        q, bits = self._minimise(q0, 0.0, _bits(i for i in (0, 1) if self.fold and q0[i] <= 0.0))
        if max(abs(a - b) for a, b in zip(q, q0)) > 1e-9 * self.L:
            self.events.append((0.0, "jump", 0))
        self._start(0.0, q, bits)

    # -- helpers ------------------------------------------------------------------------------------
    def _point(self, q, t: float) -> Point:
        return Point(q, t, *self.potential.evaluate(q, t))

    def _regular(self, q) -> bool:
        """Whether the formulas hold at ``q`` (lambda1, lambda2 above 1e-3 L)."""
        L = self.L
        s = q[0] + q[1]
        lim = (1e-3 * L) ** 2
        return (2 * L - s) * (2 * L + s) > lim and (L - q[0]) * (L + q[0]) > lim

    def _in_domain(self, q) -> bool:
        """Regular, and the actuator lengths >= 0 when the fold limit holds."""
        return self._regular(q) and (not self.fold or min(q[0], q[1]) >= 0.0)

    def _z(self, q, t, free) -> list:
        return [q[a] / self.L for a in free] + [t / self.T]

    def _q_t(self, z, template, free) -> tuple:
        q = list(template)
        for j, a in enumerate(free):
            q[a] = z[j] * self.L
        return q, z[-1] * self.T

    # -- equilibria at fixed t --------------------------------------------------------------------
    def _minimise(self, q, t: float, bits: int, max_iter: int = 500) -> tuple:
        """A stable local minimum of ``Pi(., t)`` reached from ``q`` (projected Newton with a
        backtracking line search; scaled steepest descent where ``K`` is not positive definite;
        a held actuator whose contact force would be tensile is let go). At the minimum the
        last Newton step is taken too, so the result is an equilibrium to rounding."""
        q = list(q)
        held = {i for i in (0, 1) if bits >> i & 1}
        potential = self.potential
        for _ in range(max_iter):
            G, K, _ = potential.evaluate(q, t)
            self.n_newton += 1
            free = [j for j in range(3) if j not in held]
            pd = positive_definite(K, free)
            if pd:
                d = solve_symmetric(K, free, [-G[a] for a in free])
                if max(abs(G[a]) for a in free) <= 10 * self.tol:
                    # a minimum with these actuators held: let go of the most tensile stop, if any
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        last = list(q)
                        for j, a in enumerate(free):
                            last[a] += d[j]
                        return (last if self._in_domain(last) else q), _bits(held)
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
            big = max(abs(x) for x in step)
            if big > 0.1 * self.L:
                step = [x * 0.1 * self.L / big for x in step]
            a_max, hit = 1.0, None
            if self.fold:
                for i in (0, 1):
                    if i not in held and step[i] < 0 and q[i] + step[i] < 0:
                        a = -q[i] / step[i]
                        if a < a_max:
                            a_max, hit = a, i
            if pd and hit is None and big <= NEWTON_ZONE * self.L:
                trial = [x + s for x, s in zip(q, step)]
                if self._in_domain(trial):
                    q = trial
                    continue
            pi0 = potential.value(q, t)
            slope = sum(g * s for g, s in zip(G, step))
            a = a_max
            while a > 1e-14:
                trial = [x + a * s for x, s in zip(q, step)]
                if hit is not None and a == a_max:
                    trial[hit] = 0.0
                if self._in_domain(trial) and potential.value(trial, t) <= pi0 + 1e-4 * a * slope:
                    break
                a *= 0.5
            else:
                if pd:     # no decrease left within rounding: converged as far as it goes
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        return q, _bits(held)
                    held.discard(min(pulling, key=lambda i: G[i]))
                    continue
                break
            q = trial
            if hit is not None and a == a_max:
                held.add(hit)
        raise SimulationError(f"t = {t:.9g} s: no stable equilibrium found from q = {np.array2string(np.array(q), precision=6)} "
                              f"(the springs cannot balance the actuator forces there)", t=t)

    def _equilibrium_at(self, q, t: float, bits: int):
        """Newton on ``G_F = 0`` at fixed ``t`` from ``q``: the :class:`Point`, or ``None``
        when it leaves the domain, meets a singular stiffness or does not converge."""
        free = MODE_FREE[bits]
        q = list(q)
        for _ in range(40):
            if not self._regular(q):
                return None
            G, K, Gt = self.potential.evaluate(q, t)
            self.n_newton += 1
            try:
                d = solve_symmetric(K, free, [-G[a] for a in free])
            except ZeroDivisionError:
                return None
            dq = [0.0, 0.0, 0.0]
            for j, a in enumerate(free):
                dq[a] = d[j]
            if max(abs(x) for x in d) <= 1e-13 * self.L:
                p = _stepped(q, t, G, K, Gt, dq, 0.0)
                return p if self._regular(p.q) else None
            q = [x + y for x, y in zip(q, dq)]
        return None

    # -- pseudo-arclength continuation in z = (q_free / L, t / T) ---------------------------------
    def _tangent(self, p: Point, bits: int, previous=None) -> list:
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

    def _correct(self, q, t, bits, z_pred, v, max_iter: int = 12, tol: float = CORRECT_TOL):
        """Newton on ``G_F = 0``, ``v . (z - z_pred) = 0`` until the scaled step is below
        ``tol``; the :class:`Point` reached (see :func:`_stepped`), or ``None``."""
        free = MODE_FREE[bits]
        n = len(free)
        L, T = self.L, self.T
        evaluate = self.potential.evaluate
        w, wt = [x / L for x in v[:n]], v[n] / T
        q = list(q)
        for _ in range(max_iter):
            if not self._regular(q):
                return None
            G, K, Gt = evaluate(q, t)
            self.n_newton += 1
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
                return p if self._regular(p.q) else None
            q = [x + d for x, d in zip(q, dq)]
            t += dt
        return None

    def _start(self, t: float, q, bits: int) -> None:
        """Begin a path piece at ``(t, q)`` (a zero-length segment)."""
        self.bits = bits
        free = MODE_FREE[bits]
        self._head = self._point(list(q), t)
        v = self._tangent(self._head, bits)
        z = self._z(q, t, free)
        self._seg = Segment.of(t, t, list(q), z, z, v, v, 0.0, bits)
        self._pending = None

    def advance(self, t_target: float) -> None:
        if t_target < self.t:
            raise SimulationError(f"cannot advance backwards: t = {self.t!r} s, target {t_target!r} s", t=self.t)
        # an event at t_target (to rounding) happens before the state there is seen
        while self._seg.t1 < t_target or (self._pending is not None and self._seg.t1 <= _after(t_target)):
            if self._pending is not None:
                t_e, q_e, bits_e, fired = self._pending
                self.events.extend(fired)
                self._start(t_e, q_e, bits_e)
                continue
            self._path_step()
        self.t = t_target

    def _at(self, z0, v0, h, template, bits, tol=CORRECT_TOL, max_iter=12):
        free = MODE_FREE[bits]
        zp = [a + h * b for a, b in zip(z0, v0)]
        q, t = self._q_t(zp, template, free)
        return self._correct(q, t, bits, zp, v0, max_iter=max_iter, tol=tol), zp

    def _path_step(self) -> None:
        """One accepted continuation step from the end of the current segment."""
        head, z0, v0 = self._head, self._seg.z1, self._seg.v1
        bits = self.bits
        free = MODE_FREE[bits]
        t_stop = next_breakpoint(self.laws, head.t, math.inf)
        if free == (2,):
            # Both actuators held: beta's balance -Q3(q) = 0 does not involve t, so the
            # configuration stands still; only the contact forces change (release events).
            ds, err = self.ds_max, None
            end = self._point(list(head.q), head.t + ds * self.T)
        else:
            ds, end, err = self._corrected_step(head, z0, v0, bits)
        self.n_steps += 1
        kind = self._event_kind(end, bits, t_stop)
        if kind is not None:
            self._locate(v0, ds, end, kind, t_stop)
            return
        v1 = self._tangent(end, bits, v0)
        self._seg = Segment.of(head.t, end.t, end.q, z0, self._z(end.q, end.t, free), v0, v1, ds, bits)
        self._head = end
        if err is not None:
            self.ds = ds * min(GROWTH, 0.9 / math.sqrt(max(err, 1e-12)))

    def _corrected_step(self, head: Point, z0, v0, bits: int) -> tuple:
        """Predictor and corrector with step control: ``(ds, end point, error ratio)``. The
        predictor is ``z + ds v + ds^2 / 2 kappa`` with the curvature ``kappa`` estimated from
        the tangents' change over the last step (none at a path's start)."""
        free = MODE_FREE[bits]
        seg = self._seg
        kappa = [(a - b) / seg.ds for a, b in zip(seg.v1, seg.v0)] if seg.ds > 0 else [0.0] * len(v0)
        while True:
            ds = min(self.ds, self.ds_max)
            zp = [a + ds * (b + 0.5 * ds * c) for a, b, c in zip(z0, v0, kappa)]
            q, t = self._q_t(zp, head.q, free)
            end = self._correct(q, t, bits, zp, v0)
            if end is None:
                if ds < 1e-14:
                    self._limit(head.t, head.q, "the corrector does not converge")
                self.ds = ds / 4
                continue
            err = max(abs(a - b) for a, b in zip(self._z(end.q, end.t, free), zp)) / PATH_TOL
            if err > 1.0 and ds > 1e-14:
                self.ds = ds * max(0.2, 0.9 / math.sqrt(err))
                continue
            return ds, end, err

    # -- events ---------------------------------------------------------------------------------------
    def _event_kind(self, p: Point, bits: int, t_stop: float):
        """What the path went past at ``p``, if anything."""
        if self.fold and any(not bits >> i & 1 and p.q[i] < FOLD_EPS * self.L for i in (0, 1)):
            return "fold"
        if self.fold and any(bits >> i & 1 and p.G[i] < -self.release_tol for i in (0, 1)):
            return "release"
        if not positive_definite(p.K, MODE_FREE[bits]):
            return "limit"
        if p.t > t_stop:
            return "breakpoint"
        return None

    def _event_value(self, kind: str, p: Point, bits: int, t_stop: float) -> float:
        """A continuous function of the path that changes sign at the event ``kind``."""
        if kind == "fold":
            return min(p.q[i] - FOLD_EPS * self.L for i in (0, 1) if not bits >> i & 1) / self.L
        if kind == "release":
            return min(p.G[i] + self.release_tol for i in (0, 1) if bits >> i & 1)
        if kind == "breakpoint":
            return (t_stop - p.t) / self.T
        return principal_det(p.K, MODE_FREE[bits])

    def _locate(self, v0, ds: float, end: Point, kind: str, t_stop: float) -> None:
        """Locate the first event of the step from the current head to ``end``, end the
        segment there and queue the path's new start (or stop at a limit point)."""
        bits = self.bits
        event = None
        if kind != "limit":
            event = self._solve_event(kind, end, ds, t_stop)
            if event is None and kind == "fold":
                event = self._branch_point(end, ds)
        if event is None:
            event = self._bracket_event(v0, ds, kind, t_stop)
        head, p = self._head, event.at
        free = MODE_FREE[bits]
        self._seg = Segment.of(head.t, p.t, p.q, self._z(head.q, head.t, free), self._z(p.q, p.t, free), v0,
                            event.tangent, event.ds, bits)
        if event.kind == "limit":
            self._limit(p.t, p.q, "the stiffness d2Pi/dq2 stops being positive definite")
        held = {i for i in (0, 1) if bits >> i & 1}
        fired = []
        q_new = list(p.q)
        if event.kind == "fold":
            for i in event.actuators:
                q_new[i] = 0.0
            held |= event.actuators
            fired = [(p.t, "fold", i) for i in sorted(event.actuators)]
        elif event.kind == "release":
            held -= event.actuators
            fired = [(p.t, "release", i) for i in sorted(event.actuators)]
        q_new, new_bits = self._minimise(q_new, p.t, _bits(held))
        self._pending = (p.t, q_new, new_bits, fired)

    def _closing_tangent(self, p: Point, z_head, v0) -> tuple:
        """Tangent and arc length (chord) of the last segment ending at ``p``; the chord's
        direction where the tangent is not unique (a bifurcation)."""
        free = MODE_FREE[self.bits]
        z = self._z(p.q, p.t, free)
        chord = _distance(z, z_head)
        try:
            return self._tangent(p, self.bits, v0), chord
        except ZeroDivisionError:
            return [(a - b) / chord for a, b in zip(z, z_head)] if chord > 0 else list(v0), chord

    def _before_other_events(self, p: Point, bits: int, t_stop: float, kind: str, i: int) -> bool:
        """Whether ``p`` (where event ``kind`` of actuator ``i`` happens) is still before every
        other event: stable, no other actuator past the fold or pulling, not past a breakpoint."""
        free = MODE_FREE[bits]
        if not positive_definite(p.K, free):
            return False
        if self.fold and any(j != i and not bits >> j & 1 and p.q[j] < 0.0 for j in (0, 1)):
            return False
        if self.fold and any(j != i and bits >> j & 1 and p.G[j] < -self.release_tol for j in (0, 1)):
            return False
        return kind == "breakpoint" or p.t <= t_stop

    def _solve_event(self, kind: str, end: Point, ds: float, t_stop: float):
        """The event point by Newton on ``G_F = 0`` plus the event's equation, in the scaled
        unknowns ``z = (q_F / L, t / T)``, from the chord's estimate; ``None`` if it does not
        converge to a point of this step before every other event."""
        head, bits = self._head, self.bits
        free = MODE_FREE[bits]
        L, T, rtol = self.L, self.T, self.release_tol
        if kind == "fold":
            crossings = [(head.q[i] / (head.q[i] - end.q[i]), i) for i in (0, 1)
                         if not bits >> i & 1 and end.q[i] < FOLD_EPS * L < head.q[i]]
        elif kind == "release":
            crossings = [((head.G[i] + rtol) / (head.G[i] - end.G[i]), i) for i in (0, 1)
                         if bits >> i & 1 and end.G[i] < -rtol < head.G[i]]
        else:
            crossings = [((t_stop - head.t) / (end.t - head.t), -1)] if end.t > t_stop >= head.t else []
        if not crossings:
            return None
        theta, i = min(crossings)
        z_head = self._z(head.q, head.t, free)
        z = [a + theta * (b - a) for a, b in zip(z_head, self._z(end.q, end.t, free))]
        q, t = self._q_t(z, head.q, free)
        last = math.inf
        for _ in range(EVENT_ITER):
            if not self._regular(q):
                return None
            G, K, Gt = self.potential.evaluate(q, t)
            self.n_newton += 1
            A = [[K[a][b] * L for b in free] + [Gt[a] * T] for a in free]
            rhs = [-G[a] for a in free]
            if kind == "fold":
                A.append([1.0 if b == i else 0.0 for b in free] + [0.0])
                rhs.append(-q[i] / L)
            elif kind == "release":
                A.append([K[i][b] * L for b in free] + [Gt[i] * T])
                rhs.append(-(G[i] + rtol))
            else:
                A.append([0.0] * len(free) + [1.0])
                rhs.append((t_stop - t) / T)
            try:
                dz = solve_small(A, rhs)
            except ZeroDivisionError:
                return None
            size = max(map(abs, dz))
            if size > last:           # not converging: a singular system (a degenerate contact)
                return None
            last = size
            for j, a in enumerate(free):
                q[a] += dz[j] * L
            t += dz[-1] * T
            if size <= EVENT_TOL:
                break
        else:
            return None
        if kind == "fold":
            q[i] = 0.0
        elif kind == "breakpoint":
            t = t_stop
        if not (self._regular(q) and head.t <= t):
            return None
        p = self._point(q, t)
        reach = 1.5 * max(ds, _distance(self._z(end.q, end.t, free), z_head))
        if _distance(self._z(q, t, free), z_head) > reach or not self._before_other_events(p, bits, t_stop, kind, i):
            return None
        if kind == "fold":
            actuators = frozenset(j for j in (0, 1) if not bits >> j & 1 and q[j] < FOLD_NEAR * L)
        elif kind == "release":
            actuators = frozenset({i} | {j for j in (0, 1) if bits >> j & 1 and p.G[j] < -rtol})
        else:
            actuators = frozenset()
        return Event(kind, p, actuators, *self._closing_tangent(p, z_head, self._seg.v1))

    def _branch_point(self, end: Point, ds: float):
        """Where the free branch meets the stop of an actuator at a degenerate contact: the
        time ``t`` at which the stiffness ``K_FF`` of the free mode, on the branch held at the
        stop, becomes singular (two branches of ``G_F = 0`` cross there), by the secant method
        from the chord's estimate; ``None`` if that does not settle it."""
        head, bits = self._head, self.bits
        free = MODE_FREE[bits]
        L, T = self.L, self.T
        crossings = [(head.q[i] / (head.q[i] - end.q[i]), i) for i in (0, 1)
                     if not bits >> i & 1 and end.q[i] < FOLD_EPS * L < head.q[i]]
        if not crossings:
            return None
        theta, i = min(crossings)
        held = bits | 1 << i
        t_lo = head.t
        t_hi = t_lo + 1.5 * max(ds, _distance(self._z(end.q, end.t, free), self._z(head.q, head.t, free))) * T

        def det_on_held_branch(t, q):
            p = self._equilibrium_at(q, t, held)
            return (math.nan, None) if p is None else (principal_det(p.K, free), p)

        start = list(head.q)
        start[i] = 0.0
        f_b, p_b = det_on_held_branch(t_lo, start)
        if p_b is None:
            return None
        t_a, t_b = head.t + theta * (end.t - head.t), t_lo
        f_a, p_a = det_on_held_branch(t_a, p_b.q)
        for _ in range(BRANCH_ITER):
            if p_a is None or f_a == f_b:
                return None
            t_new = t_a - f_a * (t_a - t_b) / (f_a - f_b)
            if not t_lo <= t_new <= t_hi:
                return None
            f_new, p_new = det_on_held_branch(t_new, p_a.q)
            t_b, f_b, t_a, f_a, p_a = t_a, f_a, t_new, f_new, p_new
            if abs(t_a - t_b) <= BRANCH_TOL * T:
                break
        else:
            return None
        if p_a is None or abs(p_a.G[i]) > self.release_tol:
            return None            # not a degenerate contact after all
        actuators = frozenset(j for j in (0, 1) if not bits >> j & 1 and p_a.q[j] < FOLD_NEAR * L)
        return Event("fold", p_a, actuators, *self._closing_tangent(p_a, self._z(head.q, head.t, free),
                                                                     self._seg.v1))

    def _bracket_event(self, v0, ds: float, kind: str, t_stop: float) -> Event:
        """The first point of the step where ``kind`` happens, by regula falsi (Illinois
        variant) on the event's function of the step length, each trial corrected onto the
        path: slow but it needs nothing regular (limit points)."""
        head, bits = self._head, self.bits
        free = MODE_FREE[bits]
        z0, template = self._z(head.q, head.t, free), head.q

        def g(point) -> float:
            """> 0 before the event, <= 0 past it (a failed corrector counts as past)."""
            if point is None:
                return -1.0
            if self._event_kind(point, bits, t_stop) is None:
                return max(self._event_value(kind, point, bits, t_stop), 1e-300)
            return min(self._event_value(kind, point, bits, t_stop), 0.0)

        lo, hi, p_lo = 0.0, ds, head
        g_lo = self._event_value(kind, head, bits, t_stop)
        p_hi, _ = self._at(z0, v0, hi, template, bits, tol=1e-11, max_iter=LOCATE_ITER)
        g_hi = g(p_hi)
        side = 0
        for _ in range(60):
            if hi - lo <= LOCATE_TOL * ds:
                break
            if g_hi == -1.0 or g_lo <= 0.0:
                x = 0.5 * (lo + hi)
            else:
                x = lo + (hi - lo) * g_lo / (g_lo - g_hi)
                x = min(max(x, lo + 1e-3 * (hi - lo)), hi - 1e-3 * (hi - lo))
            out, _ = self._at(z0, v0, x, template, bits, tol=1e-11, max_iter=LOCATE_ITER)
            gx = g(out)
            if gx > 0.0:
                lo, g_lo, p_lo = x, gx, out
                if side == 1 and g_hi != -1.0:
                    g_hi *= 0.5
                side = 1
            else:
                hi, g_hi, p_hi = x, gx, out
                if side == -1:
                    g_lo *= 0.5
                side = -1
        kind = self._event_kind(p_hi, bits, t_stop) if p_hi is not None else "limit"
        past = p_hi
        near = [i for i in (0, 1) if not bits >> i & 1 and p_lo.q[i] < FOLD_NEAR * self.L]
        if kind == "limit" and self.fold and near:
            # The branch ends where it meets the fold (its stiffness vanishes there): the held
            # actuator continues it.
            kind, past = "fold", p_lo
        at = p_lo
        if kind == "breakpoint":
            at = self._equilibrium_at(p_lo.q, t_stop, bits) or self._point(p_lo.q, t_stop)
        actuators = frozenset()
        if kind == "fold":
            actuators = frozenset(i for i in (0, 1) if not bits >> i & 1 and past.q[i] < FOLD_NEAR * self.L)
        elif kind == "release":
            actuators = frozenset(i for i in (0, 1) if bits >> i & 1 and past.G[i] < -self.release_tol)
        return Event(kind, at, actuators, self._tangent(at, bits, v0), lo)

    def _limit(self, t, q, why: str) -> None:
        L = self.L
        s = q[0] + q[1]
        lam1, lam2 = math.sqrt(max((2 * L - s) * (2 * L + s), 0.0)), math.sqrt(max((L - q[0]) * (L + q[0]), 0.0))
        if min(lam1, lam2) < SINGULAR_NEAR * L:
            where = "rho1 + rho2 -> 2L: struts AE and CE flat" if lam1 < lam2 else "rho1 -> L: strut BF flat"
            self.events.append((t, "singular", 0 if lam1 < lam2 else 1))
            raise SimulationError(f"t = {t:.9g} s: the equilibrium path reaches the singular configuration "
                                  f"({where}) at q = {np.array2string(np.asarray(q), precision=6)}, where the "
                                  f"coordinates break down; the simulation stops here", t=t)
        self.events.append((t, "limit", 0))
        raise SimulationError(
            f"t = {t:.9g} s: no stable equilibrium continues the path beyond q = "
            f"{np.array2string(np.asarray(q), precision=6)} ({why}: a limit point -- the actuator forces "
            f"exceed what the springs can resist); the mechanism would snap, which needs inertia", t=t)

    # -- simulator interface ---------------------------------------------------------------------------
    def set_command(self, values) -> None:
        if self.take_command(values):
            q = samples.state_at(self._seg, self.t, self.L, self.T)
            q_new, new_bits = self._minimise(q, self.t, self.bits)
            if max(abs(a - b) for a, b in zip(q_new, q)) > 1e-9 * self.L:
                self.events.append((self.t, "jump", 0))
            self._start(self.t, q_new, new_bits)

    def sample(self) -> tuple:
        """The current time with its segment: a block of one sample for :meth:`observe`."""
        return np.array([self.t]), self._seg

    def record(self, times, out: list) -> None:
        """Append blocks ``(times inside one segment, segment)`` for increasing ``times`` to
        ``out``: the path is advanced segment by segment; :meth:`observe` evaluates them."""
        times = np.asarray(times, dtype=float)
        listed = times.tolist()
        i, n = 0, len(listed)
        while i < n:
            self.advance(listed[i])
            if self._pending is None:
                j = bisect_right(listed, self._seg.t1, i)
            else:                                   # a sample at an event's time is after it
                j = bisect_left(listed, self._seg.t1, i, key=_after)
            j = max(j, i + 1)
            out.append((times[i:j], self._seg))
            self.t = listed[j - 1]
            i = j

    def observe(self, blocks) -> dict:
        """Observed quantities of recorded blocks (arrays over their samples)."""
        t, q, qd, lam, u, bits = samples.equilibria(self.potential, blocks, self.L, self.T)
        return self.observer.many(t, np.concatenate([q, qd], axis=1), bits, u, contact=lam)

    def observe_now(self) -> dict:
        """The observation at the current time (one sample, evaluated on floats)."""
        seg = self._seg
        q = samples.state_at(seg, self.t, self.L, self.T)
        q, qd, lam, u = samples.polish_one(self.potential, self.t, q, seg.bits, not seg.stationary, self.L)
        return self.observer.one(self.t, q + qd, seg.bits, u, contact=lam)

    def stats(self) -> dict:
        return {"method": "quasi-static (pseudo-arclength continuation)", "steps": self.n_steps,
                "newton_iterations": self.n_newton, "events": len(self.events)}
