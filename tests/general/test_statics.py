"""Member forces, energy, out-of-balance forces, equilibrium matrix and its SVD."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.general import (
    Configuration,
    RigidBody,
    Structure,
    equilibrium_matrix,
    generalized_force,
    member_forces,
    member_lengths,
    modes,
    out_of_balance,
    potential_energy,
    transformation_matrix,
)


def test_member_forces_by_hand():
    nodes = np.array([[0, 0, 0], [3, 4, 0], [0, 0, 1], [0, 0, 2.0]])
    s = Structure.from_arrays(nodes, [[0, 1], [0, 1], [0, 1], [2, 3]], EA=[10, 10, 10, 8],
                              rest_lengths=[4, 6, 6, 0.5], kinds=["bar", "string", "bar", "actuator"],
                              pinned=[True, True, True, True])
    np.testing.assert_allclose(member_lengths(s, nodes), [5, 5, 5, 1])
    np.testing.assert_allclose(member_forces(s, nodes), [10 * 1 / 4, 0.0, 10 * -1 / 6, 8 * 0.5 / 0.5])


def test_member_forces_are_vectorised_over_batches():
    from tensegrity_core.general import load_example

    s = load_example("spine_s")
    rng = np.random.default_rng(0)
    batch = s.nodes[None, None] + 0.01 * rng.normal(size=(2, 3, s.n_nodes, 3))
    t = member_forces(s, batch)
    assert t.shape == (2, 3, s.n_members)
    for i in range(2):
        for j in range(3):
            np.testing.assert_array_equal(t[i, j], member_forces(s, batch[i, j]))
    l0 = np.broadcast_to(s.rest_lengths * 1.01, (2, 3, s.n_members))
    assert np.all(member_forces(s, batch, rest_lengths=l0) <= t)


def test_potential_energy_by_hand():
    nodes = np.array([[0, 0, 0], [2, 0, 0], [0, 1, 0], [0.0, 0, 1]])
    s = Structure.from_arrays(nodes, [[0, 1], [2, 3]], EA=[6.0, 4.0], rest_lengths=[1.5, 2.0],
                              kinds=["bar", "string"], pinned=[True, False, True, False],
                              loads=[[0, 0, 0], [1, 2, 3], [0, 0, 0], [0, 0, 0]],
                              node_masses=[0, 0.5, 0, 0], gravity=[0, 0, -10])
    # bar: 6/(2*1.5) 0.5^2; string slack (length sqrt(2) < 2); loads: -(1*2 + 2*0 + 3*0);
    # weight 0.5 kg * -10 at z = 0 -> 0
    assert potential_energy(s, nodes) == pytest.approx(6 / 3 * 0.25 - 2.0)
    moved = nodes.copy()
    moved[1, 2] = 0.3
    assert potential_energy(s, moved) == pytest.approx(
        3 / 1.5 * (np.hypot(2, 0.3) - 1.5) ** 2 - (2.0 + 3 * 0.3) + 0.5 * 10 * 0.3)


def test_generalized_force_is_minus_the_energy_gradient(loaded_structure):
    s = loaded_structure
    c = Configuration.initial(s).retract(0.1 * np.random.default_rng(5).normal(size=s.layout.n_dof))
    h = 1e-6
    grad = np.array([(potential_energy(s, c.retract(h * e)) - potential_energy(s, c.retract(-h * e))) / (2 * h)
                     for e in np.eye(s.layout.n_dof)])
    np.testing.assert_allclose(-grad, generalized_force(s, c), rtol=1e-7, atol=1e-7)


def test_out_of_balance_is_the_physical_force_and_moment(loaded_structure):
    """Body rows of P are the net force and the moment about the body centre, computed
    here member by member."""
    s = loaded_structure
    c = Configuration.initial(s).retract(0.1 * np.random.default_rng(6).normal(size=s.layout.n_dof))
    x = c.coords
    f = s.loads + s.node_masses[:, None] * s.gravity
    for (a, b), t in zip(s.members, member_forces(s, x)):
        u = (x[b] - x[a]) / np.linalg.norm(x[b] - x[a])
        f[a] += t * u
        f[b] -= t * u
    body = list(s.bodies[0].nodes)
    centre = x[body].mean(axis=0)
    ob = out_of_balance(s, c)
    np.testing.assert_allclose(ob.body_forces[0], f[body].sum(axis=0) + s.bodies[0].mass * s.gravity, atol=1e-12)
    np.testing.assert_allclose(ob.body_moments[0], np.cross(x[body] - centre, f[body]).sum(axis=0), atol=1e-12)
    np.testing.assert_allclose(ob.node_forces, f, atol=1e-12)
    free = s.layout.free_index >= 0
    np.testing.assert_allclose(ob.generalized[s.layout.free_index[free]], f[free], atol=1e-12)
    radius = np.linalg.norm(s.nodes[body] - s.nodes[body].mean(axis=0), axis=1).max()
    expected = max(np.abs(f[free]).max(), np.abs(ob.body_forces).max(), np.abs(ob.body_moments).max() / radius)
    assert ob.residual == pytest.approx(expected)


def test_equilibrium_and_compatibility_matrices(loaded_structure):
    s = loaded_structure
    c = Configuration.initial(s).retract(0.1 * np.random.default_rng(7).normal(size=s.layout.n_dof))
    A = equilibrium_matrix(s, c)
    t = member_forces(s, c.coords)
    G = transformation_matrix(c)
    external = G.T @ s.external_forces.ravel()
    external[s.layout.body_dof[0]:s.layout.body_dof[0] + 3] += s.bodies[0].mass * s.gravity
    # Eq. 64 residual form: P = external - A_r t
    np.testing.assert_allclose(generalized_force(s, c), external - A @ t, atol=1e-12)
    h = 1e-6
    dl = np.array([(member_lengths(s, c.retract(h * e).coords) - member_lengths(s, c.retract(-h * e).coords)) / (2 * h)
                   for e in np.eye(s.layout.n_dof)]).T
    np.testing.assert_allclose(dl, A.T, atol=1e-8)          # B_r = A_r^T (Eqs. 68-70)
    np.testing.assert_allclose(equilibrium_matrix(s, c, sparse=True).toarray(), A)


def test_modes_of_a_planar_cross():
    """A free node held in a plane by four strings to pinned corners: A_r is 3 x 4 with
    rank 2; two self-stress modes (opposite strings equal), one mechanism (out of plane)."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0.0]])
    s = Structure.from_arrays(nodes, [[0, 1], [0, 2], [0, 3], [0, 4]], EA=1.0,
                              pinned=[False, True, True, True, True])
    m = modes(s)
    assert m.rank == 2 and m.self_stress.shape == (4, 2) and m.mechanisms.shape == (3, 1)
    np.testing.assert_allclose(np.abs(m.mechanisms[:, 0]), [0, 0, 1], atol=1e-14)
    P = m.self_stress @ m.self_stress.T        # projector on the self-stress space
    expected = 0.5 * np.array([[1, 0, 1, 0], [0, 1, 0, 1], [1, 0, 1, 0], [0, 1, 0, 1]])
    np.testing.assert_allclose(P, expected, atol=1e-14)


def test_modes_of_a_body_on_three_strings():
    """A rigid triangle hung from three vertical strings: rank 3 (z force, x and y tilts),
    no self-stress, three mechanisms (x, y translation and z rotation)."""
    tri = np.array([[1, 0, 0], [-0.5, 0.8, 0], [-0.5, -0.8, 0.0]])
    nodes = np.vstack([tri, tri + [0, 0, 1]])
    s = Structure.from_arrays(nodes, [[0, 3], [1, 4], [2, 5]], EA=1.0,
                              pinned=[False] * 3 + [True] * 3, bodies=[RigidBody("t", (0, 1, 2))])
    m = modes(s)
    assert (m.rank, m.self_stress.shape[1], m.mechanisms.shape[1]) == (3, 0, 3)
    W = m.mechanisms
    for e in (0, 1, 5):                          # cx, cy, rz span the mechanisms
        v = np.eye(6)[e]
        np.testing.assert_allclose(np.linalg.norm(W.T @ v), 1.0, atol=1e-12)
