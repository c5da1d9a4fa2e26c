"""Hard cases of form-finding (issue 9), each against an independent computation: the
out-of-balance recomputed here from member vectors (not the statics module), mpmath
roots in 50 digits, or a second run of another kind. Catalogue: docs/design/hard_cases.md.

Covered elsewhere and only referenced there: a rigid body at the Euler-singular attitude
(tests/general/test_formfind.py::test_a_body_turned_through_the_paper_singular_attitude_form_finds),
a symmetric start on a saddle (tests/general/test_formfind.py), the T-bar limit point
(rest_length_path tests).
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from tensegrity_core.general import (
    Structure,
    example_path,
    form_find,
    load_example,
    load_structure,
    tangent_stiffness,
    tensegrity_spine,
)
from tensegrity_core.general.formfind import unbalanced_load
from tensegrity_core.general.linalg import jacobi_scaling
from tests.general.independent import member_forces, mp_equilibrium, relative_residual

mp.mp.dps = 50


def independent_residual(s: Structure, x: np.ndarray) -> float:
    """Largest net force [N] on a free coordinate, net force on a moving body and moment
    about its centroid / its radius, from ``t = EA (l - l0)/l0`` (slack strings 0)."""
    h = x[s.members[:, 1]] - x[s.members[:, 0]]
    l = np.linalg.norm(h, axis=1)
    t = s.EA * (l - s.rest_lengths) / s.rest_lengths
    t = np.where(s.is_string & (t < 0), 0.0, t)
    f = s.loads + s.node_masses[:, None] * s.gravity
    if s.member_masses.size:
        half = 0.5 * s.member_masses[:, None] * s.gravity
        np.add.at(f, s.members[:, 0], half)
        np.add.at(f, s.members[:, 1], half)
    pull = (t / l)[:, None] * h
    np.add.at(f, s.members[:, 0], pull)
    np.add.at(f, s.members[:, 1], -pull)
    on_body = np.zeros(s.n_nodes, dtype=bool)
    worst = 0.0
    for b in s.bodies:
        idx = list(b.nodes)
        on_body[idx] = True
        if b.fixed:
            continue
        c = x[idx].mean(axis=0)
        F = f[idx].sum(axis=0) + b.mass * s.gravity
        M = np.cross(x[idx] - c, f[idx]).sum(axis=0)
        radius = np.linalg.norm(x[idx] - c, axis=1).max()
        worst = max(worst, np.abs(F).max(), np.abs(M).max() / radius)
    free = ~s.pinned & ~on_body[:, None]
    return max(worst, float(np.abs(f[free]).max(initial=0.0)))


# ------------------------------------------------------------------ free rigid-body modes
def test_case_free_rigid_body_modes_singular_KT():
    """The unsupported table: K_T has six zero eigenvalues (three translations, three
    rotations) - singular - yet form-finding converges (one coordinate per rigid motion is
    held), reports rigid_body_modes = 6 and a positive smallest eigenvalue on the rest."""
    s = load_example("tensegrity_table")
    r = form_find(s)
    assert r.success and r.rigid_body_modes == 6 and r.min_eigenvalue > 0
    assert independent_residual(s, r.nodes) <= 1e-10 * s.EA.max()
    K = tangent_stiffness(s, r.configuration)
    d = jacobi_scaling(K)
    w = np.linalg.eigvalsh(d[:, None] * K * d[None, :])
    assert np.sum(np.abs(w) < 1e-9) == 6 and w[6] > 1e-3


# ------------------------------------------------------------------ strings slack during iterations
@pytest.mark.parametrize("n", [20, 40])
def test_case_strings_going_slack_during_iterations(n):
    """The C spine drawn straight: the first Newton steps slacken up to 30 % of the side
    strings. The result is the same equilibrium with the slack-string Newton matrix and
    with the exact K_T (two different iterations) to 1e-9 m, and balanced by the
    independent residual. 40 vertebrae already take the exact K_T 4x the iterations (78
    against 19; 100 vertebrae, 122 against 48, cost twice as much CPU for the same check:
    the benchmark ``hard:slack_newton --full`` runs them)."""
    s = tensegrity_spine(n, shape="C")
    seen = []
    r = form_find(s, callback=lambda info: seen.append(info.residual) and None)
    exact = form_find(s, slack_stiffness=False, max_iter=400)
    assert r.success and exact.success
    assert np.abs(r.nodes - exact.nodes).max() < 1e-9
    assert independent_residual(s, r.nodes) <= 1e-10 * s.EA.max()
    assert r.iterations < exact.iterations


# ------------------------------------------------------------------ stiffness ratios to 1e6
def _node_on_four_members(ratio: float) -> Structure:
    """A free node held by a bar (EA ratio x that of the strings) and three strings from
    pinned anchors, loaded sideways: a 3-unknown problem with a 50-digit root."""
    anchors = np.array([[0, 0, -1.0], [1, 0, 1.0], [-0.5, 0.9, 1.0], [-0.5, -0.9, 1.0]])
    nodes = np.vstack([anchors, [[0.05, 0.02, 0.1]]])
    return Structure.from_arrays(nodes, [[0, 4], [1, 4], [2, 4], [3, 4]], EA=[100.0 * ratio, 100, 100, 100],
                                 kinds=["bar", "string", "string", "string"],
                                 rest_length_ratio=[1.0, 0.8, 0.8, 0.8], pinned=[True] * 4 + [False],
                                 loads=[[0, 0, 0]] * 4 + [[3.0, -2.0, -5.0]])


@pytest.mark.parametrize("ratio", [1.0, 1e2, 1e4, 1e6])
def test_case_stiffness_ratio_up_to_1e6(ratio):
    """Bar/string EA ratio 1 .. 1e6: the node agrees with the 50-digit root of the force
    balance (mpmath findroot) to within |P| / smallest stiffness eigenvalue (``residual_norm
    / min_eigenvalue``), the error bound of a converged iterate, and to 1e-9 m."""
    s = _node_on_four_members(ratio)
    r = form_find(s)
    assert r.success, r.message
    A = [mp.matrix([float(v) for v in a]) for a in s.nodes[:4]]
    l0 = [mp.mpf(float(v)) for v in s.rest_lengths]
    EA = [mp.mpf(float(v)) for v in s.EA]
    F = mp.matrix([3, -2, -5])

    def balance(x, y, z):
        p = mp.matrix([x, y, z])
        total = F.copy()
        for a, L0, ea in zip(A, l0, EA):
            h = a - p
            l = mp.norm(h)
            total += ea * (l - L0) / L0 / l * h
        return [total[0], total[1], total[2]]

    root = mp.findroot(balance, [mp.mpf(float(v)) for v in r.nodes[4]])
    err = max(abs(float(root[i]) - r.nodes[4, i]) for i in range(3))
    assert err <= r.residual_norm / r.min_eigenvalue + 1e-15
    assert err < 1e-9


# ------------------------------------------------------------------ nearly coincident nodes
def _short_bar(gap: float) -> Structure:
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, 0.3, 0.3], [0.3 + gap, 0.3, 0.3]])
    return Structure.from_arrays(nodes, [[0, 4], [1, 4], [2, 4], [3, 5], [4, 5]], EA=[1e3] * 5,
                                 kinds=["string"] * 4 + ["bar"], rest_length_ratio=[0.9] * 4 + [1.0],
                                 pinned=[True] * 4 + [False] * 2)


@pytest.mark.parametrize("gap", [1e-3, 1e-5, 1e-6])
def test_case_nearly_coincident_nodes_converge_above_the_rounding_floor(gap):
    """Two nodes ``gap`` apart on a bar: converged to the tolerance itself (the bar's
    rounding floor ``EA/l0 eps |x|``, ~2e-13 N / gap, stays below 1e-10 of the forces at
    its ends, ~30 N), balanced by the independent residual, equal to the 40-digit root."""
    s = _short_bar(gap)
    r = form_find(s)
    assert r.success, r.message
    assert "rounding level" not in r.message
    assert relative_residual(s, r.nodes).max() <= 1e-10
    assert independent_residual(s, r.nodes) <= 1e-10 * s.EA.max()
    np.testing.assert_allclose(r.nodes, mp_equilibrium(s, r.nodes), rtol=0, atol=1e-15)


@pytest.mark.parametrize("gap", [1e-7, 1e-9, 1e-10])
def test_case_nearly_coincident_nodes_at_the_rounding_floor_converge_and_say_so(gap):
    """Closer, the bar's force is only known to its rounding floor (EA/l0 = 1e3/gap times eps
    |x|: 2e-6 N at 1e-7, 2e-3 N at 1e-10), above 1e-10 of the forces at its ends: the result
    converges at that level and says so, naming the node and the member (it used to fail
    with status 2 here). It is as right as doubles allow: the nodes equal the 40-digit root
    to 1e-13 m (measured 6e-15 .. 1e-16), within the error bound |P| / lambda_min, and the
    bar's force equals the root's within its rounding floor."""
    s = _short_bar(gap)
    r = form_find(s)
    assert r.success, r.message
    assert "within the rounding level of the forces there" in r.message
    assert "node '5'" in r.message or "node '4'" in r.message
    assert f"member 'm4': EA/l0 = {1e3 / (gap * 1.0):.3g} N/m" in r.message
    root = mp_equilibrium(s, r.nodes, iterations=3)
    err = np.abs(r.nodes - root).max()
    assert err <= 1e-13 and err <= r.residual_norm / r.min_eigenvalue
    floor = 1e3 / gap * np.finfo(float).eps * 2 * np.linalg.norm(root[4])
    assert abs(r.member_forces[4] - member_forces(s, root)[4]) <= 4 * floor


def test_case_coincident_nodes_are_refused_naming_the_member():
    with pytest.raises(Exception) as err:
        _short_bar(0.0)
    assert "zero length" in str(err.value) and "m4" in str(err.value)


# ------------------------------------------------------------------ no stable equilibrium
TABLE = example_path("tensegrity_table").read_text()


def test_case_no_equilibrium_unbalanced_load_fails_at_once():
    """The unsupported table with 10 N down on c1: nothing balances a net force, so there is
    no equilibrium; form_find says so before iterating (it used to run 200 iterations)."""
    s = load_structure(TABLE + "loads: {c1: [0, 0, -10]}\n")
    for method in ("newton", "dynamic_relaxation"):
        r = form_find(s, method=method)
        assert not r.success and r.status == 7 and r.iterations == 0
        assert "no equilibrium exists" in r.message and "[0, 0, -10] N" in r.message
    assert unbalanced_load(load_structure(TABLE + "loads: {c1: [0, 0, -10], c2: [0, 0, 10]}\n")) is None


def test_case_no_equilibrium_gravity_on_a_roller_supported_structure():
    """Pinned in z only: gravity is resisted, a horizontal load is not (the free plane)."""
    s = Structure.from_arrays(np.array([[0, 0, 0], [1.0, 0, 0]]), [[0, 1]], EA=10.0,
                              pinned=[[False, False, True]] * 2, loads=[[0, 0, 0], [1, 0, -10]])
    u = unbalanced_load(s)
    assert u is not None and len(u.directions) == 2
    np.testing.assert_allclose(u.force, [1, 0, 0], atol=1e-12)


def test_case_no_stable_equilibrium_neutral_mechanism_reported():
    """A node held by two collinear strings only has no stable equilibrium (it can move
    freely normal to them): reported as a failure (status 4, neutral), not as converged."""
    nodes = np.array([[-1.0, 0, 0], [1.0, 0, 0], [0.0, 0, 0]])
    s = Structure.from_arrays(nodes, [[0, 2], [1, 2]], EA=100.0, rest_length_ratio=1.0,
                              pinned=[True, True, False])
    r = form_find(s)
    assert not r.success and r.status == 4 and "zero stiffness" in r.message


def test_case_no_stable_equilibrium_only_a_saddle_is_left():
    """A bar standing on a pinned foot with its top pushed down (an inverted pendulum) is in
    equilibrium upright, but unstable; form-finding leaves the saddle and finds the
    hanging equilibrium below, never reports the upright one as a result."""
    nodes = np.array([[0, 0, 0], [0, 0, 1.0]])
    s = Structure.from_arrays(nodes, [[0, 1]], EA=1e4, kinds="bar", rest_length_ratio=1.0,
                              pinned=[True, False], loads=[[0, 0, 0], [0, 0, -1.0]])
    r = form_find(s)
    assert r.success and r.nodes[1, 2] < 0


# ------------------------------------------------------------------ large with few very short members
def test_case_large_structure_with_a_few_very_short_members():
    """A 2,392-member spine plus three 1e-5 m links (EA/l0 = 7.6e11 N/m, 1e4 x the spine's
    strings) holding extra nodes: converged, balanced by the independent residual; the
    links stretch by t l0 / EA (1e-3 under the strings' pull)."""
    base = tensegrity_spine(300, shape="straight", perturbation=0.03)
    x = base.nodes.copy()
    members = base.members.tolist()
    kinds = list(base.member_kinds)
    EA = list(base.EA)
    l0 = list(base.rest_lengths)
    pinned = np.zeros((len(x) + 3, 3), dtype=bool)
    extra = []
    for k, v in enumerate((10, 20, 30)):
        c = 5 * v                                       # centre node of vertebra v
        p = x[c] + [1e-5, 0, 0]
        extra.append(p)
        j = len(x) + k
        for other, kind, ratio in ((c, "bar", 1.0), (c + 1, "string", 0.999), (c + 3, "string", 0.999),
                                   (c + 4, "string", 0.999)):
            members.append([other, j])
            kinds.append(kind)
            EA.append(float(base.EA[0]))
            l0.append(ratio * float(np.linalg.norm(x[other] - p)))
    s = Structure.from_arrays(np.vstack([x, extra]), np.array(members), EA=EA, rest_lengths=l0, kinds=kinds,
                              bodies=base.bodies, pinned=pinned)
    r = form_find(s)
    assert r.success, r.message
    assert independent_residual(s, r.nodes) <= 1e-10 * s.EA.max()
    short = np.array([i for i, m in enumerate(members) if m[1] >= len(x) and kinds[i] == "bar"])
    assert np.abs(r.member_lengths[short] / s.rest_lengths[short] - 1).max() < 1e-2
