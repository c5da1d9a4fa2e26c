"""Inverse kinematics: the paper's quartic route, root classification, round trips, branches."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st

from tensegrity_core.class2 import PAPER_PARAMS
from tensegrity_core.class2.ik_arrays import IK_BRANCHES, IK_CODES, ik_array, ik_array_all
from tensegrity_core.class2.inverse_kinematics import (
    REASON_DUPLICATE,
    REASON_MAXIMUM,
    REASON_NOT_STATIONARY,
    REASON_RANGE,
    inverse_kinematics,
    merge_radius,
    nearest_solution,
    rho1_snap_bound,
    snap_tolerance,
)
from tensegrity_core.class2.kinematics import fk_array, forward_kinematics
from tensegrity_core.errors import DomainError
from tests.class2.strategies import configurations, edged, parameter_sets, scaled

P = PAPER_PARAMS
EPS = np.finfo(float).eps


def paper_quadratic(x, y, rho1, p):
    """xi0, xi1, xi2 exactly as printed in Eqs. (15)-(17)."""
    k2, k3, L = p.k2, p.k3, p.L
    xi0 = k2**2 * (y**2 * rho1**2 - (x - rho1) ** 2 * (4 * L**2 - rho1**2))
    xi1 = 2 * k2 * rho1 * (k2 * (x - rho1) ** 2 - (2 * k3 + k2) * y**2)
    xi2 = y**2 * (2 * k3 + k2) ** 2 + k2**2 * (x - rho1) ** 2
    return xi0, xi1, xi2


def test_eqs_14_to_17_follow_from_squaring_eq10_with_eq12():
    import sympy as sp

    rho1, rho2, y, c, k2, k3, L = sp.symbols("rho1 rho2 y c k2 k3 L", real=True)
    K = 2 * k3 + k2
    squared = sp.expand(y**2 * (K * rho2 - k2 * rho1) ** 2 - c**2 * k2**2 * (4 * L**2 - (rho1 + rho2) ** 2))
    xi0 = k2**2 * (y**2 * rho1**2 - c**2 * (4 * L**2 - rho1**2))
    xi1 = 2 * k2 * rho1 * (k2 * c**2 - K * y**2)
    xi2 = y**2 * K**2 + k2**2 * c**2
    assert sp.expand(squared - (xi2 * rho2**2 + xi1 * rho2 + xi0)) == 0
    # and the discriminant factors once y^2 + c^2 = L^2 (c = x - rho1 from Eq. 13):
    disc = sp.expand((xi1**2 - 4 * xi2 * xi0).subs(L, sp.sqrt(y**2 + c**2)))
    factored = 4 * k2**2 * c**2 * (4 * (y**2 + c**2) * xi2 - (K + k2) ** 2 * rho1**2 * y**2)
    assert sp.expand(disc - factored) == 0


@given(configurations(margin=1e-4), parameter_sets())
def test_candidates_equal_eq18_roots_as_printed(rho, params):
    fk = forward_kinematics(*scaled(rho, params), params)
    assume(abs(math.cos(fk.beta)) > 1e-3 and fk.y > 1e-3 * params.L)
    res = inverse_kinematics(fk.x, fk.y, params, paper_range=False)
    for cand in res.candidates:
        xi0, xi1, xi2 = paper_quadratic(fk.x, fk.y, cand.rho1, params)
        disc = xi1**2 - 4 * xi2 * xi0
        printed = (-xi1 + cand.delta2 * math.sqrt(disc)) / (2 * xi2)
        assert cand.rho1 == pytest.approx(fk.x + cand.delta1 * math.sqrt(params.L**2 - fk.y**2), abs=1e-12)
        assert cand.rho2 == pytest.approx(printed, rel=1e-7, abs=1e-9 * params.L)


@given(edged(0.0, 1.0), edged(0.0, math.pi / 2))
@example(1.0, math.pi / 2)                           # the corner rho1 = L on the fold: a singular point
@example(1.0, math.nextafter(math.pi / 2, 0.0))      # x rounds beyond L, y rounds onto L
@example(1.0, math.pi / 2 - 1e-9)                    # rounded target 5e-19 outside W, rho1 1e-9 beyond L
@example(0.0, math.pi / 2)                           # the folded point
@example(1.0, 0.0)                                   # rho1 = L on lambda1
def test_fk_of_ik_reproduces_the_target_to_1e_10(u, beta):
    # Targets over the whole workspace W = {B + L (cos beta, sin beta): 0 <= rho1 <= L, 0 <= beta <= pi/2},
    # its boundary drawn on purpose. Each target has exactly one configuration in the paper's
    # range; on the fold (beta = pi/2) the four roots coincide within rounding: one, not two.
    x, y = u + math.cos(beta), math.sin(beta)
    res = inverse_kinematics(x, y)
    assert len(res.valid) == 1
    sol = res.valid[0]
    fk = forward_kinematics(sol.rho1, sol.rho2)
    # The map rho -> D has |dD/drho| ~ L / y near y = 0 (lambda1 -> 0), so rounding rho to
    # doubles alone moves D by ~eps L^2 / y: 1e-10 holds for y >= 1e-5 L. Below, the bound is
    # the smaller of that and the square-root law lambda1 ~ sqrt(L * 2L eps) of the rounded
    # rho1 + rho2, times k2 / d <= 1/2: about 2e-8 L (docs/class2.md).
    # Within rounding of the fold on the boundary of W, a length snapped onto its limit
    # moves D by up to snap_tolerance(c) = 1e-12 L + 8 eps L^2 / c (> 1e-10 only for c < 2e-5 L).
    tol = max(1e-10, min(8 * EPS / max(y, 1e-300), 3e-8), (snap_tolerance(math.cos(beta), 1.0)))
    assert math.hypot(fk.x - x, fk.y - y) <= tol
    assert sol.fk_residual <= tol
    assert (sol.delta1, sol.delta2) == (-1, 1)


@given(configurations(), parameter_sets())
def test_ik_of_fk_recovers_the_actuator_lengths(rho, params):
    r1, r2 = scaled(rho, params)
    fk = forward_kinematics(r1, r2, params)
    assume(fk.y > 1e-6 * params.L)
    res = inverse_kinematics(fk.x, fk.y, params, paper_range=False)
    best = res.nearest((r1, r2))
    # Recovering rho from a rounded D costs cond(J) eps; at the fold (beta = pi/2, det J = 0)
    # D depends quadratically on the distance to the fold line, so that error saturates at
    # ~sqrt(eps) L (measured: 1.2e-8 L). Targets with L - y <= DOMAIN_TOL L are snapped onto
    # the fold (|cos beta| <= 1.5e-6): there rho moves by up to ~sqrt(2 DOMAIN_TOL) L.
    if abs(math.cos(fk.beta)) > 1e-5:
        tol = max(1e-12, min(4 * fk.jacobian_cond * EPS, 6e-8)) * params.L
    else:
        tol = 1e-5 * params.L
    assert math.hypot(best.rho1 - r1, best.rho2 - r2) <= tol
    assert best.fk_residual <= (snap_tolerance(abs(math.cos(best.beta)) * params.L, params.L))
    assert best.in_paper_range == fk.in_paper_range or abs(math.cos(fk.beta)) <= 1e-5


@given(st.floats(-0.5, 2.5), st.floats(1e-6, 1.0 - 1e-6), parameter_sets())
def test_each_delta1_has_exactly_one_genuine_root_for_0_lt_y_lt_L(u, v, params):
    # Claim (docs/class2.md): for 0 < y < L and 0 <= rho1 <= L each delta1 gives exactly one
    # equilibrium root, with delta2 = -delta1: at most 2 genuine solutions, at most 1 in range.
    L = params.L
    x, y = u * L, v * L
    res = inverse_kinematics(x, y, params, paper_range=False)
    for d1 in (-1, 1):
        rho1 = x + d1 * math.sqrt(L * L - y * y)
        if not 0.0 <= rho1 <= L:
            continue
        branch = [c for c in res.candidates if c.delta1 == d1]
        assert len(branch) == 2
        genuine = [c for c in branch if "spurious" not in c.reason]
        assert [c.delta2 for c in genuine] == [-d1]
        spurious = [c for c in branch if c.delta2 == d1][0]
        assert spurious.reason.endswith(REASON_NOT_STATIONARY)
        if 0.0 <= spurious.rho2 and spurious.rho1 + spurious.rho2 <= 2 * L:
            # the spurious root is the mirror equilibrium beta' = pi - beta: FK lands 2|c| away
            assert spurious.fk_residual == pytest.approx(2 * math.sqrt(L * L - y * y), rel=1e-9, abs=1e-12)
    assert len(res.valid) <= 2
    assert sum(c.in_paper_range for c in res.valid) <= 1
    strict = inverse_kinematics(x, y, params)
    assert len(strict.valid) <= 1
    assert all(c.in_paper_range for c in strict.valid)


def test_two_equilibria_for_one_target_and_branch_choice_by_seed():
    fk = forward_kinematics(0.9, 0.1)          # beta = 1.904 > pi/2
    assert not fk.in_paper_range
    assert inverse_kinematics(fk.x, fk.y).success  # the delta1 = -1 twin is in range
    res = inverse_kinematics(fk.x, fk.y, paper_range=False)
    assert len(res.valid) == 2
    out_of_range = nearest_solution(fk.x, fk.y, (0.85, 0.15), paper_range=False)
    assert (out_of_range.rho1, out_of_range.rho2) == pytest.approx((0.9, 0.1), abs=1e-13)
    assert (out_of_range.delta1, out_of_range.delta2) == (1, -1)
    twin = nearest_solution(fk.x, fk.y, (0.2, 0.3), paper_range=False)
    assert twin.delta1 == -1 and twin.in_paper_range
    assert nearest_solution(fk.x, fk.y, (0.85, 0.15)) == twin   # paper range: the only one
    strict = inverse_kinematics(fk.x, fk.y)
    flagged = [c for c in strict.candidates if c.delta1 == 1 and c.delta2 == -1][0]
    assert not flagged.valid and flagged.reason == REASON_RANGE and flagged.stiffness_beta > 0


def test_trajectory_stays_on_one_branch_with_nearest_solution():
    seed = (0.9, 0.1)
    start = forward_kinematics(*seed)
    for t in np.linspace(0.0, 1.0, 21):
        x, y = start.x - 0.1 * t, start.y - 0.05 * t
        sol = nearest_solution(x, y, seed, paper_range=False)
        assert (sol.delta1, sol.delta2) == (1, -1) and not sol.in_paper_range
        seed = (sol.rho1, sol.rho2)


def test_y_equal_L_gives_one_solution_and_three_duplicates():
    res = inverse_kinematics(0.3, 1.0, paper_range=False)
    assert [(c.delta1, c.delta2) for c in res.candidates] == list(IK_BRANCHES)
    assert len(res.valid) == 1
    sol = res.valid[0]
    assert (sol.rho1, sol.rho2) == pytest.approx((0.3, 0.1), abs=1e-15)   # fold line 3 rho2 = rho1
    assert all(c.reason == REASON_DUPLICATE for c in res.candidates[1:])


@pytest.mark.parametrize("gap", [0.0, 1e-16, 5e-13, 1e-12, 1.01e-12, 1e-11, 1e-9, 1e-6])
@pytest.mark.parametrize("L", [0.2, 1.0, 5.0])
def test_distinct_solutions_near_the_fold(gap, L):
    # A target at height y = L (1 - gap) beside the fold has the two equilibria rho1 = x -+ w,
    # w = sqrt(L^2 - y^2) = L sqrt(gap (2 - gap)): two configurations, 2w apart in rho1. Within
    # DOMAIN_TOL L of the fold the target is on it and w = 0: the branches are one double root,
    # one configuration. merge_radius = sqrt(2 DOMAIN_TOL) L is the branch separation that a
    # target resolution of DOMAIN_TOL L leaves; the first pair not merged is >= 2.2e-6 L apart.
    params = P.with_overrides(L=L)
    y = L * (1.0 - gap)
    w = L * math.sqrt(gap * (2.0 - gap))
    x = 0.5 * L   # rho1 = x -+ w both inside [0, L]
    res = inverse_kinematics(x, y, params, paper_range=False)
    merged = gap <= 1e-12
    assert len(res.valid) == (1 if merged else 2)
    if not merged:
        a, b = res.valid
        assert abs(a.rho1 - b.rho1) == pytest.approx(2.0 * w, rel=1e-3)
        assert math.hypot(a.rho1 - b.rho1, a.rho2 - b.rho2) > merge_radius(L)
    for sol in res.valid:
        assert sol.fk_residual <= 1e-12 * L
    assert len(inverse_kinematics(x, y, params).valid) == 1


@pytest.mark.parametrize("L", [0.2, 1.0, 5.0])
@pytest.mark.parametrize("over", [0.0, 1e-16, 1e-13, 1e-9, 1e-7, 1e-6, 1.4e-6, 1.5e-6, 1e-5])
def test_corner_of_the_fold_within_the_domain_tolerance_is_reached(L, over):
    # D = (L + over, L) is at distance sqrt(L^2 + over^2) - L = over^2 / (2 L) from the corner
    # circle rho1 = L: reached (one solution, rho1 = L) while that is <= DOMAIN_TOL L = 1e-12 L,
    # i.e. over <= sqrt(2e-12) L = 1.414e-6 L; beyond it, "outside the workspace".
    params = P.with_overrides(L=L)
    res = inverse_kinematics(L + over * L, L, params, paper_range=False)
    inside = (over * L) ** 2 / (2 * L) <= 1e-12 * L
    assert over * L <= rho1_snap_bound(0.0, L) if inside else over * L > rho1_snap_bound(0.0, L)
    assert len(res.valid) == (1 if inside else 0)
    if inside:
        sol = res.valid[0]
        assert sol.rho1 == L and sol.in_paper_range
        assert sol.fk_residual <= 1e-12 * L
    else:
        assert "outside the workspace" in res.message


def test_y_zero_edge_and_energy_maximum():
    res = inverse_kinematics(1.5, 0.0, paper_range=False)
    assert [(c.rho1, c.rho2) for c in res.valid] == [(0.5, 1.5)]   # lambda1 = 0, beta = 0
    # below the X axis the only stationary roots are energy maxima; nothing is valid
    low = inverse_kinematics(1.5, -0.3, paper_range=False)
    assert not low.valid
    assert any(REASON_MAXIMUM in c.reason for c in low.candidates)
    assert low.outside_distance == pytest.approx(0.3)


@pytest.mark.parametrize(
    ("x", "y", "distance"),
    [(3.0, 0.5, math.hypot(2.0, 0.5) - 1.0), (0.5, 1.2, 0.2), (0.2, 0.2, 1 - math.hypot(0.2, 0.2))],
)
def test_unreachable_targets_report_the_distance(x, y, distance):
    res = inverse_kinematics(x, y)
    assert not res.success
    assert res.outside_distance == pytest.approx(distance, abs=1e-12)
    with pytest.raises(DomainError, match="outside the workspace") as err:
        nearest_solution(x, y, (0.5, 0.5))
    assert err.value.distance == pytest.approx(distance, abs=1e-12)


@pytest.mark.parametrize("bad", [math.nan, math.inf, "x"])
def test_non_finite_target_is_a_domain_error(bad):
    with pytest.raises(DomainError, match="y"):
        inverse_kinematics(1.0, bad)
    with pytest.raises(DomainError, match="seed"):
        nearest_solution(1.4, 0.7, (0.7, bad))
    with pytest.raises(DomainError, match="seed"):
        nearest_solution(1.4, 0.7, (0.7,))


def edge_targets():
    """Targets on and just beside the boundary of W, the fold and its corners (L = 1)."""
    off = np.array([0.0, 1e-16, 1e-13, 1e-12, 1e-9, 1e-6, 1.4e-6, 1.5e-6, 1e-3])
    off = np.concatenate([-off[::-1], off])
    ex, ey = [], []
    for corner_x in (0.0, 1.0, 2.0):
        for top in (1.0, 0.0):
            gx, gy = np.meshgrid(corner_x + off, top + off)
            ex.append(gx.ravel())
            ey.append(gy.ravel())
    beta = np.linspace(0.0, np.pi / 2, 41)
    for r1 in (0.0, 1.0):
        for sign in (-1.0, 1.0):   # just outside and inside the arcs rho1 = 0 and rho1 = L
            ex.append(r1 + (1.0 + sign * 1e-13) * np.cos(beta))
            ey.append((1.0 + sign * 1e-13) * np.sin(beta))
    return np.concatenate(ex), np.concatenate(ey)


def test_ik_array_matches_scalar_paper_branch():
    rng = np.random.default_rng(7)
    ex, ey = edge_targets()
    x = np.concatenate([rng.uniform(-0.2, 2.2, 3000), ex])
    y = np.concatenate([rng.uniform(-0.2, 1.2, 3000), ey])
    x[:4], y[:4] = [0.3, 1.5, np.nan, 1.0], [1.0, 0.0, 0.5, np.inf]
    out = ik_array(x, y)
    for i in range(len(x)):
        try:
            valid = inverse_kinematics(x[i], y[i]).valid
        except DomainError:
            valid = ()
        assert out.valid[i] == bool(valid)
        if valid:
            assert (out.rho1[i], out.rho2[i], out.beta[i]) == pytest.approx(
                (valid[0].rho1, valid[0].rho2, valid[0].beta), abs=1e-14)
        else:
            assert np.isnan(out.rho1[i]) and np.isnan(out.rho2[i])


def test_ik_array_all_codes_match_scalar_reasons():
    rng = np.random.default_rng(8)
    ex, ey = edge_targets()
    x = np.concatenate([rng.uniform(-0.5, 2.5, 1500), ex, ex])
    y = np.concatenate([rng.uniform(-1.1, 1.1, 1500), ey, -ey])
    out = ik_array_all(x, y)
    assert out.code.shape == (len(x), 4)
    for i in range(len(x)):
        res = inverse_kinematics(x[i], y[i], paper_range=False)
        by_branch = {(c.delta1, c.delta2): c for c in res.candidates}
        for j, br in enumerate(IK_BRANCHES):
            code = int(out.code[i, j])
            cand = by_branch.get(br)
            if cand is None:
                assert code == 2
                continue
            assert cand.valid == (code in (0, 1))
            if cand.valid:
                assert cand.in_paper_range == (code == 0)
                assert (out.rho1[i, j], out.rho2[i, j]) == pytest.approx((cand.rho1, cand.rho2), abs=1e-13)
            else:
                assert cand.reason.split("; ")[0] == IK_CODES[code]


def test_vectorised_round_trip_over_the_workspace():
    rng = np.random.default_rng(9)
    r1 = rng.uniform(0, 1, 100_000)
    beta = rng.uniform(1e-5, np.pi / 2, 100_000)
    x, y = r1 + np.cos(beta), np.sin(beta)
    out = ik_array(x, y)
    assert out.valid.all()
    fk = fk_array(out.rho1, out.rho2)
    assert np.hypot(fk.x - x, fk.y - y).max() <= 1e-10
    assert np.abs(out.rho1 - r1).max() <= 1e-12
