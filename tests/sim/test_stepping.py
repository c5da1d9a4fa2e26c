"""The stepping API the ROS node uses: advance / set_command / observe."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensegrity_core.errors import TensegrityError
from tensegrity_core.sim import Observation, SimulationError, Simulator, load_scene, simulate
from tensegrity_core.sim.stepper import Transition

from .helpers import class2_scene


def test_advancing_in_1ms_steps_equals_one_long_run():
    scene = load_scene("paper_fold").with_duration(2.0)
    traj = simulate(scene)
    sim = Simulator(scene)
    rows = {0: sim.observe().state}
    for k in range(1, 2001):
        sim.advance(k * 1e-3)
        if k % 10 == 0:
            rows[k // 10] = sim.observe().state
    stepped = np.array([rows[i] for i in range(len(traj.times))])
    tol = scene.integrator.rtol * np.abs(traj.states).max(axis=0) + scene.integrator.atol
    assert np.all(np.abs(stepped - traj.states) <= 10 * tol)
    assert [e[1:] for e in sim.events] == [e[1:] for e in traj.events]
    np.testing.assert_allclose([e[0] for e in sim.events], [e[0] for e in traj.events], atol=1e-9)


def test_the_observation_has_the_contract_fields():
    sim = Simulator("class2_at_rest")
    obs = sim.observe()
    assert isinstance(obs, Observation) and obs.t == 0.0
    assert obs.q.shape == obs.qdot.shape == (3,) and obs.applied_forces.shape == (2,)
    assert obs.nodes.shape == (6, 3) and obs.node_names == ("A", "B", "C", "D", "E", "F")
    assert obs.member_nodes.shape == (10, 2) and len(obs.member_names) == 10
    assert obs.member_lengths.shape == obs.member_forces.shape == (10,)
    np.testing.assert_allclose(obs.end_effector, obs.nodes[3])
    assert isinstance(obs.folded, bool) and not obs.folded
    assert obs.kinetic_energy == 0.0 and obs.potential_energy > 0


def test_commanded_inputs_hold_the_initial_state_until_a_command_arrives():
    sim = Simulator("class2_at_rest")
    np.testing.assert_allclose(sim.command, [-0.35, 0.35], atol=1e-12)
    for k in range(1, 201):
        sim.set_command(sim.command)
        sim.advance(k * 1e-3)
    obs = sim.observe()
    np.testing.assert_allclose(obs.q[:2], [0.7, 0.7], atol=1e-12)
    np.testing.assert_allclose(obs.applied_forces, [-0.35, 0.35])


def test_a_command_is_a_zero_order_hold_from_the_current_time():
    """Commands changing every millisecond equal an integration with the piecewise-constant
    forces, restarted at each change (solve_ivp per interval as the oracle)."""
    from scipy.integrate import solve_ivp

    from tensegrity_core.class2.dynamics import Class2Dynamics

    scene = class2_scene(inputs={"f1": {"law": "commanded"}, "f2": {"law": "commanded"}})
    sim = Simulator(scene)
    dyn = Class2Dynamics(scene.model.params)
    y = sim.observe().state.copy()
    for k in range(50):
        f = (2.0 * math.sin(0.3 * k), -1.0 + 0.05 * k)
        sim.set_command(f)
        sim.advance((k + 1) * 1e-3)
        y = solve_ivp(lambda t, z, f=f: dyn.rhs(t, z, *f), (k * 1e-3, (k + 1) * 1e-3), y, method="DOP853",
                      rtol=1e-12, atol=1e-14).y[:, -1]
    np.testing.assert_allclose(sim.observe().state, y, atol=1e-9)
    np.testing.assert_allclose(sim.observe().applied_forces, f)


def test_an_unchanged_command_does_not_restart_the_integrator():
    sim = Simulator("class2_at_rest")
    sim.set_command([0.5, 0.5])
    sim.advance(1e-3)
    restarts = sim.stats()["restarts"]
    assert restarts == 1                                  # the first command's
    for k in range(2, 100):
        sim.set_command([0.5, 0.5])
        sim.advance(k * 1e-3)
    assert sim.stats()["restarts"] == restarts


@pytest.mark.parametrize("command, words", [([1.0], "must have 2 values"), ([math.nan, 0.0], "must be finite"),
                                            (["a", 1.0], "must be 2 numbers")])
def test_bad_commands_are_rejected_and_leave_the_state(command, words):
    sim = Simulator("class2_at_rest")
    with pytest.raises(SimulationError, match=words):
        sim.set_command(command)
    np.testing.assert_allclose(sim.command, [-0.35, 0.35], atol=1e-12)


def test_advance_rejects_going_back_and_non_finite_times():
    sim = Simulator("class2_at_rest")
    sim.advance(0.01)
    with pytest.raises(SimulationError, match="backwards"):
        sim.advance(0.005)
    with pytest.raises(SimulationError, match="finite"):
        sim.advance(math.nan)


def test_reaching_a_singular_configuration_stops_with_an_error_and_keeps_the_state():
    """A large compressive force pushes rho1 + rho2 towards 2L (struts AE, CE flat)."""
    sim = Simulator(class2_scene(inputs={"f1": -20.0, "f2": -20.0}, duration=5.0))
    with pytest.raises(TensegrityError, match="struts AE and CE flat"):
        sim.advance(5.0)
    obs = sim.observe()
    assert np.all(np.isfinite(obs.state)) and obs.q[0] + obs.q[1] < 2.0


def test_simulate_returns_a_partial_trajectory_when_the_run_stops():
    traj = simulate(class2_scene(inputs={"f1": -20.0, "f2": -20.0}, duration=5.0))
    assert not traj.success and "struts AE and CE flat" in traj.message
    assert 0 < len(traj) < 501 and np.all(np.isfinite(traj.states))


def test_joint_sample_is_the_cheap_part_of_observe():
    import numpy as np

    from tensegrity_core.sim import Simulator, load_scene

    sim = Simulator(load_scene("class2_at_rest"))
    sim.set_command([0.5, -0.2])
    sim.advance(0.37)
    js, obs = sim.joint_sample(), sim.observe()
    assert js.t == obs.t
    for name in ("q", "qdot", "applied_forces", "end_effector"):
        np.testing.assert_allclose(getattr(js, name), getattr(obs, name), rtol=0, atol=1e-14)
    assert js.folded == obs.folded


def test_a_new_command_every_call_costs_one_step_and_no_interpolation():
    """The ROS node's pattern: set_command then advance by 1 ms. After a command change the
    solver ends at the advance target, so each call is one DOP853 step (12 stages) plus the
    first-same-as-last evaluation under the new forces: 13 evaluations, never the dense
    output's 3 more, and the step-size proposal survives the cut (no shrinking to 2 steps)."""
    sim = Simulator("class2_at_rest")
    hold = sim.command
    for k in range(1, 301):
        before = sim.stats()
        sim.set_command([hold[0] + 0.05 * math.sin(0.1 * k), hold[1] - 0.05 * math.cos(0.1 * k)])
        sim.advance(k * 1e-3)
        after = sim.stats()
        if k > 1:                    # the first call also chooses the initial step size
            assert (after["steps"] - before["steps"], after["nfev"] - before["nfev"]) == (1, 13)
        assert sim.state.work.t_integrated == sim.t == k * 1e-3     # the integrator stopped at the target
        assert after["restarts"] == k


