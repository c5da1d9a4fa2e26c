"""Events along the quasi-static class-2 path: what a continuation step went past, and where.

:class:`EventLocator` is the path follower's collaborator for events
(:class:`~tensegrity_core.sim.class2.path.PathFollower`): after each step the follower asks
it what the step's end went past --  a **fold** (a free actuator length below zero), a **release** (a
held actuator's contact force below ``-tol``: it would have to pull), a **limit point** (the
stiffness ``K_FF`` no longer positive definite) and an input law's **breakpoint**, and
locates the first one inside the step:

- by Newton on the path's equations ``G_F = 0`` plus the event's own (``rho_i = 0``,
  ``lambda_i = -tol``, ``t = t_b``) in ``(q_F, t)``, from the chord's estimate -- quadratically
  convergent where the event is regular;
- where a branch meets the stop at a *degenerate* contact (``lambda_i`` vanishes along the
  held branch too, as at the paper's full fold, an equilibrium for every ``t``), that system
  is singular: the two branches of ``G_F = 0`` cross there, so the meeting point is where the
  free mode's ``K_FF`` on the held branch is singular, found by the secant method in ``t``;
- limit points, and anything these two cannot settle, by regula falsi on the step length
  (each trial corrected onto the path).

The locator returns the located :class:`PathEvent`; the follower closes its segment there and
queues the path's new start (the fold's actuator held, the released one let go, then the
minimum of the new mode), or stops the run at a limit point. It reads the path only through
the arguments of its calls and the :class:`~tensegrity_core.sim.class2.equilibria.Equilibria`
it is given.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

from tensegrity_core.sim.class2.equilibria import Equilibria, PathPoint
from tensegrity_core.sim.class2.path_samples import MODE_FREE
from tensegrity_core.sim.class2.small_dense import positive_definite, principal_det, solve_small

#: An actuator within this distance of zero (relative to L) has reached the fold.
FOLD_EPS = 1e-12
#: A branch that ends (limit point) this close to an actuator's zero length (relative to L)
#: ends at the fold.
FOLD_NEAR = 1e-3
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


class PathEvent(NamedTuple):
    """A located event: ``kind``, the point ``at`` (last state of the branch), the
    actuators it concerns, and the closing tangent and arc length of the last segment.
    ``kind`` None: bracketing found nothing past ``at`` after all (the path starts afresh there)."""

    kind: str | None
    at: PathPoint
    actuators: frozenset[int]
    tangent: list[float]
    ds: float


def just_before(t: float) -> float:
    """The float before ``t``: an input law's last value before its breakpoint ``t`` (the laws
    take their new piece at the breakpoint itself)."""
    return math.nextafter(t, -math.inf)


def _distance(a: Sequence[float], b: Sequence[float]) -> float:
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


class EventLocator:
    """Detection and location of the events of a quasi-static path, on the path's
    :class:`~tensegrity_core.sim.class2.equilibria.Equilibria` ``eq``. A step goes from the
    path's current end ``head`` (a :class:`PathPoint`) in contact mode ``bits`` along tangent
    ``v0``; ``t_stop`` is the next breakpoint of an input law."""

    def __init__(self, eq: Equilibria):
        self.eq = eq
        self.L, self.T, self.fold, self.release_tol = eq.L, eq.T, eq.fold, eq.release_tol

    def kind(self, p: PathPoint, bits: int, t_stop: float) -> str | None:
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

    def value(self, kind: str, p: PathPoint, bits: int, t_stop: float) -> float:
        """A continuous function of the path that changes sign at the event ``kind``."""
        if kind == "fold":
            return min(p.q[i] - FOLD_EPS * self.L for i in (0, 1) if not bits >> i & 1) / self.L
        if kind == "release":
            return min(p.G[i] + self.release_tol for i in (0, 1) if bits >> i & 1)
        if kind == "breakpoint":
            return (t_stop - p.t) / self.T
        return principal_det(p.K, MODE_FREE[bits])

    def locate(self, head: PathPoint, bits: int, v0: Sequence[float], ds: float, end: PathPoint, kind: str,
               t_stop: float) -> PathEvent:
        """The first event ``kind`` of the step of arc length ``ds`` from ``head`` to ``end``."""
        event = None
        if kind != "limit":
            event = self._solve_event(head, bits, v0, kind, end, ds, t_stop)
            if event is None and kind == "fold":
                event = self._branch_point(head, bits, v0, end, ds)
        if event is None:
            event = self._bracket_event(head, bits, v0, ds, kind, t_stop)
        return event

    def closing_tangent(self, p: PathPoint, bits: int, z_head: Sequence[float],
                        v0: Sequence[float]) -> tuple[list[float], float]:
        """Tangent and arc length (chord) of the last segment ending at ``p``; the chord's
        direction where the tangent is not unique (a bifurcation)."""
        free = MODE_FREE[bits]
        z = self.eq.z(p.q, p.t, free)
        chord = _distance(z, z_head)
        try:
            return self.eq.tangent(p, bits, v0), chord
        except ZeroDivisionError:
            return [(a - b) / chord for a, b in zip(z, z_head)] if chord > 0 else list(v0), chord

    def _before_other_events(self, p: PathPoint, bits: int, t_stop: float, kind: str, i: int) -> bool:
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

    def _solve_event(self, head: PathPoint, bits: int, v0: Sequence[float], kind: str, end: PathPoint, ds: float,
                     t_stop: float) -> PathEvent | None:
        """The event point by Newton on ``G_F = 0`` plus the event's equation, in the scaled
        unknowns ``z = (q_F / L, t / T)``, from the chord's estimate; ``None`` if it does not
        converge to a point of this step before every other event."""
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
        z_head = self.eq.z(head.q, head.t, free)
        z = [a + theta * (b - a) for a, b in zip(z_head, self.eq.z(end.q, end.t, free))]
        q, t = self.eq.q_t(z, head.q, free)
        last = math.inf
        for _ in range(EVENT_ITER):
            if not self.eq.regular(q):
                return None
            G, K, Gt = self.eq.potential.evaluate(q, t)
            self.eq.counts.newton += 1
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
                rhs.append((just_before(t_stop) - t) / T)
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
            t = just_before(t_stop)
        if not (self.eq.regular(q) and head.t <= t):
            return None
        p = self.eq.point(q, t)
        reach = 1.5 * max(ds, _distance(self.eq.z(end.q, end.t, free), z_head))
        if _distance(self.eq.z(q, t, free), z_head) > reach or not self._before_other_events(p, bits, t_stop, kind, i):
            return None
        if kind == "fold":
            actuators = frozenset(j for j in (0, 1) if not bits >> j & 1 and q[j] < FOLD_NEAR * L)
        elif kind == "release":
            actuators = frozenset({i} | {j for j in (0, 1) if bits >> j & 1 and p.G[j] < -rtol})
        else:
            actuators = frozenset()
        return PathEvent(kind, p, actuators, *self.closing_tangent(p, bits, z_head, v0))

    def _branch_point(self, head: PathPoint, bits: int, v0: Sequence[float], end: PathPoint,
                      ds: float) -> PathEvent | None:
        """Where the free branch meets the stop of an actuator at a degenerate contact: the
        time ``t`` at which the stiffness ``K_FF`` of the free mode, on the branch held at the
        stop, becomes singular (two branches of ``G_F = 0`` cross there), by the secant method
        from the chord's estimate; ``None`` if that does not settle it."""
        free = MODE_FREE[bits]
        L, T = self.L, self.T
        crossings = [(head.q[i] / (head.q[i] - end.q[i]), i) for i in (0, 1)
                     if not bits >> i & 1 and end.q[i] < FOLD_EPS * L < head.q[i]]
        if not crossings:
            return None
        theta, i = min(crossings)
        held = bits | 1 << i
        t_lo = head.t
        t_hi = t_lo + 1.5 * max(ds, _distance(self.eq.z(end.q, end.t, free), self.eq.z(head.q, head.t, free))) * T

        def det_on_held_branch(t: float, q: Sequence[float]) -> tuple[float, PathPoint | None]:
            p = self.eq.equilibrium_at(q, t, held)
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
        return PathEvent("fold", p_a, actuators, *self.closing_tangent(p_a, bits, self.eq.z(head.q, head.t, free), v0))

    def _bracket_event(self, head: PathPoint, bits: int, v0: Sequence[float], ds: float, kind: str,
                       t_stop: float) -> PathEvent:
        """The first point of the step where ``kind`` happens, by regula falsi (Illinois
        variant) on the event's function of the step length, each trial corrected onto the
        path: slow but it needs nothing regular (limit points)."""
        free = MODE_FREE[bits]
        z0, template = self.eq.z(head.q, head.t, free), head.q

        def g(point: PathPoint | None) -> float:
            """> 0 before the event, <= 0 past it (a failed corrector counts as past)."""
            if point is None:
                return -1.0
            if self.kind(point, bits, t_stop) is None:
                return max(self.value(kind, point, bits, t_stop), 1e-300)
            return min(self.value(kind, point, bits, t_stop), 0.0)

        lo, hi, p_lo = 0.0, ds, head
        g_lo = self.value(kind, head, bits, t_stop)
        p_hi, _ = self.eq.at(z0, v0, hi, template, bits, tol=1e-11, max_iter=LOCATE_ITER)
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
            out, _ = self.eq.at(z0, v0, x, template, bits, tol=1e-11, max_iter=LOCATE_ITER)
            gx = g(out)
            if gx > 0.0 and out is not None:          # (g is -1 without a point)
                lo, g_lo, p_lo = x, gx, out
                if side == 1 and g_hi != -1.0:
                    g_hi *= 0.5
                side = 1
            else:
                hi, g_hi, p_hi = x, gx, out
                if side == -1:
                    g_lo *= 0.5
                side = -1
        located: str | None = "limit"          # a failed corrector past the event: a limit point
        past = p_lo
        if p_hi is not None:
            located, past = self.kind(p_hi, bits, t_stop), p_hi
        near = [i for i in (0, 1) if not bits >> i & 1 and p_lo.q[i] < FOLD_NEAR * self.L]
        if located == "limit" and self.fold and near:
            # The branch ends where it meets the fold (its stiffness vanishes there): the held
            # actuator continues it.
            located, past = "fold", p_lo
        at = p_lo
        if located == "breakpoint":
            t_b = just_before(t_stop)
            at = self.eq.equilibrium_at(p_lo.q, t_b, bits) or self.eq.point(p_lo.q, t_b)
        actuators: frozenset[int] = frozenset()
        if located == "fold":
            actuators = frozenset(i for i in (0, 1) if not bits >> i & 1 and past.q[i] < FOLD_NEAR * self.L)
        elif located == "release":
            actuators = frozenset(i for i in (0, 1) if bits >> i & 1 and past.G[i] < -self.release_tol)
        return PathEvent(located, at, actuators, self.eq.tangent(at, bits, v0), lo)
