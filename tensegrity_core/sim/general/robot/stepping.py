"""The fixed-step integrator of robot scenes: a 1 kHz loop in compiled code.

A robot's motors and friction anchors are **sampled** elements: their states change once
per physics step (:func:`tensegrity_core.sim.general.robot.loops.sampled_update`), so a robot is
integrated on a fixed grid ``t_n = n h`` (``h`` the scene's ``integrator.max_step``, 1 ms by
default) with the classical RK4, as MuJoCo steps its models, and the motors' inputs are
sampled at each step's start. :class:`FixedStepper` keeps the state ``y_n`` at the last grid
point reached and runs whole stretches of steps in one kernel call (no Python per step:
the scipy-style stepper of :mod:`tensegrity_core.sim.stepper` costs more per step in Python
than a robot's step costs in compiled code).

A target between two grid points is reached by computing the next step ahead (kept, not
redone) and interpolating with cubic Hermite polynomials from both ends' states and rates,
in that step's rotation charts (the sampled entries are constant within a step). A command
given at ``t`` acts from the first step that starts at or after ``t``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.events import LoggedEvent
from tensegrity_core.sim.errors import SimulationError, check_advance_target
from tensegrity_core.sim.general.robot.system import RobotEvaluation, RobotSystem, empty_evaluation

FloatArray = NDArray[np.float64]
#: What an observation needs of one state: ``(t [s], y, the system of its charts and inputs)``.
RobotSample = tuple[float, FloatArray, RobotSystem]
#: Steps per kernel call (bounds the motor targets' array: this many rows).
CHUNK = 2000
#: A time within this fraction of a step of a grid point is on it.
ON_GRID = 1e-9


@dataclass(frozen=True)
class _Ahead:
    """The step from grid point ``n`` computed ahead: its result ``y`` and charts ``R_ref``
    after the sampled update, and ``y_end`` before it (in the step's own charts)."""

    n: int
    y: FloatArray
    R_ref: FloatArray
    y_end: FloatArray


class FixedStepper:
    """Integrates ``system`` from ``y0`` at ``t = 0`` in fixed steps of ``h`` [s] up to
    ``t_end`` (see the module docstring); the integrator of a robot's
    :class:`~tensegrity_core.sim.model.State` (``log``: its event list; robots log none)."""

    def __init__(self, system: RobotSystem, y0: FloatArray, h: float, *, t_end: float = math.inf,
                 log: list[LoggedEvent] | None = None):
        self.system = system
        self.h = float(h)
        self.t_end = t_end
        self.event_log: list[LoggedEvent] = [] if log is None else log
        self.n = 0
        self.y_grid = np.array(y0, dtype=float)
        self.t = 0.0
        self.y = self.y_grid
        self.n_steps = 0
        self._ahead: _Ahead | None = None
        self._aims: tuple[RobotSystem, int, FloatArray] | None = None
        self._scratch: RobotEvaluation | None = None
        # the grid state ``_end[0]`` (an array never changed in place) evaluated by the kernel
        # call that reached it (``_end[1]``): the observation of a step's end without a second
        # evaluation
        self._end: tuple[FloatArray, RobotEvaluation] | None = None
        self._end_buffer: RobotEvaluation | None = None

    @property
    def mode(self) -> frozenset[int]:
        return frozenset()

    @property
    def nfev(self) -> int:
        return 4 * self.n_steps

    @property
    def t_integrated(self) -> float:
        """How far the integration has gone [s]."""
        return (self.n + (self._ahead is not None)) * self.h

    def copy(self, log: list[LoggedEvent]) -> FixedStepper:
        """An independent integrator at the same point (its state arrays are never changed in
        place, so they are shared): continuing it gives the same numbers as continuing this one."""
        new = FixedStepper.__new__(FixedStepper)
        new.__dict__.update(self.__dict__)
        new.event_log = log
        new._scratch = None
        new._end = None
        new._end_buffer = None
        return new

    def evaluation(self) -> RobotEvaluation:
        """The state ``y`` evaluated (:meth:`RobotSystem.evaluate`, a batch of one) into
        arrays this integrator reuses: valid until the next call or step (callers copy what
        they keep). At the grid point the last steps reached, their kernel call's evaluation
        of it (the same numbers)."""
        if self._end is not None and self._end[0] is self.y:
            return self._end[1]
        if self._scratch is None:
            self._scratch = empty_evaluation(self.system.plan, 1)
        return self.system.evaluate(self.y[None, :], out=self._scratch)

    def command(self, system: RobotSystem) -> None:
        """Integrate under ``system`` (new input laws, the same charts) from the first step
        that starts at or after ``t``."""
        if self._ahead is not None and self._grid_index(self.t)[1]:
            self._ahead = None                   # the step ahead starts now: it takes the command
        self.system = system.with_chart(self.system.R_ref)

    def aims(self, n: int, k: int) -> FloatArray:
        """(k, motors) the motors' targets [m] at the starts of steps ``n .. n + k - 1``: the
        input laws evaluated ahead and kept until the inputs change (a law's evaluation costs
        far more than a step). Under new inputs ``k`` rows are evaluated, and twice as many
        as the last time (up to :data:`CHUNK`) each time the same inputs run out, so a
        command per step costs one row and free running a fraction of a row per step."""
        cached = self._aims
        same = cached is not None and cached[0].same_inputs(self.system)
        if cached is None or not same or not cached[1] <= n or n + k > cached[1] + len(cached[2]):
            rows = max(k, min(2 * len(cached[2]), CHUNK)) if cached is not None and same else k
            times: FloatArray = (n + np.arange(rows, dtype=np.float64)) * self.h
            cached = self._aims = (self.system, n, self.system.aims(times))
        out: FloatArray = cached[2][n - cached[1]:n - cached[1] + k]
        return out

    def _grid_index(self, t: float) -> tuple[int, bool]:
        """``(n, on)``: the last grid point at or before ``t`` and whether ``t`` is on it."""
        x = t / self.h
        n = math.floor(x + ON_GRID)
        return n, abs(x - n) <= ON_GRID

    def _run(self, steps: int) -> None:
        """Commit ``steps`` whole steps from the grid point."""
        while steps > 0:
            if self._ahead is not None:
                a = self._ahead
                self._ahead = None
                self._commit(a.y, a.R_ref, 1)
                steps -= 1
                continue
            k = min(steps, CHUNK)
            if self._end_buffer is None:
                self._end_buffer = empty_evaluation(self.system.plan, 1)
            self._end = None
            y, R, _ = self.system.run(self.y_grid, self.system.R_ref, self.h, self.aims(self.n, k),
                                      out=self._end_buffer)
            self._commit(y, R, k)
            self._end = (y, self._end_buffer)
            steps -= k

    def _commit(self, y: FloatArray, R_ref: FloatArray, steps: int) -> None:
        if not np.isfinite(y).all():
            raise SimulationError(f"the state stopped being finite between t = {self.n * self.h:.9g} s and "
                                  f"{(self.n + steps) * self.h:.9g} s (a step of {self.h:g} s is too long for "
                                  f"this robot's stiffest mode)", t=self.n * self.h)
        self.n += steps
        self.n_steps += steps
        self.y_grid = y
        # the kernel changes the charts' bytes only when it re-charts a body
        if R_ref.tobytes() != self.system.R_ref.tobytes():
            self.system = self.system.with_chart(R_ref)

    def advance(self, t_target: float) -> None:
        """Integrate to ``t_target`` [s]; then ``t``, ``y`` are the state there."""
        check_advance_target(self.t, t_target)
        if t_target > self.t_end * (1 + 1e-12) + 1e-12:
            raise SimulationError(f"target {t_target!r} s is beyond the end {self.t_end!r} s", t=self.t)
        n, on = self._grid_index(t_target)
        if n > self.n:
            self._run(n - self.n)
        self.t = t_target
        if on:
            self.y = self.y_grid
            return
        if self._ahead is None:
            y, R, y_end = self.system.run(self.y_grid, self.system.R_ref, self.h, self.aims(self.n, 1))
            self._ahead = _Ahead(self.n, y, R, y_end)
        self.y = self._interpolate(t_target, self._ahead)

    def _interpolate(self, t: float, ahead: _Ahead) -> FloatArray:
        """Cubic Hermite interpolation over the step ahead at ``t`` [s] (in its charts)."""
        h = self.h
        y0, y1 = self.y_grid, ahead.y_end
        f0, f1 = self.system.fun(self.n * h, y0), self.system.fun((self.n + 1) * h, y1)
        x = (t - self.n * h) / h
        dy, a, b = y1 - y0, h * f0, h * f1
        out: FloatArray = y0 + x * (a + x * ((3.0 * dy - 2.0 * a - b) + x * (a + b - 2.0 * dy)))
        return out

    def record(self, times: Sequence[float] | FloatArray, out: list[RobotSample]) -> None:
        """Append ``(t, y, system)`` for increasing ``times`` to ``out``, advancing to each."""
        for t in times:
            self.advance(float(t))
            out.append((self.t, self.y.copy(), self.system))
