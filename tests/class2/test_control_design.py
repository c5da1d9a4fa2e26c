"""The control law's model pieces against independent computations.

Oracles: central finite differences of the nonlinear right-hand side
(``Class2Dynamics.rhs``) for the linearisation; an ODE integration of the linear system for
the zero-order-hold discretisation; the Riccati equation's own residual and the
closed-loop eigenvalues for the gains; the paper's stated instability of the rest at
rho = (0.7, 0.7) under constant forces.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from tensegrity_core.class2 import PAPER_PARAMS, Class2Dynamics, Class2Params, equilibrium_beta
from tensegrity_core.class2.control import (
    LQRWeights,
    augment,
    design_gain,
    discretize,
    holding_forces,
    linearize,
    rest_state,
)
from tensegrity_core.errors import ParameterError

OTHER = Class2Params(L=1.3, m=1.7, k1=0.8, k2=1.9, k3=0.6, k4=1.4, c1=0.11, c2=0.23, c3=0.07, c4=0.31)
STATES = [  # (q, qdot, f): at rest, moving, forced, on other parameters
    (PAPER_PARAMS, (0.7, 0.7, None), (0.0, 0.0, 0.0), None),
    (PAPER_PARAMS, (0.55, 0.85, 0.9), (0.2, -0.3, 0.4), (1.5, -0.7)),
    (PAPER_PARAMS, (0.3, 1.2, 0.5), (-0.1, 0.25, -0.6), (-2.0, 3.0)),
    (OTHER, (0.6, 0.9, 1.1), (0.3, 0.1, -0.2), (0.4, 0.9)),
]


def _state(params, q, qdot, f):
    q = np.array([q[0], q[1], q[2] if q[2] is not None else float(equilibrium_beta(q[0], q[1], params))])
    f = holding_forces(q[0], q[1], params) if f is None else np.array(f)
    return q, np.array(qdot), f


@pytest.mark.parametrize("params, q, qdot, f", STATES)
def test_linearisation_matches_finite_differences_of_the_nonlinear_rhs(params, q, qdot, f):
    q, qdot, f = _state(params, q, qdot, f)
    A, B = linearize(q, qdot, f, params)
    dyn = Class2Dynamics(params)
    y = np.concatenate([q, qdot])
    h = 1e-6
    A_fd = np.column_stack([(dyn.rhs(0, y + h * e, *f) - dyn.rhs(0, y - h * e, *f)) / (2 * h) for e in np.eye(6)])
    B_fd = np.column_stack([(dyn.rhs(0, y, *(f + h * e)) - dyn.rhs(0, y, *(f - h * e))) / (2 * h)
                            for e in np.eye(2)])
    assert np.allclose(A, A_fd, rtol=1e-6, atol=1e-7 * np.abs(A_fd).max())
    assert np.allclose(B, B_fd, rtol=1e-7, atol=1e-9)


def test_rest_at_0p7_is_unstable_under_constant_forces_and_controllable():
    """docs/design/class2_dynamics.md: under constant forces the rest at (0.7, 0.7) is unstable
    (the Hessian of U has a negative eigenvalue); both forces together still reach every
    mode (Kalman's rank test), so feedback can stabilise it."""
    q, qdot, f = _state(PAPER_PARAMS, (0.7, 0.7, None), (0, 0, 0), None)
    A, B = linearize(q, qdot, f, PAPER_PARAMS)
    assert np.max(np.linalg.eigvals(A).real) > 0.1
    ctrb = np.hstack([np.linalg.matrix_power(A, k) @ B for k in range(6)])
    assert np.linalg.matrix_rank(ctrb) == 6


def test_zero_order_hold_discretisation_matches_integrating_the_linear_system():
    q, qdot, f = _state(PAPER_PARAMS, (0.55, 0.85, 0.9), (0.2, -0.3, 0.4), (1.5, -0.7))
    A, B = augment(*linearize(q, qdot, f, PAPER_PARAMS), q, PAPER_PARAMS.L)
    dt = 0.05
    Ad, Bd = discretize(A, B, dt)
    x0 = np.array([0.01, -0.02, 0.03, 0.1, -0.05, 0.2, 0.001, -0.002])
    u = np.array([0.3, -0.8])
    sol = solve_ivp(lambda t, x: A @ x + B @ u, (0, dt), x0, rtol=1e-12, atol=1e-14)
    assert np.allclose(Ad @ x0 + Bd @ u, sol.y[:, -1], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("rho", [(0.7, 0.7), (0.2, 0.3), (0.9, 0.95), (0.5, 1.4), (0.95, 0.5)])
@pytest.mark.parametrize("dt", [0.01, 0.001])
def test_designed_gain_solves_the_riccati_equation_and_stabilises(rho, dt):
    params = PAPER_PARAMS
    q = rest_state(*rho, params)
    f = holding_forces(*rho, params)
    w = LQRWeights()
    g = design_gain(q, np.zeros(3), f, params, w, dt)
    assert np.max(np.abs(g.poles)) < 1.0
    assert np.all(g.continuous_poles.real < 0)
    # the gain is the Riccati one: P = Q + Ad' P (Ad - Bd K) with K = (R + Bd' P Bd)^-1 Bd' P Ad,
    # P recovered from the Lyapunov equation of the closed loop
    Ad, Bd = discretize(*augment(*linearize(q, np.zeros(3), f, params), q, params.L), dt)
    Q, R = w.matrices(q, params.L)
    Acl = Ad - Bd @ g.K
    import scipy.linalg

    P = scipy.linalg.solve_discrete_lyapunov(Acl.T, Q + g.K.T @ R @ g.K)
    K_again = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
    assert np.allclose(K_again, g.K, rtol=1e-6, atol=1e-6 * np.abs(g.K).max())


def test_weights_are_validated():
    with pytest.raises(ParameterError, match="position"):
        LQRWeights(position=0.0)
    with pytest.raises(ParameterError, match="force"):
        LQRWeights(force=math.nan)


@given(st.floats(), st.floats())
def test_holding_any_measured_lengths_holds_them_or_refuses_with_a_reason(rho1, rho2):
    """The controller starts by holding what the simulator measures: for any lengths (a rogue
    publisher's, or the folded rho = (0, 0), where the Riccati equation has no stabilising
    solution and scipy raised LinAlgError, which ended the controller node) the law either
    holds them with finite gains or refuses with a TensegrityError that says why."""
    from tensegrity_core.class2.control import TrackingController
    from tensegrity_core.errors import TensegrityError

    ctrl = TrackingController(PAPER_PARAMS, dt=0.01, max_force=5.0)
    try:
        ctrl.hold(rho1, rho2, 0.0)
    except TensegrityError as err:
        assert str(err) and ctrl.reference is None
    else:
        assert np.all(np.isfinite(ctrl.gains.K))


def test_the_folded_mechanism_cannot_be_held_and_says_so():
    from tensegrity_core.class2.control import PlanningError, TrackingController

    with pytest.raises(PlanningError, match=r"no stabilising feedback gain at rho = \(0, 0\) m"):
        TrackingController(PAPER_PARAMS, dt=0.01, max_force=5.0).hold(0.0, 0.0, 0.0)
