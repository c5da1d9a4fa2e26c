"""The quasi-static class-2 model: stable equilibria, fold events, limit points, slow loading.

Oracles: the closed-form potential gradient and Hessian of :mod:`tensegrity_core.class2`
(independent of the simulator's effects), scipy's minimiser and root finder, the analytic
time at which the paper's full fold becomes stable, and the dynamic model under slowly
changing forces.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq, minimize, root

from tensegrity_core.class2.dynamics import potential_gradient, potential_hessian
from tensegrity_core.class2.energy import equilibrium_beta, potential_energy
from tensegrity_core.sim import simulate

from .helpers import class2_scene

PAPER = {"f1": {"law": "proportional", "gain": 10.0}, "f2": {"law": "proportional", "gain": 10.0}}


def paper_qs(**kw):
    return simulate(class2_scene(effects=["springs", "fold_limit"], inputs=PAPER, duration=1.0, **kw))


def test_every_sample_is_a_stable_constrained_equilibrium():
    traj = paper_qs()
    p = class2_scene().model.params
    assert traj.success and traj.q[:, :2].min() >= 0.0
    for t, q, lam in zip(traj.times, traj.q, traj.contact_forces):
        G = potential_gradient(q, p) + np.array([10 * q[0] * t, 10 * q[1] * t, 0.0])
        held = [i for i in (0, 1) if q[i] == 0.0]
        free = [i for i in range(3) if i not in held]
        assert np.abs(G[free]).max() < 1e-9
        for i in held:
            assert G[i] == pytest.approx(lam[i], abs=1e-12) and lam[i] >= -1e-9
        K = potential_hessian(q, p) + np.diag([10 * t, 10 * t, 0.0])
        assert np.linalg.eigvalsh(K[np.ix_(free, free)]).min() > -1e-9


def test_the_start_is_the_springs_minimum_reached_from_the_paper_state():
    traj = paper_qs()
    p = class2_scene().model.params
    b = float(equilibrium_beta(0.7, 0.7, p))
    ref = minimize(lambda q: float(potential_energy(q, p)), [0.7, 0.7, b], jac=lambda q: potential_gradient(q, p),
                   bounds=[(0, 0.99), (0, 1.0), (None, None)], method="L-BFGS-B",
                   options={"ftol": 1e-15, "gtol": 1e-12})
    np.testing.assert_allclose(traj.q[0], ref.x, atol=1e-6)
    assert traj.events[0][:2] == (0.0, "jump")


def test_the_fold_events_happen_where_the_equilibrium_reaches_zero_length():
    traj = paper_qs()
    p = class2_scene().model.params
    (t1, k1, i1), (t2, k2, i2) = traj.events[1:3]
    assert (k1, i1, k2, i2) == ("fold", 0, "fold", 1)

    def rho1_at(t):
        sol = root(lambda q: potential_gradient(q, p) + np.array([10 * q[0] * t, 10 * q[1] * t, 0]),
                   rho1_at.last, tol=1e-14)
        rho1_at.last = sol.x
        return sol.x[0]

    rho1_at.last = np.array(traj.q[0])
    for t in np.linspace(0, t1 - 1e-3, 30):       # follow the branch, then bracket its zero
        rho1_at(t)
    t_zero = brentq(rho1_at, t1 - 1e-3, t1 + 1e-4, xtol=1e-14)
    assert t1 == pytest.approx(t_zero, abs=1e-9)
    # With rho1 held, the full fold (0, 0, pi/2) -- an equilibrium for every t -- becomes stable
    # when det([[1.5 + 10 t, 1.5], [1.5, 1]]) = 0, i.e. t = 0.075 (the Hessian at the fold plus
    # the actuator stiffness 10 t); there the stable branch ends on it.
    assert t2 == pytest.approx(0.075, abs=1e-8)
    assert np.all(traj.q[traj.times > 0.076, :2] == 0.0)
    np.testing.assert_allclose(traj.q[traj.times > 0.076, 2], np.pi / 2, atol=1e-12)


def test_slow_loading_makes_the_dynamics_quasi_static():
    """Ramped forces from the holding forces: the dynamic response follows the quasi-static
    path with an error that falls like the loading rate (about 4x per 4x slower ramp)."""
    params = {"kind": "class2", "params": {"k": 5.0, "m": 0.5, "c": 3.0}}
    p = class2_scene(model=params).model.params
    q0 = np.array([0.4, 0.8, float(equilibrium_beta(0.4, 0.8, p))])
    hold = -potential_gradient(q0, p)[:2]
    errors = []
    for T in (20.0, 80.0, 320.0):
        inputs = {"f1": {"law": "ramp", "from": float(hold[0]), "to": float(hold[0]) + 1.0, "t1": T},
                  "f2": {"law": "ramp", "from": float(hold[1]), "to": float(hold[1]) - 0.5, "t1": T}}
        common = dict(model=params, inputs=inputs, initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}},
                      duration=T, output={"rate": 1.0})
        dyn = simulate(class2_scene(effects=["inertia", "springs", "damping"],
                                    integrator={"method": "DOP853", "rtol": 1e-9, "atol": 1e-11}, **common))
        qs = simulate(class2_scene(effects=["springs"], **common))
        errors.append(np.abs(dyn.q - qs.q).max())
    assert errors[0] / errors[1] > 2.5 and errors[1] / errors[2] > 3.0 and errors[2] < 0.01


def test_a_limit_point_stops_the_run_instead_of_producing_garbage():
    p = class2_scene().model.params
    q0 = np.array([0.4, 0.8, float(equilibrium_beta(0.4, 0.8, p))])
    hold = -potential_gradient(q0, p)[:2]
    inputs = {"f1": {"law": "ramp", "from": float(hold[0]), "to": 2.0, "t1": 1.0}, "f2": float(hold[1])}
    common = dict(inputs=inputs, initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}}, duration=1.0)
    traj = simulate(class2_scene(effects=["springs"], **common))
    assert not traj.success and "limit point" in traj.message and traj.events[-1][1] == "limit"
    assert traj.times[-1] < 0.1 and np.all(np.isfinite(traj.q))
    folded = simulate(class2_scene(effects=["springs", "fold_limit"], **common))
    assert folded.success and folded.events[0][1] == "fold" and folded.q[-1, 0] == 0.0


def test_reaching_a_singular_configuration_is_reported_as_such():
    p = class2_scene().model.params
    q0 = np.array([0.4, 0.8, float(equilibrium_beta(0.4, 0.8, p))])
    hold = -potential_gradient(q0, p)[:2]
    inputs = {"f1": {"law": "ramp", "from": float(hold[0]), "to": -2.0, "t1": 1.0}, "f2": float(hold[1])}
    traj = simulate(class2_scene(effects=["springs"], inputs=inputs, duration=1.0,
                                 initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}}))
    assert not traj.success and "singular configuration" in traj.message and "strut BF flat" in traj.message


def test_commands_move_the_equilibrium_at_once():
    from tensegrity_core.sim import Simulator

    sim = Simulator(class2_scene(effects=["springs"], inputs={"f1": {"law": "commanded"}, "f2": {"law": "commanded"}},
                                 initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}}))
    start = sim.observe().q
    p = class2_scene().model.params
    f = np.array(sim.command) + np.array([0.05, -0.05])
    sim.set_command(f)
    sim.advance(0.1)
    q = sim.observe().q
    assert np.abs(q - start).max() > 1e-3
    np.testing.assert_allclose(potential_gradient(q, p)[:2] + f, 0.0, atol=1e-10)


def test_the_full_fold_is_located_to_rounding():
    """The branch meets the fold at a branch point (the bordered Newton converges only
    linearly there): located as the held branch's bifurcation, det K_FF = 0 at t = 0.075 s."""
    traj = paper_qs()
    (t1, kind1, _), (t2, kind2, _) = traj.events[1:3]
    assert (kind1, kind2) == ("fold", "fold") and abs(t2 - 0.075) < 1e-14
    assert traj.stats["newton_iterations"] < 100         # the old regula falsi needed ~180


