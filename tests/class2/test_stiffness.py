"""Stiffness (Sect. 4): three independent routes, the paper's matrices, Eq. (35), Fig. 2 claims."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.class2 import PAPER_PARAMS, dU_dbeta
from tensegrity_core.class2.geometry import MEMBERS, NODE_NAMES, member_lengths, node_positions
from tensegrity_core.class2.kinematics import forward_kinematics
from tensegrity_core.class2.stiffness import (
    FREE,
    critical_forces,
    equilibrium_matrix,
    member_forces,
    stiffness_along_coordinates,
    stiffness_matrix_assembled,
    stiffness_matrix_energy_fd,
    stiffness_sweep,
)
from tensegrity_core.errors import SingularityError
from tests.class2.strategies import configurations

P = PAPER_PARAMS
margin_configs = configurations(margin=0.05)
forces = st.floats(-5.0, 5.0)


def unit_vectors(rho1, rho2, beta):
    """n_i from the '-' node to the '+' node of the paper's Eq. (28) (n10: '+' at C as in Eq. 32)."""
    A, B, C, D, E, F = node_positions((rho1, rho2, beta), P)
    pairs = {1: (B, A), 2: (C, B), 3: (D, C), 4: (E, D), 5: (A, E), 6: (F, B), 7: (E, F),
             8: (B, E), 9: (D, B), 10: (E, C)}
    return {i: (b - a) / np.linalg.norm(b - a) for i, (a, b) in pairs.items()}


def printed_eq28(n, *, row_e_n10=+1):
    """Eq. (28) entry by entry (rows A..F as 2-vectors), n10's sign in row E selectable."""
    z = np.zeros(2)
    rows = [
        [n[1], z, z, z, -n[5], z, z, z, z, z],
        [-n[1], n[2], z, z, z, n[6], z, -n[8], n[9], z],
        [z, -n[2], n[3], z, z, z, z, z, z, n[10]],
        [z, z, -n[3], n[4], z, z, z, z, -n[9], z],
        [z, z, z, -n[4], n[5], z, -n[7], n[8], z, row_e_n10 * n[10]],
        [z, z, z, z, z, -n[6], n[7], z, z, z],
    ]
    return np.vstack([np.column_stack(r) for r in rows])


def printed_eq32(n):
    """Eq. (32): rows Bx; Cx; D (x, y); E (x, y); Fy."""
    z = np.zeros(2)
    return np.vstack([
        [-n[1][0], n[2][0], 0, 0, 0, n[6][0], 0, -n[8][0], n[9][0], 0],
        [0, -n[2][0], n[3][0], 0, 0, 0, 0, 0, 0, n[10][0]],
        np.column_stack([z, z, -n[3], n[4], z, z, z, z, -n[9], z]),
        np.column_stack([z, z, z, -n[4], n[5], z, -n[7], n[8], z, -n[10]]),
        [0, 0, 0, 0, 0, -n[6][1], n[7][1], 0, 0, 0],
    ])


def test_eq28_as_printed_breaks_newtons_third_law_in_column_10():
    fk = forward_kinematics(0.6, 0.9)
    n = unit_vectors(0.6, 0.9, fk.beta)
    printed = printed_eq28(n)
    ours = equilibrium_matrix(0.6, 0.9)
    # every member pushes its two nodes equally and oppositely: each column's x and y sums vanish
    sums = printed.reshape(6, 2, 10).sum(axis=0)
    assert np.abs(sums[:, :9]).max() < 1e-15 and np.abs(sums[:, 9]).max() > 0.5
    corrected = printed_eq28(n, row_e_n10=-1)
    assert np.allclose(corrected, ours, atol=1e-15)
    assert np.allclose(printed_eq32(n), ours[FREE], atol=1e-15)     # Eq. 32 has the right sign


def test_equilibrium_matrix_transpose_is_the_compatibility_matrix():
    rho1, rho2, beta = 0.4, 0.8, 0.9
    A = equilibrium_matrix(rho1, rho2, beta)
    X = node_positions((rho1, rho2, beta), P).reshape(-1)
    rng = np.random.default_rng(0)
    dX = rng.normal(size=12) * 1e-7
    ends = [(NODE_NAMES.index(m.name[0]), NODE_NAMES.index(m.name[1])) for m in MEMBERS]

    def length(X):
        p = X.reshape(6, 2)
        return np.array([np.linalg.norm(p[i] - p[j]) for i, j in ends])

    dl = (length(X + dX) - length(X - dX)) / 2
    assert A.T @ dX == pytest.approx(dl, abs=1e-14)


