"""Property-based tests over the workspace and over random structures (issue 9).

Complements the hypothesis tests that exist (FK/IK round trips and Jacobians in
tests/class2/test_ik.py, test_kinematics.py; M, C, H, grad U and the EOM Jacobian in
tests/class2/test_dynamics_structure.py): here the general statics over random
structures, the form-finding line search, conservation laws of the class-2 dynamics, and
the conditioning measures near the singular sets.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics, inverse_kinematics
from tensegrity_core.class2.dynamics import LAMBDA_MIN_REL, Class2Dynamics, SingularityApproachEvent
from tensegrity_core.general import Configuration, form_find, generalized_force, potential_energy, tangent_stiffness
from tensegrity_core.general.formfind import line_search
from tests.class2.strategies import configurations, edged, parameter_sets, scaled
from tests.hard.oracles import fk_residual
from tests.hard.stiffness_check import slack_switch, stiffness_along
from tests.hard.strategies import displacements, structures


@settings(max_examples=60)
@given(structures(), st.integers(0, 2**31))
def test_property_tangent_stiffness_symmetric_and_the_jacobian_of_the_force(s, seed):
    """At a random configuration (off equilibrium), K_T is symmetric and, with the body
    rotation rows corrected by 1/2 hat(M) (docs/general.md: -dM/dtheta = K_T + 1/2 hat(M),
    the skew part a symmetric Hessian cannot carry), K_T d equals the central difference
    -(P(U + h d) - P(U - h d)) / 2h to 1e-6 of |K_T| |d|."""
    config = Configuration.initial(s).retract(displacements(s, seed))
    K = tangent_stiffness(s, config)
    scale = np.abs(K).max()
    assert np.abs(K - K.T).max() <= 1e-12 * scale
    d = displacements(s, seed + 1, 1.0)
    d /= np.linalg.norm(d)
    h = 1e-6
    assume(not slack_switch(s, config, d, h))
    fd, expected, _ = stiffness_along(s, config, K, d, h)
    assert np.abs(fd - expected).max() <= 1e-6 * scale


@settings(max_examples=40)
@given(structures(bodies=False))
def test_property_form_finding_energy_rises_only_in_a_relaxed_step_that_the_next_undoes(s):
    """Every Newton step lowers the total potential energy (Eqs. 83-84), except a relaxed
    full step (the watchdog of docs/general.md), which the next iterate brings below where
    it started; never two rises in a row. Recomputed here from the recorded iterates'
    energies and from V of the start."""
    energies = []
    r = form_find(s, max_iter=30, check_stability=False, callback=lambda info: energies.append(info.energy) and None)
    V0 = potential_energy(s, s.nodes)
    seq = np.array([V0] + energies)
    noise = 1e-12 * np.abs(seq).max() + 1e-300
    rises = np.diff(seq) > noise
    assert not np.any(rises[:-1] & rises[1:])
    for k in np.flatnonzero(rises[:-1]):
        assert seq[k + 2] <= seq[k] + noise
    assert np.isfinite(r.nodes).all()


@settings(max_examples=40)
@given(structures(), st.integers(0, 2**31))
def test_property_line_search_step_is_a_decrease_or_nothing(s, seed):
    """Along any descent direction the line search returns x in [0, 1] with V(x) <= V(0)."""
    config = Configuration.initial(s).retract(displacements(s, seed))
    P = generalized_force(s, config)
    assume(np.linalg.norm(P) > 0)
    V0 = potential_energy(s, config.coords)
    x, V1, c1 = line_search(s, config, 0.01 * P / np.abs(P).max(), V0, P)
    assert 0.0 <= x <= 1.0 and V1 <= V0
    assert V1 == potential_energy(s, c1.coords)


@settings(max_examples=15)
@given(st.floats(0.1, 0.8), st.floats(0.1, 0.8), st.floats(0.2, 1.4),
       st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-1.0, 1.0))
def test_property_class2_energy_conserved_without_damping_or_forces(r1, r2, b, v1, v2, w):
    """T + U is a first integral of the undamped, unforced equations (DOP853, rtol 1e-10):
    relative drift over 3 s below 1e-8 from any state inside the domain."""
    p = PAPER_PARAMS.with_overrides(c1=0.0, c2=0.0, c3=0.0, c4=0.0)
    dyn = Class2Dynamics(p)
    y0 = np.array([r1, r2, b, v1, v2, w])

    def near_singular(t, y):
        return min(4 - (y[0] + y[1]) ** 2, 1 - y[0] ** 2) - 1e-2
    near_singular.terminal = True
    sol = solve_ivp(lambda t, y: dyn.rhs(t, y, 0.0, 0.0), (0, 3.0), y0, method="DOP853", rtol=1e-10,
                    atol=1e-12, events=near_singular)
    E = np.array([dyn.energy(y) for y in sol.y.T])
    assert np.abs(E - E[0]).max() <= 1e-8 * max(abs(E[0]), 1e-3)


#: Starting distances lambda/L to the lambda sets: 3 LAMBDA_MIN_REL up to L, the ends and the
#: decades between drawn on purpose (log-uniform).
_LAMBDA0 = edged(math.log10(3.0 * LAMBDA_MIN_REL), 0.0).map(lambda e: 10.0 ** e)
#: beta [rad]: the paper's range limit pi/2 and its neighbours drawn on purpose, else (0.2, 2.9).
_BETA = st.one_of(st.sampled_from([math.pi / 2, math.nextafter(math.pi / 2, 0.0), math.pi / 2 + 1e-9,
                                   math.pi / 2 - 1e-6]), st.floats(0.2, 2.9))


@settings(max_examples=30, deadline=None)
@given(_LAMBDA0, _LAMBDA0, _BETA, st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(-3.0, 3.0))
def test_property_class2_energy_conserved_near_the_singular_sets(l1, l2, b, w1, w2, wb):
    """T + U is conserved up to a bound derived from the distance to the lambda sets.

    Draws: ``lambda1 = l1 L`` (s -> 2L, struts AE, CE flat), ``lambda2 = l2 L`` (rho1 -> L,
    the fold corner with beta -> pi/2 drawn on purpose); rates ``rho1' = -l2 w2``, ``s' = -l1
    w1``, i.e. ``lambda2' = rho1 w2/L``, ``lambda1' = s w1/L`` [m/s] (bounded node speeds, so the
    approach to a set takes a time ~ lambda/w). beta = pi/2 is no singularity
    of the dynamics (M, grad U regular there); only the lambdas are.

    Derivation of the solver settings and the allowance. Stop at ``lambda_stop = lambda0/2``
    (SingularityApproachEvent, above the refusal LAMBDA_MIN_REL L): along the run every
    lambda >= lambda_stop. There ``mu = m/2 + 2 m L^2/(3 lambda1^2)`` (and ``m L^2/(3
    lambda2^2)``), so ``d ln T / d ln s <= 2 s^2/lambda^2 <= 8 (L/lambda)^2``: a relative error
    ``e`` of the state gives a relative energy error ``8 (L/lambda)^2 e``. The remaining
    distance ``2L - s = lambda^2/(2L + s)`` is resolved only with a relative tolerance below
    ``(lambda/L)^2``: ``rtol = max(1e-10 (lambda_stop/L)^2, 1e-13)`` (scipy's floor is
    2.2e-14). An RK stage must not cross the refusal: ``max_step = (lambda_stop -
    LAMBDA_MIN_REL L)/(4 w)`` with ``w`` twice the drawn rates (energy exchange with the
    springs over the window changes node speeds by less than that). Per accepted step DOP853
    keeps the error below ``sqrt(6) rtol`` of the state (RMS norm) and rounding adds ``eps``;
    over ``n`` steps, worst case without cancellation::

        |E - E0| <= n 8 (L/lambda_stop)^2 (sqrt(6) rtol + eps) (T + |U|)_max + 1e-12 E0

    The window is at most 200 ``max_step`` (cost). The bound is worst case (the drift seen is
    below 1% of it), yet a 1e-3 relative error in the velocity term ``kappa1 sdot^2`` fails it.
    """
    p = PAPER_PARAMS.with_overrides(c1=0.0, c2=0.0, c3=0.0, c4=0.0)
    L = p.L
    dyn = Class2Dynamics(p)
    lam1, lam2 = l1 * L, l2 * L
    rho1 = math.sqrt((L - lam2) * (L + lam2))
    s = math.sqrt((2.0 * L - lam1) * (2.0 * L + lam1))
    r1d = -l2 * w2                  # lambda2' = rho1 w2/L
    sd = -l1 * w1                   # lambda1' = s w1/L
    y0 = np.array([rho1, s - rho1, b, r1d, sd - r1d, wb])
    stop = 0.5 * min(l1, l2)
    rtol = max(1e-10 * stop**2, 1e-13)
    w = 2.0 * max(abs(w1), abs(w2), 1e-3)
    h_max = (stop - LAMBDA_MIN_REL) * L / (4.0 * w)
    T = min(0.2, 200 * h_max)
    sol = solve_ivp(lambda t, y: dyn.rhs(t, y), (0, T), y0, method="DOP853", rtol=rtol, atol=1e-2 * rtol * L,
                    events=[SingularityApproachEvent("lambda1", p, stop), SingularityApproachEvent("lambda2", p, stop)],
                    max_step=h_max, first_step=min(h_max, T))
    assert sol.status in (0, 1), sol.message
    E = np.array([dyn.energy(y) for y in sol.y.T])
    U = np.array([dyn.energy(np.concatenate([y[:3], np.zeros(3)])) for y in sol.y.T])
    scale = np.abs(E - U).max() + np.abs(U).max()      # max T + max |U| over the run
    n = len(sol.t) - 1
    allowance = n * 8.0 / stop**2 * (math.sqrt(6.0) * rtol + 2.2e-16) * scale + 1e-12 * abs(E[0])
    assert np.abs(E - E[0]).max() <= allowance


@given(configurations(margin=1e-3), parameter_sets())
def test_property_conditioning_measures_are_consistent_with_the_error(rho, params):
    """The conditioning measures bound the numerical error: FK of IK of FK is back within
    1e-15 (1 + jacobian_cond) L of the target (50-digit check), and the reported distance
    is the smallest of the documented set distances."""
    fk = forward_kinematics(*scaled(rho, params), params)
    assume(fk.in_paper_range and fk.y > 1e-9 * params.L)
    res = inverse_kinematics(fk.x, fk.y, params)
    assert res.success
    c = res.valid[0]
    err = fk_residual(c.rho1, c.rho2, fk.x, fk.y, params)
    assert err <= 1e-14 * (1 + min(fk.jacobian_cond, 1e8)) * params.L
    assert 0.0 <= fk.singularity_distance <= math.sqrt(2)
