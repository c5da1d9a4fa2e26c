"""Degenerate inputs of the general core give one typed refusal naming the field, or a
documented result; and the SVD of the equilibrium matrix obeys Maxwell's rule.

Refusals: coordinates that are not numbers, of the wrong shape, non-finite or beyond
MAX_MAGNITUDE, or that put a member's two nodes on one point (no direction: no equilibrium
matrix, no stiffness); overridden rest lengths that are not positive; a singular-value
threshold outside [0, 1); form-finding tolerances, iteration limits and options that do not
exist. Documented results: a mechanism without self-stress has an empty self-stress basis;
the length of a member between coincident nodes is 0 and its force that of a member shrunk
to nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from scipy.linalg import null_space

from tensegrity_core.general import (
    Structure,
    equilibrium_matrix,
    form_find,
    member_forces,
    member_lengths,
    modal_analysis,
    modes,
    out_of_balance,
    potential_energy,
    prism_tower,
    tangent_stiffness,
)
from tensegrity_core.general.structure import StructureError
from tests.hard.strategies import structures

TOWER = prism_tower(1)
N = TOWER.n_nodes


def _with(i, value):
    x = TOWER.nodes.copy()
    x[i] = value
    return x


BAD_COORDS = {
    "nan": (_with(2, [math.nan, 0.0, 0.0]), r"coords contain non-finite.*node '2'"),
    "inf": (_with(3, [0.0, math.inf, 0.0]), r"coords contain non-finite.*node '3'"),
    "overflowing": (TOWER.nodes * 1e200, r"beyond 1e\+15 m"),
    "short": (TOWER.nodes[:-1], rf"coords must have shape .*{N}, 3\), got \({N - 1}, 3\)"),
    "text": ("abc", "coords must be an array of numbers"),
    "ragged": ([[0.0, 1.0], [2.0]], "coords must be an array of numbers"),
}

USES_COORDS = {
    "equilibrium_matrix": equilibrium_matrix,
    "modes": modes,
    "tangent_stiffness": tangent_stiffness,
    "member_forces": member_forces,
    "member_lengths": member_lengths,
    "out_of_balance": out_of_balance,
    "potential_energy": potential_energy,
    "modal_analysis": modal_analysis,
    "form_find": lambda s, x: form_find(s, x0=x),
}


@pytest.mark.parametrize("bad", sorted(BAD_COORDS))
@pytest.mark.parametrize("name", sorted(USES_COORDS))
def test_bad_coordinates_are_refused_naming_coords(name, bad):
    coords, message = BAD_COORDS[bad]
    with pytest.raises(StructureError, match=message) as err:
        USES_COORDS[name](TOWER, coords)
    assert err.value.entry[0] == "coords"


NEEDS_DIRECTIONS = ("equilibrium_matrix", "modes", "tangent_stiffness", "out_of_balance", "modal_analysis",
                    "form_find")


@pytest.mark.parametrize("name", NEEDS_DIRECTIONS)
def test_a_member_of_zero_length_is_refused_where_its_direction_is_needed(name):
    a, b = TOWER.members[0]
    coords = _with(b, TOWER.nodes[a])
    with pytest.raises(StructureError, match=f"member '{TOWER.member_names[0]}' has zero length in coords"):
        USES_COORDS[name](TOWER, coords)


def test_a_member_of_zero_length_has_length_zero_and_the_force_of_a_vanished_member():
    a, b = TOWER.members[0]
    coords = _with(b, TOWER.nodes[a])
    assert member_lengths(TOWER, coords)[0] == 0.0
    # t = EA (l - l0) / l0 at l = 0: -EA for a bar, 0 for a slack string
    expected = 0.0 if TOWER.is_string[0] else -TOWER.EA[0]
    assert member_forces(TOWER, coords)[0] == pytest.approx(expected)
    assert math.isfinite(potential_energy(TOWER, coords))


@pytest.mark.parametrize(("rest", "message"), [
    (np.full(TOWER.n_members, math.nan), "finite and positive"),
    (-np.ones(TOWER.n_members), "finite and positive"),
    (np.zeros(TOWER.n_members), "finite and positive"),
    (np.ones(2), "broadcasts to"),
    ("long", "must be numbers"),
])
def test_overridden_rest_lengths_are_checked(rest, message):
    with pytest.raises(StructureError, match=message) as err:
        member_forces(TOWER, None, rest_lengths=rest)
    assert err.value.entry == ("rest_lengths",)


@pytest.mark.parametrize(("rtol", "why"), [(math.nan, "finite"), (-1e-9, ">= 0"), (1.0, "< 1"), (math.inf, "finite"),
                                           ("1e-8", "a number"), (True, "a number")])
def test_singular_value_threshold_outside_0_1_is_refused(rtol, why):
    with pytest.raises(StructureError, match=f"rtol .* must be {why}"):
        modes(TOWER, rtol=rtol)


@pytest.mark.parametrize("field", ["nodes", "EA", "rest_lengths"])
def test_structure_fields_that_are_not_numbers_are_refused_naming_the_field(field):
    with pytest.raises(StructureError, match=f"{field} must be an array of numbers") as err:
        TOWER.replace(**{field: "abc"})
    assert err.value.entry == (field,)


def test_a_mechanism_without_self_stress_has_an_empty_self_stress_basis():
    # A free node on two strings from pinned nodes: 3 DOF, 2 members, rank 2 -> s = 0, one
    # mechanism (rotation about the line through the supports).
    s = Structure.from_arrays([[0, 0, 0], [1, 0, 0], [0.5, 0.5, 0]], [[0, 2], [1, 2]], EA=1.0,
                              rest_length_ratio=0.9, pinned=[True, True, False])
    m = modes(s)
    assert (m.rank, m.self_stress.shape, m.mechanisms.shape) == (2, (2, 0), (3, 1))
    np.testing.assert_allclose(np.abs(m.mechanisms[:, 0]), [0, 0, 1], atol=1e-15)


def _node_forces(s: Structure, t: np.ndarray) -> np.ndarray:
    """Net force on each free coordinate of tensions ``t`` along the members, from the
    geometry alone (no equilibrium matrix): node a is pulled towards b and b towards a."""
    f = np.zeros((s.n_nodes, 3))
    for (a, b), ti in zip(s.members, t):
        u = (s.nodes[b] - s.nodes[a]) / np.linalg.norm(s.nodes[b] - s.nodes[a])
        f[a] += ti * u
        f[b] -= ti * u
    return f[~s.pinned]


@given(structures(bodies=False, loads=False))
def test_modes_obey_maxwells_rule_and_span_the_null_spaces(s):
    # Calladine's form of Maxwell's rule: self-stresses - mechanisms = members - DOF, with
    # s = m - r and k = n_dof - r for the rank r of A_r. The self-stress basis is the null
    # space of A_r (independently: scipy's null_space, and node forces summed from the
    # geometry vanish), the mechanisms the null space of A_r^T (inextensional motions).
    m = modes(s)
    A = equilibrium_matrix(s, None)
    n_dof, n_members = A.shape
    S, K = m.self_stress, m.mechanisms
    assert S.shape == (n_members, n_members - m.rank) and K.shape == (n_dof, n_dof - m.rank)
    assert S.shape[1] - K.shape[1] == n_members - n_dof
    assert S.shape[1] == null_space(A, rcond=m.tol / m.singular_values[0]).shape[1]
    np.testing.assert_allclose(S.T @ S, np.eye(S.shape[1]), atol=1e-12)
    np.testing.assert_allclose(K.T @ K, np.eye(K.shape[1]), atol=1e-12)
    scale = m.singular_values[0]
    assert np.abs(A @ S).max(initial=0.0) <= 1e-8 * scale
    assert np.abs(A.T @ K).max(initial=0.0) <= 1e-8 * scale
    for k in range(S.shape[1]):
        assert np.abs(_node_forces(s, S[:, k])).max() <= 1e-8


def test_an_unstiffened_mechanism_has_stability_margin_0_not_nan():
    # Dynamic relaxation leaves the node of two slack strings where it stops: K_T = 0, whose
    # rounding level is 0 too; its zero eigenvalue is neutral with margin 0 (was 0/0 = NaN,
    # printed as "nan times its rounding level").
    s = Structure.from_arrays([[0, 0, 0], [1, 0, 0], [0.5, 0.5, 0]], [[0, 2], [1, 2]], EA=1.0,
                              rest_length_ratio=0.9, pinned=[True, True, False])
    r = form_find(s, method="dynamic_relaxation")
    assert r.stability_margin == 0.0 and not r.stable
    assert "unstiffened mechanism" in r.message and "nan" not in r.message


def _triangle(nodes, **kw):
    return Structure.from_arrays(np.array(nodes, float), [[0, 1], [1, 2], [2, 0]], EA=1e3, **kw)


def test_each_refusal_of_a_member_states_the_bound_it_breaks():
    """A rest length of 1.27e15 m (0.9 x a drawn 1.41e15 m) breaks the 1e15 bound, not
    'finite and positive'; nodes 1e-300 m apart are not 'both at' one point; a structure
    spanning 1e-160 m is refused by its span (its squared lengths underflow), not by a
    member 'of zero length' whose ends differ."""
    with pytest.raises(StructureError, match=r"rest length must be at most 1e\+15 m .*got 1272792206135785\.5"):
        _triangle([[0, 0, 0], [1e15, 0, 0], [0, 1e15, 0]], rest_length_ratio=0.9)
    with pytest.raises(StructureError, match=r"EA must be at most 1e\+15 N"):
        Structure.from_arrays(np.eye(3), [[0, 1], [1, 2]], EA=[1.0, 2e15])
    with pytest.raises(StructureError, match=r"nodes '0' and '1' at \[0\.0, 0\.0, 0\.0\] and \[1e-300, 0\.0, 0\.0\] "
                                             r"are 1e-300 m apart, within 1e-12 of the structure's size 1 m"):
        _triangle([[0, 0, 0], [1e-300, 0, 0], [0, 1, 0]])
    with pytest.raises(StructureError, match=r"the nodes span 2e-160 m, less than 1e-150 m"):
        _triangle([[0, 0, 0], [2e-160, 0, 0], [0, 1e-160, 0]])
    tiny = _triangle([[0, 0, 0], [2e-150, 0, 0], [0, 1e-150, 0]])     # at the bound: built, lengths exact
    np.testing.assert_allclose(member_lengths(tiny, tiny.nodes), [2e-150, math.sqrt(5) * 1e-150, 1e-150], rtol=1e-15)
