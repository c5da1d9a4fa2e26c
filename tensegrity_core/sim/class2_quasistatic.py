"""The class-2 mechanism without inertia: the configuration tracks a stable equilibrium.

With massless struts the equations of motion ``M qddot + C = Q - (T, 0)`` reduce to the
force balance ``Q(q) = (f1, f2, 0)``. Every input law depends on time and on its own length
only, so at frozen ``t`` the actuator force is conservative, and the balance is the
stationarity of the total potential::

    Pi(q, t) = U(q) + V_gravity(q) + V_loads(q) + sum_i W_i(t, rho_i),   W_i = int_0^rho_i f_i(t, r) dr

(``W = f rho`` for laws of time only, ``W = g t rho^2 / 2`` for the paper's ``f = g rho t``).
So with forces as inputs the actuator lengths are *unknowns*: ``dPi/drho_i = 0`` says the
actuator force balances the springs' generalised force, ``dPi/dbeta = 0`` is the paper's
Eq. (10) for the angle. The quasi-static configuration is a local minimum of ``Pi(., t)``
followed continuously in ``t``; with the fold limit the minimum is taken over ``rho_i >= 0``
and a held actuator carries the contact force ``lambda_i = dPi/drho_i >= 0`` (KKT).

**Path following.** ``G = dPi/dq`` restricted to the coordinates not held (``F``) defines a
curve ``G_F(q, t) = 0``. It is followed by pseudo-arclength continuation in the scaled
variables ``z = (q/L, t/T)`` (``T`` the scene's duration): the tangent ``v`` spans the null
space of ``[K_FF L, dG_F/dt T]`` (``K = d2Pi/dq2``), the predictor is ``z + ds v`` and Newton
corrects on ``G_F = 0`` plus ``v . (z - z_pred) = 0``. Unlike stepping in ``t``, this stays
regular where ``dq/dt`` is infinite -- which happens in the paper's scenario, where the
stable branch meets the fold at a limit point. The step ``ds`` is controlled by the
predictor's error against ``rtol, atol``. An accepted point must be a stable equilibrium
(``K_FF`` positive definite) reached forward in time.

Events along the path: an actuator reaching zero length (``fold``: held from then on), a held
actuator whose contact force falls to zero (``release``), and a **limit point**: time would
have to run backwards to stay on the branch, i.e. the equilibrium stops existing because the
forces exceed what the springs can resist. The quasi-static model cannot continue there (the
mechanism would snap; that needs inertia): the run stops with a :class:`SimulationError`.

Between path points the state is the cubic Hermite interpolant in ``s``; each observed
sample is polished by Newton (vectorised over samples) to an exact equilibrium. If the
initial state is not an equilibrium under the inputs at ``t = 0`` (e.g. the paper's start:
the equilibrium angle for locked actuators, but zero actuator force), the model starts from
the minimum of ``Pi(., 0)`` reached by descent from it (event ``jump``); a changed command
does the same at its time.
"""

from __future__ import annotations

import math

import numpy as np

from tensegrity_core.sim import class2_effects as fx
from tensegrity_core.sim.class2_model import build_force_effects
from tensegrity_core.sim.backend import Commands
from tensegrity_core.sim.class2_sim import (
    generalized_static_force,
    initial_configuration,
    observe_class2,
    runtime_laws,
)
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.inputs import next_breakpoint

#: Coordinates not held, per contact mode (bit i set: actuator i held at zero length).
MODE_FREE = {0: (0, 1, 2), 1: (1, 2), 2: (0, 2), 3: (2,)}
#: Predictor error allowed per continuation step (scaled variables). The path only needs to
#: stay on the branch and start each sample's polishing Newton close enough: the observed
#: samples are then equilibria to rounding, whatever this tolerance.
PATH_TOL = 1e-2
#: An actuator within this distance of zero (relative to L) has reached the fold.
FOLD_EPS = 1e-12
#: A branch that ends (limit point) this close to an actuator's zero length (relative to L)
#: ends at the fold.
FOLD_NEAR = 1e-3
#: Events are located to this fraction of the continuation step (a step is at most a quarter
#: of the run in scaled arc length, so event times are exact to ~1e-8 of the duration).
LOCATE_TOL = 1e-7
#: Newton iterations per trial point when locating an event; a trial that needs more (the
#: stiffness nearly singular) counts as past the event.
LOCATE_ITER = 6
#: A path that cannot continue within this distance (relative to L) of lambda1 = 0 or
#: lambda2 = 0 has reached the singular configuration rather than a limit point.
SINGULAR_NEAR = 0.05
#: Polishing steps larger than this (relative to L) are not taken (K nearly singular there).
POLISH_LIMIT = 0.05


