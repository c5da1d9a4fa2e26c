"""A general model's integration steps computed whole in compiled code (:class:`~tensegrity_core.sim.integrators.Stages`).

Each step is one call into :mod:`.loops` that evaluates all its stages; only the rest
lengths at the stages' times come from Python (input laws are Python objects), one row
per stage, and only when an actuator's law can change them. With constant rest lengths a
whole stretch of steps is one call (:meth:`CompiledStages.rk4_run`,
:meth:`CompiledStages.dop853_run`): it returns to Python only at the step that reaches the
caller's horizon or the bound, or that may hold a string's slack/taut event or a
re-charting, so the stepper's event location and re-charting see every such step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.integrate._ivp import dop853_coefficients as dop853

from tensegrity_core.sim.general.kernels import loops
from tensegrity_core.sim.general.kernels.plan import Plan, frozen
from tensegrity_core.sim.integrators import Run

FloatArray = NDArray[np.float64]

#: The classical RK4 as a tableau: stages 0-3, then row 4 (its weights ``B``) gives the rate at
#: the step's end, the next step's first stage; ``RK4_C`` the stages' times over the step.
RK4_B = np.array([1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0])
RK4_A = np.zeros((5, 5))
RK4_A[1, 0] = RK4_A[2, 1] = 0.5
RK4_A[3, 2] = 1.0
RK4_A[4, :4] = RK4_B
RK4_C = np.array([0.0, 0.5, 0.5, 1.0, 1.0])
#: DOP853's tableau (scipy's tables of Hairer's coefficients): 12 stages, the rate at the
#: step's end (row 12 of ``A`` is ``B``), three more for the dense output.
A = np.ascontiguousarray(dop853.A, dtype=float)
C = np.ascontiguousarray(dop853.C, dtype=float)
E3 = np.ascontiguousarray(dop853.E3, dtype=float)
E5 = np.ascontiguousarray(dop853.E5, dtype=float)
D = np.ascontiguousarray(dop853.D, dtype=float)
N_STAGES = dop853.N_STAGES                     # 12
N_EXTENDED = dop853.N_STAGES_EXTENDED          # 16


class CompiledStages:
    """The steps of the model of ``plan`` in the charts ``R_ref`` (nb, 3, 3) with rest lengths
    ``rest_lengths(t)`` [m] (``constant``: they do not depend on ``t``). A stretch of steps
    stops at a step that may hold an event of the strings ``strings`` (member indices;
    ``moving``: per string, its rest length moves with an input) or that leaves a body's
    rotation vector near or past ``rechart_angle`` [rad]."""

    #: The methods whose steps this computes.
    methods = ("RK4", "DOP853")

    def __init__(self, plan: Plan, R_ref: FloatArray, rest_lengths: Callable[[float], FloatArray], constant: bool,
                 *, strings: NDArray[np.int64], moving: NDArray[np.bool_], rechart_angle: float):
        self.plan = frozen(plan)
        self.R_ref = np.array(R_ref, dtype=float)
        self.rest_lengths = rest_lengths
        self.constant = constant
        self._screen = (np.array(strings, dtype=np.int64), np.array(moving, dtype=bool), float(rechart_angle))
        fixed = np.ascontiguousarray(rest_lengths(0.0), dtype=float)
        self._fixed = {k: np.ascontiguousarray(np.tile(fixed, (k, 1))) for k in (len(RK4_C), len(C))} \
            if constant else None

    def _lengths(self, t: float, h: float, fractions: FloatArray) -> FloatArray:
        """(len(fractions), m) rest lengths [m] at ``t + fraction h``."""
        if self._fixed is not None:
            return self._fixed[len(fractions)]
        return np.ascontiguousarray([self.rest_lengths(t + c * h) for c in fractions], dtype=float)

    def rk4(self, t: float, y: FloatArray, f: FloatArray, h: float) -> tuple[FloatArray, FloatArray]:
        K = np.empty((5, len(y)))
        K[0] = f
        loops.rk_stages(*self.plan, y, h, self.R_ref, self._lengths(t, h, RK4_C), RK4_A, 1, 5, K)
        y_new = np.empty_like(y)
        loops.combine(y, h, RK4_B, K, y_new)
        return y_new, K[4].copy()

    def dop853(self, t: float, y: FloatArray, f: FloatArray, h: float, rtol: float,
               atol: float) -> tuple[FloatArray, FloatArray, float]:
        K = np.empty((N_EXTENDED, len(y)))
        K[0] = f
        y_new = np.empty_like(y)
        error = loops.dop853_attempt(*self.plan, y, h, self.R_ref, self._lengths(t, h, C), A, E5, E3, rtol, atol, K,
                                     y_new)
        return y_new, K, float(error)

    def rk4_run(self, t: float, y: FloatArray, f: FloatArray, h: float, t_bound: float, horizon: float,
                samples: FloatArray, sample: int) -> Run:
        """RK4 steps of ``h`` [s] from ``(t, y)`` (rate ``f``) in one compiled call, as far as
        ``horizon`` [s] or a step that may hold an event (module docstring), with the states
        at ``samples[sample:]`` [s] that the steps before the last one cover; constant rest
        lengths only."""
        assert self._fixed is not None, "a stretch of steps needs constant rest lengths"
        y_start, f_start = y.copy(), f.copy()
        K, y_end, Y = np.empty((5, len(y))), np.empty_like(y), np.empty((len(samples), len(y)))
        steps, t_start, t_end, done = loops.rk4_run(*self.plan, *self._screen, t, y_start, f_start, h, t_bound,
                                                    horizon, self.R_ref, self._fixed[len(RK4_C)], RK4_A, RK4_B, K,
                                                    y_end, samples, sample, Y)
        return Run(steps, steps, t_start, y_start, f_start, t_end, y_end, K[4].copy(), sampled=done, Y=Y)

    def dop853_run(self, t: float, y: FloatArray, f: FloatArray, t_bound: float, horizon: float, h_abs: float,
                   max_step: float, rtol: float, atol: float, control: tuple[float, float, float],
                   samples: FloatArray, sample: int) -> Run:
        """Adaptive DOP853 steps from ``(t, y)`` (rate ``f``, first proposal ``h_abs`` [s],
        bounded by ``max_step``; ``control``: the controller's safety factor and bounds of the
        change per step) in one compiled call, as far as ``horizon`` [s] or a step that may
        hold an event (module docstring), with the states at ``samples[sample:]`` [s] that the
        steps before the last one cover; constant rest lengths only."""
        assert self._fixed is not None, "a stretch of steps needs constant rest lengths"
        y_start = y.copy()
        K, y_end, Y = np.empty((N_EXTENDED, len(y))), np.empty_like(y), np.empty((len(samples), len(y)))
        K[0] = f
        failed, steps, attempts, t_start, t_end, h_next, done, dense = loops.dop853_run(
            *self.plan, *self._screen, t, y_start, t_bound, horizon, h_abs, max_step, rtol, atol, self.R_ref,
            self._fixed[len(C)], A, E5, E3, *control, D, K, y_end, np.empty((7, len(y))), samples, sample, Y)
        if failed:
            return Run(steps, attempts, t_end, y_start, K[0], t_end, y_start, K[0], None, h_next, True, done, Y,
                       dense)
        return Run(steps, attempts, t_start, y_start, K[0], t_end, y_end, K[N_STAGES], K, h_next, False, done, Y,
                   dense)

    def dop853_dense(self, t: float, y: FloatArray, y_new: FloatArray, K: FloatArray, h: float) -> FloatArray:
        F = np.empty((7, len(y)))
        loops.dop853_dense(*self.plan, y, y_new, h, self.R_ref, self._lengths(t, h, C), A, D, K, F)
        return F
