"""Explicit integrators whose stages run in compiled code: fixed-step RK4 and adaptive DOP853.

scipy's solvers (``solve_ivp``'s ``RK45``, ``DOP853``, ...) run every stage in Python:
about 5 us of numpy per stage and 20-50 us per step, where a compiled right-hand side of a
tensegrity costs 1-3 us. No maintained library steps a numba-compiled system one step at a
time with dense output and restarts, as the :class:`~tensegrity_core.sim.stepper.Stepper`
needs (numbalsoda integrates whole spans without dense output or events), so these two
solvers are written here as scipy ``OdeSolver`` subclasses: the stepper drives them like
scipy's, while a system's :class:`Stages` compute each whole step -- all stages, the error
estimate -- in one compiled call. Where the system's inputs are constant, one call of
``step()`` runs a whole **stretch** of steps in compiled code (:class:`StretchSolver`): as
far as the stepper's next target (:attr:`StretchSolver.horizon`: a record time, the end
of an ``advance``), stopping early at the first step that may hold a discrete change of the
system (a string going slack or taut, a rotation chart due for re-anchoring), which the
stepper then checks and locates as after any step. The steps are exactly those of one step
per call (same sizes, same arithmetic); only the Python between them is gone, about half
of a step's cost on a structure of a few dozen members.

- :class:`RK4`: the classical fourth-order method with a fixed step ``max_step`` [s] (the
  sampled-data choice of a ROS simulator: a 1 ms tick is one or a few steps), shortened only
  to land on the solver's bound (the end, an input breakpoint); dense output by cubic Hermite interpolation between the
  step's ends (third order), whose end rate is the next step's first stage (4 evaluations
  per step). No error control: its error is stated against a converged reference in
  docs/design/performance.md.
- :class:`DOP853`: Dormand and Prince's 8(5,3) pair with step-size control (Hairer,
  Norsett & Wanner, Solving ODEs I, Sect. II.10) and its seventh-order dense output, the
  method of scipy's ``DOP853`` with scipy's coefficient tables; it needs compiled stages.

Without compiled stages (a system that offers none) ``RK4`` runs its stages through the
system's ``fun`` and ``DOP853`` is scipy's; stages that compute RK4 steps only (the numpy
kernels' stretches) leave ``DOP853`` to scipy.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import DenseOutput, OdeSolver
from scipy.integrate._ivp.common import select_initial_step
from scipy.integrate._ivp.rk import Dop853DenseOutput

from tensegrity_core.sim.errors import SimulationError

FloatArray = NDArray[np.float64]

#: Step-size control of :class:`DOP853`: safety factor and bounds of the change per step.
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0


class Run(NamedTuple):
    """A stretch of steps computed in one call: ``steps`` accepted (``attempts`` DOP853
    attempts in all), the last one from ``(t_start, y_start)`` (rate ``f_start``) to
    ``(t_end, y_end)`` (rate ``f_end``) [s]; DOP853's stages ``K`` of that step and its next
    step proposal ``h_abs`` [s]; ``failed``: DOP853's next step fell below the rounding of
    ``t_end`` (the state there is ``y_end``). The states at the sample times the steps
    before the last one cover are the rows of ``Y`` up to ``sampled`` (the index of the
    first time left); ``dense``: how many DOP853 dense outputs that took (3 evaluations each)."""

    steps: int
    attempts: int
    t_start: float
    y_start: FloatArray
    f_start: FloatArray
    t_end: float
    y_end: FloatArray
    f_end: FloatArray
    K: FloatArray | None = None
    h_abs: float = 0.0
    failed: bool = False
    sampled: int = 0
    Y: FloatArray | None = None
    dense: int = 0


class Stages(Protocol):
    """A system's steps computed whole (compiled): ``rk4(t, y, f, h) -> (y_new, f_new)`` with
    ``f``, ``f_new`` the rates at both ends; ``dop853(t, y, f, h, rtol, atol) -> (y_new, K,
    error)`` with ``K`` (16, N) the stages (row 12: the rate at ``y_new``) and the step's
    error norm (< 1: accept); ``dop853_dense(t, y, y_new, K, h) -> F`` (7, N), the dense
    output's coefficients (it fills ``K``'s last three rows).

    Where ``constant`` (the system's inputs do not depend on ``t``), whole stretches of steps
    in one call: ``rk4_run(t, y, f, h, t_bound, horizon)`` and ``dop853_run(t, y, f, t_bound,
    horizon, h_abs, max_step, rtol, atol, (safety, min_factor, max_factor))`` take the steps
    the one-step methods would take, one after the other, until a step ends at or past
    ``horizon`` or ``t_bound`` or may hold one of the system's discrete changes (its events,
    a re-charting), and return that last step as a :class:`Run`, with the states at the
    times ``samples[sample:]`` [s] the steps before it cover (the stepper's samples: the end
    state of a step that ends exactly at its only sample, else the dense output).
    ``methods``: the solvers (names of :data:`~tensegrity_core.sim.stepper.COMPILED_SOLVERS`)
    whose steps it computes."""

    methods: tuple[str, ...]

    @property
    def constant(self) -> bool: ...

    def rk4(self, t: float, y: FloatArray, f: FloatArray, h: float) -> tuple[FloatArray, FloatArray]: ...

    def dop853(self, t: float, y: FloatArray, f: FloatArray, h: float, rtol: float,
               atol: float) -> tuple[FloatArray, FloatArray, float]: ...

    def dop853_dense(self, t: float, y: FloatArray, y_new: FloatArray, K: FloatArray, h: float) -> FloatArray: ...

    def rk4_run(self, t: float, y: FloatArray, f: FloatArray, h: float, t_bound: float, horizon: float,
                samples: FloatArray, sample: int) -> Run: ...

    def dop853_run(self, t: float, y: FloatArray, f: FloatArray, t_bound: float, horizon: float, h_abs: float,
                   max_step: float, rtol: float, atol: float, control: tuple[float, float, float],
                   samples: FloatArray, sample: int) -> Run: ...


class HermiteDense(DenseOutput):  # type: ignore[misc]  # scipy is untyped
    """Cubic Hermite interpolation over ``[t_old, t]`` from both ends' states and rates."""

    def __init__(self, t_old: float, t: float, y_old: FloatArray, y: FloatArray, f_old: FloatArray, f: FloatArray):
        super().__init__(t_old, t)
        self.h = t - t_old
        self.y_old, self.dy = y_old, y - y_old
        self.hf_old, self.hf = self.h * f_old, self.h * f

    def _call_impl(self, t: FloatArray) -> FloatArray:
        x = (np.asarray(t) - self.t_old) / self.h
        if np.ndim(x):
            x = x[None, :]
            y_old, dy, a, b = (v[:, None] for v in (self.y_old, self.dy, self.hf_old, self.hf))
        else:
            y_old, dy, a, b = self.y_old, self.dy, self.hf_old, self.hf
        # y(x) = y0 + x a + x^2 (3 dy - 2 a - b) + x^3 (a + b - 2 dy), x in [0, 1]
        out: FloatArray = y_old + x * (a + x * ((3.0 * dy - 2.0 * a - b) + x * (a + b - 2.0 * dy)))
        return out


