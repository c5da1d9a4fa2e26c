"""The paper's equations checked numerically; each test names the equation and the erratum.

See docs/design/general.md, "Errata", for the list.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.general import (
    Configuration,
    RigidBody,
    Structure,
    equilibrium_matrix,
    form_find,
    load_example,
    modes,
    out_of_balance,
    potential_energy,
    tangent_stiffness,
    transformation_matrix,
)
from tensegrity_core.general.rotation import hat
from tests.general.paper_oracle import (
    euler_configuration,
    euler_generalized_force,
    euler_matrix,
    euler_rate_matrix,
    euler_transform,
    paper_tangent_stiffness,
)

angles = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)


def passive(axis, a):
    c, s = np.cos(a), np.sin(a)
    return {1: np.array([[1, 0, 0], [0, c, s], [0, -s, c]]),
            2: np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]]),
            3: np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])}[axis]


def unhat(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def euler_angles(R):
    """Inverse of Eq. 24 (away from beta = +-pi/2)."""
    return np.array([np.arctan2(-R[2, 1], R[2, 2]), np.arcsin(R[2, 0]), np.arctan2(-R[1, 0], R[0, 0])])


@given(angles)
def test_eq24_is_R3_R2_R1_of_passive_rotations(phi):
    R = euler_matrix(phi)
    np.testing.assert_allclose(R, passive(3, phi[2]) @ passive(2, phi[1]) @ passive(1, phi[0]), atol=1e-14)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(R) == pytest.approx(1.0)
    if abs(phi[1]) < 1.5:
        np.testing.assert_allclose(euler_angles(R), phi, atol=1e-9)


@given(angles)
def test_eq37_maps_euler_rates_to_the_inertial_angular_velocity(phi):
    """With n = c + R^T p (Eq. 29), hat(omega) = d(R^T)/dt R: omega = B phi_dot (Eq. 36-37)."""
    h = 1e-6
    Q = lambda p: euler_matrix(p).T  # noqa: E731
    B = np.array([unhat((Q(phi + h * e) - Q(phi - h * e)) / (2 * h) @ Q(phi).T) for e in np.eye(3)]).T
    np.testing.assert_allclose(B, euler_rate_matrix(phi), atol=1e-8)
    assert np.linalg.det(euler_rate_matrix(phi)) == pytest.approx(np.cos(phi[1]), abs=1e-12)


def test_B_is_singular_at_beta_half_pi_not_at_zero():
    """Erratum (Sect. 2.2.1): the text puts the singularity at beta = 0; det B = cos(beta)."""
    assert np.linalg.matrix_rank(euler_rate_matrix([0.4, 0.0, 0.2])) == 3
    for beta in (np.pi / 2, -np.pi / 2):
        assert np.linalg.matrix_rank(euler_rate_matrix([0.4, beta, 0.2]), tol=1e-12) == 2


def test_eq29_second_form_has_the_wrong_sign(platform):
    """r_ij = R^T (n_qij0 - n_ci0) (first form, correct) = n_qij - n_ci, whereas the printed
    second form (E_nci^T - E_nqij^T) n is n_ci - n_qij = -r_ij."""
    s = platform
    phi = np.array([0.3, -0.5, 1.2])
    c = euler_configuration(s, [], [[0.1, 0.2, 0.3]], [phi])
    idx = list(s.bodies[0].nodes)
    r_first = (s.nodes[idx] - s.nodes[idx].mean(axis=0)) @ euler_matrix(phi)   # rows: (R^T p)^T
    np.testing.assert_allclose(c.coords[idx] - c.centres[0], r_first, atol=1e-14)
    printed_second = c.centres[0] - c.coords[idx]
    np.testing.assert_allclose(printed_second, -r_first, atol=1e-14)


def test_eqs40_41_G_of_the_euler_parametrisation(platform):
    s = platform
    phi = np.array([0.3, -0.5, 1.2])
    cfg = lambda p: euler_configuration(s, [], [[0.1, 0.2, 0.3]], [p]).coords[:4]  # noqa: E731
    h = 1e-6
    dn = np.array([(cfg(phi + h * e) - cfg(phi - h * e)) / (2 * h) for e in np.eye(3)])   # (3, 4, 3)
    c = euler_configuration(s, [], [[0.1, 0.2, 0.3]], [phi])
    for j in range(4):
        r = c.coords[j] - c.centres[0]
        np.testing.assert_allclose(dn[:, j, :].T, -hat(r) @ euler_rate_matrix(phi), atol=1e-8)
    G_paper = transformation_matrix(c).toarray() @ euler_transform(s, [phi])
    np.testing.assert_allclose(G_paper[:12, 3:], dn.transpose(1, 2, 0).reshape(12, 3), atol=1e-8)


def test_eqs55_58_generalized_force_is_B_transpose_moment(platform):
    s = platform.replace(loads=np.r_[np.random.default_rng(0).normal(size=(4, 3)), np.zeros((8, 3))])
    phi = np.array([0.3, -0.5, 1.2])
    centre = np.array([0.05, -0.02, 0.01])
    V = lambda p: potential_energy(s, euler_configuration(s, [], [centre], [p]).coords)  # noqa: E731
    h = 1e-6
    dV = np.array([(V(phi + h * e) - V(phi - h * e)) / (2 * h) for e in np.eye(3)])
    c = euler_configuration(s, [], [centre], [phi])
    np.testing.assert_allclose(euler_generalized_force(c, [phi])[3:], -dV, rtol=1e-6, atol=1e-6)


def test_at_the_singular_attitude_the_generalized_force_vanishes_under_a_real_moment():
    """The paper's convergence measure (generalised force, Eq. 62) can be zero while the
    body carries an unbalanced moment: B^T m = 0 for m in the null space of B^T."""
    tri = np.array([[1, 0, 0], [-0.5, 0.8, 0], [-0.5, -0.8, 0.0]])
    phi = np.array([0.7, np.pi / 2, -0.3])
    m = np.linalg.svd(euler_rate_matrix(phi).T)[2][-1]             # B^T m = 0, |m| = 1
    assert np.abs(euler_rate_matrix(phi).T @ m).max() < 1e-15
    s0 = Structure.from_arrays(np.vstack([tri, [[0, 0, 5.0]]]), [[0, 3]], EA=1.0, rest_length_ratio=2.0,
                               bodies=[RigidBody("t", (0, 1, 2))], pinned=[False] * 3 + [True])
    x = euler_configuration(s0, [], [[0, 0, 0]], [phi]).coords[:3]
    # least-norm nodal loads with zero resultant and moment m about the centre
    A = np.zeros((6, 9))
    for j in range(3):
        A[:3, 3 * j:3 * j + 3] = np.eye(3)
        A[3:, 3 * j:3 * j + 3] = hat(x[j])
    f = np.linalg.lstsq(A, np.r_[np.zeros(3), m], rcond=None)[0].reshape(3, 3)
    s = s0.replace(loads=np.vstack([f, np.zeros((1, 3))]))
    c = euler_configuration(s, [], [[0, 0, 0]], [phi])
    physical = out_of_balance(s, c)
    np.testing.assert_allclose(physical.body_moments[0], m, atol=1e-12)
    np.testing.assert_allclose(physical.body_forces[0], 0, atol=1e-12)
    assert np.abs(euler_generalized_force(c, [phi])).max() < 1e-12        # "converged"
    assert physical.residual > 0.5                                         # but it is not


def test_eq66_kronecker_form_equals_the_assembled_equilibrium_matrix(loaded_structure):
    s = loaded_structure
    c = Configuration.initial(s).retract(0.1 * np.random.default_rng(1).normal(size=s.layout.n_dof))
    C = np.zeros((s.n_members, s.n_nodes))
    C[np.arange(s.n_members), s.members[:, 0]] = -1                     # Eq. 13
    C[np.arange(s.n_members), s.members[:, 1]] = 1
    H = c.coords.T @ C.T                                                 # Eq. 15
    lengths = np.linalg.norm(H, axis=0)
    bd = np.zeros((3 * s.n_members, s.n_members))
    for i in range(s.n_members):
        bd[3 * i:3 * i + 3, i] = H[:, i]
    A2 = np.kron(C.T, np.eye(3)) @ bd @ np.diag(1 / lengths)             # Eq. 66
    G = transformation_matrix(c).toarray()
    np.testing.assert_allclose(G.T @ A2, equilibrium_matrix(s, c), atol=1e-13)   # Eq. 65


def _platform_equilibrium(s, phi_eq):
    """The platform's equilibrium (net forces below 1e-6 N: tol 1e-12 of the forces at the
    body) redrawn so that its Euler angles there are ``phi_eq``."""
    ref = form_find(s, tol=1e-12).configuration
    Q = euler_matrix(phi_eq).T
    drawn = s.nodes.copy()
    drawn[:4] = ref.centres[0] + (ref.coords[:4] - ref.centres[0]) @ Q
    s2 = s.with_nodes(drawn)
    return s2, euler_configuration(s2, [], ref.centres, [phi_eq])


def _euler_hessian(s, centre, phi, h=1e-4):
    def V(x):
        return potential_energy(s, euler_configuration(s, [], [x[:3]], [x[3:]]).coords)
    x0 = np.r_[centre, phi]
    H = np.zeros((6, 6))
    for i in range(6):
        for j in range(6):
            ei, ej = h * np.eye(6)[i], h * np.eye(6)[j]
            H[i, j] = (V(x0 + ei + ej) - V(x0 + ei - ej) - V(x0 - ei + ej) + V(x0 - ei - ej)) / (4 * h * h)
    return H


def test_eqs73_80_are_exact_at_an_unloaded_equilibrium(platform):
    phi = np.array([0.4, -0.6, 0.9])
    s, c = _platform_equilibrium(platform, phi)
    assert out_of_balance(s, c).residual < 1e-6
    H = _euler_hessian(s, c.centres[0], phi)
    np.testing.assert_allclose(paper_tangent_stiffness(c, [phi]), H, atol=1e-5 * np.abs(H).max())


def test_eqs73_80_miss_terms_off_equilibrium_and_under_loads(platform):
    """Off equilibrium the paper's K_G lacks dB/dphi and is not symmetric; with dead loads
    on body nodes it lacks the load stiffness. The exact K_T (rotation vector) matches FD."""
    phi = np.array([0.4, -0.6, 0.9])
    s, c = _platform_equilibrium(platform, phi)
    off = euler_configuration(s, [], c.centres + 0.05, [phi + 0.2])
    H = _euler_hessian(s, off.centres[0], phi + 0.2)
    K = paper_tangent_stiffness(off, [phi + 0.2])
    assert np.abs(K - H).max() > 1e-2 * np.abs(H).max()
    assert np.abs(K - K.T).max() > 1e-3 * np.abs(K).max()

    loads = np.zeros((12, 3))
    loads[:4] = [[2000, 0, 0], [-2000, 0, 0], [0, 1500, 0], [0, -1500, 0]]   # a couple on the body
    sl = s.replace(loads=loads)
    eq = form_find(sl, x0=c.coords).configuration
    phi_l = euler_angles(eq.rotations[0].T)
    ceq = euler_configuration(sl, [], eq.centres, [phi_l])
    np.testing.assert_allclose(ceq.coords, eq.coords, atol=1e-10)
    H = _euler_hessian(sl, ceq.centres[0], phi_l)
    rot = np.s_[3:, 3:]
    assert np.abs(paper_tangent_stiffness(ceq, [phi_l]) - H)[rot].max() > 1e-2 * np.abs(H[rot]).max()
    T = euler_transform(sl, [phi_l])
    np.testing.assert_allclose(T.T @ tangent_stiffness(sl, eq) @ T, H, atol=1e-5 * np.abs(H).max())


PRINTED_A_R = np.array([            # Eq. 88 as printed (row 3, column 5 reads 1)
    [0, 0, -0.0189, -0.8251, 0.8300],
    [0, 0, -0.9998, 0.5649, 0.5577],
    [0, 0, 0, 0, 1],
    [-0.8523, 0.8635, 0.0189, 0, 0],
    [-0.5231, -0.5044, 0.9998, 0, 0],
    [0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0],
    [-0.0259, 0.0060, 0.0199, 0, 0]])
PRINTED_V2 = np.array([-0.4678, -0.4514, -0.4725, -0.4166, -0.4250])     # Eq. 89


def test_eq88_entry_row3_col5_is_a_misprint():
    assert abs((PRINTED_A_R @ PRINTED_V2)[2]) > 0.4
    fixed = PRINTED_A_R.copy()
    fixed[2, 4] = 0.0
    assert np.abs(fixed @ PRINTED_V2).max() < 2e-4


def test_eq86_connectivity_has_one_column_too_many():
    """Eq. 86 prints C as 5 x 9 for 8 nodes; dropping the last (all-zero) column gives the
    members of the shipped example in the paper's numbering."""
    printed = np.array([[-1, 0, 0, 1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 1, 0, 0, 0, 0],
                        [0, 0, -1, 0, 0, 1, 0, 0, 0], [0, 0, 0, 0, 0, -1, 1, 0, 0],
                        [0, 0, 0, 0, 0, -1, 0, 1, 0]])
    assert printed.shape == (5, 9) and not printed[:, 8].any()
    s = load_example("patio_shade")
    C = np.zeros((5, 8))
    C[np.arange(5), s.members[:, 0]] = -1
    C[np.arange(5), s.members[:, 1]] = 1
    np.testing.assert_array_equal(C, printed[:, :8])


PRINTED_V2_TABLE = np.array([0.2887, 0.2887, 0.2887, 0.8660])                # Eq. 91


def test_eq91_is_one_one_one_three():
    """Eq. 91: the tensegrity table's one self-stress mode at its equilibrium. The core's
    mode (SVD of A_r at the form-found shape) matches the printed digits and is exactly
    [1, 1, 1, 3] / sqrt(12): the three long strings equally taut, the short one three times."""
    s = load_example("tensegrity_table")
    r = form_find(s)
    assert r.success
    m = modes(s, r.configuration)
    assert m.self_stress.shape == (4, 1)
    v = m.self_stress[:, 0]
    np.testing.assert_allclose(v, PRINTED_V2_TABLE, atol=5e-5)
    np.testing.assert_allclose(v, np.array([1, 1, 1, 3]) / np.sqrt(12), atol=1e-12)
