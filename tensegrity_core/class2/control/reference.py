"""A reference for the tracking law: state and feedforward forces on a uniform time grid.

``q(tau), qdot(tau)`` [m, m, rad; m/s, m/s, rad/s] and ``force(tau)`` [N, tensile positive]
for ``tau`` in ``[0, duration]`` (relative time); before 0 and after the end the first and
last samples hold. Sampling interpolates linearly between grid points (the grids here are
a few milliseconds: the interpolation error is below 1e-6 of the motion). A reference
ending at rest (``qdot = 0``, holding forces) can be held indefinitely.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.control.holding import holding_forces, rest_state
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params

#: Columns of the packed sample array: q (3), qdot (3), force (2), D (2).
_Q: Final = slice(0, 3)
_QD: Final = slice(3, 6)
_F: Final = slice(6, 8)
_D: Final = slice(8, 10)


@dataclass(frozen=True)
class ReferenceSample:
    """The reference at one instant: ``q``, ``qdot``, feedforward ``force``, end-effector ``D``."""

    q: NDArray[np.float64]
    qdot: NDArray[np.float64]
    force: NDArray[np.float64]
    end_effector: NDArray[np.float64]


class Reference:
    """State and feedforward on the grid ``tau_k = k * step``, ``k = 0..N-1``.

    ``q``, ``qdot`` (N, 3), ``force`` (N, 2); ``kind`` says what built it (``hold``,
    ``end_effector``, ``actuator``); ``target`` is the end-effector goal (x, y) [m] when there
    is one.
    """

    def __init__(self, step: float, q: ArrayLike, qdot: ArrayLike, force: ArrayLike, params: Class2Params, *,
                 kind: str, target: tuple[float, float] | None = None) -> None:
        qa, qdota, forcea = (np.atleast_2d(np.asarray(v, dtype=np.float64)) for v in (q, qdot, force))
        L = params.L
        D = np.stack([qa[:, 0] + L * np.cos(qa[:, 2]), L * np.sin(qa[:, 2])], -1)
        self._data: NDArray[np.float64] = np.hstack([qa, qdota, forcea, D])
        self._data.setflags(write=False)
        self.step = float(step) if len(qa) > 1 else 1.0
        self.params = params
        self.kind = kind
        self.target = target if target is not None else (float(D[-1, 0]), float(D[-1, 1]))
        self._last = len(qa) - 1

    @property
    def duration(self) -> float:
        """Length of the reference [s] (0 for a hold)."""
        return self._last * self.step

    @property
    def times(self) -> NDArray[np.float64]:
        return np.arange(self._last + 1, dtype=np.float64) * self.step

    @property
    def q(self) -> NDArray[np.float64]:
        return self._data[:, _Q]

    @property
    def qdot(self) -> NDArray[np.float64]:
        return self._data[:, _QD]

    @property
    def force(self) -> NDArray[np.float64]:
        return self._data[:, _F]

    @property
    def end_effector(self) -> NDArray[np.float64]:
        return self._data[:, _D]

    def packed(self, tau: float) -> NDArray[np.float64]:
        """The interpolated row (q, qdot, force, D) at relative time ``tau`` [s]."""
        x = tau / self.step
        row: NDArray[np.float64]
        if x <= 0.0:
            row = self._data[0]
        elif x >= self._last:
            row = self._data[self._last]
        else:
            i = int(x)
            w = x - i
            row = self._data[i] + w * (self._data[i + 1] - self._data[i])
        return row

    def sample(self, tau: float) -> ReferenceSample:
        row = self.packed(tau)
        return ReferenceSample(row[_Q], row[_QD], row[_F], row[_D])

    def final(self) -> ReferenceSample:
        return self.sample(self.duration)


def hold_reference(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> Reference:
    """Rest at the actuator lengths ``(rho1, rho2)`` [m] with the holding forces."""
    return Reference(1.0, rest_state(rho1, rho2, params), np.zeros(3), holding_forces(rho1, rho2, params),
                     params, kind="hold")
