"""Hard cases of the class-2 mechanism (issue 9): accuracy near every singular set,
measured against 50-digit evaluations (tests/hard/oracles.py), or the documented error.

Catalogue and measured limits: docs/design/hard_cases.md. Cases already covered elsewhere are
referenced there, not repeated here (e.g. the degenerate beta at k3 -> 0,
tests/class2/test_kinematics.py::test_degenerate_every_beta_is_reported_not_zero).
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest

from tensegrity_core.class2 import (
    PAPER_PARAMS,
    distance_to_full_workspace,
    forward_kinematics,
    inverse_kinematics,
    mass_matrix,
    stiffness_along_coordinates,
)
from tensegrity_core.errors import DomainError, SingularityError
from tests.hard.oracles import fk_exact, fk_residual, ik_exact

L = PAPER_PARAMS.L
EPS = [10.0 ** -k for k in range(1, 16)]


def fk_error(rho1: float, rho2: float) -> float:
    """max |beta|, |x|, |y| error of the double-precision FK against 50 digits."""
    fk = forward_kinematics(rho1, rho2)
    beta, x, y = fk_exact(rho1, rho2)
    return max(abs(fk.beta - float(beta)), abs(fk.x - float(x)), abs(fk.y - float(y)))


# ------------------------------------------------------------------ rho1 + rho2 -> 2L
@pytest.mark.parametrize("gap", EPS)
def test_case_lambda1_fk_stays_accurate_as_rho1_plus_rho2_tends_to_2L(gap):
    """beta ~ lambda1 ~ sqrt(2L - s): rounding of s costs eps L / sqrt(gap) at most
    (measured 3.1e-13 at gap 1e-8, 8.6e-10 at 1e-15), and the distance and the
    Jacobian's condition number (~ 1/sqrt(gap)) warn about it."""
    rho1 = 0.6
    rho2 = 2 * L - rho1 - gap
    gap = float(2 * L - mp.mpf(rho1) - mp.mpf(rho2))       # the gap the doubles really have
    err = fk_error(rho1, rho2)
    assert err <= 4e-16 * L / math.sqrt(gap / L) + 1e-16
    assert err < 1e-8
    fk = forward_kinematics(rho1, rho2)
    assert fk.nearest_singularity == "lambda1"
    exact = float((2 * L - mp.mpf(rho1) - mp.mpf(rho2)) / (mp.sqrt(2) * L))
    assert fk.singularity_distance == pytest.approx(exact, rel=1e-6, abs=1e-16)
    assert fk.jacobian_cond >= 0.5 / math.sqrt(gap / L)


def test_case_lambda1_on_the_set_fk_is_exact_and_the_jacobian_is_refused():
    fk = forward_kinematics(0.6, 1.4)
    assert fk.beta == 0.0 and fk.y == 0.0 and fk.x == pytest.approx(1.6, abs=1e-15)
    assert fk.singularity_distance == 0.0 and fk.jacobian_cond == math.inf
    with pytest.raises(SingularityError) as err:
        _ = fk.jacobian
    assert err.value.kind == "lambda1"


@pytest.mark.parametrize("gap", [1e-2, 1e-4, 1e-6, 1e-8, 1e-9, 1e-12])
def test_case_lambda1_mass_matrix_accurate_until_lambda_min_then_refused(gap):
    """M grows like 1/lambda1^2 (mu = m/2 + 2 m L^2 / (3 lambda1^2)); relative error
    against 50 digits <= 1e-13 * (L/lambda1)^2 * eps-level, and below lambda_min = 1e-4 L
    the dynamics refuse with the distance."""
    rho1, beta = 0.6, 0.3
    rho2 = 2 * L - rho1 - gap
    s = mp.mpf(rho1) + mp.mpf(rho2)
    lam1 = mp.sqrt((2 * L - s) * (2 * L + s))
    q = np.array([rho1, rho2, beta])
    assert (float(lam1) < 1e-4 * L) == (gap <= 1e-9)       # lambda1 = 2 sqrt(gap L) roughly
    if float(lam1) < 1e-4 * L:
        with pytest.raises(SingularityError) as err:
            mass_matrix(q, PAPER_PARAMS)
        assert err.value.kind == "lambda1"
        # the reported lambda1 carries the rounding of 4L^2 - s^2: relative eps (2L/lambda1)^2
        assert err.value.distance == pytest.approx(float(lam1), rel=1e-6 + 8e-16 * float(L**2 / lam1**2))
        assert "lambda1" in str(err.value)
        return
    m = mp.mpf(PAPER_PARAMS.m)
    mu = m / 2 + 2 * m * L**2 / (3 * lam1**2)
    M = mass_matrix(q, PAPER_PARAMS)
    assert abs(M[1, 1] - float(mu)) <= 1e-15 * float(mu) * float(L**2 / lam1**2) * 10