def solve_small(A, b) -> list:
    """Solve the small dense system ``A x = b`` (lists) by Gaussian elimination with partial
    pivoting (pure Python: for n <= 4 much cheaper than a numpy call). Raises
    :class:`ZeroDivisionError` when ``A`` is singular."""
    n = len(b)
    M = [list(row) + [b[i]] for i, row in enumerate(A)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(M[r][c]))
        if M[p][c] == 0.0:
            raise ZeroDivisionError("singular matrix")
        M[c], M[p] = M[p], M[c]
        for r in range(c + 1, n):
            f = M[r][c] / M[c][c]
            if f:
                for j in range(c, n + 1):
                    M[r][j] -= f * M[c][j]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        x[r] = (M[r][n] - sum(M[r][j] * x[j] for j in range(r + 1, n))) / M[r][r]
    return x


def positive_definite(K, idx) -> bool:
    """Sylvester's criterion on the principal submatrix ``K[idx][:, idx]`` (size <= 3)."""
    if len(idx) == 1:
        return K[idx[0]][idx[0]] > 0.0
    a, b = idx[0], idx[1]
    if K[a][a] <= 0.0 or K[a][a] * K[b][b] - K[a][b] ** 2 <= 0.0:
        return False
    if len(idx) == 2:
        return True
    return _det3(K) > 0.0


