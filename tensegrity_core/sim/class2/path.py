"""The quasi-static path follower: a stable equilibrium branch followed continuously in time.

:class:`PathFollower` is the integrator of a quasi-static class-2 state. It keeps
the path's current piece -- the head :class:`~tensegrity_core.sim.class2.equilibria.PathPoint`,
the :class:`~tensegrity_core.sim.class2.path_samples.Segment` that ends there, the contact
mode, the continuation step -- and asks two collaborators:

- :class:`~tensegrity_core.sim.class2.equilibria.Equilibria` for equilibria, tangents and
  corrected points of the total potential under the current input laws;
- :class:`~tensegrity_core.sim.class2.path_events.EventLocator` for what a step went past
  (fold, release, limit point, an input law's breakpoint) and where.

Each accepted step (:meth:`PathFollower.advance`) is a pseudo-arclength predictor with the
curvature term from the tangents' change over the last step, corrected by Newton, its size
controlled by the predictor's error (:data:`PATH_TOL`). At an event the segment closes and
the path's new start is queued (held, released, or the minimum under a law's new piece); at a
limit point or the singular configuration the run stops with a
:class:`~tensegrity_core.sim.errors.SimulationError`.
"""

from __future__ import annotations

import math
import sys
from bisect import bisect_left, bisect_right
from collections.abc import Iterable, Sequence
from typing import NoReturn

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.class2 import path_samples as samples
from tensegrity_core.sim.class2.equilibria import Equilibria, PathCounts, PathPoint, bits_of
from tensegrity_core.sim.class2.path_events import EventLocator, PathEvent, just_before
from tensegrity_core.sim.class2.path_samples import MODE_FREE, Segment
from tensegrity_core.sim.class2.potential import TotalPotential
from tensegrity_core.sim.errors import SimulationError, check_advance_target
from tensegrity_core.sim.inputs import Law, next_breakpoint

#: The path's queued new start: ``(t, q, contact mode bits, the events fired there)``.
Pending = tuple[float, list[float], int, list[LoggedEvent]]

#: Predictor error allowed per continuation step (scaled variables). The path only needs to
#: stay on the branch and start each sample's polishing Newton close enough: the observed
#: samples are then equilibria to rounding, whatever this tolerance.
PATH_TOL = 2e-2
#: The step grows by at most this factor after an accepted step.
GROWTH = 4.0
#: A path that cannot continue within this distance (relative to L) of lambda1 = 0 or
#: lambda2 = 0 has reached the singular configuration rather than a limit point.
SINGULAR_NEAR = 0.05


def _after(t: float) -> float:
    """``t`` plus a few units of rounding: an event this close to a time counts as at it."""
    return t + 8 * sys.float_info.epsilon * max(1.0, abs(t))


