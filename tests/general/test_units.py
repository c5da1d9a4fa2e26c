"""Form-finding and its stability verdict do not depend on the units of length and force.

A regular n-prism (bars from bottom node i to top node i+1, vertical strings bottom i to
top i, two rings of strings) has a self-stress only at the twist pi/2 - pi/n of the top
ring over the bottom one, with force densities vertical / ring = 2 sin(pi/n) = -bar / ring
(independent computation: the null space of the force-density equilibrium matrix, scanned
over the twist, gives these to 1e-9 for n = 3..8). Scaling every length by lam and every
EA by mu scales forces by mu and leaves twist, force-density ratios and the verdict as they
are; before the rigid-body rotations were measured in units of the structure's size, a
prism of 1e-15 m or 1e13 m was called "neutral" (status 4) with its rotations left in.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.general import Structure, form_find, load_example


def prism(n: int, twist: float, lam: float, mu: float) -> Structure:
    ang = 2 * np.pi * np.arange(n) / n
    bottom = np.c_[np.cos(ang), np.sin(ang), np.zeros(n)]
    top = np.c_[np.cos(ang + twist), np.sin(ang + twist), np.full(n, 1.3)]
    ring = np.arange(n)
    members = np.vstack([np.c_[ring, n + (ring + 1) % n], np.c_[ring, (ring + 1) % n],
                         np.c_[n + ring, n + (ring + 1) % n], np.c_[ring, n + ring]])
    return Structure.from_arrays(lam * np.vstack([bottom, top]), members, EA=[100 * mu] * n + [mu] * (3 * n),
                                 kinds=["bar"] * n + ["string"] * (3 * n), rest_length_ratio=[1.0] * n + [0.9] * (3 * n))


@settings(max_examples=12, deadline=None)
@given(n=st.integers(3, 8), length_exp=st.floats(-40.0, 14.0), force_exp=st.floats(-6.0, 12.0))
def test_a_prism_finds_the_same_stable_form_in_any_units(n, length_exp, force_exp):
    lam, mu = 10.0**length_exp, 10.0**force_exp
    r = form_find(prism(n, 0.3, lam, mu))
    assert r.status == 0 and r.stable and r.rigid_body_modes == 6, r.message
    X = r.nodes
    bottom, top = X[:n] - X[:n].mean(axis=0), X[n:] - X[n:].mean(axis=0)
    axis = X[n:].mean(axis=0) - X[:n].mean(axis=0)
    axis /= np.linalg.norm(axis)
    twist = np.arctan2(np.cross(bottom, top) @ axis, np.sum(bottom * top, axis=1))
    np.testing.assert_allclose(twist, np.pi / 2 - np.pi / n, atol=1e-9)
    q = r.member_forces / r.member_lengths
    ratio = q / q[n]
    np.testing.assert_allclose(ratio[3 * n:], 2 * np.sin(np.pi / n), rtol=1e-8)
    np.testing.assert_allclose(ratio[:n], -2 * np.sin(np.pi / n), rtol=1e-8)


def test_the_supported_t_bar_scaled_by_1e_20_keeps_its_forces_and_verdict():
    s = load_example("t_bar")
    ref = form_find(s)
    lam = 1e-20
    small = Structure.from_arrays(lam * s.nodes, s.members, EA=s.EA, rest_lengths=lam * s.rest_lengths,
                                  kinds=list(s.member_kinds), pinned=s.pinned)
    r = form_find(small)
    assert ref.status == 0 and r.status == 0, r.message
    np.testing.assert_allclose(r.member_forces, ref.member_forces, rtol=1e-8, atol=1e-9 * np.abs(ref.member_forces).max())
    np.testing.assert_allclose(r.nodes / lam, ref.nodes, atol=1e-9)
