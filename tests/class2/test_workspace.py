"""Workspace, boundary and singular sets of the class-2 mechanism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.class2 import PAPER_PARAMS
from tensegrity_core.class2.full_workspace import distance_to_full_workspace, in_full_workspace
from tensegrity_core.class2.kinematics import fk_array, forward_kinematics, jacobian_D_rho
from tensegrity_core.class2.singularities.report import classify_singularities
from tensegrity_core.class2.workspace import workspace
from tensegrity_core.errors import DomainError

P = PAPER_PARAMS


@pytest.mark.parametrize("L", [1.0, 2.5])
def test_full_workspace_has_area_L_squared(L):
    # (rho1, beta) -> D is one-to-one on [0, L] x [0, pi/2] with Jacobian L cos(beta):
    # area = int_0^L int_0^{pi/2} L cos(beta) dbeta drho1 = L^2.
    p = P.with_overrides(L=L, k2=0.6, k3=1.7)
    assert workspace(p).area() == pytest.approx(L * L, rel=1e-10)


def test_union_with_beta_above_half_pi_adds_nothing_for_full_ranges():
    ws = workspace(paper_range=False)
    assert ws.area(resolution=400) == pytest.approx(1.0, abs=4 * 4 / 400)   # perimeter x cell
    rng = np.random.default_rng(1)
    r1 = rng.uniform(0, 1, 5000)
    r2 = rng.uniform(0, 1, 5000) * r1 / 3          # beta > pi/2 sheet
    fk = fk_array(r1, r2)
    assert np.all([in_full_workspace(x, y, 1.0, 1e-12) for x, y in zip(fk.x, fk.y)])


def test_polygon_vertices_map_to_the_corners_of_W():
    ws = workspace()
    corners = {tuple(np.round(v, 12)) for v in ws.polygon}
    assert corners == {(0.0, 0.0), (0.0, 2.0), (1.0, 1.0), (1.0, round(1 / 3, 12))}
    images = {tuple(np.round(c.xy[0], 12)) for c in ws.edges} | {tuple(np.round(c.xy[-1], 12)) for c in ws.edges}
    assert images == {(0.0, 1.0), (1.0, 0.0), (2.0, 0.0), (1.0, 1.0)}
    assert all(c.on_boundary.all() for c in ws.edges)
    kinds = {c.kind for c in ws.singular_curves}
    assert kinds == {"lambda1", "lambda2", "beta_half_pi", "folded"}


def test_closed_form_W_agrees_with_ik_membership():
    ws = workspace()
    rng = np.random.default_rng(2)
    x = rng.uniform(-0.2, 2.2, 20000)
    y = rng.uniform(-0.2, 1.2, 20000)
    inside = ws.contains(x, y)
    d = np.array([distance_to_full_workspace(a, b, 1.0) for a, b in zip(x, y)])
    clear = np.abs(d) > 1e-9
    assert np.array_equal(inside[clear], d[clear] < 0)


def test_distance_to_W_matches_dense_boundary_samples():
    ws = workspace(n=4000)
    boundary = np.concatenate(ws.boundary_xy())
    rng = np.random.default_rng(3)
    for x, y in rng.uniform([-1, -1], [3, 2], size=(200, 2)):
        brute = np.min(np.hypot(boundary[:, 0] - x, boundary[:, 1] - y))
        # sampled boundary: spacing <= ~2e-3, so brute - exact <= 1e-3 (half a chord)
        assert abs(distance_to_full_workspace(x, y, 1.0)) == pytest.approx(brute, abs=1e-3)


LIMITS = [((0.2, 0.8), (0.0, 0.3)), ((0.0, 0.5), (0.5, 1.2)), ((0.3, 1.0), (0.05, 2.0)), (None, (0.0, 0.2))]


@pytest.mark.parametrize(("r1", "r2"), LIMITS)
@pytest.mark.parametrize("paper_range", [True, False])
def test_limited_workspace_contains_exactly_the_images_of_admissible_lengths(r1, r2, paper_range):
    ws = workspace(rho1_range=r1, rho2_range=r2, paper_range=paper_range)
    (a1, b1), (a2, b2) = ws.rho1_range, ws.rho2_range
    rng = np.random.default_rng(4)
    rho1 = rng.uniform(a1, b1, 4000)
    rho2 = rng.uniform(a2, b2, 4000)
    ok = rho1 + rho2 <= 2.0
    if paper_range:
        ok &= 3 * rho2 >= rho1
    fk = fk_array(rho1, rho2)
    assert ws.contains(fk.x[ok], fk.y[ok]).all()
    # images of lengths outside the polygon that land in the set must have a twin inside it
    out = ~ok & fk.valid
    hit = ws.contains(fk.x[out], fk.y[out])
    for x, y in zip(fk.x[out][hit], fk.y[out][hit]):
        from tensegrity_core.class2.inverse_kinematics import inverse_kinematics
        sols = inverse_kinematics(x, y, paper_range=paper_range).valid
        assert any(a1 - 1e-12 <= s.rho1 <= b1 + 1e-12 and a2 - 1e-12 <= s.rho2 <= b2 + 1e-12 for s in sols)


@pytest.mark.parametrize(("r1", "r2"), LIMITS)
def test_exact_area_matches_grid_count(r1, r2):
    ws = workspace(rho1_range=r1, rho2_range=r2)
    x0, x1, y0, y1 = ws.bounds()
    n = 600
    xs = np.linspace(x0, x1, n + 1)
    ys = np.linspace(y0, y1, n + 1)
    xc, yc = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (ys[1:] + ys[:-1])
    count = ws.contains(xc[None, :], yc[:, None]).sum() * (xs[1] - xs[0]) * (ys[1] - ys[0])
    perimeter = sum(np.sum(np.hypot(*np.diff(c.xy, axis=0).T)) for c in ws.edges)
    cell = max(xs[1] - xs[0], ys[1] - ys[0])
    assert ws.area() == pytest.approx(count, abs=perimeter * cell)


def test_boundary_points_have_unreachable_neighbours_and_interior_points_do_not():
    ws = workspace(rho1_range=(0.2, 0.8), rho2_range=(0.0, 0.3), paper_range=False)
    # on_boundary means "some point at distance 1e-6 L is unreachable" (16 directions)
    ring = np.exp(1j * np.linspace(0, 2 * np.pi, 64, endpoint=False))
    marked = 0
    for curve in ws.edges:
        for (x, y), on in zip(curve.xy[1:-1:3], curve.on_boundary[1:-1:3]):
            if on:
                assert not ws.contains(x + 1e-6 * ring.real, y + 1e-6 * ring.imag).all()
                marked += 1
            else:
                assert ws.contains(x + 5e-7 * ring.real, y + 5e-7 * ring.imag).all()
    assert 0 < marked < sum(len(c.xy[1:-1:3]) for c in ws.edges)


@pytest.mark.parametrize(
    ("r1", "r2", "message"),
    [((2.0, 3.0), None, "does not meet"), ((0.5, 0.1), None, "exceeds max"),
     ((0.9, 1.0), (1.5, 2.0), "no admissible"), ((0.5, 1.0), (0.0, 0.1), "try paper_range=False"),
     ((math.nan, 1.0), None, "finite")],
)
def test_bad_limits_are_rejected_with_reasons(r1, r2, message):
    with pytest.raises(DomainError, match=message):
        workspace(rho1_range=r1, rho2_range=r2)


def test_singularity_report_on_each_set():
    fold = classify_singularities(0.6, 0.2)
    assert fold.nearest.kind in {"beta_half_pi", "ik_discriminant", "det_jacobian"}
    by = {s.kind: s for s in fold.sets}
    assert by["beta_half_pi"].distance == pytest.approx(0.0, abs=1e-16)
    assert abs(by["det_jacobian"].value) < 1e-14 and abs(by["ik_discriminant"].value) < 1e-12
    flat = classify_singularities(0.5, 1.5)
    assert flat.distance == 0.0 and flat.jacobian is None and flat.jacobian_cond == math.inf
    assert {s.kind for s in flat.near(0.0)} == {"lambda1", "beta_zero"}
    top = classify_singularities(1.0, 0.5)
    assert top.nearest.kind == "lambda2" and top.nearest.value == 0.0
    folded = classify_singularities(0.0, 0.0)
    assert {s.kind for s in folded.near(0.0)} >= {"folded", "beta_half_pi", "det_jacobian"}
    with pytest.raises(DomainError):
        classify_singularities(1.2, 0.1)


@given(st.floats(0.01, 0.99), st.floats(0.01, 0.99))
def test_ik_discriminant_equals_factorised_form_and_det_formula(u, v):
    r1 = u
    r2 = v * (2 - r1) * 0.999
    rep = classify_singularities(r1, r2)
    fk = forward_kinematics(r1, r2)
    c, y, K, k2 = fk.x - r1, fk.y, 3.0, 1.0
    q2 = 4 * (K**2 * y**2 + k2**2 * c**2) - (K + k2) ** 2 * r1**2 * y**2
    by = {s.kind: s for s in rep.sets}
    assert by["ik_discriminant"].value == pytest.approx(4 * k2**2 * c**2 * q2, rel=1e-8, abs=1e-12)
    assert rep.jacobian_det == pytest.approx(np.linalg.det(jacobian_D_rho(r1, r2)), rel=1e-12)
    # det changes sign across the fold line exactly: sign(det) = -sign(cos beta)
    if abs(3 * r2 - r1) > 1e-9:
        assert np.sign(rep.jacobian_det) == -np.sign(math.cos(fk.beta))


#: How a singular set's value scales when every length is multiplied by s and every stiffness
#: by kappa, by its unit (dimensional analysis: a force N = (N/m) m scales as kappa s).
UNIT_SCALING = {"rad": lambda s, kappa: 1.0, "m/m": lambda s, kappa: 1.0, "L": lambda s, kappa: 1.0,
                "2L": lambda s, kappa: 1.0, "N^4 m^2": lambda s, kappa: (kappa * s) ** 4 * s**2}


@given(st.floats(0.05, 0.95), st.floats(0.05, 0.9), st.floats(0.1, 10.0), st.floats(0.1, 10.0))
def test_each_singular_value_scales_as_its_unit_says(r1, r2, s, kappa):
    """The unit each set's value is given in is its dimension: scaling lengths by s and
    stiffnesses by kappa scales the value as the unit says, and no other way."""
    from dataclasses import replace

    stiff = {name: kappa * getattr(PAPER_PARAMS, name) for name in ("k1", "k2", "k3", "k4", "ka", "kb")}
    scaled = replace(PAPER_PARAMS, L=s * PAPER_PARAMS.L, **stiff)
    base = {v.kind: v for v in classify_singularities(r1, r2).sets}
    for v in classify_singularities(s * r1, s * r2, scaled).sets:
        factor = UNIT_SCALING[v.unit](s, kappa)
        assert v.unit == base[v.kind].unit
        assert v.value == pytest.approx(factor * base[v.kind].value, rel=1e-9, abs=1e-12 * factor), v.kind