# ------------------------------------------------------------------ rho1 -> L
@pytest.mark.parametrize("gap", EPS)
def test_case_lambda2_fk_is_unaffected_as_rho1_tends_to_L(gap):
    """beta does not involve lambda2: FK stays at rounding level (measured <= 2.2e-16)."""
    assert fk_error(L - gap, 0.5) <= 1e-15
    fk = forward_kinematics(L - gap, 0.5)
    assert fk.nearest_singularity == "lambda2"
    assert fk.singularity_distance == pytest.approx(gap / L, rel=1e-3)


@pytest.mark.parametrize("gap", [1e-3, 1e-5, 1e-7, 1e-9, 1e-12])
def test_case_lambda2_dynamics_refused_below_lambda_min_with_distance(gap):
    q = np.array([L - gap, 0.5, 0.8])
    lam2 = math.sqrt((L - q[0]) * (L + q[0]))
    assert (lam2 < 1e-4 * L) == (gap <= 1e-9)             # lambda2 = sqrt(2 gap L) roughly
    if lam2 < 1e-4 * L:
        with pytest.raises(SingularityError) as err:
            mass_matrix(q, PAPER_PARAMS)
        assert err.value.kind == "lambda2" and err.value.distance == pytest.approx(lam2, rel=1e-6)
    else:
        M = mass_matrix(q, PAPER_PARAMS)
        m = PAPER_PARAMS.m
        exact = float(3 * mp.mpf(m) / 2 + 2 * m * L**2 / (3 * (4 * L**2 - (mp.mpf(q[0]) + mp.mpf(q[1]))**2))
                      + m * L**2 / (3 * (L**2 - mp.mpf(q[0])**2)))
        assert M[0, 0] == pytest.approx(exact, rel=1e-9)


def test_case_lambda2_beyond_the_domain_is_a_domain_error_with_distance():
    with pytest.raises(DomainError) as err:
        forward_kinematics(L + 1e-9, 0.5)
    assert err.value.distance == pytest.approx(1e-9, rel=1e-6)


# ------------------------------------------------------------------ folded rho1 = rho2 = 0
@pytest.mark.parametrize("r", [0.0, 1e-300, 1e-12, 1e-6])
def test_case_folded_configuration_fk_exact(r):
    """At rho = 0 all nodes are on the Y axis: beta = pi/2, D = (0, L) exactly."""
    assert fk_error(r, r) <= 1e-16
    fk = forward_kinematics(r, r)
    assert fk.singularity_distance <= math.hypot(r, r) / L + 1e-300
    if r == 0.0:
        assert (fk.beta, fk.x, fk.y) == (math.pi / 2, pytest.approx(0.0, abs=1e-16), L)
        assert fk.nearest_singularity == "folded"


def test_case_folded_stiffness_refused_with_kind():
    with pytest.raises(SingularityError) as err:
        stiffness_along_coordinates(0.0, 0.0)
    assert err.value.kind == "rho1_zero" and err.value.distance == 0.0


# ------------------------------------------------------------------ beta -> 0 and beta -> pi/2
@pytest.mark.parametrize("gap", EPS)
def test_case_beta_to_zero_is_the_lambda1_set(gap):
    """beta = 0 on the equilibrium manifold only at lambda1 = 0: beta ~ sqrt(gap)."""
    rho1 = 0.6
    fk = forward_kinematics(rho1, 2 * L - rho1 - gap)
    beta, _, _ = fk_exact(rho1, 2 * L - rho1 - gap)
    assert abs(fk.beta - float(beta)) <= 4e-16 / math.sqrt(gap) + 1e-16
    assert 0.0 < fk.beta < 2 * math.sqrt(gap) + 1e-7


