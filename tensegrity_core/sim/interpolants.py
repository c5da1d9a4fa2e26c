"""The solution over one integrator step, as the stepper and the event search read it.

:class:`Interpolant` is what both need (scipy's ``DenseOutput`` is one); :class:`Constant` stands
for a step of zero length (a restart), :class:`LazyDense` for a step whose dense output is
built only if something asks for it (DOP853's costs three more evaluations).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import OdeSolver

FloatArray = NDArray[np.float64]


class Interpolant(Protocol):
    """The solution over the current step (scipy's ``DenseOutput``, :class:`Constant`,
    :class:`LazyDense`): scalar ``t`` -> (n,), array (k,) -> (n, k)."""

    def __call__(self, t: float | FloatArray) -> FloatArray: ...


class Constant:
    """Dense output of a zero-length segment (scalar ``t`` -> (n,), array -> (n, k))."""

    def __init__(self, y: ArrayLike):
        self.y = np.array(y, dtype=float)

    def __call__(self, t: float | FloatArray) -> FloatArray:
        if np.ndim(t):
            return np.repeat(self.y[:, None], np.size(t), axis=1)
        return self.y.copy()


class LazyDense:
    """The solver's dense output for its last step, built on first use (before the next step)."""

    def __init__(self, solver: OdeSolver):
        self.solver = solver
        self.t_end: float = solver.t
        self.y: FloatArray = solver.y.copy()
        self._fn: Interpolant | None = None

    def __call__(self, t: float | FloatArray) -> FloatArray:
        if np.ndim(t) == 0 and t == self.t_end:
            return self.y.copy()
        if self._fn is None:
            if self.solver.t != self.t_end:
                raise RuntimeError("dense output requested after the solver moved on")
            self._fn = self.solver.dense_output()
        return self._fn(t)
