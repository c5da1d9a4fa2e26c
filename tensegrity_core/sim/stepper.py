"""A long-lived integrator: scipy's ``OdeSolver`` stepped directly, with events and restarts.

``solve_ivp`` starts a solver per call; the simulator advances in small slices (the ROS
node: 1 ms at up to 1 kHz) with inputs that change between slices, so it keeps one solver
alive and steps it itself:

- :meth:`Stepper.advance` steps until the current step covers the target time, then
  interpolates with the step's dense output (built only when needed: DOP853's costs three
  extra evaluations);
- after every step the model's event functions are evaluated at the step's end; a sign
  change in the event's direction is located with Brent's method on the dense output
  (as ``solve_ivp`` does) and the step is cut there. A component that starts and ends on
  the same side may still cross zero and come back inside the step (a graze): the distance
  to a hard stop (the fold limit) is minimised on the step's dense output, and a dip deeper
  than the position tolerance ``atol`` is located (a shallower one cannot be told from the
  interpolant's error: the integration holds a length near zero only to ``atol``); any
  other function is checked where the cubic Hermite interpolant of its end values and rates
  dips (:mod:`~tensegrity_core.sim.event_location`). The located time is the first at which
  the component is on its new side, so the model's discrete change applies to a state
  where it holds;
- progress: a graze whose handling changes nothing (the same contact mode, and no event
  logged or the function's value and rate back where they were at its step's start: an
  actuator lifting off, caught by a wiggle of the interpolant at rest speed and left at
  rest on the stop) would be found again by the restarted integration, without end: that
  component's grazes are not looked for again before the end of that step. Any other
  handled crossing changed the motion (a bounce, a mode change, a string going slack). A
  sign change between two step ends is always located: the accepted solution crossed;
- an event is applied when the integration goes past it: the model returns the state and
  the system to go on with (impact, contact mode, re-charting) and what to log, and the
  solver restarts there. Until then the step's dense output and the old system describe
  the state at any time up to the event, so ``advance`` to a time before it, a sample, or
  a copy see the motion as it was integrated. A re-charting of the coordinates after an
  accepted step is handled the same way, at the step's end;
- the solver restarts at input breakpoints (its ``t_bound`` is the next one) and when an
  input changed (:meth:`change_system`): the model re-resolves its discrete state under the
  new inputs (a contact that must let go now). A restart keeps the last step size, so it
  costs no initial-step search (except LSODA, see ``FRESH_START``). After an input change
  the first solver ends at the target of the next :meth:`advance` (the ROS node's pattern:
  a new command every tick): a step past it would be thrown away at the next change, after
  paying for its dense output to interpolate the target.

The state at any time between the last restart and the end of the current step is
available; the solver never steps past a pending event.

What is integrated is an :class:`OdeSystem`: a model's equations with its discrete state
(contact mode, rotation charts) and its input laws fixed. An event, a re-charting or an
input change returns a :class:`Transition` to the system of the new discrete state. The
stepper is the integrator of a :class:`~tensegrity_core.sim.model.State`: it
writes the located events into the state's event log.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Generic, NamedTuple, Protocol, Self, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, OdeSolver, Radau

from tensegrity_core.errors import TensegrityError
from tensegrity_core.events import EventKind, LoggedEvent
from tensegrity_core.sim import integrators
from tensegrity_core.sim.errors import SimulationError, check_advance_target
from tensegrity_core.sim.event_location import Crossing, StateEvent, candidates, dips, event_values, locate
from tensegrity_core.sim.interpolants import Constant, Interpolant, LazyDense

FloatArray = NDArray[np.float64]
#: ``jac(t, y)``: a dense (n, n) array or a scipy.sparse matrix (which has no type information).
Jacobian = Callable[[float, FloatArray], Any]

SOLVERS: dict[str, type[OdeSolver]] = {"RK23": RK23, "RK45": RK45, "DOP853": DOP853, "Radau": Radau, "BDF": BDF,
                                       "LSODA": LSODA, "RK4": integrators.RK4}
#: Solvers that run a whole step in one call of a system's compiled ``stages`` where the
#: system offers them for the method (:mod:`tensegrity_core.sim.integrators`; general models).
COMPILED_SOLVERS: dict[str, type[OdeSolver]] = {"RK4": integrators.RK4, "DOP853": integrators.DOP853}
#: Methods that use a Jacobian.
IMPLICIT = ("Radau", "BDF", "LSODA")
#: Methods that choose their own first step after a restart: LSODA restarts in its
#: non-stiff (Adams) mode, which cannot take the step its stiff mode had reached (the stiff
#: fold failed with "repeated convergence failures" right after its first fold event).
FRESH_START = ("LSODA",)
#: How many times a failing step is retried with a smaller first step.
MAX_RETRIES = 30


#: The system type a transition leads to.
T_co = TypeVar("T_co", covariant=True)


class Transition(NamedTuple, Generic[T_co]):
    """What a discrete change does: the state ``y`` to go on from, the ``system`` of the new
    discrete state, and the events to log at that instant as ``(kind, index)``."""

    y: FloatArray
    system: T_co
    log: tuple[tuple[EventKind, int], ...] = ()


class OdeSystem(Protocol):
    """What :class:`Stepper` integrates between restarts: ``dy/dt = fun(t, y)`` with its
    discrete state and input laws fixed.

    ``mode`` is the contact mode (the actuators held at zero length; empty without contacts);
    ``jac`` is ``jac(t, y)`` (dense or sparse) or None (implicit methods then difference);
    ``events()`` the state events to watch; ``handle_event(crossing, y)`` applies one located
    at ``crossing.t`` where the state is ``y``; ``after_step(t, y)`` may re-chart the
    coordinates after an accepted step, or return None; ``resume(t, y)`` re-resolves the
    discrete state where the input laws change (a new command, a breakpoint: a contact that
    must let go); ``next_breakpoint(t)`` is the first time after ``t`` where an input law is
    not smooth (the solver restarts there). The three transitions are applied by the stepper
    only; each returns the system of the new discrete state. A system may also offer ``stages``
    (:class:`~tensegrity_core.sim.integrators.Stages`, or None): whole steps in compiled
    code, which the methods of :data:`COMPILED_SOLVERS` then use."""

    @property
    def mode(self) -> frozenset[int]: ...

    @property
    def jac(self) -> Jacobian | None: ...

    def fun(self, t: float, y: FloatArray) -> FloatArray: ...

    def events(self) -> Sequence[StateEvent]: ...

    def handle_event(self, crossing: Crossing, y: FloatArray) -> Transition[Self]: ...

    def after_step(self, t: float, y: FloatArray) -> Transition[Self] | None: ...

    def resume(self, t: float, y: FloatArray) -> Transition[Self]: ...

    def next_breakpoint(self, t: float) -> float: ...


#: The system a stepper integrates (each event or restart gives another of the same type).
Sys = TypeVar("Sys", bound=OdeSystem)


class _Graze(NamedTuple):
    """Where a graze was found: the end ``step_end`` [s] of its step, and its component's
    ``value`` and ``rate`` (nan if unknown) at the step's start."""

    step_end: float
    value: float
    rate: float


