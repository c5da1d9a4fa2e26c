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

**Events** along the path (:mod:`.class2_path_events`): an actuator reaching zero length
(``fold``: held from then on), a held actuator whose contact force falls to zero
(``release``), an input law's breakpoint, and a **limit point**: time would have to run
backwards to stay on the branch, i.e. the equilibrium stops existing because the forces
exceed what the springs can resist. The quasi-static model cannot continue there (the
mechanism would snap; that needs inertia): the run stops with a :class:`SimulationError`.
Events are located by Newton on the path's equations plus the event's own (quadratically
convergent), a degenerate contact as the bifurcation of the held branch. An event at a
sample's time (to rounding) comes before the sample.

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

import numpy as np

from tensegrity_core.sim import class2_path_samples as samples
from tensegrity_core.sim.backend import Commands
from tensegrity_core.sim.class2_model import build_force_effects
from tensegrity_core.sim.class2_observe import Class2Observer
from tensegrity_core.sim.class2_path_events import Event, PathEvents, Point, bits_of, just_before
from tensegrity_core.sim.class2_path_samples import MODE_FREE, Segment
from tensegrity_core.sim.class2_potential import TotalPotential
from tensegrity_core.sim.class2_sim import generalized_static_force, initial_configuration, runtime_laws
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.inputs import next_breakpoint
from tensegrity_core.sim.small_dense import positive_definite, solve_bordered, solve_symmetric

#: Predictor error allowed per continuation step (scaled variables). The path only needs to
#: stay on the branch and start each sample's polishing Newton close enough: the observed
#: samples are then equilibria to rounding, whatever this tolerance.
PATH_TOL = 2e-2
#: The step grows by at most this factor after an accepted step.
GROWTH = 4.0
#: The corrector stops once its scaled step is below this: Newton converges quadratically
#: there (the next step would be ~1e-12), and the path's points only need to be that good
#: (samples off stationary segments are polished into exact equilibria).
CORRECT_TOL = 1e-6
#: Near a minimum the potential's decrease falls below its rounding and the line search
#: cannot judge a step: a Newton step shorter than this (relative to L) is taken as it is.
NEWTON_ZONE = 1e-6


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


class Class2QuasiStatic(PathEvents, Commands):
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
        self.ds = self.ds_max / 4
        self.events: list = []
        self.n_steps = 0
        self.n_newton = 0
        self.t = 0.0
        q0 = [float(v) for v in q0]
        q, bits = self._minimise(q0, 0.0, bits_of(i for i in (0, 1) if self.fold and q0[i] <= 0.0))
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
        pi_q = None                    # Pi(q, t) when known
        for _ in range(max_iter):
            G, K, _ = potential.evaluate(q, t)
            self.n_newton += 1
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
                        return (last if self._in_domain(last) else q), bits_of(held)
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
                        a = -q[i] / step[i]
                        if a < a_max:
                            a_max, hit = a, i
            if pd and hit is None and big <= NEWTON_ZONE * self.L:
                trial = [x + s for x, s in zip(q, step)]
                if self._in_domain(trial):
                    q, pi_q = trial, None
                    continue
            if pi_q is None:
                pi_q = potential.value(q, t)
            slope = sum(g * s for g, s in zip(G, step))
            a = a_max
            while a > 1e-14:
                trial = [x + a * s for x, s in zip(q, step)]
                if hit is not None and a == a_max:
                    trial[hit] = 0.0
                if self._in_domain(trial):
                    pi_trial = potential.value(trial, t)
                    if pi_trial <= pi_q + 1e-4 * a * slope:
                        break
                a *= 0.5
            else:
                if pd:     # no decrease left within rounding: converged as far as it goes
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        return q, bits_of(held)
                    held.discard(min(pulling, key=lambda i: G[i]))
                    continue
                break
            q, pi_q = trial, pi_trial
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
            ds, end, err = self._corrected_step(head, z0, v0, bits, t_stop)
        self.n_steps += 1
        kind = self._event_kind(end, bits, t_stop)
        if kind is not None:
            self._locate(v0, ds, end, kind, t_stop)
            return
        if end.t == just_before(t_stop):
            # landed at an input law's breakpoint: the path goes on from there with the law's
            # new piece (a fresh start: tangent and curvature change at the kink)
            self._close(Event("breakpoint", end, frozenset(), *self._closing_tangent(end, z0, v0)), v0, t_stop)
            return
        v1 = self._tangent(end, bits, v0)
        self._seg = Segment.of(head.t, end.t, end.q, z0, self._z(end.q, end.t, free), v0, v1, ds, bits)
        self._head = end
        if err is not None:
            self.ds = ds * min(GROWTH, 0.9 / math.sqrt(max(err, 1e-12)))

    def _corrected_step(self, head: Point, z0, v0, bits: int, t_stop: float) -> tuple:
        """Predictor and corrector with step control: ``(ds, end point, error ratio)``. The
        predictor is ``z + ds v + ds^2 / 2 kappa`` with the curvature ``kappa`` estimated from
        the tangents' change over the last step (none at a path's start). A prediction past
        the next breakpoint ``t_stop`` of an input law is cut there and corrected at the time
        just before it (Newton would not converge across the kink), the step ending there
        (error ratio ``None``)."""
        free = MODE_FREE[bits]
        seg = self._seg
        kappa = [(a - b) / seg.ds for a, b in zip(seg.v1, seg.v0)] if seg.ds > 0 else [0.0] * len(v0)
        while True:
            ds = min(self.ds, self.ds_max)
            zp = [a + ds * (b + 0.5 * ds * c) for a, b, c in zip(z0, v0, kappa)]
            if zp[-1] * self.T > t_stop > head.t:
                cut = (t_stop / self.T - z0[-1]) / (zp[-1] - z0[-1])
                q, _ = self._q_t([a + cut * (b - a) for a, b in zip(z0, zp)], head.q, free)
                end = self._equilibrium_at(q, just_before(t_stop), bits)
                if end is not None:
                    return ds * cut, end, None
                self.ds = ds * cut / 2
                continue
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