def test_A0_of_eq35_is_singular_with_the_rotation_of_D_as_left_null_vector():
    fk = forward_kinematics(0.7, 0.7)
    A_r = equilibrium_matrix(0.7, 0.7)[FREE]
    A0 = A_r[:, [0, 1, 4, 5, 7, 8, 9]]
    sv = np.linalg.svd(A0, compute_uv=False)
    assert sv[-1] < 1e-14 * sv[0] and sv[-2] > 0.1
    rotation = np.zeros(7)
    rotation[2:4] = [-math.sin(fk.beta), math.cos(fk.beta)]        # dD/dbeta / L on (Dx, Dy)
    assert np.abs(rotation @ A0).max() < 1e-15
    assert abs(rotation @ A_r[:, 2]) > 0.1 and abs(rotation @ A_r[:, 3]) > 0.1   # only L3, L4 change
    # a right null vector: self-stress of AB, BC, AE, BE, CE (t6 = t9 = 0)
    _, _, vt = np.linalg.svd(A0)
    s = vt[-1]
    assert abs(s[3]) < 1e-12 and abs(s[5]) < 1e-12 and np.abs(A0 @ s).max() < 1e-14


@given(margin_configs, forces, st.floats(-math.pi, math.pi))
def test_residual_is_zero_only_at_the_fkp_equilibrium(rho, f, beta):
    t, residual = member_forces(*rho, f, beta)
    # the residual is along the rotation of D, of size |dU/dbeta| / L
    assert np.linalg.norm(residual) == pytest.approx(abs(float(dU_dbeta((*rho, beta), P))) / P.L, abs=1e-12)
    t_eq, res_eq = member_forces(*rho, f)
    assert np.abs(res_eq).max() < 1e-12
    springs = [2, 3, 6, 7]
    lengths = member_lengths((*rho, forward_kinematics(*rho).beta), P)
    assert t_eq[springs] == pytest.approx(np.array([P.k3, P.k2, P.k1, P.k4]) * lengths[springs], rel=1e-14)


@given(margin_configs, forces)
def test_paper_procedure_equals_generic_assembly(rho, f):
    res = stiffness_along_coordinates(*rho, f)
    K_b = stiffness_matrix_assembled(*rho, f)
    assert np.abs(res.K - K_b).max() <= 1e-12 * np.abs(res.K).max()
    assert np.abs(res.K - res.K.T).max() <= 1e-12 * np.abs(res.K).max()


@given(margin_configs, forces, st.booleans())
def test_energy_hessian_by_finite_differences_agrees(rho, f, off_equilibrium):
    beta = forward_kinematics(*rho).beta + (0.3 if off_equilibrium else 0.0)
    K_a = stiffness_along_coordinates(*rho, f, beta=beta).K
    K_c = stiffness_matrix_energy_fd(*rho, f, beta)
    # step h = 1e-4 L: truncation ~ h^2 kb / l_min^2 <= 1e-8 * 1000 / 0.05^2 = 4e-3 (l_min >= 0.05
    # L with this margin) ~ 2e-6 max|K|; rounding ~ eps |energy| / h^2 ~ 1e-7.
    assert np.abs(K_a - K_c).max() <= 2e-5 * np.abs(K_a).max()


def test_eq39_reduced_stress_matrix_as_printed():
    res = stiffness_along_coordinates(0.5, 0.8, 1.5)
    th = dict(zip(range(1, 11), res.t / res.lengths))
    z2 = th[1] + th[2] + th[6] + th[8] + th[9]
    z3 = th[2] + th[3] + th[10]
    z4 = th[3] + th[4] + th[9]
    z5 = th[4] + th[5] + th[7] + th[8] + th[10]
    z6 = th[6] + th[7]
    S = np.array([
        [z2, -th[2], -th[9], 0, -th[8], 0, 0],
        [-th[2], z3, -th[3], 0, -th[10], 0, 0],
        [-th[9], -th[3], z4, 0, -th[4], 0, 0],
        [0, 0, 0, z4, 0, -th[4], 0],
        [-th[8], -th[10], -th[4], 0, z5, 0, 0],
        [0, 0, 0, -th[4], 0, z5, -th[7]],
        [0, 0, 0, 0, 0, -th[7], z6],
    ])
    A_r = equilibrium_matrix(0.5, 0.8)[FREE]
    assert res.K - A_r @ np.diag(res.g_hat) @ A_r.T == pytest.approx(S, abs=1e-12)


def test_modified_axial_stiffness_of_zero_free_length_springs_vanishes():
    res = stiffness_along_coordinates(0.3, 1.1, 2.0)
    assert res.g_hat[[2, 3, 6, 7]] == pytest.approx(np.zeros(4), abs=1e-14)
    assert res.g_hat[[0, 1]] == pytest.approx(10.0 - res.t[[0, 1]] / res.lengths[[0, 1]])