@dataclass(frozen=True)
class _Pending(Generic[Sys]):
    """A discrete change at time ``t`` that the integration has reached but not yet gone past:
    a located ``crossing``, or a re-charting's ``transition`` at a step's end. A crossing
    that is a graze (its component on the old side at both ends of its step) has ``graze``."""

    t: float
    crossing: Crossing | None = None
    transition: Transition[Sys] | None = None
    graze: _Graze | None = None


def _dense_jacobian(jac: Jacobian) -> Jacobian:
    """LSODA (ODEPACK) takes only dense Jacobians; the general models return sparse ones
    (a sparse Jacobian crashed LSODA as soon as it switched to its stiff method)."""
    def dense(t: float, y: FloatArray) -> Any:
        J = jac(t, y)
        return J.toarray() if hasattr(J, "toarray") else J
    return dense


class Stepper(Generic[Sys]):
    """Integrates ``system.fun`` from ``(t0, y0)`` on demand.

    ``system`` is an :class:`OdeSystem` (of type ``Sys`` in ``Stepper[Sys]``); ``t_end`` bounds
    the integration (``inf``: open-ended); located events are appended to ``log`` as
    ``(t, kind, index)``.
    """

    def __init__(self, system: Sys, t0: float, y0: ArrayLike, *, method: str, rtol: float, atol: float,
                 max_step: float = math.inf, t_end: float = math.inf, log: list[LoggedEvent] | None = None):
        if method not in SOLVERS:
            raise SimulationError(f"unknown integration method {method!r}; use one of {', '.join(SOLVERS)}")
        self.system = system
        self.method = method
        self.options = dict(rtol=rtol, atol=atol, max_step=max_step)
        self.t_end = t_end
        self.solver: OdeSolver | None = None
        self._nfev_done = 0
        self.n_steps = 0
        self.n_restarts = 0
        self.n_events = 0
        self.event_log: list[LoggedEvent] = [] if log is None else log
        self._h: float | None = None
        self._to_target = False       # the next solver ends at the advance target
        self._cut_short = False       # the current solver's bound is an advance target
        # event components (kind, index) whose last graze changed nothing: no graze of theirs
        # is looked for before the end [s] of the step it was found in (module docstring)
        self._spent: dict[tuple[EventKind, int], float] = {}
        # set by restart: the state at t, the current step [t0, t1] and its dense output, the
        # discrete change reached at t1 (applied at the next advance past it), the events
        # watched and their values and rates at t0
        self.t: float
        self.y: FloatArray
        self._seg: tuple[float, float]
        self._dense: Interpolant
        self._pending: _Pending[Sys] | None
        self._events: Sequence[StateEvent]
        self._g: list[tuple[FloatArray, FloatArray | None]]
        self.restart(t0, y0)

    def copy(self, log: list[LoggedEvent]) -> Stepper[Sys]:
        """A stepper at the same ``(t, y)`` with the same system, counters and step size,
        logging into ``log``. It starts a fresh solver at ``t`` (as after an event), so it
        agrees with this one to the integration tolerance, not bit for bit; a discrete change
        reached but not yet applied (an event, a re-charting) is kept, with the step's dense
        output up to it, and applied at the copy's next advance past it, as here."""
        new = Stepper.__new__(Stepper)
        new.__dict__.update(self.__dict__)
        new.event_log = log
        new._spent = dict(self._spent)
        new.solver = None
        new._nfev_done = self.nfev
        if self._pending is None:
            new.restart(self.t, self.y, input_changed=self._to_target)
        return new

    # -- state ------------------------------------------------------------------------------
    @property
    def nfev(self) -> int:
        return self._nfev_done + (int(self.solver.nfev) if self.solver is not None else 0)

    @property
    def mode(self) -> frozenset[int]:
        """The contact mode of the system being integrated."""
        return self.system.mode

    @property
    def _floor(self) -> float:
        """The depth [m] a hard stop's dip must pass to be located: the integration's position
        tolerance near zero (its absolute tolerance; the largest if given per component)."""
        return float(np.max(self.options["atol"]))

    @property
    def t_integrated(self) -> float:
        """How far the integration has gone [s] (``>= t``: the current step may reach past it)."""
        return self._seg[1]

    def restart(self, t: float, y: ArrayLike, *, system: Sys | None = None,
                input_changed: bool = False) -> None:
        """Start a fresh solver at ``(t, y)``, with a new ``system`` if given, as it is (the
        caller has resolved its discrete state; :meth:`change_system` does that for new
        inputs). After an input change the first solver ends at the next :meth:`advance` target."""
        y = np.array(y, dtype=float)
        if self.solver is not None:
            self._nfev_done += self.solver.nfev
        if system is not None:
            self.system = system
        self.t = t
        self.y = y
        self._seg = (t, t)
        self._dense = Constant(y)
        self._pending = None
        self.solver = None
        self.n_restarts += 1
        self._events = self.system.events()
        self._g = [event_values(ev, t, y) for ev in self._events]
        self._to_target = input_changed

    def change_system(self, system: Sys, *, input_changed: bool = True) -> None:
        """Go on from the current time with ``system`` (new input laws): a discrete change
        reached at this very instant is applied first, then the new system re-resolves its
        discrete state here (:meth:`OdeSystem.resume`, logged) and a fresh solver starts."""
        if self._pending is not None and self._pending.t <= self.t:
            self._fire()
        self._resume(self.t, self.y, system, input_changed=input_changed)

    def _resume(self, t: float, y: FloatArray, system: Sys, *, input_changed: bool = False) -> None:
        self._spent.clear()           # new input laws: what changed nothing may change something now
        transition = system.resume(t, y)
        self._log(t, transition.log)
        self.restart(t, transition.y, system=transition.system, input_changed=input_changed)

    def _log(self, t: float, entries: Sequence[tuple[EventKind, int]]) -> None:
        self.event_log.extend((t, kind, index) for kind, index in entries)
        self.n_events += len(entries)

    def _new_solver(self, t_target: float) -> OdeSolver:
        t0 = self._seg[1]
        y0 = self._dense(t0)
        system = self.system
        bound = min(system.next_breakpoint(t0), self.t_end)
        if not bound > t0:
            bound = self.t_end
        self._cut_short = self._to_target and t0 < t_target < bound
        if self._cut_short:
            bound = t_target
        self._to_target = False
        first = None
        if self._h is not None and self.method not in FRESH_START:
            first = min(self._h, bound - t0, self.options["max_step"])
        options: dict[str, Any] = dict(self.options)
        if self.method in IMPLICIT and system.jac is not None:
            options["jac"] = _dense_jacobian(system.jac) if self.method == "LSODA" else system.jac
        cls = SOLVERS[self.method]
        stages = getattr(system, "stages", None)      # optional: see OdeSystem
        if stages is not None and self.method in COMPILED_SOLVERS and self.method in stages.methods:
            cls = COMPILED_SOLVERS[self.method]
            options["stages"] = stages
        solver = cls(system.fun, t0, y0, bound, first_step=first, **options)
        self.solver = solver
        return solver

    # -- stepping ------------------------------------------------------------------------------
    def advance(self, t_target: float) -> None:
        """Integrate until ``t_target`` is covered; then ``self.t, self.y`` are the state there."""
        check_advance_target(self.t, t_target)
        if t_target > self.t_end * (1 + 1e-12) + 1e-12:
            raise SimulationError(f"target {t_target!r} s is beyond the end {self.t_end!r} s", t=self.t)
        t_target = min(t_target, self.t_end)      # within rounding of the end: the end itself
        while self._seg[1] < t_target:
            if self._pending is not None:
                self._fire()
                continue
            solver = self.solver
            if solver is None or solver.status != "running":
                if solver is not None and solver.status == "failed":
                    raise SimulationError(f"integrator failed at t = {solver.t!r} s: {solver.message}", t=solver.t)
                if solver is not None and self._cut_short:    # ended at the last target: go on
                    self._nfev_done += solver.nfev
                elif solver is not None:                      # reached a breakpoint
                    self._resume(solver.t, solver.y, self.system)
                solver = self._new_solver(t_target)
            self._step(solver, t_target)
        self.t = t_target
        self.y = self._dense(t_target) if t_target < self._seg[1] or self._pending is not None \
            else self._end_state()
        return None

    def _end_state(self) -> FloatArray:
        if self.solver is not None and self.solver.t == self._seg[1]:
            y: FloatArray = self.solver.y.copy()
            return y
        return self._dense(self._seg[1])

    def _step(self, solver: OdeSolver, t_target: float) -> None:
        """One step, or with a :class:`~tensegrity_core.sim.integrators.StretchSolver` the
        steps up to the one that covers ``t_target`` or may hold an event or a re-charting
        (the steps before it hold none): the events and re-charting are checked on that last one."""
        t_old, y_old = solver.t, solver.y.copy()
        for attempt in range(MAX_RETRIES + 1):
            try:
                if isinstance(solver, integrators.StretchSolver):
                    solver.horizon = t_target
                message = solver.step()
                break
            except TensegrityError as err:
                # A trial stage left the model's domain: retry from the last accepted state
                # with a smaller step (events stop the integration before real trouble).
                if attempt == MAX_RETRIES:
                    raise SimulationError(f"integration cannot continue past t = {t_old:.9g} s: {err}",
                                          t=t_old) from None
                h = (self._h or abs(self.t_end - t_old) or 1e-3) / 8.0
                self._h = h
                self._nfev_done += solver.nfev
                self._seg = (t_old, t_old)
                self._dense = Constant(y_old)
                solver = self._new_solver(self.t_end)
        if solver.status == "failed":
            raise SimulationError(f"integrator failed at t = {solver.t:.9g} s: {message}", t=solver.t)
        stretch = isinstance(solver, integrators.StretchSolver)
        self.n_steps += solver.steps_taken if stretch else 1
        if stretch and solver.steps_taken > 1:      # the stretch's last step is the one to check
            t_old, y_old = solver.t_start, solver.y_start
            self._g = [event_values(ev, t_old, y_old) for ev in self._events]
        size = abs(solver.t - t_old)
        if self._cut_short and solver.t == solver.t_bound:
            # cut at the target: keep the step-size controller's own proposal, not the cut
            size = getattr(solver, "h_abs", size)
        self._h = size if size else self._h
        t_new, y_new = solver.t, solver.y
        g_new = [event_values(ev, t_new, y_new) for ev in self._events]
        dense: Interpolant | None = None
        hit: Crossing | None = None
        graze: _Graze | None = None
        spent = {key: end for key, end in self._spent.items() if end > t_old}
        self._spent = spent
        for ev, (g0, r0), (g1, r1) in zip(self._events, self._g, g_new):
            rates0 = np.full_like(g0, np.nan) if r0 is None else r0
            found = candidates(ev.direction, g0, r0, g1, r1, t_old, t_new, dense_dips=ev.hard_stop)
            if not found:
                continue
            if dense is None:
                dense = solver.dense_output()
            for k, falling, t_hi in found:
                lo = t_old
                dip = t_hi != t_new
                if dip:                       # a graze: from where it may be looked for again
                    lo = max(t_old, spent.get((ev.kind, ev.indices[k]), t_old))
                if t_hi is None and lo < t_new:  # a hard stop: decided on the dense output
                    t_hi = next((t for _, _, t in dips(ev, [(k, falling)], dense, lo, t_new, self._floor)), None)
                if t_hi is None or t_hi <= lo:
                    continue
                te = locate(ev, k, falling, dense, lo, t_hi)
                if te is not None and (hit is None or te < hit.t):
                    hit = Crossing(float(te), ev, k, falling)
                    graze = _Graze(t_new, float(g0[k]), float(rates0[k])) if dip else None
        self._g = g_new
        if hit is not None and dense is not None:       # (a hit has computed the dense output)
            self._seg = (t_old, hit.t)
            self._dense = dense
            self._pending = _Pending(hit.t, crossing=hit, graze=graze)
            return
        self._seg = (t_old, t_new)
        self._dense = LazyDense(solver) if dense is None else dense
        moved = self.system.after_step(t_new, y_new)
        if moved is not None:
            self._pending = _Pending(t_new, transition=moved)

    def _fire(self) -> None:
        """Apply the pending discrete change and restart after it."""
        pending = self._pending
        assert pending is not None
        crossing = pending.crossing
        if crossing is not None:
            try:
                transition = self.system.handle_event(crossing, self._dense(pending.t))
            except SimulationError:           # the event stops the run (a singular set): it is logged
                self._log(pending.t, ((crossing.kind, crossing.index),))
                raise
            if pending.graze is not None and self._changes_nothing(crossing, pending.graze, transition):
                self._spent[(crossing.kind, crossing.index)] = pending.graze.step_end
        else:
            assert pending.transition is not None
            transition = pending.transition
        self._log(pending.t, transition.log)
        self.restart(pending.t, transition.y, system=transition.system)

    def _changes_nothing(self, crossing: Crossing, graze: _Graze, transition: Transition[Sys]) -> bool:
        """Whether handling the graze ``crossing`` by ``transition`` changed nothing (module
        docstring): the same contact mode, and no event logged or the crossing's value and rate
        where they were at the start of its step (to the integration's tolerances)."""
        if transition.system.mode != self.system.mode:
            return False
        if not transition.log:
            return True
        g, r = event_values(crossing.event, crossing.t, transition.y)
        now = np.array([g[crossing.component], math.nan if r is None else r[crossing.component]])
        return bool(np.allclose(now, [graze.value, graze.rate], rtol=self.options["rtol"], atol=self._floor,
                                equal_nan=True))

    def record(self, times: Sequence[float] | FloatArray, out: list[tuple[float, FloatArray, Sys]]) -> None:
        """Append ``(t, y, system)`` for increasing ``times`` to ``out``: advance to each time,
        and interpolate every time the current step covers in one vectorised call (the system
        -- its contact mode, its charts -- is constant within a step). A stretch solver takes
        the times its quiet steps cover in compiled code, with the same numbers."""
        i, n = 0, len(times)
        samples = np.ascontiguousarray(times, dtype=float)
        while i < n:
            i = self._record_stretch(samples, i, out)
            if i == n:
                break
            self.advance(float(times[i]))
            j = i + 1
            while j < n and times[j] <= self._seg[1]:
                j += 1
            ts = np.asarray(times[i:j], dtype=float)
            system = self.system
            if j - i == 1:
                out.append((float(ts[0]), self.y.copy(), system))
            else:
                Y = self._dense(ts)
                out.extend((float(t), Y[:, k].copy(), system) for k, t in enumerate(ts))
                self.t, self.y = float(ts[-1]), Y[:, -1].copy()
            i = j


    def _record_stretch(self, times: FloatArray, i: int, out: list[tuple[float, FloatArray, Sys]]) -> int:
        """With a :class:`~tensegrity_core.sim.integrators.StretchSolver` running past the
        current step: one stretch towards the last of ``times``, its samples at ``times[i:]``
        appended to ``out`` (the same states :meth:`record` takes one by one); the index of
        the first time left (``i`` if none was taken)."""
        solver = self.solver
        if not (isinstance(solver, integrators.StretchSolver) and solver.status == "running"
                and self._pending is None and self._seg[1] < times[i]):
            return i
        check_advance_target(self.t, float(times[i]))
        solver.samples, solver.sample = times, i
        try:
            self._step(solver, min(float(times[-1]), self.t_end))
        finally:
            solver.samples, solver.sample = integrators.StretchSolver.samples, 0
        if solver.sampled is None:
            return i
        first, last, Y = solver.sampled
        system = self.system            # the steps before the stretch's last one hold no discrete change
        out.extend((float(times[k]), Y[k].copy(), system) for k in range(first, last))
        self.t, self.y = float(times[last - 1]), Y[last - 1].copy()
        return last