def test_an_event_at_a_sample_time_comes_before_the_sample():
    """At 40 Hz the full fold (t = 0.075 s) falls on a sample: it reports the folded rest (the
    branch's own rate is unbounded there)."""
    traj = paper_qs(output={"rate": 40.0})
    k = int(np.flatnonzero(np.isclose(traj.times, 0.075))[0])
    assert traj.success and traj.folded[k]
    np.testing.assert_allclose(traj.q[k], [0.0, 0.0, np.pi / 2], atol=1e-15)
    np.testing.assert_array_equal(traj.qdot[k], 0.0)


def test_a_held_actuator_lets_go_where_its_contact_force_would_pull():
    """rho1 starts held at the stop and f1 falls linearly: while held the configuration stands
    still and the contact force is f1 + dU/drho1 (closed-form gradient); the release happens
    where that reaches -1e-9 N (the release threshold), after it the samples are free
    equilibria."""
    p = class2_scene().model.params
    q0 = np.array([0.0, 0.7, float(equilibrium_beta(0.0, 0.7, p))])
    g = potential_gradient(q0, p)
    u0 = 0.5 - g[0]                                    # contact force 0.5 N at t = 0, falling 1 N/s
    inputs = {"f1": {"law": "ramp", "from": float(u0), "to": float(u0 - 1.0), "t1": 1.0}, "f2": float(-g[1])}
    traj = simulate(class2_scene(effects=["springs", "fold_limit"], inputs=inputs, duration=0.8,
                                 initial={"equilibrium": {"rho1": 0.0, "rho2": 0.7}}, output={"rate": 50.0}))
    assert traj.success and [e[1:] for e in traj.events] == [("release", 0)]
    assert traj.events[0][0] == pytest.approx(0.5 + 1e-9, abs=1e-13)
    held = traj.times < 0.5
    np.testing.assert_allclose(traj.q[held], np.broadcast_to(q0, traj.q[held].shape), atol=1e-14)
    np.testing.assert_allclose(traj.contact_forces[held, 0], u0 - traj.times[held] + g[0], atol=1e-13)
    for t, q in zip(traj.times[~held], traj.q[~held]):
        np.testing.assert_allclose(potential_gradient(q, p) + np.array([u0 - t, -g[1], 0.0]), 0.0, atol=1e-11)
    assert traj.q[-1, 0] > 0.1


