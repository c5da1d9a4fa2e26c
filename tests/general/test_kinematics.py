"""Rotations and configurations: the exponential map, best-fit rotations, G = dn/dU."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tensegrity_core.general import Configuration, StructureError, load_example, transformation_matrix
from tensegrity_core.general.rotation import best_fit_rotation, exp_so3, hat

vectors = st.lists(st.floats(-4.0, 4.0), min_size=3, max_size=3).map(np.array)


@given(vectors)
def test_exp_map_matches_scipy(theta):
    np.testing.assert_allclose(exp_so3(theta), Rotation.from_rotvec(theta).as_matrix(), atol=1e-14)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-5, 9.99e-5, 1.0001e-4, 1e-3])
def test_exp_map_is_accurate_near_zero(angle):
    theta = angle * np.array([0.6, -0.8, 0.0])
    np.testing.assert_allclose(exp_so3(theta), Rotation.from_rotvec(theta).as_matrix(), atol=1e-16)


@given(vectors, vectors)
def test_hat_is_the_cross_product(a, b):
    np.testing.assert_allclose(hat(a) @ b, np.cross(a, b), atol=1e-12)


@given(vectors)
def test_best_fit_rotation_recovers_a_rotation(theta):
    P = np.random.default_rng(0).normal(size=(5, 3))
    P -= P.mean(axis=0)
    R = Rotation.from_rotvec(theta).as_matrix()
    R_fit, misfit = best_fit_rotation(P, P @ R.T)
    np.testing.assert_allclose(R_fit, R, atol=1e-10)
    assert misfit < 1e-12


def test_configuration_from_coords_round_trip_and_rigidity_check():
    s = load_example("tensegrity_table")
    c0 = Configuration.initial(s)
    c1 = c0.retract(np.random.default_rng(1).normal(size=s.layout.n_dof))
    back = Configuration.from_coords(s, c1.coords)
    np.testing.assert_allclose(back.coords, c1.coords, atol=1e-12)
    np.testing.assert_allclose(back.rotations, c1.rotations, atol=1e-12)
    bent = c1.coords.copy()
    bent[0] += 0.01
    with pytest.raises(StructureError, match="coords deform rigid body 'bottom'"):
        Configuration.from_coords(s, bent)


def test_retract_composes_rotations_on_the_left():
    s = load_example("tensegrity_table")
    c = Configuration.initial(s)
    d1, d2 = np.zeros(s.layout.n_dof), np.zeros(s.layout.n_dof)
    d1[3:6] = [0.3, -0.2, 0.5]
    d2[3:6] = [-0.1, 0.4, 0.2]
    R = c.retract(d1).retract(d2).rotations[0]
    np.testing.assert_allclose(R, Rotation.from_rotvec(d2[3:6]).as_matrix() @ Rotation.from_rotvec(d1[3:6]).as_matrix(),
                               atol=1e-14)
    np.testing.assert_allclose(c.retract(d1).retract(d2).coords[:4].mean(axis=0), s.nodes[:4].mean(axis=0), atol=1e-14)


@pytest.mark.parametrize("name", ["tensegrity_table", "t_bar", "patio_shade", "spine_c"])
def test_G_is_the_derivative_of_node_positions(name):
    s = load_example(name)
    c = Configuration.initial(s).retract(0.2 * np.random.default_rng(2).normal(size=s.layout.n_dof))
    G = transformation_matrix(c).toarray()
    h = 1e-6
    fd = np.array([(c.retract(h * e).coords - c.retract(-h * e).coords).ravel() / (2 * h)
                   for e in np.eye(s.layout.n_dof)]).T
    np.testing.assert_allclose(G, fd, atol=1e-8)


def test_labels_name_every_coordinate():
    s = load_example("t_bar")
    assert s.layout.labels() == ["n2.x", "n3.x", "n3.z", "n4.x", "n4.z", "n5.x", "n5.z"]
    assert load_example("tensegrity_table").layout.labels()[:6] == [
        "bottom.cx", "bottom.cy", "bottom.cz", "bottom.rx", "bottom.ry", "bottom.rz"]