def test_after_the_last_command_change_the_steps_grow_again_without_restarts():
    sim = Simulator("class2_at_rest")
    sim.set_command([-0.3, 0.3])
    sim.advance(1e-3)
    before = sim.stats()
    for k in range(2, 1001):
        sim.set_command([-0.3, 0.3])
        sim.advance(k * 1e-3)
    after = sim.stats()
    assert after["restarts"] == before["restarts"] == 1
    assert after["steps"] - before["steps"] < 100                   # steps of several milliseconds


class _StiffLinear:
    """y' = A y with A = diag(-1, -1e6) given as a *sparse* Jacobian (as the general
    structures' models give theirs): exact solution exp(diag(A) t) y0."""

    mode = frozenset()

    def __init__(self):
        import scipy.sparse as sp

        self.A = sp.diags([-1.0, -1e6], format="csc")
        self.jac_calls = 0

    def fun(self, t, y):
        return self.A @ y

    def jac(self, t, y):
        self.jac_calls += 1
        return self.A

    def events(self):
        return []

    def handle_event(self, crossing, y):
        return Transition(y, self)

    def after_step(self, t, y):
        return None

    def resume(self, t, y):
        return Transition(y, self)

    def next_breakpoint(self, t):
        return math.inf


@pytest.mark.parametrize("method", ["LSODA", "Radau", "BDF"])
def test_implicit_methods_take_a_sparse_model_jacobian(method):
    """LSODA needs dense Jacobians (it crashed on the general models' sparse one as soon as
    it switched to its stiff method); Radau and BDF take sparse ones as they are."""
    from tensegrity_core.sim.stepper import Stepper

    model = _StiffLinear()
    stepper = Stepper(model, 0.0, [1.0, 1.0], method=method, rtol=1e-8, atol=1e-12, t_end=2.0)
    stepper.advance(2.0)
    assert model.jac_calls > 0
    np.testing.assert_allclose(stepper.y, [math.exp(-2.0), 0.0], rtol=1e-6, atol=1e-12)


