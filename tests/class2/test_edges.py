"""The class-2 public API over its whole accepted range, the edges drawn on purpose.

Targets on and beside every piece of the workspace boundary, configurations on the limits
of the configuration domain, spring constants and sizes over six decades: IK succeeds
exactly for the targets within ``DOMAIN_TOL L`` of W, FK and IK are inverse up to the
conditioning of the map, the equilibrium is the minimum of the energy summed from the
springs' lengths (finite differences), and the singular measures vanish exactly where the
finite-difference Jacobian drops rank; the stiffness matrix is the energy's Hessian, and
where its definiteness and the rigid-strut energy's disagree the difference is real.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tensegrity_core.class2 import (
    distance_to_full_workspace,
    forward_kinematics,
    inverse_kinematics,
    potential_energy,
    singularity_distances,
    stiffness_matrix_energy_fd,
    stiffness_matrix_paper,
)
from tensegrity_core.class2.energy import d2U_dbeta2, equilibrium_beta
from tensegrity_core.class2.geometry import member_lengths, node_positions
from tensegrity_core.class2.inverse_kinematics import DOMAIN_TOL, EPS
from tensegrity_core.class2.params import PAPER_PARAMS
from tensegrity_core.class2.stiffness import (
    FREE,
    axial_stiffnesses,
    critical_forces,
    member_forces,
    total_potential_energy,
)
from tensegrity_core.errors import SingularityError
from tests.class2.strategies import boundary_targets, edge_configurations, edged, extreme_parameter_sets


@st.composite
def targets_and_params(draw):
    params = draw(extreme_parameter_sets())
    return draw(boundary_targets(params)), params


@given(targets_and_params(), st.booleans())
def test_ik_succeeds_exactly_within_the_domain_tolerance_of_the_workspace(case, paper_range):
    # W = {0 <= y <= L, 0 <= x - sqrt(L^2 - y^2) <= L} is reached in the paper's range and
    # beyond it alike (docs/class2.md); IK treats a target within DOMAIN_TOL L of W as on it.
    (x, y), params = case
    L = params.L
    d = distance_to_full_workspace(x, y, L)
    tol = DOMAIN_TOL * L
    assume(not 0.5 * tol < d < 2.0 * tol)          # the grey band of the rounding of d itself
    res = inverse_kinematics(x, y, params, paper_range=paper_range)
    assert res.success == (d <= tol), (res.message, d / L)
    for sol in res.valid:
        # the snaps move D by at most tol; near y = 0 rounding rho to doubles moves D by
        # ~eps L^2 / y, capped by the square-root law at lambda1 = 0 at ~2e-8 L (test_ik.py)
        rounding = 8 * EPS * L + min(8 * EPS * L * L / max(y, 1e-300), 3e-8 * L)
        assert sol.fk_residual <= max(d, 0.0) + tol + rounding, sol


def _energy(rho1, rho2, beta, params):
    return float(potential_energy((rho1, rho2, beta), params))


@given(extreme_parameter_sets().flatmap(lambda p: st.tuples(edge_configurations(p), st.just(p))))
def test_fk_is_the_energy_minimum_and_ik_returns_its_lengths(case):
    (rho1, rho2), params = case
    L = params.L
    try:
        fk = forward_kinematics(rho1, rho2, params)
    except SingularityError as err:              # a = b = 0: only through underflow of R
        assert err.kind == "indeterminate_beta"
        return
    # stationary and a minimum of U summed from the spring lengths (central differences,
    # step h: truncation ~ U h^2, rounding ~ eps U / h)
    scale = (params.k2 + params.k3) * L * L
    h = 1e-4
    g = (_energy(rho1, rho2, fk.beta + h, params) - _energy(rho1, rho2, fk.beta - h, params)) / (2 * h)
    assert abs(g) <= 1e-7 * scale
    h = 1e-3
    curv = (_energy(rho1, rho2, fk.beta + h, params) - 2 * _energy(rho1, rho2, fk.beta, params)
            + _energy(rho1, rho2, fk.beta - h, params)) / h**2
    assert abs(curv - fk.stiffness_beta) <= 1e-6 * scale + 1e-5 * fk.stiffness_beta
    assert fk.stiffness_beta > 0.0
    # and IK of its D gives these lengths back, up to the conditioning of rho -> D
    res = inverse_kinematics(fk.x, fk.y, params, paper_range=False)
    assert res.success, res.message
    best = res.nearest((rho1, rho2))
    # FK of the returned lengths: their rounding (eps L) times |dD/drho|, or at lambda1 = 0
    # (|dD/drho| unbounded) the square-root law, ~2e-8 L (test_ik.py)
    try:
        gain = max(1.0, float(np.linalg.norm(fk.jacobian, 2)))
    except SingularityError:
        gain = math.inf
    assert best.fk_residual <= DOMAIN_TOL * L + min(16 * EPS * L * gain, 3e-8 * L) \
        or best.fk_residual <= 16 * EPS * L * gain
    if fk.y > 1e-6 * L and abs(math.cos(fk.beta)) > 1e-5:
        tol = max(1e-12, min(4 * fk.jacobian_cond * EPS, 6e-8)) * L
        assert math.hypot(best.rho1 - rho1, best.rho2 - rho2) <= tol


def _fd_jacobian(rho1, rho2, params, h):
    def D(r1, r2):
        fk = forward_kinematics(r1, r2, params)
        return np.array([fk.x, fk.y])
    return np.column_stack([(D(rho1 + h, rho2) - D(rho1 - h, rho2)) / (2 * h),
                            (D(rho1, rho2 + h) - D(rho1, rho2 - h)) / (2 * h)])


@given(extreme_parameter_sets(), st.floats(0.05, 0.95), st.sampled_from([0.0, 1e-2, -1e-2, 0.2, -0.2]))
def test_the_fold_distance_vanishes_exactly_where_the_jacobian_drops_rank(params, u, off):
    # The beta = pi/2 line K rho2 = k2 rho1 (K = 2 k3 + k2): det(dD/drho) by central
    # differences of FK vanishes on it (relative to |J|^2) and not beside it, where the
    # reported distance is the distance of the point to that line.
    L, k2 = params.L, params.k2
    K = 2 * params.k3 + k2
    rho1 = u * L
    n = np.array([-k2, K]) / math.hypot(K, k2)          # unit normal of the line
    rho = np.array([rho1, k2 * rho1 / K]) + off * L * n
    assume(min(rho) > 1e-3 * L and rho.sum() < 2 * L - 1e-2 * L and rho[0] < L - 1e-3 * L)
    dist = singularity_distances(rho[0], rho[1], params)["beta_half_pi"]
    assert dist * L == pytest.approx(abs(off) * L, abs=1e-9 * L)
    h = 1e-6 * L
    J = _fd_jacobian(rho[0], rho[1], params, h)
    rel = abs(np.linalg.det(J)) / (np.linalg.norm(J) ** 2)
    if off == 0.0:
        assert rel <= 1e-5
    else:
        analytic = forward_kinematics(rho[0], rho[1], params).jacobian
        rel_analytic = abs(np.linalg.det(analytic)) / np.linalg.norm(analytic) ** 2
        assert rel > 1e-5 and math.isclose(rel, rel_analytic, rel_tol=1e-3)


@st.composite
def stiff_cases(draw):
    """Springs over six decades, actuators and struts 1e2 to 1e6 times stiffer than the
    softest spring, the pre-stress force on F within +-(k2 + k3) L, and a configuration at
    least 1e-2 L from the sets where the stiffness matrix does not exist (the edges of that
    band drawn on purpose)."""
    k = edged(1e-3, 1e3).filter(lambda v: v > 0.0)
    L = draw(edged(1e-2, 1e2).filter(lambda v: v > 0.0))
    springs = {name: draw(k) for name in ("k1", "k2", "k3", "k4")}
    rigid = max(springs.values()) * draw(edged(1e2, 1e6))
    params = PAPER_PARAMS.with_overrides(L=L, ka=rigid, kb=rigid, **springs)
    rho1 = L * draw(edged(1e-2, 1.0 - 1e-2))
    rho2 = (2 * L - rho1) * draw(edged(1e-2, 1.0 - 1e-2))
    f = (springs["k2"] + springs["k3"]) * L * draw(edged(-1.0, 1.0))
    return rho1, rho2, f, params


@settings(max_examples=25)   # 112 energy sums per example
@given(stiff_cases())
def test_stiffness_matrix_is_the_symmetric_energy_hessian_and_its_inertia_the_energys(case):
    # Route (a), the paper's K = A_r G^ A_r^T + S_r, against route (c), central second
    # differences of the total potential energy summed over the members: equal (step
    # 1e-4 L: truncation ~ h^2 g / l^2 <= 1e-4 g with l >= 1e-2 L, rounding ~ eps E / h^2),
    # symmetric, and the sign of its smallest eigenvalue is the sign of the energy's second
    # difference along that eigenvector (definite K <=> strict energy minimum).
    rho1, rho2, f, params = case
    K = stiffness_matrix_paper(rho1, rho2, f, None, params)
    scale = np.abs(K).max()
    assert np.abs(K - K.T).max() <= 1e-12 * scale
    H = stiffness_matrix_energy_fd(rho1, rho2, f, None, params)
    assert np.abs(K - H).max() <= 2e-4 * scale
    w, v = np.linalg.eigh(K)
    assume(abs(w[0]) > 1e-3 * scale)                     # a sign the differences can resolve
    h = 1e-3 * params.L
    q = v[:, 0] * h
    second = q @ H @ q
    assert np.sign(second) == np.sign(w[0])


def test_negative_stiffness_eigenvalue_at_the_folded_point_is_real_and_the_rigid_limit_is_definite():
    """Soft actuators (ka) and struts (kb) against stiff springs k2 = k4 near the folded point
    rho1 = rho2 = 1e-6 L: d2U/dbeta2 > 0 (from energy.py's closed form it tends to k2 L^2 as
    rho -> 0: a -> 0, b -> -2 k2 L, beta = pi/2), yet K(0) has a negative eigenvalue.

    It is real: the second difference of the member energies (stiffness_matrix_energy_fd's
    energy, rest lengths from the member forces) along its eigenvector v is negative and equal
    to the eigenvalue. Step h = 1e-5 L: the actuators' lengths |Bx|, |Cx - Bx| and the
    zero-free-length springs' energies are exactly linear/quadratic while B moves less than
    rho1 (|v_Bx| h < rho1), the struts add O(kb h^2/L^2) = 4e-5 N/m, rounding 4 eps E/h^2 ~ 4e-3
    N/m (E ~ 430 J). In the rigid limit ka = 1e12, kb = 1e15 N/m (kb (s/2L)^2 = 4e3 N/m
    exceeds the struts' geometric stiffness |t|/L ~ 430 N/m) K(0) is positive definite, as
    d2U/dbeta2 > 0 says it must be; and K(f) keeps the inertia of K(0) up to the critical forces
    around 0."""
    params = PAPER_PARAMS.with_overrides(k2=428.0, k4=428.0, ka=1e4, kb=4.3e5)
    L = params.L
    rho1 = rho2 = 1e-6 * L
    beta = float(equilibrium_beta(rho1, rho2, params))
    assert float(d2U_dbeta2(np.array([rho1, rho2, beta]), params)) == pytest.approx(params.k2 * L**2, rel=1e-6)
    K = stiffness_matrix_paper(rho1, rho2, 0.0, None, params)
    w, v = np.linalg.eigh(K)
    assert w[0] < -1.0                                     # N/m, well beyond the 1e-2 N/m resolution
    assert w[1] > 0.0
    t, _ = member_forces(rho1, rho2, 0.0, None, params)
    X0 = node_positions((rho1, rho2, beta), params).reshape(-1)
    rest = member_lengths((rho1, rho2, beta), params) - t / axial_stiffnesses(params)
    h = 1e-5 * L
    assert abs(v[0, 0]) * h < rho1                         # v[0] is Bx
    d = np.zeros(12)
    d[FREE] = v[:, 0] * h
    E0 = total_potential_energy(X0, rest, 0.0, params)
    second = (total_potential_energy(X0 + d, rest, 0.0, params) - 2.0 * E0
              + total_potential_energy(X0 - d, rest, 0.0, params)) / h**2
    assert second == pytest.approx(w[0], abs=1e-2)
    rigid = params.with_overrides(ka=1e12, kb=1e15)     # the largest kb accepted
    assert np.linalg.eigvalsh(stiffness_matrix_paper(rho1, rho2, 0.0, None, rigid))[0] > 0.0
    crit = critical_forces(rho1, rho2, params)
    lo = max(crit[crit < 0], default=-1e3)
    hi = min(crit[crit > 0], default=1e3)
    for f in (0.5 * lo, 0.5 * hi):
        assert (np.linalg.eigvalsh(stiffness_matrix_paper(rho1, rho2, f, None, params)) < 0).sum() == 1


@settings(max_examples=40)
@given(st.data())
def test_stiffness_at_zero_force_is_positive_definite_at_the_papers_parameters(data):
    """At the paper's parameters K(0) is positive definite over the configuration domain,
    drawn down to about 1e-6 L from its edges (K exists from 1e-12 L on)."""
    params = PAPER_PARAMS
    L = params.L
    rho1 = L * data.draw(edged(1e-6, 1.0 - 1e-6))
    top = 2.0 * L - rho1
    rho2 = top * data.draw(edged(1e-6 / 2.0, 1.0 - 1e-6 / 2.0))
    assume(2.0 * L - rho1 - rho2 >= 1e-6 * L)
    assert np.linalg.eigvalsh(stiffness_matrix_paper(rho1, rho2, 0.0, None, params))[0] > 0.0