class StretchSolver(OdeSolver):  # type: ignore[misc]  # scipy is untyped
    """A solver whose ``step()`` may take many steps: as many as reach :attr:`horizon` [s]
    (set by the caller before each call; ``-inf``, the default: one step, as scipy's
    solvers), stopping early at a step that may hold a discrete change of the system (its
    :class:`Stages` decide). ``steps_taken`` is how many the last call took, ``t_start``,
    ``y_start`` the start of the last one, whose dense output ``dense_output()`` gives."""

    horizon: float = -math.inf
    steps_taken: int = 0
    t_start: float
    y_start: FloatArray
    #: Sample times [s] (increasing) and the index of the next one, set by the caller: a
    #: stretch fills in the states at those its steps before the last one cover.
    samples: FloatArray = np.zeros(0)
    sample: int = 0
    #: After a call: ``(first, last, Y)``, the states at ``samples[first:last]`` are ``Y[first:last]``.
    sampled: tuple[int, int, FloatArray] | None = None

    def stretch(self, stages: Stages | None) -> bool:
        """Whether this call takes its steps as one compiled stretch."""
        self.sampled = None
        return stages is not None and stages.constant and self.direction > 0

    def _keep_samples(self, run: Run) -> None:
        if run.Y is not None and run.sampled > self.sample:
            self.sampled = (self.sample, run.sampled, run.Y)


