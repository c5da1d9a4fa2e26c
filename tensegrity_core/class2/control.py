"""Actuator-force control of the class-2 mechanism: holding forces and a tracking law.

The mechanism is driven by forces, not lengths. At rest in the configuration
``(rho1, rho2, beta*(rho))`` the equations of motion reduce to ``dU/dq + (f1, f2, 0) = 0``
(``beta*`` makes ``dU/dbeta`` vanish), so the holding forces are
``f_i = -dU/drho_i`` [N] (positive = tensile, pulls the actuator's nodes together).
Under constant forces that equilibrium can be unstable (the paper's start at
rho = (0.7, 0.7) is: see docs/class2_dynamics.md), so tracking needs feedback:
:class:`ActuatorTracker` adds a proportional-derivative term on the actuator lengths.

beta is not actuated: it follows the actuators only through the springs, as a lightly
damped oscillator (natural period about 5 s with the paper's parameters, damping from
c = 0.01 only). The tracker damps it through that same coupling: it shifts the length
reference by ``-kbeta * betadot * grad(beta*)`` so that the springs' equilibrium beta*
moves against beta's motion and the springs' torque acts as a damper on beta.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tensegrity_core.class2.dynamics import potential_gradient
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.geometry import check_actuator_lengths
from tensegrity_core.class2.kinematics import dbeta_drho
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import ParameterError


def holding_forces(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> np.ndarray:
    """Actuator forces ``(f1, f2)`` [N] that keep the mechanism at rest at ``(rho1, rho2)``."""
    check_actuator_lengths(rho1, rho2, params.L)
    beta = float(equilibrium_beta(rho1, rho2, params))
    g = potential_gradient(np.array([rho1, rho2, beta]), params)
    return -g[:2]


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

    def forces(self, rho_ref, rho, rho_dot, beta_dot: float = 0.0) -> np.ndarray:
        """Forces ``(f1, f2)`` [N] for references ``rho_ref`` [m], lengths ``rho`` [m], their
        rates ``rho_dot`` [m/s] and beta's rate ``beta_dot`` [rad/s]."""
        rho_ref, rho, rho_dot = (np.asarray(v, dtype=float) for v in (rho_ref, rho, rho_dot))
        target = rho_ref
        if self.kbeta and beta_dot:
            _, g1, g2 = dbeta_drho(float(rho_ref[0]), float(rho_ref[1]), self.params)
            target = rho_ref - self.kbeta * float(beta_dot) * np.array([g1, g2])
        f = holding_forces(rho_ref[0], rho_ref[1], self.params) + self.kp * (rho - target) + self.kd * rho_dot
        return np.clip(f, -self.max_force, self.max_force)
