"""Convergence of form-finding (issue 16): the physically scaled residual, Newton's speed
against a plain Newton, iterations that do not grow with size, quadratic convergence, and
the large-structure generators it is measured on."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.general import form_find, modes
from tensegrity_core.general.generators import PAPER_EA, prism_grid, prism_tower
from tests.general.independent import (
    member_forces,
    mp_equilibrium,
    net_forces,
    plain_newton,
    relative_residual,
)


def rest_length_step(s, factor: float):
    """The structure with every string's rest length times ``factor`` (one step of a
    rest-length path from the drawn equilibrium)."""
    return s.with_rest_lengths(np.where(s.is_string, factor, 1.0) * s.rest_lengths)


# ------------------------------------------------------------------ the generators
@pytest.mark.parametrize("make, members, dof", [
    (lambda: prism_tower(7), 18 * 7, 18 * 7),
    (lambda: prism_tower(4, sides=3, free=True), 9 * 4 + 3, 15 * 3),
    (lambda: prism_grid(3, 5), 16 * 15 - 2 * 8, 12 * 15),
])
def test_generated_structures_are_drawn_in_equilibrium(make, members, dof):
    """Sizes as documented, and the drawing balanced to rounding by the independent net
    forces (the closed-form force densities are right)."""
    s = make()
    assert (s.n_members, s.layout.n_dof) == (members, dof)
    assert relative_residual(s, s.nodes).max() < 1e-13
    t = member_forces(s, s.nodes)
    assert np.all(t[s.is_string] >= 0) and np.all(t[~s.is_string] < 0)     # the grid's ties carry nothing


def test_a_prism_stage_carries_its_one_self_stress():
    """One free 6-prism has a single self-stress mode (SVD of the equilibrium matrix): the
    generator's forces are proportional to it, bars against strings."""
    s = prism_tower(1, free=True)
    m = modes(s)
    assert m.self_stress.shape[1] == 1
    t = member_forces(s, s.nodes)
    np.testing.assert_allclose(t / np.linalg.norm(t), m.self_stress[:, 0], atol=1e-12)


# ------------------------------------------------------------------ the measure
def test_the_residual_is_the_force_at_a_node_over_the_forces_that_meet_there():
    """Part way to an equilibrium, the reported residual is the independent relative
    residual of the free nodes, and residual_norm the Euclidean norm of their net forces."""
    s = rest_length_step(prism_tower(3), 0.9)
    r = form_find(s, max_iter=2)
    assert r.status == 1
    assert r.residual == pytest.approx(relative_residual(s, r.nodes).max(), rel=1e-12)
    net = np.where(s.pinned, 0.0, net_forces(s, r.nodes))
    assert r.residual_norm == pytest.approx(np.linalg.norm(net), rel=1e-12)


@pytest.mark.parametrize("stages, prestrain, factor", [(3, 1.0, 0.9), (3, 0.5, 0.8)])
def test_bars_a_million_times_stiffer_converge_like_a_plain_newton_to_the_exact_root(stages, prestrain, factor):
    """Bars 10^6 times stiffer than the strings, a rest-length step of 10-20 % from the drawn
    equilibrium. At the default tolerance every force agrees with the 40-digit root of the
    plain equilibrium equations to 1e-9 relative and every length to 1e-10 m, in at most
    1.5x the iterations of a plain Newton (full steps, no shift, no line search) from the
    same start. (Measured: the same iteration count; forces to 1.3e-10 .. 1.9e-10, lengths
    to 2.4e-12 m. The energy line search alone needed 3x: the watchdog of docs/design/general.md.)"""
    s = rest_length_step(prism_tower(stages, bar_EA=1e6 * PAPER_EA, prestrain=prestrain), factor)
    r = form_find(s)
    assert r.success, r.message
    x_plain, plain_iterations = plain_newton(s, s.nodes, 1e-10)
    root = mp_equilibrium(s, x_plain, iterations=3)        # from 1e-16: 1e-32, then 40 digits
    t = member_forces(s, root)
    lengths = np.linalg.norm(root[s.members[:, 1]] - root[s.members[:, 0]], axis=1)
    assert np.abs(r.member_forces - t).max() <= 1e-9 * np.abs(t).min()
    assert np.abs(r.member_lengths - lengths).max() <= 1e-10
    assert r.iterations <= 1.5 * plain_iterations


# ------------------------------------------------------------------ speed
@pytest.mark.parametrize("family, sizes", [
    ("tower", [100, 400]),                  # 1,800 and 7,200 members
    ("grid", [(3, 3), (6, 24), (12, 96)]),  # 138 to 18,300 members
])
def test_iterations_do_not_grow_with_size(family, sizes):
    """A 1 % rest-length step of every string from the drawn equilibrium: the same number of
    Newton iterations at every size (compared across sizes)."""
    counts = []
    for size in sizes:
        s = prism_tower(size) if family == "tower" else prism_grid(*size)
        r = form_find(rest_length_step(s, 0.99))
        assert r.success, r.message
        counts.append(r.iterations)
    assert max(counts) == min(counts), counts


def test_convergence_is_quadratic():
    """Near the end each residual is about C times the square of the one before (C within a
    factor 4 over the last steps above the rounding level), the signature of Newton's method
    with a shift that vanishes where the matrix is definite."""
    r = form_find(rest_length_step(prism_grid(8, 32), 0.99))
    assert r.success
    res = np.array([h["residual"] for h in r.history])
    tail = res[res > 1e-11]
    C = tail[1:] / tail[:-1] ** 2
    assert len(C) >= 2 and C.max() <= 4 * C.min() and tail[-1] < tail[-2] ** 1.5


def test_a_fixed_shift_is_slower_on_a_soft_structure():
    """The paper's fixed shift (here 1e-10 on the scaled matrix) on a tower whose softest
    mode is ~1e-10 of its stiffest: more iterations than the default, which shifts only to
    the rounding level of a definite matrix, to the same equilibrium (to 1e-10 of the
    tower's height: its soft bending leaves ~1e-9 m between two results at tol 1e-10)."""
    s = rest_length_step(prism_tower(200), 0.99)
    adaptive, fixed = form_find(s), form_find(s, shift=1e-10)
    assert adaptive.success and fixed.success
    assert adaptive.iterations < fixed.iterations
    np.testing.assert_allclose(adaptive.nodes, fixed.nodes, rtol=0, atol=1e-10 * np.ptp(s.nodes[:, 2]))
