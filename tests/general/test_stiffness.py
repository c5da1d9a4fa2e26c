"""The exact tangent stiffness against finite differences, in and out of equilibrium."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.general import (
    Configuration,
    equilibrium_matrix,
    form_find,
    generalized_force,
    load_example,
    modal_analysis,
    out_of_balance,
    stiffness_parts,
    tangent_stiffness,
)
from tensegrity_core.general.rotation import hat
from tensegrity_core.general.statics import axial_stiffness, member_lengths


def left_jacobian(theta):
    """Left Jacobian of SO(3), by its series where the closed form cancels."""
    a = np.linalg.norm(theta)
    K = hat(theta)
    if a < 1e-3:
        return np.eye(3) + (0.5 - a**2 / 24) * K + (1 / 6 - a**2 / 120) * K @ K
    return np.eye(3) + (1 - np.cos(a)) / a**2 * K + (a - np.sin(a)) / a**3 * K @ K


def energy_gradient(s, base, dU):
    """dV/dU at the increment dU from ``base`` (chain rule through exp: J_l^T on rotations)."""
    g = -generalized_force(s, base.retract(dU))
    for b in s.layout.body_dof:
        g[b + 3:b + 6] = left_jacobian(dU[b + 3:b + 6]).T @ g[b + 3:b + 6]
    return g


def fd_hessian(s, base, h=1e-5):
    n = s.layout.n_dof
    return np.array([(energy_gradient(s, base, h * e) - energy_gradient(s, base, -h * e)) / (2 * h)
                     for e in np.eye(n)]).T


def assert_matches_fd(s, base, rtol=1e-7):
    K = tangent_stiffness(s, base)
    H = fd_hessian(s, base)
    scale = np.abs(K).max()
    np.testing.assert_allclose(K, H, atol=rtol * scale)
    np.testing.assert_allclose(K, K.T, atol=1e-12 * scale)
    return K


@pytest.mark.parametrize("seed", range(8))
def test_exact_stiffness_off_equilibrium_with_loads_on_body_nodes(loaded_structures, seed):
    s = loaded_structures(seed)
    base = Configuration.initial(s).retract(0.2 * np.random.default_rng(seed).normal(size=s.layout.n_dof))
    assert out_of_balance(s, base).residual > 1.0           # far from equilibrium
    assert_matches_fd(s, base)


@pytest.mark.parametrize("name", ["tensegrity_table", "patio_shade", "spherical_octahedron", "spine_s", "t_bar"])
def test_exact_stiffness_of_the_examples_off_and_at_equilibrium(name):
    s = load_example(name)
    # a random nudge keeps every string off its kink (l = l0)
    assert_matches_fd(s, Configuration.initial(s).retract(1e-3 * np.random.default_rng(1).normal(size=s.layout.n_dof)))
    r = form_find(s)
    assert_matches_fd(s, r.configuration)


def test_stiffness_with_gravity_and_loads_at_an_equilibrium():
    """Dead loads and weights on body nodes at an equilibrium: K_L is needed to match."""
    from tensegrity_core.general import RigidBody

    s = load_example("tensegrity_table")
    loads = np.zeros((8, 3))
    loads[4:7] = [[1e5, 0, -2e5], [-1e5, 5e4, -2e5], [0, -5e4, -2e5]]
    s = s.replace(loads=loads, gravity=np.array([0, 0, -9.81]), node_masses=np.full(8, 100.0),
                  bodies=(RigidBody("bottom", s.bodies[0].nodes, fixed=True),
                          RigidBody("top", s.bodies[1].nodes, mass=500.0)))
    base = form_find(s, check_stability=False).configuration
    assert out_of_balance(s, base).residual < 1e-3
    K = assert_matches_fd(s, base)
    parts = stiffness_parts(s, base)
    assert np.abs(parts["KL"]).max() > 1e3                   # the load stiffness matters here
    np.testing.assert_allclose(parts["KE"] + parts["KG"] + parts["KL"], K, atol=1e-8)


def test_sparse_equals_dense_and_material_part_is_A_k_At(loaded_structure):
    s = loaded_structure
    c = Configuration.initial(s).retract(0.1 * np.random.default_rng(9).normal(size=s.layout.n_dof))
    np.testing.assert_array_equal(tangent_stiffness(s, c, sparse=True).toarray(), tangent_stiffness(s, c))
    A = equilibrium_matrix(s, c)
    k = axial_stiffness(s, member_lengths(s, c.coords))
    np.testing.assert_allclose(stiffness_parts(s, c)["KE"], A @ np.diag(k) @ A.T, atol=1e-12)   # Eq. 72


def test_jacobian_of_the_physical_moment_is_not_symmetric_off_equilibrium(loaded_structure):
    """-d(moment)/d(theta) = K_T + 1/2 hat(M): the physical residual's Jacobian differs from
    the energy Hessian by 1/2 hat(M) in each body's rotation block (zero at equilibrium)."""
    s = loaded_structure
    base = Configuration.initial(s).retract(0.2 * np.random.default_rng(4).normal(size=s.layout.n_dof))
    h = 1e-6
    J = -np.array([(generalized_force(s, base.retract(h * e)) - generalized_force(s, base.retract(-h * e))) / (2 * h)
                   for e in np.eye(s.layout.n_dof)]).T
    K = tangent_stiffness(s, base)
    M = out_of_balance(s, base).body_moments[0]
    b = s.layout.body_dof[0] + 3
    expected = K.copy()
    expected[b:b + 3, b:b + 3] += 0.5 * hat(M)
    np.testing.assert_allclose(J, expected, atol=1e-6 * np.abs(K).max())
    assert np.linalg.norm(M) > 1.0


def test_modal_analysis_of_the_table():
    s = load_example("tensegrity_table")
    r = form_find(s)
    ma = modal_analysis(s, r.configuration)
    K = tangent_stiffness(s, r.configuration)
    np.testing.assert_allclose(K @ ma.modes, ma.modes * ma.eigenvalues, atol=1e-6 * np.abs(K).max())
    assert ma.displacements.shape == (12, 8, 3)
    assert np.all(np.diff(ma.eigenvalues) >= 0)


@pytest.mark.parametrize("n_modes", [0, -1, 2.5, True, "3"])
def test_modal_analysis_refuses_a_mode_count_that_is_not_a_whole_number_of_at_least_one(n_modes):
    """No silent clamp: asking for 0 or -1 modes is a mistake, not a request for one."""
    from tensegrity_core.errors import ParameterError

    with pytest.raises(ParameterError, match=f"n_modes must be a whole number >= 1 .*got {n_modes!r}"):
        modal_analysis(load_example("t_bar"), n_modes=n_modes)


def test_modal_analysis_gives_the_modes_asked_for_up_to_the_degrees_of_freedom():
    s = load_example("t_bar")
    n = s.layout.n_dof
    assert [len(modal_analysis(s, n_modes=k).eigenvalues) for k in (1, np.int64(2), n, n + 5)] == [1, 2, n, n]
