"""Event functions for ``scipy.integrate.solve_ivp`` on the class-2 equations of motion.

The equations of motion alone let an actuator length pass through zero and become
negative (the mirrored, non-physical configuration), and they break down where lambda1 or
lambda2 vanishes. These events locate those moments; a simulator decides what happens
there (stop, clamp, impact law). State layout ``y = (rho1, rho2, beta, rho1_dot,
rho2_dot, beta_dot)`` as in :class:`~tensegrity_core.class2.dynamics.Class2Dynamics`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.params import Class2Params
from tensegrity_core.errors import ParameterError


@dataclass(frozen=True)
class ActuatorLengthEvent:
    """Zero when actuator ``index`` (1 for rho1, 2 for rho2) has length ``length`` [m].

    ``direction = -1`` (default) triggers only while the length decreases through the
    level; ``terminal`` stops the integration there (solve_ivp reads both attributes).
    """

    index: int
    length: float = 0.0
    terminal: bool = True
    direction: float = -1.0

    def __post_init__(self) -> None:
        if self.index not in (1, 2):
            raise ParameterError(f"actuator index must be 1 or 2, got {self.index!r}")

    def __call__(self, t: float, y: NDArray[np.float64]) -> float:
        return float(y[self.index - 1]) - self.length


@dataclass(frozen=True)
class SingularityApproachEvent:
    """Zero when ``lambda1`` or ``lambda2`` reaches ``margin * L`` (decreasing).

    The value is ``lambda^2 - (margin L)^2`` [m^2], smooth across the level. ``margin`` must
    exceed the model's ``lambda_min`` so the event fires before the equations refuse, and the
    integrator's trial stages must not jump past the refusal: with ``lambda'`` [m/s] the
    largest rate of approach, ``max_step <= (margin - lambda_min) L / |lambda'|``. Near the
    set the remaining length ``2L - s = lambda1^2/(2L + s)`` (and ``L - rho1``) is a fraction
    ``~ (lambda/L)^2`` of the state, so ``rtol`` must be below that fraction to resolve the
    approach; otherwise a step that crosses the set raises
    :class:`~tensegrity_core.errors.DomainError` before the event can fire.
    """

    kind: str
    params: Class2Params
    margin: float = 1e-2
    terminal: bool = True
    direction: float = -1.0

    def __post_init__(self) -> None:
        if self.kind not in ("lambda1", "lambda2"):
            raise ParameterError(f"kind must be 'lambda1' or 'lambda2', got {self.kind!r}")
        if not 0.0 < self.margin < 1.0:
            raise ParameterError(f"margin must be in (0, 1) (relative to L), got {self.margin!r}")

    def __call__(self, t: float, y: NDArray[np.float64]) -> float:
        L = self.params.L
        rho1 = float(y[0])
        if self.kind == "lambda1":
            s = rho1 + float(y[1])
            lam_sq = (2.0 * L - s) * (2.0 * L + s)
        else:
            lam_sq = (L - rho1) * (L + rho1)
        return lam_sq - (self.margin * L) ** 2