class PathFollower:
    """The path of one quasi-static state from ``(t, q)`` in contact mode ``bits``, on the
    equilibria ``eq``; events go into ``log`` as ``(t, kind, index)``. Call :meth:`start`
    (or :meth:`jump`) before advancing."""

    def __init__(self, eq: Equilibria, log: list[LoggedEvent]):
        self.eq = eq
        self.locator = EventLocator(eq)
        self.events = log
        self.counts = eq.counts
        self.ds = eq.settings.ds_max / 4
        self.t = 0.0
        # set by start: the contact mode, the path's head point, the segment that ends there and
        # the new start queued at an event
        self.bits: int
        self.head: PathPoint
        self.seg: Segment
        self.pending: Pending | None

    # -- the integrator's view ---------------------------------------------------------------------
    @property
    def y(self) -> NDArray[np.float64]:
        """``(q, dq/dt)`` at ``t``: the segment's interpolant polished into an equilibrium."""
        q, qd, _, _ = self.equilibrium_now()
        return np.array(q + qd)

    @property
    def mode(self) -> frozenset[int]:
        return frozenset(i for i in (0, 1) if self.bits >> i & 1)

    def copy(self, log: list[LoggedEvent]) -> PathFollower:
        """An exact, independent copy logging into ``log`` (the path's pieces are immutable)."""
        new = PathFollower.__new__(PathFollower)
        new.__dict__.update(self.__dict__)
        new.events = log
        new.counts = PathCounts(self.counts.steps, self.counts.newton)
        new.eq = Equilibria(self.eq.potential, self.eq.settings, new.counts)
        new.locator = EventLocator(new.eq)
        return new

    def with_laws(self, laws: Iterable[Law]) -> None:
        """Follow the path under other input laws from now on (a new command)."""
        self.eq = self.eq.with_potential(self.eq.potential.with_laws(laws))
        self.locator = EventLocator(self.eq)

    @property
    def potential(self) -> TotalPotential:
        return self.eq.potential

    # -- pieces -------------------------------------------------------------------------------------
    def start(self, t: float, q: Sequence[float], bits: int) -> None:
        """Begin a path piece at ``(t, q)`` (a zero-length segment)."""
        self.bits = bits
        free = MODE_FREE[bits]
        self.head = self.eq.point(list(q), t)
        v = self.eq.tangent(self.head, bits)
        z = self.eq.z(q, t, free)
        self.seg = Segment.of(t, t, list(q), z, z, v, v, 0.0, bits)
        self.pending = None

    def jump(self, t: float, q: Iterable[float], bits: int) -> None:
        """Start at the minimum reached from ``q`` at ``t`` (event ``jump`` if it moved)."""
        q = [float(v) for v in q]
        q_new, new_bits = self.eq.minimise(q, t, bits)
        if max(abs(a - b) for a, b in zip(q_new, q)) > 1e-9 * self.eq.L:
            self.events.append((t, "jump", 0))
        self.start(t, q_new, new_bits)

    def jump_here(self) -> None:
        """After a change of the input laws: start again from the minimum reached from the
        current state."""
        self.jump(self.t, samples.state_at(self.seg, self.t, self.eq.L, self.eq.T), self.bits)

    def equilibrium_now(self) -> tuple[list[float], list[float], list[float], list[float]]:
        """``(q, dq/dt, contact forces, actuator forces)`` at ``t`` (lists)."""
        seg = self.seg
        q = samples.state_at(seg, self.t, self.eq.L, self.eq.T)
        return samples.polish_one(self.eq.potential, self.t, q, seg.bits, not seg.stationary, self.eq.L)

    # -- following the path --------------------------------------------------------------------------
    def advance(self, t_target: float) -> None:
        check_advance_target(self.t, t_target)
        # an event at t_target (to rounding) happens before the state there is seen
        while self.seg.t1 < t_target or (self.pending is not None and self.seg.t1 <= _after(t_target)):
            if self.pending is not None:
                t_e, q_e, bits_e, fired = self.pending
                self.events.extend(fired)
                self.start(t_e, q_e, bits_e)
                continue
            self._path_step()
        self.t = t_target

    def record(self, times: Sequence[float] | NDArray[np.float64], out: list[samples.Block]) -> None:
        """Append blocks ``(times inside one segment, segment)`` for increasing ``times`` to
        ``out``, advancing segment by segment."""
        times = np.asarray(times, dtype=float)
        listed: list[float] = times.tolist()
        i, n = 0, len(listed)
        while i < n:
            self.advance(listed[i])
            if self.pending is None:
                j = bisect_right(listed, self.seg.t1, i)
            else:                                   # a sample at an event's time is after it
                j = bisect_left(listed, self.seg.t1, i, key=_after)
            j = max(j, i + 1)
            out.append((times[i:j], self.seg))
            self.t = listed[j - 1]
            i = j

    def _path_step(self) -> None:
        """One accepted continuation step from the end of the current segment."""
        eq, locator = self.eq, self.locator
        head, z0, v0 = self.head, self.seg.z1, self.seg.v1
        bits = self.bits
        free = MODE_FREE[bits]
        t_stop = next_breakpoint(eq.potential.laws, head.t, math.inf)
        if free == (2,):
            # Both actuators held: beta's balance -Q3(q) = 0 does not involve t, so the
            # configuration stands still; only the contact forces change (release events).
            ds, err = eq.settings.ds_max, None
            end = eq.point(list(head.q), head.t + ds * eq.T)
        else:
            ds, end, err = self._corrected_step(head, z0, v0, bits, t_stop)
        self.counts.steps += 1
        kind = locator.kind(end, bits, t_stop)
        if kind is not None:
            self._close(locator.locate(head, bits, v0, ds, end, kind, t_stop), v0, t_stop)
            return
        if end.t == just_before(t_stop):
            # landed at an input law's breakpoint: the path goes on from there with the law's
            # new piece (a fresh start: tangent and curvature change at the kink)
            self._close(PathEvent("breakpoint", end, frozenset(), *locator.closing_tangent(end, bits, z0, v0)), v0,
                        t_stop)
            return
        v1 = eq.tangent(end, bits, v0)
        self.seg = Segment.of(head.t, end.t, end.q, z0, eq.z(end.q, end.t, free), v0, v1, ds, bits)
        self.head = end
        if err is not None:
            self.ds = ds * min(GROWTH, 0.9 / math.sqrt(max(err, 1e-12)))

    def _corrected_step(self, head: PathPoint, z0: Sequence[float], v0: Sequence[float], bits: int,
                        t_stop: float) -> tuple[float, PathPoint, float | None]:
        """Predictor and corrector with step control: ``(ds, end point, error ratio)``. The
        predictor is ``z + ds v + ds^2 / 2 kappa`` with the curvature ``kappa`` estimated from
        the tangents' change over the last step (none at a path's start). A prediction past
        the next breakpoint ``t_stop`` of an input law is cut there and corrected at the time
        just before it (Newton would not converge across the kink), the step ending there
        (error ratio ``None``)."""
        eq = self.eq
        T, ds_max = eq.T, eq.settings.ds_max
        free = MODE_FREE[bits]
        seg = self.seg
        kappa = [(a - b) / seg.ds for a, b in zip(seg.v1, seg.v0)] if seg.ds > 0 else [0.0] * len(v0)
        while True:
            ds = min(self.ds, ds_max)
            zp = [a + ds * (b + 0.5 * ds * c) for a, b, c in zip(z0, v0, kappa)]
            if zp[-1] * T > t_stop > head.t:
                cut = (t_stop / T - z0[-1]) / (zp[-1] - z0[-1])
                q, _ = eq.q_t([a + cut * (b - a) for a, b in zip(z0, zp)], head.q, free)
                end = eq.equilibrium_at(q, just_before(t_stop), bits)
                if end is not None:
                    return ds * cut, end, None
                self.ds = ds * cut / 2
                continue
            q, t = eq.q_t(zp, head.q, free)
            end = eq.correct(q, t, bits, zp, v0)
            if end is None:
                if ds < 1e-14:
                    self._limit(head.t, head.q, "the corrector does not converge")
                self.ds = ds / 4
                continue
            err = max(abs(a - b) for a, b in zip(eq.z(end.q, end.t, free), zp)) / PATH_TOL
            if err > 1.0 and ds > 1e-14:
                self.ds = ds * max(0.2, 0.9 / math.sqrt(err))
                continue
            return ds, end, err

    def _close(self, event: PathEvent, v0: list[float], t_stop: float) -> None:
        """End the segment at ``event`` and queue the path's new start (or stop at a limit
        point). At a breakpoint the path ends just before it and restarts from the minimum
        reached under the law's new piece (event ``jump`` if the state moved: a law that jumps,
        like a series held between samples)."""
        eq = self.eq
        bits = self.bits
        head, p = self.head, event.at
        free = MODE_FREE[bits]
        self.seg = Segment.of(head.t, p.t, p.q, eq.z(head.q, head.t, free), eq.z(p.q, p.t, free), v0,
                              event.tangent, event.ds, bits)
        if event.kind == "limit":
            self._limit(p.t, p.q, "the stiffness d2Pi/dq2 stops being positive definite")
        held = {i for i in (0, 1) if bits >> i & 1}
        fired: list[LoggedEvent] = []
        q_new, t_new = list(p.q), p.t
        if event.kind == "fold":
            for i in event.actuators:
                q_new[i] = 0.0
            held |= event.actuators
            fired = [(p.t, "fold", i) for i in sorted(event.actuators)]
        elif event.kind == "release":
            held -= event.actuators
            fired = [(p.t, "release", i) for i in sorted(event.actuators)]
        elif event.kind == "breakpoint":
            t_new = t_stop
        q_min, new_bits = eq.minimise(q_new, t_new, bits_of(held))
        if event.kind == "breakpoint" and max(abs(a - b) for a, b in zip(q_min, q_new)) > 1e-9 * eq.L:
            fired = [(t_new, "jump", 0)]
        self.pending = (t_new, q_min, new_bits, fired)

    def _limit(self, t: float, q: Sequence[float], why: str) -> NoReturn:
        """Stop the path at ``(t, q)``: the singular configuration when near it, else a limit point."""
        L = self.eq.L
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