@pytest.mark.parametrize("gap", EPS)
def test_case_beta_to_half_pi_fk_exact_and_det_J_reported(gap):
    """(2k3 + k2) rho2 = k2 rho1 is the fold line (beta = pi/2, det J = 0): FK stays at
    rounding level; jacobian_cond grows like 1/gap (measured 3.2e4 at 1e-4)."""
    rho1 = 0.6
    rho2 = (rho1 + gap) / 3.0          # paper springs: K = 3, k2 = 1
    assert fk_error(rho1, rho2) <= 4e-16
    fk = forward_kinematics(rho1, rho2)
    assert fk.nearest_singularity == "beta_half_pi"
    assert fk.beta <= math.pi / 2
    if gap >= 1e-13:
        assert fk.jacobian_cond >= 0.1 / gap


# ------------------------------------------------------------------ workspace boundary
BOUNDARY = [  # (name, target on the boundary of W)
    ("arc_about_A", (math.cos(0.7), math.sin(0.7))),
    ("fold_segment_y_L", (0.4, L)),
    ("arc_about_(L,0)", (L + math.cos(0.7), math.sin(0.7))),
    ("base_segment_y_0", (1.5, 0.0)),
]


@pytest.mark.parametrize("name, target", BOUNDARY)
def test_case_workspace_boundary_targets_are_reached(name, target):
    """On the boundary: one valid solution, FK of it within 1e-8 L of the target (50 digits)."""
    x, y = target
    res = inverse_kinematics(x, y)
    assert res.success, res.message
    c = res.valid[0]
    assert fk_residual(c.rho1, c.rho2, x, y) <= 1e-8 * L
    assert distance_to_full_workspace(x, y, L) <= 1e-12


@pytest.mark.parametrize("name, target", BOUNDARY)
@pytest.mark.parametrize("outside", [1e-6, 1e-9])
def test_case_workspace_just_outside_is_refused_with_distance(name, target, outside):
    """Just outside (normal offset): no valid solution, a message, and the distance."""
    x, y = target
    normal = {"arc_about_A": (-x, -y), "fold_segment_y_L": (0.0, 1.0),
              "arc_about_(L,0)": (x - L, y), "base_segment_y_0": (0.0, -1.0)}[name]
    n = np.array(normal) / np.hypot(*normal)
    xo, yo = x + outside * n[0], y + outside * n[1]
    res = inverse_kinematics(xo, yo)
    assert not res.success and res.message
    assert distance_to_full_workspace(xo, yo, L) == pytest.approx(outside, rel=1e-3)


# ------------------------------------------------------------------ IK branches merging
@pytest.mark.parametrize("k", range(1, 16))
def test_case_ik_branches_merge_as_y_tends_to_L(k):
    """The two delta1 branches merge at y = L (discriminant 4 k2^2 c^2 Q^2 -> 0, c -> 0).
    The valid answer is the paper-range branch (delta1 = -1, beta <= pi/2) - never the other
    one. Backward error (50-digit FK of the answer) <= 1e-15 L for gap >= 1e-11 L; closer
    the target is put on the fold (documented snap at 1e-12 L) and the backward error is the
    gap itself. Forward error in rho grows like sqrt(eps/gap) there (the fold is a square-
    root map), 1.4e-6 m at gap 1e-12; singularity_distance reports it."""
    gap = 10.0 ** -k
    x, y = 0.9, L - gap
    res = inverse_kinematics(x, y)
    assert len(res.valid) == 1
    c = res.valid[0]
    assert c.delta1 == -1 and c.beta <= math.pi / 2 and c.in_paper_range
    back = fk_residual(c.rho1, c.rho2, x, y)
    assert back <= max(1e-15 * L, 1.01 * gap if gap <= 1e-12 * L else 0.0)
    assert back < 1e-8
    r1, r2 = ik_exact(x, y, -1)
    fwd = max(abs(c.rho1 - float(r1)), abs(c.rho2 - float(r2)))
    assert fwd <= 1e-15 + 2 * math.sqrt(2 * 1e-12 * L * L) if gap <= 1e-12 else fwd <= 1e-14
    assert c.singularity_distance <= 3 * math.sqrt(gap / L) + 1e-16