@given(margin_configs, forces)
def test_stiffness_along_a_coordinate_is_the_inverse_compliance(rho, f):
    res = stiffness_along_coordinates(*rho, f)
    compliance = np.linalg.inv(res.K)
    assert res.K_i == pytest.approx(1.0 / np.diag(compliance), rel=1e-8)


def test_stiffness_is_affine_in_f_and_critical_force_makes_K_singular():
    k0 = stiffness_along_coordinates(0.76, 0.76, 0.0).K
    k1 = stiffness_along_coordinates(0.76, 0.76, 1.0).K
    k3 = stiffness_along_coordinates(0.76, 0.76, -2.7).K
    assert k3 == pytest.approx(k0 - 2.7 * (k1 - k0), abs=1e-11)
    crit = critical_forces(0.76, 0.76)
    assert len(crit) == 1 and -3.5 < crit[0] < -2.0            # a load along -Y buckles it
    eig = np.linalg.eigvalsh(stiffness_along_coordinates(0.76, 0.76, crit[0]).K)
    assert abs(eig[0]) < 1e-10 * eig[-1]
    assert np.linalg.eigvalsh(k0)[0] > 0


def test_min_eigenvalue_against_an_independent_nodal_energy_hessian():
    """Expected values: an independent Hessian of the members' energies over the six nodes
    (own sympy code: springs k l^2 / 2 with zero free length; actuators and struts with axial
    stiffness ka, kb and the forces that balance the springs and f at the FKP equilibrium).
    At the paper's parameters K is positive definite. With every spring at k = 100 N/m
    against actuators of ka = 10 N/m the framework near the fold is unstable (one negative
    eigenvalue), yet all seven K_i come out positive: only the eigenvalue tells."""
    assert stiffness_along_coordinates(0.7, 0.7, 0.0).min_eigenvalue == pytest.approx(0.7440988671, rel=1e-8)
    assert stiffness_along_coordinates(0.7, 0.7, 1.0).min_eigenvalue == pytest.approx(0.7602916495, rel=1e-8)
    stiff_springs = dataclasses.replace(P, k1=100.0, k2=100.0, k3=100.0, k4=100.0)
    res = stiffness_along_coordinates(0.05, 0.05, 0.0, stiff_springs)
    assert res.min_eigenvalue == pytest.approx(-72.47869617, rel=1e-8)
    np.testing.assert_allclose(res.K_i, [44.7231, 36.699, 93.2782, 1245.4394, 61.0983, 2200.111, 1033.5642],
                               rtol=1e-5)
    assert res.as_dict()["min_eigenvalue"] == res.min_eigenvalue


def test_sweep_shapes_and_values():
    sweep = stiffness_sweep(0.7, 0.7, np.linspace(0, 5, 6))
    assert sweep["K_i"].shape == (6, 7) and sweep["cond_K_r"].shape == (6, 7)
    assert sweep["K_i"][3] == pytest.approx(stiffness_along_coordinates(0.7, 0.7, 3.0).K_i)
    assert sweep["min_eigenvalue"][3] == stiffness_along_coordinates(0.7, 0.7, 3.0).min_eigenvalue


@pytest.mark.parametrize(
    ("rho1", "rho2", "kind"),
    [(0.0, 0.5, "rho1_zero"), (0.5, 0.0, "rho2_zero"), (1.0, 0.5, "lambda2"), (0.5, 1.5, "lambda1")],
)
def test_stiffness_does_not_exist_on_singular_sets(rho1, rho2, kind):
    with pytest.raises(SingularityError) as err:
        stiffness_along_coordinates(rho1, rho2, 0.0)
    assert err.value.kind == kind


@given(configurations(margin=0.1), st.floats(0.0, 5.0))
def test_rigid_limit_stiffness_of_D_is_the_fkp_rotational_stiffness(rho, f):
    # With ka, kb -> infinity every node but D is fixed and D turns about B against
    # U''(beta) = d2U/dbeta2 (the FKP stiffness). A force along y acts with arm L cos(beta):
    # K_Dy -> U'' / (L cos beta)^2, and along x: K_Dx -> U'' / (L sin beta)^2 (error O(1/scale)).
    scale = 1e6
    params = P.with_overrides(ka=10 * scale, kb=1000 * scale)
    fk = forward_kinematics(*rho, params)
    res = stiffness_along_coordinates(*rho, f, params)
    u2, L = fk.stiffness_beta, params.L
    if abs(math.sin(fk.beta)) > 0.05:
        assert res.K_i[2] == pytest.approx(u2 / (L * math.sin(fk.beta)) ** 2, rel=1e-3)
    if abs(math.cos(fk.beta)) > 0.05:
        assert res.K_i[3] == pytest.approx(u2 / (L * math.cos(fk.beta)) ** 2, rel=1e-3)
