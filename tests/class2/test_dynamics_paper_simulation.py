"""The paper's Sect. 5.3 simulation and the solve_ivp events.

Numbers asserted here come from the paper's statements (beta0 = 0.8, folded at 2.5 s),
from the FKP (energy.equilibrium_beta), from a second integrator (Radau with the
analytic Jacobian) and from the power balance of the force law as a time-dependent
potential V_a = 5 t (rho1^2 + rho2^2).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from studies.paper_simulation import PAPER_FOLD_TIME, plot_paper_figures, simulate_paper
from tensegrity_core.class2.dynamics import (
    ActuatorLengthEvent,
    Class2Dynamics,
    SingularityApproachEvent,
    damping_matrix,
)
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.params import PAPER_PARAMS
from tensegrity_core.errors import ParameterError


@pytest.fixture(scope="module")
def sim():
    return simulate_paper(5.0, samples=5001)


def test_initial_state_is_the_fkp_equilibrium_the_paper_rounds_to_0_8(sim):
    assert sim.beta0 == float(equilibrium_beta(0.7, 0.7, PAPER_PARAMS))
    assert sim.beta0 == pytest.approx(0.8, abs=0.005)          # the paper's "beta0 = 0.8"
    assert sim.beta0 != pytest.approx(0.8, abs=1e-3)            # ... but 0.8 is not at rest in equilibrium
    np.testing.assert_allclose(sim.y[0], [0.7, 0.7, sim.beta0, 0, 0, 0])
    assert sim.x[0] == pytest.approx(sim.x0[0], abs=1e-14) and sim.y_d[0] == pytest.approx(sim.y0[0], abs=1e-14)


def test_actuators_reach_zero_length_well_before_the_papers_fold_time(sim):
    t1, t2 = sim.first_zero["rho1"], sim.first_zero["rho2"]
    assert t1 is not None and t2 is not None
    assert t2 < t1 < PAPER_FOLD_TIME - 0.5
    # Independent integrator: Radau with the analytic Jacobian (incl. d f / d y).
    radau = simulate_paper(2.0, method="Radau", rtol=1e-9, atol=1e-12, samples=3)
    assert radau.first_zero["rho1"] == pytest.approx(t1, abs=1e-6)
    assert radau.first_zero["rho2"] == pytest.approx(t2, abs=1e-6)


def test_actuators_arrive_at_zero_with_speed_and_pass_through(sim):
    dyn = Class2Dynamics(PAPER_PARAMS)

    def rhs(t, y):
        return dyn.rhs(t, y, 10 * y[0] * t, 10 * y[1] * t)

    for index, name in ((1, "rho1"), (2, "rho2")):
        ev = ActuatorLengthEvent(index)
        sol = solve_ivp(rhs, (0, 3), sim.y[0], method="DOP853", rtol=1e-10, atol=1e-12, events=ev)
        assert sol.status == 1 and sol.t[-1] == pytest.approx(sim.first_zero[name], abs=1e-8)
        y_hit = sol.y_events[0][0]
        assert abs(y_hit[index - 1]) < 1e-12
        assert y_hit[2 + index] < -0.3            # still closing (rho2 at ~0.39, rho1 at ~1.4 m/s)
    # Without a stop the lengths go negative and change sign repeatedly.
    assert sim.y[:, 0].min() < -0.3 and sim.y[:, 1].min() < -0.3
    assert len(sim.zero_crossings["rho1"]) >= 3 and len(sim.zero_crossings["rho2"]) >= 5


def test_the_papers_fold_statement_does_not_hold(sim):
    """q_F = (0, 0, pi/2) 'at about 2.5 s and stays there': at 2.5 s the actuator lengths are
    far from zero (negative), and over 3-5 s the state keeps moving."""
    i = int(np.searchsorted(sim.t, PAPER_FOLD_TIME))
    assert abs(sim.y[i, 0]) > 0.2 and abs(sim.y[i, 1]) > 0.2
    late = sim.t >= 3.0
    assert np.ptp(sim.y[late, 0]) > 0.3 and np.ptp(sim.y[late, 1]) > 0.3 and np.ptp(sim.y[late, 2]) > 1.0


def test_power_balance_with_the_force_law_as_time_dependent_potential(sim):
    """d/dt (T + U + V_a) = dV_a/dt - qdot^T H qdot with V_a = (gain t / 2)(rho1^2 + rho2^2)."""
    t, y = sim.t, sim.y
    rho_sq = y[:, 0] ** 2 + y[:, 1] ** 2
    v_a = 0.5 * sim.gain * t * rho_sq
    qdot = y[:, 3:]
    lost = np.einsum("ni,nij,nj->n", qdot, damping_matrix(y[:, :3], PAPER_PARAMS), qdot)
    source = 0.5 * sim.gain * rho_sq - lost
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (source[1:] + source[:-1]) * np.diff(t))])
    total = sim.energy + v_a - integral
    assert np.abs(total - total[0]).max() < 1e-4 * np.abs(sim.energy).max()
    assert (sim.energy + v_a)[-1] > (sim.energy + v_a)[0] + 1.0     # net energy is pumped in


def test_equilibrium_curve_is_blank_while_a_length_is_negative(sim):
    negative = (sim.y[:, 0] < 0) | (sim.y[:, 1] < 0)
    assert negative.any() and np.all(np.isnan(sim.x0[negative])) and np.all(np.isfinite(sim.x0[~negative]))
    ok = ~negative
    beta_eq = equilibrium_beta(sim.y[ok, 0], sim.y[ok, 1], PAPER_PARAMS)
    np.testing.assert_allclose(sim.y0[ok], np.sin(beta_eq) * PAPER_PARAMS.L)
    np.testing.assert_allclose(sim.f[:, 0], 10 * sim.y[:, 0] * sim.t)


def test_plots_are_written(tmp_path):
    short = simulate_paper(2.0, samples=201, rtol=1e-8, atol=1e-10)
    paths = plot_paper_figures(tmp_path, short, long_sim=short)
    assert [p.name for p in paths] == ["fig3_rho1.png", "fig4_rho2.png", "fig5_beta.png", "fig6_x.png", "fig7_y.png",
                                       "long_run.png"]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000


@pytest.mark.parametrize("kw, match", [({"t_end": 0.0}, "t_end"), ({"t_end": float("nan")}, "t_end"),
                                       ({"samples": 1}, "samples")])
def test_simulate_paper_validates_arguments(kw, match):
    kw = {"t_end": 1.0, **kw}
    with pytest.raises(ParameterError, match=match):
        simulate_paper(kw.pop("t_end"), **kw)


def test_event_classes_validate_and_evaluate():
    with pytest.raises(ParameterError, match="index"):
        ActuatorLengthEvent(3)
    with pytest.raises(ParameterError, match="kind"):
        SingularityApproachEvent("lambda3", PAPER_PARAMS)
    with pytest.raises(ParameterError, match="margin"):
        SingularityApproachEvent("lambda1", PAPER_PARAMS, margin=0.0)
    y = [0.3, 0.5, 0.0, 0, 0, 0]
    assert ActuatorLengthEvent(2, length=0.1)(0.0, y) == pytest.approx(0.4)
    ev = SingularityApproachEvent("lambda2", PAPER_PARAMS, margin=0.1)
    assert ev(0.0, y) == pytest.approx(1 - 0.09 - 0.01)
    ev1 = SingularityApproachEvent("lambda1", PAPER_PARAMS, margin=0.1)
    assert ev1(0.0, y) == pytest.approx(4 - 0.64 - 0.01)


def test_singularity_event_stops_integration_before_the_equations_refuse():
    """Free motion (c = 0, f = 0) from this state drives rho1 to -L (lambda2 -> 0)."""
    params = PAPER_PARAMS.with_overrides(c=0.0, L=1.1, k1=1.3, k2=0.9, k3=1.6, k4=0.7, m=1.5)
    dyn = Class2Dynamics(params)
    events = [SingularityApproachEvent("lambda1", params, 1e-2), SingularityApproachEvent("lambda2", params, 1e-2)]
    sol = solve_ivp(dyn.rhs, (0, 10), [0.3, 0.9, 2.0, 0.1, -0.1, 1.5], method="DOP853", rtol=1e-10,
                    atol=1e-12, events=events)
    assert sol.status == 1
    hit = [i for i, te in enumerate(sol.t_events) if te.size]
    assert hit == [1]
    rho1 = sol.y_events[1][0][0]
    assert math.sqrt(params.L**2 - rho1**2) == pytest.approx(1e-2 * params.L, rel=1e-6)