def _det3(K) -> float:
    return (K[0][0] * (K[1][1] * K[2][2] - K[1][2] * K[2][1]) - K[0][1] * (K[1][0] * K[2][2] - K[1][2] * K[2][0])
            + K[0][2] * (K[1][0] * K[2][1] - K[1][1] * K[2][0]))


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
        q, bits = self._minimise(q0, 0.0, sum(1 << i for i in (0, 1) if self.fold and q0[i] <= 0.0))
        if max(abs(a - b) for a, b in zip(q, q0)) > 1e-9 * self.L:
            self.events.append((0.0, "jump", 0))
        self._start(0.0, q, bits)

    # -- the total potential and its derivatives (scalar) -----------------------------------------
    def gradient(self, q, t: float) -> tuple:
        """``(G = dPi/dq as a list of 3, kinematic context)``."""
        k = fx.context(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0))
        Q1 = Q2 = Q3 = 0.0
        for e in self.effects:
            a, b, c = e.force(k)
            Q1 += a
            Q2 += b
            Q3 += c
        l1, l2 = self.laws
        return [l1.value_at(t, q[0]) - Q1, l2.value_at(t, q[1]) - Q2, -Q3], k

    def stiffness(self, k, q, t: float) -> list:
        """``K = d2Pi/dq2`` as a 3 x 3 list."""
        K = [0.0] * 6
        for e in self.effects:
            for i, v in enumerate(e.stiffness(k)):
                K[i] += v
        K11, K12, K13, K22, K23, K33 = K
        K11 += self.laws[0].d_length(t, q[0])
        K22 += self.laws[1].d_length(t, q[1])
        return [[K11, K12, K13], [K12, K22, K23], [K13, K23, K33]]

    def d_time(self, q, t: float) -> list:
        """``dG/dt`` (3,)."""
        return [self.laws[0].d_time(t, q[0]), self.laws[1].d_time(t, q[1]), 0.0]

    def potential(self, q, t: float) -> float:
        k = fx.context(self.L, (q[0], q[1], q[2], 0.0, 0.0, 0.0))
        return sum(e.energy(k) for e in self.effects) + self.laws[0].potential(t, q[0]) + \
            self.laws[1].potential(t, q[1])

    def _regular(self, q) -> bool:
        """Whether the formulas hold at ``q`` (lambda1, lambda2 above 1e-3 L)."""
        L = self.L
        s = q[0] + q[1]
        lim = (1e-3 * L) ** 2
        return (2 * L - s) * (2 * L + s) > lim and (L - q[0]) * (L + q[0]) > lim

    def _in_domain(self, q) -> bool:
        """Regular, and the actuator lengths >= 0 when the fold limit holds."""
        return self._regular(q) and (not self.fold or min(q[0], q[1]) >= 0.0)

    def _contact_forces(self, G, bits: int) -> list:
        return [G[i] if bits >> i & 1 else 0.0 for i in (0, 1)]

    # -- equilibria at fixed t --------------------------------------------------------------------
    def _minimise(self, q, t: float, bits: int, max_iter: int = 500) -> tuple:
        """A stable local minimum of ``Pi(., t)`` reached from ``q`` (projected Newton with a
        backtracking line search; scaled steepest descent where ``K`` is not positive definite;
        a held actuator whose contact force would be tensile is let go)."""
        q = list(q)
        held = {i for i in (0, 1) if bits >> i & 1}
        for _ in range(max_iter):
            G, k = self.gradient(q, t)
            K = self.stiffness(k, q, t)
            self.n_newton += 1
            free = [j for j in range(3) if j not in held]
            pd = positive_definite(K, free)
            if pd:
                d = solve_small([[K[a][b] for b in free] for a in free], [-G[a] for a in free])
                if max(abs(G[a]) for a in free) <= 10 * self.tol:
                    # a minimum with these actuators held: let go of the most tensile stop, if any
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        return q, sum(1 << i for i in held)
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
            pi0 = self.potential(q, t)
            slope = sum(g * s for g, s in zip(G, step))
            a = a_max
            while a > 1e-14:
                trial = [x + a * s for x, s in zip(q, step)]
                if hit is not None and a == a_max:
                    trial[hit] = 0.0
                if self._in_domain(trial) and self.potential(trial, t) <= pi0 + 1e-4 * a * slope:
                    break
                a *= 0.5
            else:
                if pd:     # no decrease left within rounding: converged as far as it goes
                    pulling = [i for i in held if G[i] < -self.release_tol]
                    if not pulling:
                        return q, sum(1 << i for i in held)
                    held.discard(min(pulling, key=lambda i: G[i]))
                    continue
                break
            q = trial
            if hit is not None and a == a_max:
                held.add(hit)
        raise SimulationError(f"t = {t:.9g} s: no stable equilibrium found from q = {np.array2string(np.array(q), precision=6)} "
                              f"(the springs cannot balance the actuator forces there)", t=t)

    # -- pseudo-arclength continuation in z = (q_free / L, t / T) ---------------------------------
    def _z(self, q, t, free) -> list:
        return [q[a] / self.L for a in free] + [t / self.T]

    def _q_t(self, z, template, free) -> tuple:
        q = list(template)
        for j, a in enumerate(free):
            q[a] = z[j] * self.L
        return q, z[-1] * self.T

    def _bordered(self, q, t, free, last_row) -> tuple:
        """``[[K_FF L, dG_F/dt T], [last_row]]`` and ``G``."""
        G, k = self.gradient(q, t)
        K = self.stiffness(k, q, t)
        Gt = self.d_time(q, t)
        L, T = self.L, self.T
        A = [[K[a][b] * L for b in free] + [Gt[a] * T] for a in free] + [list(last_row)]
        return A, G, K

    def _tangent(self, q, t, bits, previous=None) -> list:
        """Unit tangent ``dz/ds`` (n_free + 1): the null vector of ``[K_FF L, dG_F/dt T]``
        from the bordered system with the previous tangent (forward in time at a start)."""
        free = MODE_FREE[bits]
        prev = previous if previous is not None else [0.0] * len(free) + [1.0]
        A, _, _ = self._bordered(q, t, free, prev)
        v = solve_small(A, [0.0] * len(free) + [1.0])
        norm = math.sqrt(sum(x * x for x in v))
        return [x / norm for x in v]

    def _correct(self, q, t, bits, z_pred, v, max_iter: int = 12, tol: float = 1e-9):
        """Newton on ``G_F = 0``, ``v . (z - z_pred) = 0`` until the scaled step is below
        ``tol``; ``(q, t, G, K)`` or ``None``."""
        free = MODE_FREE[bits]
        L, T = self.L, self.T
        q = list(q)
        for _ in range(max_iter):
            if not self._regular(q):
                return None
            A, G, K = self._bordered(q, t, free, v)
            self.n_newton += 1
            z = self._z(q, t, free)
            try:
                dz = solve_small(A, [-G[a] for a in free] + [-sum(vi * (zi - zp) for vi, zi, zp in zip(v, z, z_pred))])
            except ZeroDivisionError:
                return None
            for j, a in enumerate(free):
                q[a] += dz[j] * L
            t += dz[-1] * T
            if max(abs(x) for x in dz) <= tol:
                if not self._regular(q):
                    return None
                G, k = self.gradient(q, t)
                return q, t, G, self.stiffness(k, q, t)
        return None

    def _start(self, t: float, q, bits: int) -> None:
        """Begin a path piece at ``(t, q)`` (a zero-length segment)."""
        self.bits = bits
        free = MODE_FREE[bits]
        v = self._tangent(q, t, bits)
        z = self._z(q, t, free)
        self._seg = (t, t, list(q), z, z, v, v, 0.0)
        self._pending = None
        self._table = None

    def advance(self, t_target: float) -> None:
        if t_target < self.t:
            raise SimulationError(f"cannot advance backwards: t = {self.t!r} s, target {t_target!r} s", t=self.t)
        while self._seg[1] < t_target:
            if self._pending is not None:
                t_e, q_e, bits_e, fired = self._pending
                self.events.extend(fired)
                self._start(t_e, q_e, bits_e)
                continue
            self._path_step()
        self.t = t_target

    def _at(self, z0, v0, h, template, bits, tol=1e-9, max_iter=12):
        free = MODE_FREE[bits]
        zp = [a + h * b for a, b in zip(z0, v0)]
        q, t = self._q_t(zp, template, free)
        return self._correct(q, t, bits, zp, v0, max_iter=max_iter, tol=tol), zp

    def _path_step(self) -> None:
        """One accepted continuation step from the end of the current segment."""
        _, t0, template, _, z0, _, v0, _ = self._seg
        bits = self.bits
        free = MODE_FREE[bits]
        t_stop = next_breakpoint(self.laws, t0, math.inf)
        while True:
            ds = min(self.ds, self.ds_max)
            out, zp = self._at(z0, v0, ds, template, bits)
            if out is None:
                if ds < 1e-14:
                    self._limit(t0, template, "the corrector does not converge")
                self.ds = ds / 4
                continue
            q1, t1, G1, K1 = out
            z1 = self._z(q1, t1, free)
            err = max(abs(a - b) for a, b in zip(z1, zp)) / PATH_TOL
            if err > 1.0 and ds > 1e-14:
                self.ds = ds * max(0.2, 0.9 / math.sqrt(err))
                continue
            break
        self.n_steps += 1
        kind = self._event_kind(q1, t1, G1, K1, bits, t_stop)
        if kind is not None:
            self._locate(z0, v0, ds, template, bits, kind, t_stop)
            return
        v1 = self._tangent(q1, t1, bits, v0)
        self._seg = (t0, t1, q1, z0, z1, v0, v1, ds)
        self.ds = ds * min(4.0, 0.9 / math.sqrt(max(err, 1e-12)))

    def _event_kind(self, q, t, G, K, bits, t_stop):
        """What the path went past at ``(q, t)``, if anything."""
        if self.fold and any(not bits >> i & 1 and q[i] < FOLD_EPS * self.L for i in (0, 1)):
            return "fold"
        if self.fold and min(self._contact_forces(G, bits)) < -self.release_tol:
            return "release"
        if not positive_definite(K, MODE_FREE[bits]):
            return "limit"
        if t > t_stop:
            return "breakpoint"
        return None

    def _locate(self, z0, v0, ds, template, bits, kind: str, t_stop: float) -> None:
        """Find the first point of the step where ``kind`` happens (regula falsi, Illinois
        variant, on the event's function of the step length); end the segment there and
        queue the path's new start."""
        def g(point) -> float:
            """> 0 before the event, <= 0 past it (a failed corrector counts as past)."""
            if point is None:
                return -1.0
            q, t, G, K = point
            if self._event_kind(q, t, G, K, bits, t_stop) is None:
                return max(self._event_value(kind, q, t, G, K, bits, t_stop), 1e-300)
            return min(self._event_value(kind, q, t, G, K, bits, t_stop), 0.0)

        lo, hi, p_lo, p_hi = 0.0, ds, None, None
        g_lo = self._event_value(kind, *self._point(z0, template, bits), bits, t_stop)
        out, _ = self._at(z0, v0, hi, template, bits, tol=1e-11, max_iter=LOCATE_ITER)
        g_hi, p_hi = g(out), out
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
        if p_lo is None:
            p_lo = self._point(z0, template, bits)
        kind = self._event_kind(*p_hi, bits, t_stop) if p_hi is not None else "limit"
        q_e, t_e, G_e, _ = p_lo
        near = [i for i in (0, 1) if not bits >> i & 1 and q_e[i] < FOLD_NEAR * self.L]
        if kind == "limit" and self.fold and near:
            # The branch ends where it meets the fold (its stiffness vanishes there, as in the
            # paper's scenario): the held actuator continues it.
            kind = "fold"
            p_hi = (q_e, t_e, G_e, None)
        if kind == "breakpoint":
            q_e, t_e = self._correct_at_time(q_e, t_stop, bits), t_stop
        free = MODE_FREE[bits]
        self._seg = (self._seg[1], t_e, q_e, z0, self._z(q_e, t_e, free), v0,
                     self._tangent(q_e, t_e, bits, v0), lo)
        if kind == "limit":
            self._limit(t_e, q_e, "the stiffness d2Pi/dq2 stops being positive definite")
        held = {i for i in (0, 1) if bits >> i & 1}
        fired = []
        q_new = list(q_e)
        if kind == "fold":
            hit = [i for i in (0, 1) if i not in held and p_hi[0][i] < FOLD_NEAR * self.L]
            for i in hit:
                q_new[i] = 0.0
            held |= set(hit)
            fired = [(t_e, "fold", i) for i in hit]
        elif kind == "release":
            gone = [i for i in held if p_hi[2][i] < -self.release_tol]
            held -= set(gone)
            fired = [(t_e, "release", i) for i in gone]
        q_new, new_bits = self._minimise(q_new, t_e, sum(1 << i for i in held))
        self._pending = (t_e, q_new, new_bits, fired)

    def _point(self, z, template, bits) -> tuple:
        q, t = self._q_t(z, template, MODE_FREE[bits])
        G, k = self.gradient(q, t)
        return q, t, G, self.stiffness(k, q, t)

    def _event_value(self, kind, q, t, G, K, bits, t_stop) -> float:
        """A continuous function of the path that changes sign at the event ``kind``."""
        if kind == "fold":
            return min(q[i] - FOLD_EPS * self.L for i in (0, 1) if not bits >> i & 1) / self.L
        if kind == "release":
            return min(G[i] + self.release_tol for i in (0, 1) if bits >> i & 1)
        if kind == "breakpoint":
            return (t_stop - t) / self.T
        free = MODE_FREE[bits]
        sub = [[K[a][b] for b in free] for a in free]
        return float(np.linalg.det(np.array(sub)))

    def _correct_at_time(self, q, t, bits) -> list:
        """Newton on ``G_F = 0`` at fixed ``t`` (for a breakpoint)."""
        free = MODE_FREE[bits]
        q = list(q)
        for _ in range(40):
            G, k = self.gradient(q, t)
            K = self.stiffness(k, q, t)
            d = solve_small([[K[a][b] for b in free] for a in free], [-G[a] for a in free])
            for j, a in enumerate(free):
                q[a] += d[j]
            if max(abs(x) for x in d) <= 1e-13 * self.L:
                break
        return q

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
            q, bits = self._state_at(self.t)
            q_new, new_bits = self._minimise(q, self.t, bits)
            if max(abs(a - b) for a, b in zip(q_new, q)) > 1e-9 * self.L:
                self.events.append((self.t, "jump", 0))
            self._start(self.t, q_new, new_bits)

    def _state_at(self, t: float) -> tuple:
        """Cubic Hermite interpolation of the current segment at time ``t``."""
        t0, t1, q1, z0, z1, v0, v1, ds = self._seg
        if t1 <= t0 or t >= t1:
            return list(q1), self.bits
        tau = t / self.T

        def hermite(u, j):
            u2, u3 = u * u, u * u * u
            return ((2 * u3 - 3 * u2 + 1) * z0[j] + (u3 - 2 * u2 + u) * ds * v0[j] + (-2 * u3 + 3 * u2) * z1[j]
                    + (u3 - u2) * ds * v1[j])

        lo, hi = 0.0, 1.0
        u = (t - t0) / (t1 - t0)
        for _ in range(60):                      # safeguarded Newton on tau(u) = t / T
            f = hermite(u, -1) - tau
            if f < 0:
                lo = u
            else:
                hi = u
            if abs(f) <= 1e-15 * max(1.0, abs(tau)) or hi - lo < 1e-15:
                break
            u2 = u * u
            df = (6 * u2 - 6 * u) * z0[-1] + (3 * u2 - 4 * u + 1) * ds * v0[-1] + (-6 * u2 + 6 * u) * z1[-1] \
                + (3 * u2 - 2 * u) * ds * v1[-1]
            nxt = u - f / df if df > 0 else 0.5 * (lo + hi)
            u = nxt if lo < nxt < hi else 0.5 * (lo + hi)
        free = MODE_FREE[self.bits]
        q = list(q1)
        for j, a in enumerate(free):
            q[a] = hermite(u, j) * self.L
        return q, self.bits

    def sample(self) -> tuple:
        q, bits = self._state_at(self.t)
        return self.t, q, bits

    def record(self, times, out: list) -> None:
        """Append samples at increasing ``times`` to ``out``: the path is advanced segment by
        segment and the samples inside a segment are interpolated together."""
        i, n = 0, len(times)
        while i < n:
            self.advance(float(times[i]))
            j = i
            while j < n and times[j] <= self._seg[1]:
                j += 1
            j = max(j, i + 1)
            for t, q in zip(times[i:j], self._states_at(np.asarray(times[i:j], dtype=float))):
                out.append((float(t), q, self.bits))
            self.t = float(times[j - 1])
            i = j

    def _states_at(self, times) -> np.ndarray:
        """:meth:`_state_at` for an array of times in the current segment (vectorised)."""
        t0, t1, q1, z0, z1, v0, v1, ds = self._seg
        q = np.tile(np.asarray(q1, dtype=float), (len(times), 1))
        if t1 <= t0 or (z0[:-1] == z1[:-1] and not any(v0[:-1]) and not any(v1[:-1])):
            return q                                       # a point, or a path standing still
        z0, z1, v0, v1 = (np.asarray(a, dtype=float) for a in (z0, z1, v0, v1))
        tau = np.minimum(times, t1) / self.T
        c = np.array([z0[-1], ds * v0[-1], z1[-1], ds * v1[-1]])

        def tau_of(u):
            u2, u3 = u * u, u * u * u
            return np.stack([2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2], -1) @ c

        # tau(u) increases on the segment: invert a fine table (once per segment), then two
        # Newton steps
        if self._table is None or self._table[0] is not self._seg:
            grid = np.linspace(0.0, 1.0, 129)
            self._table = (self._seg, grid, np.maximum.accumulate(tau_of(grid)))
        _, grid, table = self._table
        u = np.interp(tau, table, grid)
        for _ in range(2):
            u2 = u * u
            df = (6 * u2 - 6 * u) * c[0] + (3 * u2 - 4 * u + 1) * c[1] + (-6 * u2 + 6 * u) * c[2] + \
                (3 * u2 - 2 * u) * c[3]
            with np.errstate(all="ignore"):
                step = (tau_of(u) - tau) / df
            u = np.where(np.isfinite(step) & (np.abs(step) < 1.0 / 128), np.clip(u - step, 0.0, 1.0), u)
        u2, u3 = u * u, u * u * u
        H = np.stack([2 * u3 - 3 * u2 + 1, (u3 - 2 * u2 + u) * ds, -2 * u3 + 3 * u2, (u3 - u2) * ds], -1)
        Z = H @ np.stack([z0, v0, z1, v1])
        free = list(MODE_FREE[self.bits])
        q[:, free] = Z[:, :-1] * self.L
        return q

    def observe(self, samples) -> dict:
        t = np.array([s[0] for s in samples], dtype=float)
        bits = np.array([s[2] for s in samples])
        q, qd, lam, T = self._polish(t, np.array([s[1] for s in samples], dtype=float), bits)
        rows = [(t[j], np.concatenate([q[j], qd[j]]), int(bits[j]), T[j]) for j in range(len(t))]
        return observe_class2(self.scene, self.effects, rows, inertia=False, contact=lam)

    def _polish(self, t, q, bits) -> tuple:
        """Newton, vectorised over samples, from interpolated states to exact equilibria;
        returns ``(q, dq/dt, contact forces, actuator forces)``."""
        q = q.copy()
        N = len(t)
        for it in range(4):
            k = fx.context_array(self.L, q, np.zeros_like(q))
            G = np.zeros((N, 3))
            for e in self.effects:
                G -= np.stack(np.broadcast_arrays(*e.force(k)), -1)
            K = [np.zeros(N) for _ in range(6)]
            for e in self.effects:
                for i, v in enumerate(e.stiffness(k)):
                    K[i] = K[i] + v
            (u1, du1, dt1), (u2, du2, dt2) = (law.arrays(t, q[:, a]) for a, law in enumerate(self.laws))
            T = np.stack([u1, u2], -1)
            G[:, :2] += T
            K[0] = K[0] + du1
            K[3] = K[3] + du2
            Km = fx.stiffness_matrix(K)
            if it == 3:
                break
            for mode in np.unique(bits):
                sel = np.flatnonzero(bits == mode)
                free = list(MODE_FREE[int(mode)])
                with np.errstate(all="ignore"):
                    d = np.linalg.solve(Km[sel][:, free][:, :, free], -G[sel][:, free][..., None])[..., 0]
                d[~np.all(np.isfinite(d) & (np.abs(d) < POLISH_LIMIT * self.L), axis=1)] = 0.0
                q[np.ix_(sel, free)] += d
        Gt = np.stack([dt1, dt2, np.zeros(N)], -1)
        qd = np.zeros_like(q)
        lam = np.zeros((N, 2))
        for mode in np.unique(bits):
            sel = np.flatnonzero(bits == mode)
            free = list(MODE_FREE[int(mode)])
            with np.errstate(all="ignore"):
                qd[np.ix_(sel, free)] = np.linalg.solve(Km[sel][:, free][:, :, free], -Gt[sel][:, free][..., None])[..., 0]
            for i in (0, 1):
                if int(mode) >> i & 1:
                    lam[sel, i] = G[sel, i]
        return q, qd, lam, T

    def stats(self) -> dict:
        return {"method": "quasi-static (pseudo-arclength continuation)", "steps": self.n_steps,
                "newton_iterations": self.n_newton, "events": len(self.events)}
