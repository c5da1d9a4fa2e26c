"""The demo's present law, kept as the baseline of the controller benchmarks.

:class:`ActuatorTracker`: holding forces plus a proportional-derivative term on the
actuator lengths. beta is not actuated: it follows the actuators only through the
springs, as a lightly damped oscillator (natural period about 5 s with the paper's
parameters, damping from c = 0.01 only). The tracker damps it through that same
coupling: it shifts the length reference by ``-kbeta * betadot * grad(beta*)`` so that the
springs' equilibrium beta* moves against beta's motion and the springs' torque acts as a
damper on beta. Hand-tuned gains; it leaves millimetres of settled error after seconds
(docs/control.md compares it with :class:`~tensegrity_core.class2.control.TrackingController`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.control.holding import holding_forces
from tensegrity_core.class2.kinematics import dbeta_drho
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import ParameterError


@dataclass(frozen=True)
class ActuatorTracker:
    """Force law that makes the actuator lengths follow a reference.

    ``f = holding_forces(rho_ref) + kp (rho - r) + kd rhodot`` [N] with
    ``r = rho_ref - kbeta * betadot * grad(beta*)(rho_ref)``: an actuator longer than its
    reference, or lengthening, pulls harder (tension positive shortens it); ``kbeta``
    [m^2 s/rad^2 ... i.e. (rad/m)^-2 s] damps the unactuated beta through the springs (0 turns it off).
    ``kp`` [N/m], ``kd`` [N s/m], ``max_force`` [N] saturates the output.
    """

    params: Class2Params = PAPER_PARAMS
    kp: float = 40.0
    kd: float = 12.0
    kbeta: float = 0.0
    max_force: float = 50.0

    def __post_init__(self) -> None:
        for name in ("kp", "kd", "kbeta", "max_force"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ParameterError(f"{name} must be finite and >= 0, got {v!r}")

    def forces(self, rho_ref: ArrayLike, rho: ArrayLike, rho_dot: ArrayLike,
               beta_dot: float = 0.0) -> NDArray[np.float64]:
        """Forces ``(f1, f2)`` [N] for references ``rho_ref`` [m], lengths ``rho`` [m], their
        rates ``rho_dot`` [m/s] and beta's rate ``beta_dot`` [rad/s]."""
        ref, length, rate = (np.asarray(v, dtype=np.float64) for v in (rho_ref, rho, rho_dot))
        target = ref
        if self.kbeta and beta_dot:
            _, g1, g2 = dbeta_drho(float(ref[0]), float(ref[1]), self.params)
            target = ref - self.kbeta * float(beta_dot) * np.array([g1, g2])
        f = holding_forces(ref[0], ref[1], self.params) + self.kp * (length - target) + self.kd * rate
        clipped: NDArray[np.float64] = np.clip(f, -self.max_force, self.max_force)
        return clipped
