"""The pure-Python small solvers of the quasi-static path follower against numpy's LAPACK."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tensegrity_core.sim.class2.small_dense import (
    positive_definite,
    principal_det,
    solve_bordered,
    solve_small,
    solve_symmetric,
)

INDEX_SETS = [idx for n in (1, 2, 3) for idx in itertools.combinations(range(3), n)]


def symmetric(rng, smallest: float) -> np.ndarray:
    """A random symmetric 3 x 3 matrix whose principal submatrices' eigenvalues are set below:
    the matrix itself has eigenvalues ``smallest``, 1.5 and 3 in a random basis."""
    V, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return V @ np.diag([smallest, 1.5, 3.0]) @ V.T


@pytest.mark.parametrize("idx", INDEX_SETS, ids=str)
def test_symmetric_and_bordered_solves_equal_lapack(idx):
    rng = np.random.default_rng(len(idx) * 10 + idx[0])
    n = len(idx)
    for smallest in (2.0, 0.3, -0.7):
        K = symmetric(rng, smallest)
        sub = K[np.ix_(idx, idx)]
        r, g, w = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
        x = solve_symmetric(K.tolist(), idx, r.tolist())
        np.testing.assert_allclose(x, np.linalg.solve(sub, r), rtol=1e-12, atol=1e-12)
        A = np.block([[sub, g[:, None]], [w[None, :], np.array([[0.7]])]])
        y = solve_bordered(K.tolist(), idx, g.tolist(), w.tolist(), 0.7, r.tolist(), -0.4)
        np.testing.assert_allclose(y, np.linalg.solve(A, np.append(r, -0.4)), rtol=1e-11, atol=1e-12)


def test_a_bordered_system_with_a_singular_block_is_solved_by_elimination():
    """At a limit point K_FF is singular but the bordered matrix is regular: the adjugate's
    block elimination would divide by ~0, the fallback must not."""
    rng = np.random.default_rng(7)
    for idx in INDEX_SETS:
        n = len(idx)
        V, _ = np.linalg.qr(rng.normal(size=(n, n)))
        for smallest in (0.0, 1e-13):
            sub = V @ np.diag([smallest] + [1.0 + j for j in range(n - 1)]) @ V.T
            K = np.eye(3)
            K[np.ix_(idx, idx)] = sub
            g, w, r = V[:, 0] + 0.1, V[:, 0] - 0.2, rng.normal(size=n)
            A = np.block([[sub, g[:, None]], [w[None, :], np.array([[0.3]])]])
            y = solve_bordered(K.tolist(), idx, g.tolist(), w.tolist(), 0.3, r.tolist(), 0.5)
            np.testing.assert_allclose(A @ np.array(y), np.append(r, 0.5), atol=1e-10)


def test_singular_systems_raise_zero_division():
    with pytest.raises(ZeroDivisionError):
        solve_small([[1.0, 2.0], [2.0, 4.0]], [1.0, 1.0])
    with pytest.raises(ZeroDivisionError):
        solve_symmetric([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], (0,), [1.0])
    with pytest.raises(ZeroDivisionError):
        solve_bordered([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], (2,), [0.0], [0.0], 0.0, [1.0], 1.0)


@pytest.mark.parametrize("idx", INDEX_SETS, ids=str)
def test_sylvester_criterion_agrees_with_the_eigenvalues(idx):
    rng = np.random.default_rng(3)
    for _ in range(40):
        K = rng.normal(size=(3, 3))
        K = K + K.T + rng.uniform(-1, 4) * np.eye(3)
        sub = K[np.ix_(idx, idx)]
        assert positive_definite(K.tolist(), idx) == bool(np.linalg.eigvalsh(sub).min() > 0)
        assert principal_det(K.tolist(), idx) == pytest.approx(np.linalg.det(sub), rel=1e-12, abs=1e-12)
