"""Energy and equilibrium of the class-2 equations of motion.

- conservative case (c = 0, f = 0): T + U constant along DOP853 trajectories;
- power balance: dE/dt = -qdot^T H qdot - f1 rho1_dot - f2 rho2_dot, pointwise (finite
  differences of E along the flow) and integrated along a driven, damped trajectory;
- equilibrium: at the FKP beta (energy.equilibrium_beta) with the static actuator forces
  (from finite differences of energy.potential_energy) the acceleration vanishes and the
  integrated state does not move; the stability of that equilibrium under force control
  follows the Hessian of U, and the linearisation (analytic Jacobian) agrees.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from tensegrity_core.class2 import dynamics as dyn
from tensegrity_core.class2.dynamics import potential_hessian
from tensegrity_core.class2.energy import equilibrium_beta, potential_energy
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params

PARAMS = Class2Params(L=1.1, m=1.5, k1=1.3, k2=0.9, k3=1.6, k4=0.7, c1=0.2, c2=0.15, c3=0.3, c4=0.1)


def static_forces(rho1, rho2, params):
    """Actuator forces holding (rho1, rho2, FKP beta) at rest: f_i = -dU/drho_i (FD of energy.py)."""
    beta = float(equilibrium_beta(rho1, rho2, params))
    h = 1e-6
    q = np.array([rho1, rho2, beta])
    grad = [(potential_energy(q + h * e, params) - potential_energy(q - h * e, params)) / (2 * h)
            for e in np.eye(3)[:2]]
    return beta, -grad[0], -grad[1]


@pytest.mark.parametrize("y0", [
    [0.7, 0.7, 0.8, 0.0, 0.0, 0.0],
    [0.4, 0.5, 3.0, 0.0, 0.0, 3.0],
    [0.2, 0.3, 1.0, 0.0, 0.0, 1.0],
])
def test_energy_is_conserved_without_damping_and_forces(y0):
    params = PARAMS.with_overrides(c=0.0)
    model = dyn.Class2Dynamics(params)
    sol = solve_ivp(model.rhs, (0.0, 10.0), y0, method="DOP853", rtol=1e-10, atol=1e-12, dense_output=True)
    assert sol.success
    ts = np.linspace(0, 10, 201)
    ys = sol.sol(ts).T
    E = dyn.mechanical_energy(ys[:, :3], ys[:, 3:], params)
    scale = (np.abs(dyn.kinetic_energy(ys[:, :3], ys[:, 3:], params)).max()
             + np.abs(potential_energy(ys[:, :3], params)).max())
    assert np.abs(E - E[0]).max() < 1e-8 * scale
    # The trajectory really moves (the check is not on a resting state).
    assert np.ptp(ys[:, 2]) > 0.1


@settings(max_examples=100)
@given(rho1=st.floats(0.05, 0.9), rho2=st.floats(0.05, 1.0), beta=st.floats(-3, 3),
       v=st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(-2, 2)),
       f1=st.floats(-5, 5), f2=st.floats(-5, 5))
def test_power_balance_pointwise(rho1, rho2, beta, v, f1, f2):
    model = dyn.Class2Dynamics(PARAMS)
    y = np.array([rho1, rho2, beta, *v])
    ydot = model.rhs(0.0, y, f1, f2)
    h = 1e-6
    dE = (model.energy(y + h * ydot) - model.energy(y - h * ydot)) / (2 * h)
    qdot = y[3:]
    want = -qdot @ dyn.damping_matrix(y[:3], PARAMS) @ qdot - f1 * qdot[0] - f2 * qdot[1]
    assert dE == pytest.approx(want, rel=1e-6, abs=1e-7)


def test_power_balance_integrated_along_driven_damped_trajectory():
    """E(t) + integral of (dissipated power + power into the actuators) = E(0)."""
    model = dyn.Class2Dynamics(PARAMS)

    def forces(t):
        return 0.8 * math.sin(1.3 * t), -0.5 + 0.3 * math.cos(0.7 * t)

    def rhs(t, z):
        y = z[:6]
        f1, f2 = forces(t)
        qdot = y[3:]
        lost = qdot @ dyn.damping_matrix(y[:3], PARAMS) @ qdot + f1 * qdot[0] + f2 * qdot[1]
        return np.concatenate([model.rhs(t, y, f1, f2), [lost]])

    z0 = [0.5, 0.6, 1.0, 0.2, -0.1, 0.5, 0.0]
    sol = solve_ivp(rhs, (0.0, 8.0), z0, method="DOP853", rtol=1e-10, atol=1e-12, t_eval=np.linspace(0, 8, 81))
    assert sol.success
    E = np.array([model.energy(y) for y in sol.y[:6].T])
    np.testing.assert_allclose(E + sol.y[6], E[0], atol=1e-8)
    assert sol.y[6, -1] != pytest.approx(0.0, abs=1e-3)   # damping and forces did real work


@pytest.mark.parametrize("rho", [(0.7, 0.7), (0.3, 0.5), (0.5, 0.2), (0.8, 0.9), (0.1, 1.6)])
def test_equilibrium_of_dynamics_is_the_fkp_with_static_forces(rho):
    rho1, rho2 = rho
    beta, f1, f2 = static_forces(rho1, rho2, PARAMS)
    q = np.array([rho1, rho2, beta])
    a = dyn.acceleration(q, np.zeros(3), f1, f2, PARAMS)
    assert np.abs(a).max() < 1e-8
    # dU/dbeta = 0 there: the beta equation needs no actuator force.
    assert dyn.potential_gradient(q, PARAMS)[2] == pytest.approx(0.0, abs=1e-13)
    # And the integrated dynamics stays put.
    model = dyn.Class2Dynamics(PARAMS)
    sol = solve_ivp(lambda t, y: model.rhs(t, y, f1, f2), (0, 5), [*q, 0, 0, 0], method="DOP853",
                    rtol=1e-11, atol=1e-13)
    assert np.abs(sol.y[:, -1] - [*q, 0, 0, 0]).max() < 1e-6


def test_other_beta_is_not_an_equilibrium():
    rho1, rho2 = 0.7, 0.7
    beta, f1, f2 = static_forces(rho1, rho2, PAPER_PARAMS)
    a = dyn.acceleration([rho1, rho2, beta + 0.1], [0, 0, 0], f1, f2, PAPER_PARAMS)
    assert abs(a[2]) > 1e-3


@pytest.mark.parametrize("rho, stable", [((0.8, 0.9), True), ((0.7, 0.7), False)])
def test_force_controlled_equilibrium_stability_follows_hessian_of_U(rho, stable):
    """Under constant actuator forces the equilibrium is stable iff hess U is positive
    definite (the Hessian of the paper's U has a negative eigenvalue at the paper's start
    configuration, so a force-controlled mechanism does not stay there). The linearised
    dynamics from the analytic Jacobian agrees: an eigenvalue with positive real part
    exactly when hess U is indefinite."""
    params = PAPER_PARAMS
    beta, f1, f2 = static_forces(*rho, params)
    q = np.array([*rho, beta])
    hess_pd = np.linalg.eigvalsh(potential_hessian(q, params)).min() > 0
    assert hess_pd == stable
    jac = dyn.Class2Dynamics(params).jacobian(0.0, np.concatenate([q, np.zeros(3)]), f1, f2)
    growth = np.linalg.eigvals(jac).real.max()
    assert (growth < 1e-9) == stable
    # Undamped check: eigenvalues of M^-1 hess U give the same verdict.
    om2 = np.linalg.eigvals(np.linalg.solve(dyn.mass_matrix(q, params), potential_hessian(q, params))).real
    assert (om2.min() > 0) == stable