def test_lsoda_runs_the_stiff_fold_through_its_events():
    """LSODA restarted after an event with the step its stiff mode had reached used to fail
    at the first fold (t = 1.411 s, "repeated convergence failures"); it now chooses its own
    first step and agrees with Radau."""
    d = dict(load_scene("stiff_fold").data)
    d["duration"] = 2.0
    d["integrator"] = {"method": "LSODA", "rtol": 1e-8, "atol": 1e-11}
    lsoda = simulate(load_scene(d))
    assert lsoda.success, lsoda.message
    assert any(kind == "fold" for _, kind, _ in lsoda.events)
    d["integrator"] = {"method": "Radau", "rtol": 1e-10, "atol": 1e-13}
    radau = simulate(load_scene(d))
    assert np.abs(lsoda.nodes - radau.nodes).max() < 1e-6


def test_evaluations_are_counted_across_step_retries():
    """Near a singular set trial stages leave the domain and steps are retried with a fresh
    solver; the evaluations of the abandoned solvers count too (they were dropped:
    64 evaluations reported for 393 DOP853 steps, which take 12 each)."""
    traj = simulate(class2_scene(effects=["inertia", "springs"], inputs={"f1": 0.0, "f2": 0.0},
                                 initial={"q": [0.6, 0.5, 1.0], "qdot": [0.3, -0.2, 0.5]}, duration=195.0,
                                 model={"kind": "class2", "params": {"L": 1.0, "k": 1.0, "c": 0.0, "m": 2.0}},
                                 integrator={"method": "DOP853", "rtol": 1e-6, "atol": 1e-8}, output={"rate": 1}))
    assert not traj.success and "lambda1" in traj.message          # the motion reaches s = 2L at ~191.5 s
    assert traj.stats["nfev"] >= 12 * traj.stats["steps"]


@pytest.mark.parametrize("duration", [1.2099999999999997, 0.30000000000000004, 0.29999999999999993])
def test_a_duration_a_rounding_off_an_output_point_ends_exactly_there(duration):
    """1.21 * 100 rounds to a grid point above 1.2099999999999997 s: that point is the end
    itself (it had asked the integrator for a step past its end: "first_step must be positive")."""
    traj = simulate(load_scene("paper_fold"), duration=duration)
    assert traj.times[-1] == duration
    assert len(traj.times) == round(duration * 100) + 1
    assert np.all(np.diff(traj.times) > 0)