class RK4(StretchSolver):
    """Classical Runge-Kutta with fixed steps of ``max_step`` [s] (see the module docstring);
    ``stages``: the system's compiled steps, or None (stages through ``fun``). ``rtol``,
    ``atol`` and ``first_step`` are accepted and not used: nothing is adapted."""

    t: float
    y: FloatArray

    def __init__(self, fun: Any, t0: float, y0: FloatArray, t_bound: float, *, max_step: float = math.inf,
                 stages: Stages | None = None, rtol: float | None = None, atol: float | None = None,
                 first_step: float | None = None, vectorized: bool = False):
        super().__init__(fun, t0, y0, t_bound, vectorized, support_complex=False)
        if not (math.isfinite(max_step) and max_step > 0):
            raise SimulationError("RK4 takes fixed steps of integrator.max_step [s]: give it (e.g. max_step: 0.001)")
        self.h = float(max_step)
        self.stages = stages
        self.f = self.fun(self.t, self.y)
        self.f_start: FloatArray | None = None

    def _step_impl(self) -> tuple[bool, str | None]:
        t, y, f = self.t, self.y, self.f
        if self.stretch(self.stages):
            assert self.stages is not None
            run = self.stages.rk4_run(t, y, f, self.h, self.t_bound, self.horizon, self.samples, self.sample)
            self.nfev += 4 * run.steps
            self.steps_taken = run.steps
            self._keep_samples(run)
            self.t_start, self.y_start, self.f_start = run.t_start, run.y_start, run.f_start
            self.t, self.y, self.f = run.t_end, run.y_end, run.f_end
            return True, None
        left = self.direction * (self.t_bound - t)
        h = left if left < self.h * (1.0 + 1e-9) else self.h      # land on the bound, no sliver step
        h *= self.direction
        if self.stages is not None:
            y_new, f_new = self.stages.rk4(t, y, f, h)
            self.nfev += 4
        else:
            k2 = self.fun(t + 0.5 * h, y + 0.5 * h * f)
            k3 = self.fun(t + 0.5 * h, y + 0.5 * h * k2)
            k4 = self.fun(t + h, y + h * k3)
            y_new = y + h / 6.0 * (f + 2.0 * k2 + 2.0 * k3 + k4)
            f_new = self.fun(t + h, y_new)
        self.steps_taken = 1
        self.t_start, self.y_start, self.f_start = t, y, f
        self.t = self.t_bound if h == self.direction * left else t + h
        self.y, self.f = y_new, f_new
        return True, None

    def _dense_output_impl(self) -> HermiteDense:
        assert self.f_start is not None
        return HermiteDense(self.t_start, self.t, self.y_start, self.y, self.f_start, self.f)


class DOP853(StretchSolver):
    """Adaptive DOP853 on a system's compiled :class:`Stages` (see the module docstring)."""

    t: float
    y: FloatArray

    def __init__(self, fun: Any, t0: float, y0: FloatArray, t_bound: float, *, stages: Stages,
                 rtol: float = 1e-3, atol: float = 1e-6, max_step: float = math.inf,
                 first_step: float | None = None, vectorized: bool = False):
        super().__init__(fun, t0, y0, t_bound, vectorized, support_complex=False)
        self.stages = stages
        self.rtol = max(float(rtol), 100 * np.finfo(float).eps)
        self.atol = float(atol)
        self.max_step = float(max_step)
        self.f = self.fun(self.t, self.y)
        if first_step is None:
            self.h_abs = float(select_initial_step(self.fun, self.t, self.y, t_bound, self.max_step, self.f,
                                                   self.direction, 7, self.rtol, self.atol))
        else:
            self.h_abs = float(first_step)
        self.K: FloatArray | None = None
        self.h_previous = 0.0

    def _step_impl(self) -> tuple[bool, str | None]:
        t, y = self.t, self.y
        if self.stretch(self.stages):
            run = self.stages.dop853_run(t, y, self.f, self.t_bound, self.horizon, self.h_abs, self.max_step,
                                         self.rtol, self.atol, (SAFETY, MIN_FACTOR, MAX_FACTOR), self.samples,
                                         self.sample)
            self.nfev += 12 * run.attempts + 3 * run.dense
            self.steps_taken = run.steps
            self._keep_samples(run)
            self.h_abs = run.h_abs
            if run.failed:
                self.t, self.y, self.f = run.t_end, run.y_end, run.f_end
                return False, "the step size fell below the rounding of t"
            self.t_start, self.y_start, self.K, self.h_previous = run.t_start, run.y_start, run.K, \
                run.t_end - run.t_start
            self.t, self.y, self.f = run.t_end, run.y_end, run.f_end
            return True, None
        min_step = 10.0 * abs(np.nextafter(t, self.direction * np.inf) - t)
        rejected = False
        while True:
            h_abs = min(self.h_abs, self.max_step)
            if h_abs < min_step:
                return False, "the step size fell below the rounding of t"
            t_new = t + self.direction * h_abs
            if self.direction * (t_new - self.t_bound) > 0:
                t_new = self.t_bound
            h = t_new - t
            h_abs = abs(h)
            y_new, K, error = self.stages.dop853(t, y, self.f, h, self.rtol, self.atol)
            self.nfev += 12
            if error < 1.0:
                factor = MAX_FACTOR if error == 0.0 else min(MAX_FACTOR, SAFETY * error ** (-1.0 / 8.0))
                self.h_abs = h_abs * (min(1.0, factor) if rejected else factor)
                break
            self.h_abs = h_abs * max(MIN_FACTOR, SAFETY * error ** (-1.0 / 8.0))
            rejected = True
        self.steps_taken = 1
        self.t_start, self.y_start, self.K, self.h_previous = t, y, K, h
        self.t, self.y, self.f = t_new, y_new, K[12]
        return True, None

    def _dense_output_impl(self) -> Dop853DenseOutput:
        assert self.K is not None
        F = self.stages.dop853_dense(self.t_start, self.y_start, self.y, self.K, self.h_previous)
        self.nfev += 3
        return Dop853DenseOutput(self.t_start, self.t, self.y_start, F)
