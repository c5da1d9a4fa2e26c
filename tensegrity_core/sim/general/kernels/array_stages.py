"""A general model's RK4 steps with the numpy kernels: :mod:`.stages`' stretches in a Python loop.

The twin of :class:`~.stages.CompiledStages` for :mod:`.arrays` (numba not installed, or
``TENSEGRITY_KERNELS=numpy``), RK4 only (adaptive DOP853 on the numpy kernels is scipy's).
A stretch of steps runs in one call of :meth:`ArrayStages.rk4_run`, without the stepper's
per-step work: the strings' gaps and their rates at a step's end come from that end's own
evaluation (its member lengths and lengthening rates), where the stepper would place the
nodes again. The screens are those of the compiled stretch (:func:`quiet_step`,
:func:`chart_due`), so both stop at the same steps; the numbers agree to rounding.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sim.general.kernels import arrays
from tensegrity_core.sim.general.kernels.plan import Plan
from tensegrity_core.sim.general.kernels.stages import RK4_B
from tensegrity_core.sim.integrators import Run

FloatArray = NDArray[np.float64]


def quiet_step(g0: FloatArray, a0: FloatArray, s0: FloatArray, g1: FloatArray, a1: FloatArray, s1: FloatArray,
               fixed: NDArray[np.bool_] | None, h: float) -> bool:
    """:func:`.loops.quiet_step` over arrays: no string can cross zero in a step of ``h`` [s]
    whose gaps are ``g0``, ``g1`` [m] at its ends, given with their magnitudes ``a0``, ``a1``
    and the magnitudes ``s0``, ``s1`` of their rates [m/s] (computed once per step end: a
    step's end is the next one's start); ``fixed``: per string, its rest length does not
    move with an input (None: none moves)."""
    if not (g0 * g1 > 0.0).all():
        return False
    near = np.minimum(a0, a1) < (4.0 / 27.0) * h * (s0 + s1) * (1.0 + 1e-9)
    if fixed is not None:
        near &= fixed
    return not near.any()


def chart_due(rotation_columns: NDArray[np.int64], y: FloatArray, angle: float) -> bool:
    """:func:`.loops.chart_due`: a body's rotation vector (columns ``rotation_columns`` (nb, 3)
    of ``y``) near or past ``angle`` [rad]."""
    if not len(rotation_columns):
        return False
    theta = y.take(rotation_columns)
    theta *= theta
    return bool(np.add.reduce(theta, 1).max() > (angle * (1.0 - 1e-9)) ** 2)     # the loops' sum order


def hermite(y_start: FloatArray, f_start: FloatArray, y_end: FloatArray, f_end: FloatArray, h: float,
            x: FloatArray) -> FloatArray:
    """(len(x), N): :func:`.loops.hermite_value` at the fractions ``x`` of a step of ``h`` [s]."""
    a, b = h * f_start, h * f_end
    dy = y_end - y_start
    xc = x[:, None]
    out: FloatArray = y_start + xc * (a + xc * ((3.0 * dy - 2.0 * a - b) + xc * (a + b - 2.0 * dy)))
    return out


class ArrayStages:
    """RK4 steps of the model of ``plan`` (its numpy kernels' ``sums``) in the charts
    ``R_ref`` (nb, 3, 3) with rest lengths ``rest_lengths(t)`` [m] (``constant``: they do not
    depend on ``t``). A stretch stops at a step that may hold an event of the strings
    ``strings`` (member indices; ``moving``: per string, its rest length moves with an input)
    or that leaves a body's rotation vector near or past ``rechart_angle`` [rad]."""

    #: The methods whose steps this computes (the stepper runs others as scipy's).
    methods = ("RK4",)

    def __init__(self, plan: Plan, sums: arrays.Sums, R_ref: FloatArray, rest_lengths: Callable[[float], FloatArray],
                 constant: bool, *, strings: NDArray[np.int64], moving: NDArray[np.bool_], rechart_angle: float):
        self.plan, self.sums = plan, sums
        self.R_ref = np.ascontiguousarray(R_ref, dtype=float)[None]
        self.rest_lengths = rest_lengths
        self.constant = constant
        self.strings, self.moving, self.rechart_angle = strings, moving, float(rechart_angle)
        self.rotation_columns = plan.body_dof[:, None] + 3 + np.arange(3)
        nb, m = len(plan.body_dof), len(plan.EA)
        self._R, self._lengths, self._forces = np.empty((1, nb, 3, 3)), np.empty((1, m)), np.empty((1, m))
        self._rates = np.empty((1, m))
        self._contributions = arrays.contributions(plan.external, 1, m)
        N = 2 * plan.n_dof
        self._K, self._stage = np.empty((4, N)), np.empty(N)          # a step's stages and stage state

    def _rate(self, y: FloatArray, l0: FloatArray, out: FloatArray, rates: bool = False) -> None:
        """``out`` (N,) = ``dy/dt`` of one state; its member lengths [m] are left in
        ``self._lengths[0]`` and, if ``rates``, their lengthening rates [m/s] in ``self._rates[0]``."""
        arrays.derivatives(*self.plan, y[None], self.R_ref, l0[None], out[None], None, None, self._R, self._lengths,
                           self._forces, self.sums, self._rates if rates else None, self._contributions)

    def _step(self, t: float, y: FloatArray, f: FloatArray, h: float,
              l0: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
        """One RK4 step: ``(y_new, f_new)``, the member rates at ``y_new`` in ``self._rates[0]``;
        ``l0`` the rest lengths [m] at every stage if constant, else None."""
        K, stage = self._K, self._stage
        K[0] = f
        for j, c in ((1, 0.5), (2, 0.5), (3, 1.0)):        # stage j at y + c h K[j - 1]
            np.multiply(K[j - 1], c * h, out=stage)
            stage += y
            self._rate(stage, self.rest_lengths(t + c * h) if l0 is None else l0, K[j])
        y_new = RK4_B @ K
        y_new *= h
        y_new += y
        f_new = np.empty_like(y)
        self._rate(y_new, self.rest_lengths(t + h) if l0 is None else l0, f_new, rates=True)
        return y_new, f_new

    def rk4(self, t: float, y: FloatArray, f: FloatArray, h: float) -> tuple[FloatArray, FloatArray]:
        return self._step(t, y, f, h)

    def _gaps(self, l0: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The strings' gaps ``l - l0`` [m], their magnitudes and the magnitudes of their rates
        [m/s] of the last evaluation with rates."""
        gap = self._lengths[0].take(self.strings)
        gap -= l0
        return gap, np.abs(gap), np.abs(self._rates[0].take(self.strings))

    def rk4_run(self, t: float, y: FloatArray, f: FloatArray, h_fixed: float, t_bound: float, horizon: float,
                samples: FloatArray, sample: int) -> Run:
        """:meth:`.stages.CompiledStages.rk4_run` with the numpy kernels: RK4 steps of
        ``h_fixed`` [s] from ``(t, y)`` (rate ``f``) as far as ``horizon`` [s] or a step that
        may hold an event, with the states at ``samples[sample:]`` [s] that the steps before
        the last one cover; constant rest lengths only."""
        assert self.constant, "a stretch of steps needs constant rest lengths"
        l0 = self.rest_lengths(t)
        l0_strings = l0.take(self.strings)
        fixed = None if not self.moving.any() else ~self.moving
        Y = np.empty((len(samples), len(y)))
        self._rate(y, l0, np.empty_like(y), rates=True)
        g0, a0, s0 = self._gaps(l0_strings)
        steps = 0
        while True:
            left = t_bound - t
            h = left if left < h_fixed * (1.0 + 1e-9) else h_fixed
            y_new, f_new = self._step(t, y, f, h, l0)
            t_new = t_bound if h == left else t + h
            steps += 1
            g1, a1, s1 = self._gaps(l0_strings)
            if t_new >= horizon or t_new >= t_bound or not quiet_step(g0, a0, s0, g1, a1, s1, fixed, t_new - t) \
                    or chart_due(self.rotation_columns, y_new, self.rechart_angle):
                return Run(steps, steps, t, y, f, t_new, y_new, f_new, sampled=sample, Y=Y)
            if sample < len(samples) and samples[sample] <= t_new:
                end = int(np.searchsorted(samples, t_new, side="right"))
                if end == sample + 1 and samples[sample] == t_new:
                    Y[sample] = y_new
                else:
                    Y[sample:end] = hermite(y, f, y_new, f_new, t_new - t, (samples[sample:end] - t) / (t_new - t))
                sample = end
            t, y, f, g0, a0, s0 = t_new, y_new, f_new, g1, a1, s1
