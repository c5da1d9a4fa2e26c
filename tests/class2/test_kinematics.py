"""Forward kinematics: closed form vs energy minimisation, root choice, domain, Jacobian."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.class2 import PAPER_PARAMS, potential_energy
from tensegrity_core.class2.geometry import member_lengths
from tensegrity_core.class2.kinematics import (
    fk_array,
    forward_kinematics,
    forward_kinematics_numeric,
    jacobian_D_rho,
)
from tensegrity_core.errors import DomainError, SingularityError
from tests.class2.strategies import configurations, parameter_sets, scaled

P = PAPER_PARAMS


def test_paper_initial_configuration_beta0_is_0_8():
    # Sect. 5.3: rho1 = rho2 = 0.7 m gives beta0 = 0.8 (one decimal in the paper).
    fk = forward_kinematics(0.7, 0.7)
    assert fk.beta == pytest.approx(0.8, abs=0.005)
    # Derivation: with k2 = k3 and rho1 = rho2 = rho, tan(beta) = lambda1 / (2 rho) = tan(alpha),
    # and R^2 = (2 rho)^2 + lambda1^2 = 4 L^2, so d2U/dbeta2 = L R / 2 = L^2.
    assert fk.beta == pytest.approx(fk.alpha, abs=1e-15)
    assert fk.beta == pytest.approx(math.atan2(math.sqrt(4 - 1.4**2), 1.4), abs=1e-15)
    assert fk.stiffness_beta == pytest.approx(1.0, abs=1e-14)
    assert (fk.x, fk.y) == pytest.approx((0.7 + math.cos(fk.beta), math.sin(fk.beta)), abs=1e-15)
    assert fk.stable and fk.in_paper_range and fk.note == ""


def test_eq9_potential_energy_expansion_matches_member_lengths():
    # Eq. (9) as printed, term by term, against 1/2 sum k L^2 from node positions.
    p = P.with_overrides(k1=1.3, k2=0.7, k3=2.1, k4=0.4, L=1.2)
    rng = np.random.default_rng(3)
    for _ in range(50):
        r1 = rng.uniform(0, p.L)
        r2 = rng.uniform(0, 2 * p.L - r1)
        b = rng.uniform(-np.pi, np.pi)
        L, s = p.L, r1 + r2
        eq9 = ((2 * (p.k1 + p.k2) + p.k3 + p.k4) / 2 * L**2 + p.k3 * r2**2 / 2 - p.k1 * r1**2 / 2
               - p.k1 * math.sqrt((L**2 - r1**2) * (4 * L**2 - s**2)) / 2
               - r1 * r2 * (p.k2 + p.k4) / 2 + (p.k2 * r1 - (2 * p.k3 + p.k2) * r2) / 2 * L * math.cos(b)
               - math.sqrt(4 * L**2 - s**2) / 2 * p.k2 * L * math.sin(b))
        assert float(potential_energy((r1, r2, b), p)) == pytest.approx(eq9, rel=1e-12, abs=1e-12)


def test_eq7_as_printed_is_wrong_and_corrected_form_holds():
    # Erratum: L7 = |EF| = sqrt(2L^2 - rho1^2 - lambda1 lambda2), not ... - 2 L sqrt(L^2 - rho1^2).
    r1, r2, L = 0.5, 0.9, 1.0
    l7 = member_lengths((r1, r2, 0.3), P)[6]
    lam1, lam2 = math.sqrt(4 - (r1 + r2) ** 2), math.sqrt(1 - r1**2)
    assert l7 == pytest.approx(math.sqrt(2 * L**2 - r1**2 - lam1 * lam2), rel=1e-14)
    printed = math.sqrt(2 * L**2 - r1**2 - 2 * L * lam2)
    assert abs(l7 - printed) > 0.1


def test_energy_root_choice_beyond_pi_over_2():
    # d = 3 rho2 - rho1 < 0: the minimum is above pi/2; the plain arctan of Eq. 10 is the maximum.
    fk = forward_kinematics(0.9, 0.1)
    lam1 = math.sqrt(4 - 1.0)
    plain = math.atan(lam1 / (3 * 0.1 - 0.9))
    assert plain < 0 and fk.beta == pytest.approx(plain + math.pi, abs=1e-14)
    u = lambda b: float(potential_energy((0.9, 0.1, b), P))  # noqa: E731
    assert u(fk.beta) < u(plain)
    assert not fk.in_paper_range and fk.stable
    # Eq. 9 at locked actuators (k = L = 1): U(beta) = const + (a cos beta + b sin beta)/2 with
    # a = k2 rho1 - (k2 + 2 k3) rho2 = 0.6, b = -k2 lambda1 = -sqrt(3); the sinusoid's minimum
    # is where (cos beta, sin beta) points along -(a, b).
    minimum = math.atan2(lam1, -0.6)
    assert fk.beta == pytest.approx(minimum, abs=1e-14)
    assert fk.note == f"no stable equilibrium in the paper's range [0, pi/2]: the minimum is at beta = {minimum:.6g} rad"


@given(configurations(), parameter_sets())
def test_closed_form_equals_numeric_energy_minimum(rho, params):
    rho = scaled(rho, params)
    closed = forward_kinematics(*rho, params)
    numeric = forward_kinematics_numeric(*rho, params)
    assert numeric.beta == pytest.approx(closed.beta, abs=1e-9)
    assert (numeric.x, numeric.y) == pytest.approx((closed.x, closed.y), abs=1e-9 * params.L)
    assert numeric.stiffness_beta == pytest.approx(closed.stiffness_beta, rel=1e-6, abs=1e-9)
    assert closed.stiffness_beta > 0 and closed.stable
    assert 0.0 <= closed.beta <= math.pi and 0.0 <= closed.alpha <= math.pi / 2
    assert closed.in_paper_range == (closed.beta <= math.pi / 2 + 1e-12)


@given(configurations())
def test_result_nodes_respect_member_lengths(rho):
    fk = forward_kinematics(*rho)
    n = fk.nodes
    assert n[3] == pytest.approx([fk.x, fk.y], abs=1e-15)
    for i, j in ((0, 4), (1, 5), (1, 3), (2, 4)):   # the struts AE, BF, BD, CE have length L
        assert np.linalg.norm(n[i] - n[j]) == pytest.approx(P.L, abs=1e-12)


@pytest.mark.parametrize(
    ("rho1", "rho2", "distance"),
    [(-0.1, 0.5, 0.1), (0.5, -0.25, 0.25), (1.2, 0.1, 0.2), (0.9, 1.3, 0.2)],
)
def test_domain_errors_carry_the_distance_outside(rho1, rho2, distance):
    with pytest.raises(DomainError) as err:
        forward_kinematics(rho1, rho2)
    assert err.value.distance == pytest.approx(distance)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, "abc", None])
def test_non_finite_or_non_numeric_input_is_a_domain_error(bad):
    with pytest.raises(DomainError, match="rho2"):
        forward_kinematics(0.5, bad)


def test_degenerate_every_beta_is_reported_not_zero():
    # a = b = 0 needs lambda1 = 0 and (2 k3 + k2) rho2 = k2 rho1, impossible for k3 > 0 on the
    # domain; k3 = 1e-15 against k2 = 1e15 (both in the accepted range) rounds 2 k3 + k2 to k2
    # and reaches it at rho = (L, L).
    p = P.with_overrides(k3=1e-15, k2=1e15)
    with pytest.raises(SingularityError) as err:
        forward_kinematics(1.0, 1.0, p)
    assert err.value.kind == "indeterminate_beta"
    with pytest.raises(SingularityError):
        forward_kinematics_numeric(1.0, 1.0, p)
    assert not fk_array(1.0, 1.0, p).valid


def test_limits_of_the_domain():
    folded = forward_kinematics(0.0, 0.0)          # every node on the Y axis, D = F = E = (0, L)
    assert (folded.beta, folded.x, folded.y) == (math.pi / 2, 0.0, 1.0)
    assert folded.nearest_singularity == "folded" and folded.singularity_distance == 0.0
    flat = forward_kinematics(0.4, 1.6)            # lambda1 = 0: beta = 0, D = (rho1 + L, 0)
    assert (flat.beta, flat.x, flat.y) == (0.0, 1.4, 0.0)
    assert flat.nearest_singularity == "lambda1"
    fold = forward_kinematics(0.6, 0.2)            # 3 rho2 = rho1: beta = pi/2 exactly
    assert fold.beta == pytest.approx(math.pi / 2, abs=1e-15) and fold.in_paper_range
    assert fold.nearest_singularity == "beta_half_pi"
    assert fold.jacobian_cond > 1e12
    assert flat.jacobian_cond == math.inf


def test_fk_array_matches_scalar_and_flags_invalid():
    rng = np.random.default_rng(5)
    r1 = rng.uniform(-0.2, 1.2, 2000)
    r2 = rng.uniform(-0.2, 2.2, 2000)
    r2[:3] = [np.nan, np.inf, 0.5]
    out = fk_array(r1, r2)
    for i in range(len(r1)):
        try:
            fk = forward_kinematics(r1[i], r2[i])
        except DomainError:
            assert not out.valid[i] and np.isnan(out.beta[i]) and np.isnan(out.x[i])
            continue
        assert out.valid[i]
        assert (out.beta[i], out.x[i], out.y[i]) == pytest.approx((fk.beta, fk.x, fk.y), abs=1e-15)
    assert fk_array(np.zeros((3, 1)), np.linspace(0, 1, 4)).beta.shape == (3, 4)


@given(configurations(margin=1e-3), parameter_sets())
def test_jacobian_matches_central_differences(rho, params):
    r1, r2 = scaled(rho, params)
    h = 1e-7 * params.L
    J = jacobian_D_rho(r1, r2, params)
    fd = np.empty((2, 2))
    for j, (a, b) in enumerate(((h, 0.0), (0.0, h))):
        lo = max(0.0, r1 - a), max(0.0, r2 - b)
        hi = r1 + a, r2 + b
        plus, minus = forward_kinematics(*hi, params), forward_kinematics(*lo, params)
        step = (hi[0] - lo[0]) + (hi[1] - lo[1])
        fd[:, j] = [(plus.x - minus.x) / step, (plus.y - minus.y) / step]
    # central differences: error O(h^2 D''') + O(eps / h); the first-order one-sided step at
    # rho = 0 is O(h D''). D'' grows like lambda1^-3 near lambda1 = 0, hence the margin.
    assert J == pytest.approx(fd, rel=2e-5, abs=2e-5)


def test_jacobian_determinant_vanishes_on_the_fold_line_and_blows_up_at_lambda1():
    for r1 in (0.1, 0.5, 1.0):
        J = jacobian_D_rho(r1, r1 / 3, P)
        assert abs(np.linalg.det(J)) < 1e-14
    with pytest.raises(SingularityError) as err:
        jacobian_D_rho(0.5, 1.5, P)
    assert err.value.kind == "lambda1"
    near = jacobian_D_rho(0.5, 1.5 - 1e-10, P)
    assert np.abs(near).max() > 1e3


@given(configurations(margin=1e-3))
def test_jacobian_determinant_is_L_cos_beta_dbeta_drho2_and_negative_derivative(rho):
    fk = forward_kinematics(*rho)
    J = jacobian_D_rho(*rho)
    # beta decreases with rho2 everywhere (d beta / d rho2 < 0, docs/class2.md)
    h = 1e-7
    db2 = (forward_kinematics(rho[0], rho[1] + h).beta - forward_kinematics(rho[0], rho[1] - h).beta) / (2 * h)
    assert db2 < 0
    assert np.linalg.det(J) == pytest.approx(P.L * math.cos(fk.beta) * db2, rel=1e-5, abs=1e-9)


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_fk_in_paper_range_iff_above_fold_line(u, v):
    r1 = u
    r2 = v * (2 - r1)
    fk = forward_kinematics(r1, r2)
    d = 3 * r2 - r1
    if abs(d) > 1e-12:
        assert fk.in_paper_range == (d > 0)


@pytest.mark.parametrize("rho1, rho2", [(0.7, 0.7), (0.3, 1.1), (0.95, 0.2)])
def test_end_effector_of_a_state_is_the_forward_kinematics_d(rho1, rho2):
    from tensegrity_core.class2 import end_effector_of

    fk = forward_kinematics(rho1, rho2)
    assert end_effector_of((rho1, rho2, fk.beta), 1.0) == pytest.approx((fk.x, fk.y), abs=1e-15)
