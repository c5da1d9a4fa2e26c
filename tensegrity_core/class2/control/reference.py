"""A reference for the tracking law: state and feedforward forces on a uniform time grid.

``q(tau), qdot(tau)`` [m, m, rad; m/s, m/s, rad/s] and ``force(tau)`` [N, tensile positive]
for ``tau`` in ``[0, duration]`` (relative time); before 0 and after the end the first and
last samples hold. Sampling interpolates linearly between grid points (the grids here are
a few milliseconds: the interpolation error is below 1e-6 of the motion). A reference
ending at rest (``qdot = 0``, holding forces) can be held indefinitely.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tensegrity_core.class2.control.holding import holding_forces, rest_state
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params

#: Columns of the packed sample array: q (3), qdot (3), force (2), D (2).
_Q, _QD, _F, _D = slice(0, 3), slice(3, 6), slice(6, 8), slice(8, 10)


@dataclass(frozen=True)
class ReferenceSample:
    """The reference at one instant: ``q``, ``qdot``, feedforward ``force``, end-effector ``D``."""

    q: np.ndarray
    qdot: np.ndarray
    force: np.ndarray
    end_effector: np.ndarray


class Reference:
    """State and feedforward on the grid ``tau_k = k * step``, ``k = 0..N-1``.

    ``q``, ``qdot`` (N, 3), ``force`` (N, 2); ``kind`` says what built it (``hold``,
    ``end_effector``, ``actuator``); ``target`` is the end-effector goal (x, y) [m] when there
    is one.
    """

    def __init__(self, step: float, q, qdot, force, params: Class2Params, *, kind: str,
                 target: tuple[float, float] | None = None):
        q, qdot, force = (np.atleast_2d(np.asarray(v, dtype=float)) for v in (q, qdot, force))
        L = params.L
        D = np.stack([q[:, 0] + L * np.cos(q[:, 2]), L * np.sin(q[:, 2])], -1)
        self._data = np.hstack([q, qdot, force, D])
        self._data.setflags(write=False)
        self.step = float(step) if len(q) > 1 else 1.0
        self.params = params
        self.kind = kind
        self.target = target if target is not None else (float(D[-1, 0]), float(D[-1, 1]))
        self._last = len(q) - 1

    @property
    def duration(self) -> float:
        """Length of the reference [s] (0 for a hold)."""
        return self._last * self.step

    @property
    def times(self) -> np.ndarray:
        return np.arange(self._last + 1) * self.step

    @property
    def q(self) -> np.ndarray:
        return self._data[:, _Q]

    @property
    def qdot(self) -> np.ndarray:
        return self._data[:, _QD]

    @property
    def force(self) -> np.ndarray:
        return self._data[:, _F]

    @property
    def end_effector(self) -> np.ndarray:
        return self._data[:, _D]

    def packed(self, tau: float) -> np.ndarray:
        """The interpolated row (q, qdot, force, D) at relative time ``tau`` [s]."""
        x = tau / self.step
        if x <= 0.0:
            return self._data[0]
        if x >= self._last:
            return self._data[self._last]
        i = int(x)
        w = x - i
        return self._data[i] + w * (self._data[i + 1] - self._data[i])

    def sample(self, tau: float) -> ReferenceSample:
        row = self.packed(tau)
        return ReferenceSample(row[_Q], row[_QD], row[_F], row[_D])

    def final(self) -> ReferenceSample:
        return self.sample(self.duration)


def hold_reference(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> Reference:
    """Rest at the actuator lengths ``(rho1, rho2)`` [m] with the holding forces."""
    return Reference(1.0, rest_state(rho1, rho2, params), np.zeros(3), holding_forces(rho1, rho2, params),
                     params, kind="hold")
