"""Shared fixtures of the general-tensegrity tests (BLAS runs on one thread, as in the whole
run: tests/conftest.py)."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.general import RigidBody, Structure


@pytest.fixture
def loaded_structure() -> Structure:
    """See :func:`make_loaded_structure`."""
    return make_loaded_structure()


@pytest.fixture
def loaded_structures():
    """The factory :func:`make_loaded_structure` (seed -> structure)."""
    return make_loaded_structure


def make_loaded_structure(seed: int = 3) -> Structure:
    """A small irregular structure with everything at once: a rigid body with a point
    load on one of its nodes, bars and strings, a node pinned on one axis, a fully pinned
    node, point masses, a heavy body and gravity."""
    rng = np.random.default_rng(seed)
    nodes = rng.normal(size=(9, 3))
    members = np.array([[0, 3], [1, 4], [2, 5], [3, 6], [4, 6], [5, 7], [6, 8], [7, 8],
                        [0, 8], [1, 7], [3, 4], [2, 6]])
    pinned = np.zeros((9, 3), dtype=bool)
    pinned[8] = True
    pinned[7, 2] = True
    ratios = rng.uniform(1.05, 1.2, len(members))
    ratios[6:] = rng.uniform(0.8, 0.95, 6)          # bars: compressed
    ratios[:6] = rng.uniform(0.7, 0.9, 6)           # strings: taut (away from the kink)
    return Structure.from_arrays(
        nodes, members, EA=100.0, rest_length_ratio=ratios, kinds=["string"] * 6 + ["bar"] * 6,
        bodies=[RigidBody("B", (0, 1, 2), mass=2.0)], pinned=pinned,
        loads=rng.normal(size=(9, 3)), gravity=[0, 0, -9.81], node_masses=np.full(9, 0.1),
        name="loaded test structure")


def make_platform(*, loads=None) -> Structure:
    """A rigid tetrahedron held inside a cube of pinned anchors by twelve strings (l0 = l/2):
    one stable equilibrium, used for large-rotation and Euler-angle checks."""
    body = np.array([[0.3, 0, 0], [-0.15, 0.26, 0], [-0.15, -0.26, 0], [0, 0, 0.35]]) - [0, 0, 0.0875]
    anchors = np.array([[x, y, z] for z in (1, -1) for x in (1, -1) for y in (1, -1)], dtype=float)
    nodes = np.vstack([body, anchors])
    members = [[int(np.argmin(np.linalg.norm(body - a, axis=1))), 4 + k] for k, a in enumerate(anchors)]
    members += [[0, 6], [1, 9], [2, 4], [3, 11]]
    pinned = np.zeros((12, 3), dtype=bool)
    pinned[4:] = True
    return Structure.from_arrays(nodes, np.array(members), EA=1e4, rest_length_ratio=0.5,
                                 bodies=[RigidBody("platform", (0, 1, 2, 3))], pinned=pinned,
                                 loads=loads, name="platform")


@pytest.fixture
def platform() -> Structure:
    return make_platform()
