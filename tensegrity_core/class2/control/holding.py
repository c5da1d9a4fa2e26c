"""Holding forces: the actuator forces that keep the mechanism at rest.

At rest in the configuration ``(rho1, rho2, beta*(rho))`` the equations of motion reduce
to ``dU/dq + (f1, f2, 0) = 0`` (``beta*`` makes ``dU/dbeta`` vanish), so the holding forces
are ``f_i = -dU/drho_i`` [N] (positive = tensile, pulls the actuator's nodes together).
Under constant forces that equilibrium can be unstable (the paper's start at
rho = (0.7, 0.7) is: see docs/design/class2_dynamics.md), so a controller adds feedback.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2 import potential_gradient
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.geometry import check_actuator_lengths
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params


def rest_state(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """``q = (rho1, rho2, beta*)`` [m, m, rad] at rest with the actuators at ``(rho1, rho2)``."""
    check_actuator_lengths(rho1, rho2, params.L)
    return np.array([float(rho1), float(rho2), float(equilibrium_beta(rho1, rho2, params))])


def holding_forces(rho1: float, rho2: float, params: Class2Params = PAPER_PARAMS) -> NDArray[np.float64]:
    """Actuator forces ``(f1, f2)`` [N] that keep the mechanism at rest at ``(rho1, rho2)``."""
    return -potential_gradient(rest_state(rho1, rho2, params), params)[:2]
