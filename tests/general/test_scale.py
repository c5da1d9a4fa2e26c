"""Large structures: generators, the sparse path, the tangent predictor of the path."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.general import (
    StructureError,
    form_find,
    rest_length_path,
    t_bar,
    tangent_stiffness,
    tensegrity_spine,
)
from tensegrity_core.general.path import tangent_displacement


def test_spine_generator_sizes():
    s = tensegrity_spine(251, perturbation=0.02, seed=1)
    assert s.n_members == 8 * 250 and s.layout.n_dof == 6 * 250 and len(s.bodies) == 251
    assert s.bodies[0].fixed and not s.bodies[1].fixed
    free = tensegrity_spine(5, fixed_base=False)
    assert free.layout.n_dof == 30
    with pytest.raises(StructureError, match="n_vertebrae must be >= 2"):
        tensegrity_spine(1)
    with pytest.raises(StructureError, match="shape must be"):
        tensegrity_spine(5, shape="U")


def test_a_long_spine_form_finds_on_the_sparse_path():
    s = tensegrity_spine(201, perturbation=0.03, seed=2)
    r = form_find(s)
    assert r.method == "newton (sparse)" and r.success, r.message
    assert r.residual <= 1e-10 and r.residual_norm <= 1e-10 * s.EA.max() and r.min_eigenvalue > 0
    assert r.iterations < 40


def test_sparse_pattern_assembly_matches_dense_on_a_long_spine():
    s = tensegrity_spine(60, perturbation=0.03, seed=3)
    from tensegrity_core.general import Configuration

    c = Configuration.initial(s).retract(1e-3 * np.random.default_rng(0).normal(size=s.layout.n_dof))
    Ks = tangent_stiffness(s, c, sparse=True)
    assert Ks.nnz < 0.1 * s.layout.n_dof**2                 # banded: a chain of joints
    np.testing.assert_array_equal(Ks.toarray(), tangent_stiffness(s, c))


def test_tangent_predictor_matches_a_finite_difference_of_equilibria():
    s = t_bar(0.7)
    L = s.initial_lengths
    l0 = lambda p: np.array([1, 1, 1, 1, p, p, 0.8, 0.8]) * L  # noqa: E731
    r0 = form_find(s.with_rest_lengths(l0(0.7)), tol=1e-9)
    h = 1e-5
    r1 = form_find(s.with_rest_lengths(l0(0.7 + h)), x0=r0.configuration, tol=1e-9)
    fd = np.abs(r1.nodes - r0.nodes).max() / h
    predicted = tangent_displacement(s.with_rest_lengths(l0(0.7)), r0, (l0(1.0) - l0(0.0)))
    assert predicted == pytest.approx(fd, rel=1e-3)


def test_path_arguments_are_validated():
    s = t_bar()
    with pytest.raises(StructureError, match="strictly monotonic"):
        rest_length_path(s, lambda p: s.rest_lengths, [0.8, 0.7, 0.75])
    with pytest.raises(StructureError, match="at least one value"):
        rest_length_path(s, lambda p: s.rest_lengths, [])
    done = rest_length_path(s, lambda p: s.rest_lengths * p, [1.0, 0.99, 0.98])
    assert done.completed and done.parameters == [1.0, 0.99, 0.98] and done.limit_point is None
