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


#: Geometries at the edge of what a user can draw: ``general`` (a cloud), ``coplanar`` and
#: ``collinear`` (exactly, or to 1e-9 of the size: nets and chains whose out-of-plane motions
#: are infinitesimal mechanisms), ``clustered`` (two nodes 1e-9 of the size apart: a member
#: ~1e4 above the length floor of 1e-12 x size), ``coincident`` (a member of zero length,
#: which the structure refuses).
GEOMETRIES = ("general", "coplanar", "nearly coplanar", "collinear", "nearly collinear", "clustered", "coincident")


@st.composite
def drawn_structures(draw, bodies: bool = True) -> dict:
    """The arguments of ``Structure.from_arrays`` for a structure over the accepted ranges:
    4-9 nodes scaled from 1 mm to 1 km in one of :data:`GEOMETRIES`; as few members as a
    mechanism with many modes or as many as three per node, with duplicates (the same pair,
    either way round); axial stiffness EA over a drawn window of 1e-6 .. 1e15 N (up to
    21 decades between members); rest lengths 0.5-1.5 of the drawn lengths (prestress
    either sign); 0-3 nodes pinned, or single axes; point masses 1e-3 .. 1e3 kg and
    gravity, dead loads; optionally a rigid triangle with a mass. Returned as keyword
    arguments so a refusal by the structure itself is seen by the test.

    Two draws in three are *held* (``held`` in the name), in any geometry, so form-finding
    has an answer to check: three nodes pinned, every other node on members to three
    earlier nodes, EA over at most two decades, every rest length 0.1-0.5 of the drawn
    length, weights and loads at most 1 % of the weakest EA [N]. All members pull, so the
    potential is convex (``(l - l0)^2`` of a convex ``l >= l0``) and bounded below; a node
    stays on taut members where its anchors are further apart than the sum of its members'
    rest lengths, and a taut member stiffens it across (``t / l``), flat or straight too."""
    seed = draw(st.integers(0, 2**32 - 1))
    geometry = draw(st.sampled_from(("general", "general") + GEOMETRIES))
    rng = np.random.default_rng(seed)
    held = draw(st.sampled_from((True, True, False)))
    n = draw(st.integers(4, 9))
    nodes = rng.uniform(-1.0, 1.0, (n, 3))
    if "coplanar" in geometry:
        nodes[:, 2] *= 1e-9 if geometry.startswith("nearly") else 0.0
    if "collinear" in geometry:
        nodes[:, 1:] *= 1e-9 if geometry.startswith("nearly") else 0.0
    if geometry in ("clustered", "coincident"):
        nodes[1] = nodes[0] + (1e-9 if geometry == "clustered" else 0.0) * rng.normal(size=3)
    nodes *= 10.0 ** draw(st.floats(-3.0, 3.0))
    m = draw(st.integers(n - 1, 3 * n))
    pairs = [(0, 1)] if geometry in ("clustered", "coincident") else []
    for i in range(1, n):                                      # every node on a member: a tree
        ends = rng.choice(i, min(i, 3) if held and i >= 3 else 1, replace=False)
        pairs += [(int(a), i) for a in ends]
    while len(pairs) < m:
        a, b = rng.choice(n, 2, replace=False).tolist()
        pairs.append((int(a), int(b)))
    for _ in range(draw(st.integers(0, 2))):                   # duplicates, either way round
        a, b = pairs[int(rng.integers(len(pairs)))]
        pairs.append((b, a) if rng.random() < 0.5 else (a, b))
    members = np.array(pairs)
    lo = draw(st.floats(-6.0, 15.0))
    hi = draw(st.floats(lo, min(lo + 2.0, 15.0) if held else 15.0))
    EA = 10.0 ** rng.uniform(lo, hi, len(members))
    kinds = ["bar" if k else "string" for k in rng.random(len(members)) < 0.3]
    pinned = np.zeros((n, 3), dtype=bool)
    pinned[:3 if held else draw(st.sampled_from((3, 3, 2, 1, 0)))] = True   # mostly supported
    if draw(st.booleans()):
        pinned[int(rng.integers(n)), int(rng.integers(3))] = True
    body = ()
    if bodies and n >= 6 and draw(st.booleans()):
        body = (RigidBody("tri", (n - 3, n - 2, n - 1), mass=float(10.0 ** rng.uniform(-3, 3))),)
        pinned[n - 3:] = False
        inside = np.isin(members, [n - 3, n - 2, n - 1]).all(axis=1)
        members, EA, kinds = members[~inside], EA[~inside], [k for k, q in zip(kinds, inside) if not q]
    masses = np.where(rng.random(n) < 0.5, 10.0 ** rng.uniform(-3, 3, n), 0.0)
    loads = rng.normal(0.0, 1.0, (n, 3)) * (rng.random((n, 1)) < 0.3) * 10.0 ** draw(st.floats(-3.0, 6.0))
    ratio = rng.uniform(0.1 if held else 0.5, 0.5 if held else 1.5, len(members))
    if held:                                                   # weights [N] and loads within 1 % of EA
        cap = 1e-2 * EA.min()
        masses *= min(1.0, cap / (9.81 * 1e3))
        loads *= cap / max(np.abs(loads).max(), cap)
        if body:
            body = (RigidBody("tri", body[0].nodes, mass=body[0].mass * min(1.0, cap / (9.81 * 1e3))),)
    return dict(nodes=nodes, members=members, EA=EA, rest_length_ratio=ratio,
                kinds=kinds, pinned=pinned, bodies=body, loads=loads, node_masses=masses,
                gravity=[0.0, 0.0, -9.81] if draw(st.booleans()) else [0.0, 0.0, 0.0],
                name=f"drawn {geometry} structure{' held' if held else ''} (seed {seed})")
