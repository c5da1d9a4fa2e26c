"""Hypothesis strategies for random general structures (issue 9 property tests).

Random small structures: 4-8 nodes in a unit cube, the first three pinned (so some rigid
motions are stopped, others may stay free), 6-14 members between random node pairs
(bars or strings), axial stiffnesses over six decades (ratios up to 1e6), rest lengths
0.7-1.1 of the drawn lengths, random dead loads, optionally one free rigid triangle.
"""

from __future__ import annotations

import numpy as np
from hypothesis import assume
from hypothesis import strategies as st

from tensegrity_core.general import RigidBody, Structure


@st.composite
def structures(draw, bodies: bool = True, loads: bool = True) -> Structure:
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(4, 8))
    nodes = rng.uniform(-1.0, 1.0, (n, 3))
    m = min(draw(st.integers(6, 14)), n * (n - 1) // 2)
    pairs = set()
    for i in range(3, n):                       # every free node reaches the pinned base
        pairs.add((int(rng.integers(0, i)), i))
    while len(pairs) < m:
        a, b = sorted(rng.choice(n, 2, replace=False).tolist())
        pairs.add((a, b))
    members = np.array(sorted(pairs))
    assume(np.linalg.norm(nodes[members[:, 0]] - nodes[members[:, 1]], axis=1).min() > 0.05)
    kinds = ["bar" if k else "string" for k in rng.random(len(members)) < 0.3]
    EA = 10.0 ** rng.uniform(0, 6, len(members))
    ratio = rng.uniform(0.7, 1.1, len(members))
    pinned = np.zeros((n, 3), dtype=bool)
    pinned[:3] = True
    body = ()
    if bodies and n >= 6 and draw(st.booleans()):
        tri = nodes[n - 3:]
        assume(np.linalg.norm(np.cross(tri[1] - tri[0], tri[2] - tri[0])) > 0.05)
        body = (RigidBody("tri", (n - 3, n - 2, n - 1)),)
        keep = ~np.isin(members, [n - 3, n - 2, n - 1]).all(axis=1)
        members, kinds, EA, ratio = members[keep], [k for k, q in zip(kinds, keep) if q], EA[keep], ratio[keep]
        assume(len(members) >= 3)
    f = rng.normal(0.0, 1.0, (n, 3)) * (rng.random((n, 1)) < 0.5) if loads else np.zeros((n, 3))
    return Structure.from_arrays(nodes, members, EA=EA, rest_length_ratio=ratio, kinds=kinds, pinned=pinned,
                                 bodies=body, loads=f, name=f"random structure (seed {seed})")


def displacements(structure: Structure, seed: int, scale: float = 0.05) -> np.ndarray:
    """A random increment of the minimal coordinates U (size ``scale``)."""
    return np.random.default_rng(seed).normal(0.0, scale, structure.layout.n_dof)