@pytest.mark.parametrize("k", range(1, 16, 2))
def test_case_ik_near_y_zero_backward_error_bounded(k):
    """y -> 0 is the lambda1 set (|dD/drho| ~ L/y): error * y <= 5e-16 L^2 (documented),
    never above 2e-8 L. Measured max 5.3e-9 L at y = 1e-13 L."""
    y = 10.0 ** -k
    res = inverse_kinematics(1.5, y)
    c = res.valid[0]
    back = fk_residual(c.rho1, c.rho2, 1.5, y)
    assert back <= min(5e-16 * L * L / y, 2e-8 * L) + 1e-15


# ------------------------------------------------------------------ stiffness at f = 0
@pytest.mark.parametrize("rho", [(0.7, 0.7), (0.5, 1.49), (0.99, 0.5), (0.3, 0.1), (0.05, 0.05)])
def test_case_stiffness_at_zero_force_reports_cond_K_r(rho):
    """At f = 0 K_2..K_4 are small beside the strut terms and K_r is ill-conditioned by
    the stiffness ratio kb/k; cond(K_r) is reported and equals numpy's 2-norm condition
    number of K with that row/column removed; K_i = 1/(K^-1)_ii (independent route) to
    cond * 1e-15."""
    r = stiffness_along_coordinates(*rho, f=0.0)
    K = r.K
    for i in range(7):
        keep = np.arange(7) != i
        assert r.cond_K_r[i] == pytest.approx(np.linalg.cond(K[np.ix_(keep, keep)]), rel=1e-9)
        Kinv = np.array(mp.inverse(mp.matrix(K.tolist())).tolist(), dtype=float)
        assert r.K_i[i] == pytest.approx(1.0 / Kinv[i, i], rel=max(1e-12, 1e-15 * r.cond_K_r[i]))
    assert np.all(np.isfinite(r.cond_K_r)) and r.cond_K_r.max() < 1e8


@pytest.mark.parametrize("rho1, rho2, kind", [(0.6, 1.4 - 1e-13, "lambda1"), (1.0 - 1e-13, 0.5, "lambda2"),
                                              (1e-13, 0.7, "rho1_zero"), (0.7, 1e-13, "rho2_zero")])
def test_case_stiffness_next_to_a_singular_set_refused_with_distance(rho1, rho2, kind):
    with pytest.raises(SingularityError) as err:
        stiffness_along_coordinates(rho1, rho2)
    assert err.value.kind == kind and err.value.distance <= 1e-12 and err.value.limit == 1e-12 * L


# ------------------------------------------------------------------ dynamics conditioning measure
@pytest.mark.parametrize("rho1, rho2", [(0.7, 0.7), (0.6, 1.4 - 1e-6), (1.0 - 1e-7, 0.3), (-0.5, -0.9),
                                        (-1.0, 0.2), (0.6, 1.4)])
def test_case_dynamics_singularity_measure_is_lambda_over_L(rho1, rho2):
    """lambda1/L, lambda2/L (50 digits; the nearer one), also for the negative lengths the
    unconstrained dynamics reach; 0 on a set. The dynamics refuse below 1e-4 of it.
    Absolute error <= sqrt(4 eps) = 3e-8: rounding of s = rho1 + rho2 (0.6 + 1.4 is 2.0 in
    doubles, 2 - 1.1e-16 exactly, where lambda1/L = 2.1e-8)."""
    from tensegrity_core.class2 import dynamics_singularity

    r1, r2 = mp.mpf(rho1), mp.mpf(rho2)
    lam1 = mp.sqrt(max(mp.mpf(0), 4 * L**2 - (r1 + r2) ** 2)) / L
    lam2 = mp.sqrt(max(mp.mpf(0), L**2 - r1**2)) / L
    name, d = dynamics_singularity(rho1, rho2, PAPER_PARAMS)
    assert name == ("lambda1" if lam1 <= lam2 else "lambda2")
    assert d == pytest.approx(float(min(lam1, lam2)), rel=1e-9, abs=3e-8)