def test_a_ramp_starting_mid_run_is_followed_across_its_corners():
    """A law's breakpoint is a kink in t: Newton does not converge across it, so a step that
    would cross is cut there (the old path follower reported a limit point at the corner)."""
    params = {"kind": "class2", "params": {"k": 5.0}}
    p = class2_scene(model=params).model.params
    q0 = np.array([0.4, 0.8, float(equilibrium_beta(0.4, 0.8, p))])
    hold = -potential_gradient(q0, p)[:2]
    inputs = {"f1": {"law": "ramp", "from": float(hold[0]), "to": float(hold[0]) + 1.0, "t0": 5.0, "t1": 12.0},
              "f2": {"law": "ramp", "from": float(hold[1]), "to": float(hold[1]) - 0.5, "t1": 16.0}}
    traj = simulate(class2_scene(model=params, effects=["springs"], inputs=inputs, duration=20.0,
                                 initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}}, output={"rate": 2.0}))
    assert traj.success and traj.events == []
    for t, q, u in zip(traj.times, traj.q, traj.applied_forces):
        expected = [float(np.clip(hold[0] + (t - 5.0) / 7.0, hold[0], hold[0] + 1.0)),
                    float(np.clip(hold[1] - 0.5 * t / 16.0, hold[1] - 0.5, hold[1]))]
        np.testing.assert_allclose(u, expected, atol=1e-14)
        np.testing.assert_allclose(potential_gradient(q, p) + np.r_[u, 0.0], 0.0, atol=1e-11)
    np.testing.assert_allclose(traj.qdot[traj.times > 16.0], 0.0, atol=1e-14)


def test_a_force_that_jumps_moves_the_equilibrium_at_once(tmp_path):
    """A series held between samples jumps at each: the path stops just before, and restarts
    from the minimum under the new value (event jump), like a changed command."""
    params = {"kind": "class2", "params": {"k": 5.0}}
    p = class2_scene(model=params).model.params
    q0 = np.array([0.4, 0.8, float(equilibrium_beta(0.4, 0.8, p))])
    hold = [float(x) for x in -potential_gradient(q0, p)[:2]]
    csv = tmp_path / "f1.csv"
    csv.write_text(f"t,f1\n0,{hold[0]!r}\n1,{hold[0] + 0.5!r}\n2,{hold[0] + 1.0!r}\n")
    inputs = {"f1": {"law": "series", "file": str(csv), "column": "f1", "interpolation": "previous"}, "f2": hold[1]}
    traj = simulate(class2_scene(model=params, effects=["springs"], inputs=inputs, duration=3.0,
                                 initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}}, output={"rate": 4.0}))
    assert traj.success and [e[:2] for e in traj.events] == [(1.0, "jump"), (2.0, "jump")]
    for t, q in zip(traj.times, traj.q):
        f1 = hold[0] + 0.5 * min(np.floor(t), 2.0)
        np.testing.assert_allclose(potential_gradient(q, p) + np.array([f1, hold[1], 0.0]), 0.0, atol=1e-11)
    assert np.abs(traj.qdot).max() < 1e-12                 # constant forces between the jumps
