"""Structure of the class-2 equations of motion, checked against independent computations.

Independent oracles: the kinetic energy of the four rods from finite differences of
geometry.node_positions; spring-length gradients from finite differences of
geometry.member_lengths; grad U from finite differences of energy.potential_energy;
the rhs Jacobian from finite differences of the rhs.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.class2 import dynamics as dyn
from tensegrity_core.class2.dynamics import potential_hessian, rhs_jacobian
from tensegrity_core.class2.energy import potential_energy
from tensegrity_core.class2.geometry import MEMBERS, SPRINGS, member_lengths, node_positions
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import DomainError, ParameterError, SingularityError

PARAMS = Class2Params(L=1.3, m=1.7, k1=0.8, k2=1.9, k3=0.6, k4=1.4, c1=0.11, c2=0.23, c3=0.07, c4=0.31)


@st.composite
def states(draw, L=PARAMS.L):
    rho1 = draw(st.floats(0.02, 0.95)) * L
    rho2 = draw(st.floats(0.02, 0.98)) * (1.95 * L - rho1)
    beta = draw(st.floats(-math.pi, math.pi))
    qdot = [draw(st.floats(-3.0, 3.0)) for _ in range(3)]
    return np.array([rho1, rho2, beta]), np.array(qdot)


def node_jacobian(q, params, h=1e-6):
    """d(node positions)/dq by central differences, shape (6, 2, 3)."""
    cols = [(node_positions(q + h * e, params) - node_positions(q - h * e, params)) / (2 * h) for e in np.eye(3)]
    return np.stack(cols, -1)


def rods_kinetic_energy(q, qdot, params):
    """Sum over struts of 1/2 m |v_centroid|^2 + 1/2 (m L^2/12) omega^2, from node velocities."""
    p = node_positions(q, params)
    v = node_jacobian(q, params) @ qdot
    t = 0.0
    for member in MEMBERS:
        if member.kind != "strut":
            continue
        i, j = member.nodes
        r, rd = p[j] - p[i], v[j] - v[i]
        omega = (r[0] * rd[1] - r[1] * rd[0]) / (r @ r)
        vc = 0.5 * (v[i] + v[j])
        t += 0.5 * params.m * vc @ vc + 0.5 * params.inertia * omega**2
    return t


@given(states())
def test_kinetic_energy_equals_rod_energy_from_node_velocities(state):
    q, qdot = state
    want = rods_kinetic_energy(q, qdot, PARAMS)
    assert dyn.kinetic_energy(q, qdot, PARAMS) == pytest.approx(want, rel=1e-7, abs=1e-9)


@given(states())
def test_mass_matrix_is_the_hessian_of_the_independent_kinetic_energy(state):
    q, _ = state
    T = lambda v: rods_kinetic_energy(q, v, PARAMS)  # noqa: E731
    E = np.eye(3)
    numeric = np.array([[T(E[i] + E[j]) - T(E[i]) - T(E[j]) for j in range(3)] for i in range(3)])
    M = dyn.mass_matrix(q, PARAMS)
    np.testing.assert_allclose(M, numeric, rtol=1e-6, atol=1e-7)


@given(states())
def test_mass_matrix_symmetric_positive_definite_with_known_zero(state):
    q, _ = state
    M = dyn.mass_matrix(q, PARAMS)
    np.testing.assert_array_equal(M, M.T)
    assert M[1, 2] == 0.0 and M[0, 1] == M[1, 1]
    assert np.linalg.eigvalsh(M).min() > 0
    # Schur complement of the rho1 row: >= m/4 (module docstring).
    schur = M[0, 0] - M[0, 1] - M[0, 2] ** 2 / M[2, 2]
    assert schur >= PARAMS.m / 4 * (1 - 1e-12)


@given(states())
def test_damping_matrix_is_sum_of_c_grad_length_outer_products(state):
    q, _ = state
    h = 1e-6
    grads = np.stack([(member_lengths(q + h * e, PARAMS) - member_lengths(q - h * e, PARAMS)) / (2 * h)
                      for e in np.eye(3)], -1)
    want = sum(getattr(PARAMS, m.damping) * np.outer(grads[m.number - 1], grads[m.number - 1]) for m in SPRINGS)
    H = dyn.damping_matrix(q, PARAMS)
    np.testing.assert_allclose(H, want, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(H, H.T, atol=1e-15)
    assert np.linalg.eigvalsh(H).min() > -1e-12 * np.abs(H).max()


def test_damping_matrix_is_rank_deficient_psd_not_pd():
    """Four dampers on three coordinates can still miss a direction: H is PSD, and exactly
    singular when all c_j but one vanish (rank 1)."""
    one = PARAMS.with_overrides(c1=0.0, c2=0.0, c4=0.0)
    H = dyn.damping_matrix([0.4, 0.5, 0.9], one)
    ev = np.linalg.eigvalsh(H)
    assert ev[:2] == pytest.approx([0, 0], abs=1e-15) and ev[2] > 0


@given(states())
def test_potential_gradient_and_hessian_match_finite_differences(state):
    q, _ = state
    h = 1e-6
    grad = np.array([(potential_energy(q + h * e, PARAMS) - potential_energy(q - h * e, PARAMS)) / (2 * h)
                     for e in np.eye(3)])
    np.testing.assert_allclose(dyn.potential_gradient(q, PARAMS), grad, rtol=1e-6, atol=1e-8)
    hess = np.stack([(dyn.potential_gradient(q + h * e, PARAMS) - dyn.potential_gradient(q - h * e, PARAMS)) / (2 * h)
                     for e in np.eye(3)], -1)
    np.testing.assert_allclose(potential_hessian(q, PARAMS), hess, rtol=1e-6, atol=1e-7)


@given(states())
def test_velocity_terms_satisfy_the_skew_symmetry_identity(state):
    """qdot^T C = 1/2 qdot^T Mdot qdot (Mdot from finite differences of M along qdot)."""
    q, qdot = state
    h = 1e-6
    Mdot = (dyn.mass_matrix(q + h * qdot, PARAMS) - dyn.mass_matrix(q - h * qdot, PARAMS)) / (2 * h)
    lhs = qdot @ dyn.velocity_terms(q, qdot, PARAMS)
    assert lhs == pytest.approx(0.5 * qdot @ Mdot @ qdot, rel=1e-6, abs=1e-7)


@given(states(), st.floats(-5, 5), st.floats(-5, 5))
def test_acceleration_solves_the_matrix_equation(state, f1, f2):
    q, qdot = state
    rhs = -(dyn.velocity_terms(q, qdot, PARAMS) + dyn.damping_matrix(q, PARAMS) @ qdot
            + dyn.potential_gradient(q, PARAMS) + np.array([f1, f2, 0.0]))
    want = np.linalg.solve(dyn.mass_matrix(q, PARAMS), rhs)
    np.testing.assert_allclose(dyn.acceleration(q, qdot, f1, f2, PARAMS), want, rtol=1e-10, atol=1e-10)
    gen = dyn.generalized_forces(q, qdot, f1, f2, PARAMS)
    np.testing.assert_allclose(gen, -dyn.damping_matrix(q, PARAMS) @ qdot - [f1, f2, 0], atol=1e-14)


@given(states(), st.floats(-5, 5), st.floats(-5, 5))
def test_scalar_batch_and_function_paths_agree(state, f1, f2):
    q, qdot = state
    model = dyn.Class2Dynamics(PARAMS)
    scalar = np.array(model.acceleration_scalar(*q.tolist(), *qdot.tolist(), f1, f2))
    batch = model.acceleration_batch(np.concatenate([q, qdot])[None, :], f1, f2)[0]
    np.testing.assert_allclose(batch, scalar, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(model.rhs(0.0, np.concatenate([q, qdot]), f1, f2), np.concatenate([qdot, scalar]),
                               rtol=1e-13, atol=1e-13)


def test_batch_of_many_states_with_per_state_forces():
    rng = np.random.default_rng(2)
    n = 500
    y = np.column_stack([rng.uniform(0.05, 0.9, n) * PARAMS.L, rng.uniform(0.05, 0.9, n) * PARAMS.L,
                         rng.uniform(-3, 3, n), rng.normal(size=(n, 3))])
    f1, f2 = rng.normal(size=n), rng.normal(size=n)
    model = dyn.Class2Dynamics(PARAMS)
    batch = model.acceleration_batch(y, f1, f2)
    assert batch.shape == (n, 3)
    loop = np.array([model.acceleration_scalar(*row, a, b) for row, a, b in zip(y.tolist(), f1, f2)])
    np.testing.assert_allclose(batch, loop, rtol=1e-13, atol=1e-12)
    # Leading dimensions broadcast in the function form too.
    grid = dyn.acceleration(y[:, :3].reshape(25, 20, 3), y[:, 3:].reshape(25, 20, 3), f1.reshape(25, 20),
                            f2.reshape(25, 20), PARAMS)
    np.testing.assert_allclose(grid.reshape(n, 3), loop, rtol=1e-13, atol=1e-12)


@given(states(), st.floats(-5, 5), st.floats(-5, 5))
def test_rhs_jacobian_matches_finite_differences(state, f1, f2):
    q, qdot = state
    y = np.concatenate([q, qdot])
    dfy = np.array([[0.3, -0.2, 0.1, 0.5, 0.0, -0.4], [0.0, 1.1, -0.3, 0.2, 0.7, 0.0]])
    model = dyn.Class2Dynamics(PARAMS)

    def rhs(yy):
        return model.rhs(0.0, yy, f1 + dfy[0] @ (yy - y), f2 + dfy[1] @ (yy - y))

    h = 1e-6
    numeric = np.stack([(rhs(y + h * e) - rhs(y - h * e)) / (2 * h) for e in np.eye(6)], -1)
    analytic = model.jacobian(0.0, y, f1, f2, dforce_dy=dfy)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-6 * (1 + np.abs(numeric).max()))


def test_negative_actuator_lengths_are_evaluated_not_refused():
    """The unconstrained equations continue through rho = 0 (the paper simulation needs it)."""
    a = dyn.acceleration([-0.2, -0.1, 1.0], [0.1, 0.0, 0.0], 0.0, 0.0, PAPER_PARAMS)
    assert np.all(np.isfinite(a))


@pytest.mark.parametrize("q, kind", [
    ([0.5, 1.5 - 1e-9, 0.3], "lambda1"),        # rho1 + rho2 -> 2L: struts AE, CE flat
    ([1.0 - 4e-9, 0.2, 0.3], "lambda2"),        # rho1 -> L: strut BF flat
    ([-1.0 + 4e-9, 0.2, 0.3], "lambda2"),
])
def test_singular_sets_raise_with_kind_and_distance(q, kind):
    model = dyn.Class2Dynamics(PAPER_PARAMS)
    L = PAPER_PARAMS.L
    with pytest.raises(SingularityError) as err:
        model.acceleration_scalar(*q, 0.0, 0.0, 0.0)
    assert err.value.kind == kind
    rho1, rho2 = q[0], q[1]
    lam = math.sqrt(4 * L**2 - (rho1 + rho2) ** 2) if kind == "lambda1" else math.sqrt(L**2 - rho1**2)
    assert err.value.distance == pytest.approx(lam, rel=1e-6)
    assert err.value.limit == pytest.approx(dyn.LAMBDA_MIN_REL * L)
    assert kind in str(err.value)
    for fn in (lambda: dyn.mass_matrix(q, PAPER_PARAMS), lambda: dyn.acceleration(q, [0, 0, 0], 0, 0, PAPER_PARAMS),
               lambda: model.acceleration_batch(np.array([[0.3, 0.3, 0, 0, 0, 0], [*q, 0, 0, 0]]))):
        with pytest.raises(SingularityError, match=kind):
            fn()


def test_batch_error_names_the_offending_state():
    model = dyn.Class2Dynamics(PAPER_PARAMS)
    y = np.zeros((4, 6))
    y[:, :2] = 0.3
    y[2, 0] = 1.0
    with pytest.raises(SingularityError, match=r"state \(2,\)"):
        model.acceleration_batch(y)


def test_lambda_min_is_configurable_and_validated():
    q = [0.5, 1.5 - 1e-9, 0.3]
    assert np.all(np.isfinite(dyn.Class2Dynamics(PAPER_PARAMS, lambda_min=1e-6).acceleration_scalar(*q, 0, 0, 0)))
    for bad in (0.0, -1.0, 1.0, float("nan"), "x", True):
        with pytest.raises(ParameterError, match="lambda_min"):
            dyn.Class2Dynamics(PAPER_PARAMS, lambda_min=bad)
        with pytest.raises(ParameterError, match="lambda_min"):
            dyn.mass_matrix([0.3, 0.3, 0.0], PAPER_PARAMS, lambda_min=bad)


@pytest.mark.parametrize("q", [[1.2, 0.1, 0.0], [0.9, 1.2, 0.0], [-0.9, -1.2, 0.0]])
def test_nonexistent_configurations_raise_domain_error(q):
    with pytest.raises(DomainError, match="does not exist"):
        dyn.Class2Dynamics(PAPER_PARAMS).acceleration_scalar(*q, 0, 0, 0)
    with pytest.raises(DomainError, match="does not exist"):
        dyn.mass_matrix(q, PAPER_PARAMS)


@pytest.mark.parametrize("bad", [
    (float("nan"), 0.3, 0.1, 0, 0, 0, 0, 0),
    (0.3, 0.3, float("nan"), 0, 0, 0, 0, 0),
    (0.3, 0.3, float("inf"), 0, 0, 0, 0, 0),
    (0.3, 0.3, 0.1, float("inf"), 0, 0, 0, 0),
    (0.3, 0.3, 0.1, 0, 0, 0, float("nan"), 0),
])
def test_non_finite_input_raises_instead_of_returning_nan(bad):
    model = dyn.Class2Dynamics(PAPER_PARAMS)
    with pytest.raises(DomainError):
        model.acceleration_scalar(*bad)
    with pytest.raises(DomainError):
        model.acceleration_batch(np.array([bad[:6]]), bad[6], bad[7])
    with pytest.raises(DomainError):
        model.rhs(0.0, np.array(bad[:6]), bad[6], bad[7])


def test_shape_validation_messages():
    with pytest.raises(DomainError, match="trailing dimension of q must be 3"):
        dyn.mass_matrix([0.1, 0.2], PAPER_PARAMS)
    with pytest.raises(DomainError, match="trailing dimension of states must be 6"):
        dyn.Class2Dynamics().acceleration_batch(np.zeros((3, 5)))
    with pytest.raises(DomainError, match="dforce_dy"):
        rhs_jacobian([0.3, 0.3, 0.1], [0, 0, 0], 0, 0, PAPER_PARAMS, dforce_dy=np.zeros((3, 3)))
    with pytest.raises(ParameterError, match="Class2Params"):
        dyn.Class2Dynamics({"L": 1.0})


def test_zero_length_spring_damper_is_bounded_and_continuous():
    """At the folded configuration springs EF and DE have zero length: the damper force is
    defined (zero for that spring) and the neighbourhood stays bounded by c |ddot|."""
    q_fold = np.array([0.0, 0.0, math.pi / 2])
    H = dyn.damping_matrix(q_fold, PAPER_PARAMS)
    assert np.all(np.isfinite(H))
    qdot = np.array([0.3, -0.2, 0.5])
    for eps in (1e-3, 1e-6, 1e-9):
        F = dyn.damping_matrix(q_fold + eps * np.array([1.0, 0.5, 0.2]), PAPER_PARAMS) @ qdot
        assert np.all(np.isfinite(F)) and np.abs(F).max() < 4 * 0.01 * 10 * np.abs(qdot).max()
