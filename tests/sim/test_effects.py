"""Each effect on or off changes exactly what it should (class-2 mechanism).

Energy balances are computed from the trajectory's node positions (not from the effects'
own energy functions); reference runs use the independent closed-form dynamics of
:mod:`tensegrity_core.class2.dynamics` with scipy's ``solve_ivp``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import simpson, solve_ivp

from tensegrity_core.class2.dynamics import Class2Dynamics
from tensegrity_core.class2.dynamics import effects as fx
from tensegrity_core.class2.dynamics import springs as spring_members
from tensegrity_core.class2.dynamics.inertia import Inertia
from tensegrity_core.class2.dynamics.kinematics import kinematics
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.geometry import SPRINGS, node_positions
from tensegrity_core.sim import Simulator, compile_scene, simulate
from tensegrity_core.sim.class2.contact import impact

from .helpers import class2_scene

FREE = {"f1": 0.0, "f2": 0.0}
START = {"q": [0.6, 0.5, 1.0], "qdot": [0.3, -0.2, 0.5]}
TIGHT = {"method": "DOP853", "rtol": 1e-11, "atol": 1e-13}


def strut_centre_heights(nodes):
    """Sum of the four struts' centre coordinates (x, y) from node positions (N, 6, 3)."""
    A, B, C, D, E, F = (nodes[:, i, :2] for i in range(6))
    return 0.5 * ((A + E) + (B + F) + (B + D) + (C + E)).sum(axis=0) if nodes.ndim == 2 else \
        0.5 * ((A + E) + (B + F) + (B + D) + (C + E))


def spring_energy(traj, params):
    """``U`` from the member lengths in the trajectory (CD k3, DE k2, EF k1, BE k4)."""
    L = traj.member_lengths
    return 0.5 * (params.k3 * L[:, 2] ** 2 + params.k2 * L[:, 3] ** 2 + params.k1 * L[:, 6] ** 2
                  + params.k4 * L[:, 7] ** 2)


def test_without_damping_the_energy_is_conserved():
    traj = simulate(class2_scene(effects=["inertia", "springs"], inputs=FREE, initial=START, duration=3.0,
                                 integrator=TIGHT))
    E = spring_energy(traj, traj_params()) + traj.kinetic_energy
    assert np.ptp(E) < 1e-9 * E[0]
    np.testing.assert_allclose(traj.potential_energy, spring_energy(traj, traj_params()), rtol=1e-12)


def traj_params():
    return class2_scene().model.params


def test_damping_dissipates_exactly_the_dampers_work():
    scene = class2_scene(effects=["inertia", "springs", "damping"], inputs=FREE, initial=START, duration=2.0,
                         integrator=TIGHT, output={"rate": 2000},
                         model={"kind": "class2", "params": {"c": 0.3}})
    traj = simulate(scene)
    p = scene.model.params
    E = spring_energy(traj, p) + traj.kinetic_energy
    assert np.all(np.diff(E) <= 1e-12)
    # spring rates from the geometry's node positions, differentiated along qdot
    h = 1e-6
    P = node_positions(traj.q, p)
    V = (node_positions(traj.q + h * traj.qdot, p) - node_positions(traj.q - h * traj.qdot, p)) / (2 * h)
    power = np.zeros(len(traj))
    for member in SPRINGS:
        a, b = member.nodes
        d, dv = P[:, b] - P[:, a], V[:, b] - V[:, a]
        Ldot = np.sum(d * dv, axis=1) / np.sqrt(np.sum(d * d, axis=1))
        power += getattr(p, member.damping) * Ldot**2
    dissipated = simpson(power, x=traj.times)
    assert E[0] - E[-1] == pytest.approx(dissipated, rel=1e-7)


def test_gravity_in_the_plane_does_the_work_m_g_dh():
    g = np.array([0.0, -9.81, 0.0])
    scene = class2_scene(effects=["inertia", "springs", {"gravity": {"vector": g.tolist()}}], inputs=FREE,
                         initial=START, duration=1.0, integrator=TIGHT)
    traj = simulate(scene)
    p = scene.model.params
    T_plus_U = spring_energy(traj, p) + traj.kinetic_energy
    heights = strut_centre_heights(traj.nodes)                      # (N, 2)
    work = p.m * (heights - heights[0]) @ g[:2]
    np.testing.assert_allclose(T_plus_U - T_plus_U[0], work, atol=1e-8)
    assert np.ptp(work) > 1.0                                        # gravity did matter


def test_gravity_normal_to_the_horizontal_mechanism_changes_nothing():
    kwargs = dict(inputs=FREE, initial=START, duration=0.5, integrator=TIGHT)
    plain = simulate(class2_scene(effects=["inertia", "springs"], **kwargs))
    down = simulate(class2_scene(effects=["inertia", "springs", "gravity"], **kwargs))
    np.testing.assert_array_equal(plain.states, down.states)


def test_loads_do_the_work_of_dead_forces():
    F = {"D": [0.4, -0.6, 0.0], "E": [-0.3, 0.2, 0.0], "F": [0.0, 0.5, 0.0]}
    scene = class2_scene(effects=["inertia", "springs", {"loads": F}], inputs=FREE, initial=START, duration=1.0,
                         integrator=TIGHT)
    traj = simulate(scene)
    p = scene.model.params
    work = sum((traj.nodes[:, "ABCDEF".index(n), :2] - traj.nodes[0, "ABCDEF".index(n), :2]) @ np.array(v[:2])
               for n, v in F.items())
    T_plus_U = spring_energy(traj, p) + traj.kinetic_energy
    np.testing.assert_allclose(T_plus_U - T_plus_U[0], work, atol=1e-8)


def test_the_fold_limit_keeps_lengths_non_negative_and_fires_at_the_first_zero_crossing():
    scene = class2_scene(effects=["inertia", "springs", "damping", "fold_limit"], duration=5.0,
                         integrator={"method": "DOP853", "rtol": 1e-10, "atol": 1e-12})
    traj = simulate(scene)
    assert traj.q[:, :2].min() >= 0.0
    p = scene.model.params
    dyn = Class2Dynamics(p)
    hit = lambda t, y: min(y[0], y[1])                                  # noqa: E731
    hit.terminal, hit.direction = True, -1
    b = float(equilibrium_beta(0.7, 0.7, p))
    ref = solve_ivp(lambda t, y: dyn.rhs(t, y, 10 * y[0] * t, 10 * y[1] * t), (0, 5), [0.7, 0.7, b, 0, 0, 0],
                    method="DOP853", rtol=1e-12, atol=1e-14, events=hit)
    t_first, kind, index = traj.events[0]
    assert kind == "fold" and t_first == pytest.approx(ref.t_events[0][0], abs=1e-8)
    assert index == int(np.argmin(ref.y_events[0][0][:2]))
    folded = traj.folded
    assert folded.any() and np.all(traj.contact_forces[folded].max(axis=1) >= -1e-9)
    held = traj.contact_forces > 0
    assert np.all(traj.q[:, :2][held] == 0.0) and np.all(traj.qdot[:, :2][held] == 0.0)


# The paper's fold with plastic stops, from an independent hybrid integration: the
# Lagrangian of the four rods derived afresh with sympy (M = Hessian of T, Lagrange's
# equations written out, Rayleigh damping), plastic impacts and contact modes found by
# enumerating the complementarity cases of the stops at zero length, events of solve_ivp
# (DOP853, rtol 1e-11, atol 1e-13). (t [s], kind, actuator index)
PAPER_FOLD_EVENTS = [(1.38083268190, "fold", 1), (1.53463057905, "fold", 0), (1.55792412432, "fold", 1),
                     (1.75493954774, "release", 0), (2.94659967363, "fold", 0), (3.03369531309, "fold", 1),
                     (3.04249319358, "fold", 0)]


def test_the_paper_fold_with_plastic_stops_matches_an_independent_hybrid_run():
    """Every impact, lift-off and release of the first 5 s, not only the first fold: rho2
    lifts off its stop at once after its impact (its contact force would pull), rho1's impact
    at 1.535 s leaves rho1 held and rho2 free, ..., both held from 3.042 s with beta still
    swinging (1.90203660 rad, -1.02262982 rad/s at 5 s)."""
    scene = class2_scene(effects=["inertia", "springs", "damping", "fold_limit"], duration=5.0,
                         integrator={"method": "DOP853", "rtol": 1e-10, "atol": 1e-12})
    traj = simulate(scene)
    assert [(k, i) for _, k, i in traj.events] == [(k, i) for _, k, i in PAPER_FOLD_EVENTS]
    np.testing.assert_allclose([t for t, _, _ in traj.events], [t for t, _, _ in PAPER_FOLD_EVENTS], atol=1e-8)
    np.testing.assert_allclose(traj.q[-1], [0.0, 0.0, 1.90203659742], atol=1e-7)
    np.testing.assert_allclose(traj.qdot[-1], [0.0, 0.0, -1.02262981606], atol=1e-7)


def test_the_impact_law_against_the_single_contact_formulas():
    rng = np.random.default_rng(4)
    inertia = Inertia(traj_params())
    for restitution in (0.0, 0.5, 1.0):
        q = [0.0, 0.4, 1.1]
        M = inertia.mass_matrix(kinematics(1.0, (*q, 0.0, 0.0, 0.0), 1e-4))
        v = np.array([-0.8, rng.normal(), rng.normal()])
        new, _ = impact(np.linalg.inv(M), v, [0], restitution)
        assert new[0] == pytest.approx(-restitution * v[0])
        impulse = M @ (new - v)
        assert abs(impulse[1]) < 1e-12 and abs(impulse[2]) < 1e-12 and impulse[0] > 0
        loss = 0.5 * v @ M @ v - 0.5 * new @ M @ new
        assert loss == pytest.approx((1 - restitution**2) * v[0] ** 2 / (2 * np.linalg.inv(M)[0, 0]), rel=1e-12)


@pytest.mark.parametrize("restitution", [0.0, 0.5, 1.0])
def test_a_double_impact_is_poissons_law_on_both_stops(restitution):
    """Both actuators at zero length, both approaching: the compression impulses ``P_c >= 0``
    stop both (plastic: zero normal velocity for each stop that pushes, none entering its stop),
    the stops give back ``r P_c``, and the kinetic energy falls by ``(1 - r^2) P_c^T W P_c / 2``
    (``W = (M^-1)_AA``) -- computed here by trying the four sets of pushing stops."""
    inertia = Inertia(traj_params())
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = [0.0, 0.0, rng.uniform(0.2, 2.9)]
        M = inertia.mass_matrix(kinematics(1.0, (*q, 0.0, 0.0, 0.0), 1e-4))
        Minv = np.linalg.inv(M)
        v = np.array([-rng.uniform(0.1, 1), -rng.uniform(0.1, 1), rng.normal()])
        W = Minv[:2, :2]
        expected = None
        for S in ([0, 1], [0], [1], []):
            Pc = np.zeros(2)
            if S:
                Pc[S] = np.linalg.solve(W[np.ix_(S, S)], -v[S])
            after = v[:2] + W @ Pc
            if np.all(Pc >= -1e-12) and np.all(after >= -1e-12):
                expected = Pc
                break
        new, P = impact(Minv, v, [0, 1], restitution)
        after_all = v[:2] + (1 + restitution) * W @ expected
        if np.all(after_all >= 0):                 # no plastic correction needed
            np.testing.assert_allclose(P, (1 + restitution) * expected, rtol=1e-9, atol=1e-12)
            loss = 0.5 * v @ M @ v - 0.5 * new @ M @ new
            assert loss == pytest.approx((1 - restitution**2) * expected @ W @ expected / 2, rel=1e-9, abs=1e-14)
        assert np.all(new[:2] >= -1e-12) and np.all(P >= 0)
        np.testing.assert_allclose(M @ (new - v), [P[0], P[1], 0.0], atol=1e-12)
        assert 0.5 * new @ M @ new <= 0.5 * v @ M @ v + 1e-12


@pytest.mark.parametrize("restitution", [0.0, 0.8])
def test_restitution_sets_the_rebound_speed(restitution):
    scene = class2_scene(effects=["inertia", "springs", "damping", {"fold_limit": {"restitution": restitution}}],
                         duration=1.45)
    t_hit, kind, i = simulate(scene).events[0]
    sim = Simulator(scene)
    sim.advance(t_hit - 1e-9)
    before = sim.observe().qdot[i]
    sim.advance(t_hit + 1e-9)
    after = sim.observe()
    assert kind == "fold" and before < -0.1
    assert after.qdot[i] == pytest.approx(-restitution * before, abs=1e-6)
    assert after.q[i] == pytest.approx(0.0, abs=1e-8)


def test_actuator_lag_follows_the_command_with_its_time_constant(tmp_path):
    (tmp_path / "step.csv").write_text("t,f\n0,0\n0.5,2\n")
    tau = 0.1
    scene = class2_scene(effects=["inertia", "springs", "damping", {"actuator_lag": {"tau": tau}}],
                         inputs={"f1": {"law": "series", "file": str(tmp_path / "step.csv"), "column": "f",
                                        "interpolation": "previous"}, "f2": 0.0},
                         duration=1.0, integrator=TIGHT)
    traj = simulate(scene)
    t = traj.times
    expected = np.where(t < 0.5, 0.0, 2.0 * (1 - np.exp(-(t - 0.5) / tau)))
    np.testing.assert_allclose(traj.applied_forces[:, 0], expected, atol=1e-9)
    np.testing.assert_allclose(traj.states[:, 6], expected, atol=1e-9)


def test_stiff_actuator_compliance_tends_to_the_force_plus_the_drive_damping():
    """With k_a -> inf the compliant drive transmits f + c_d drho/dt (singular perturbation:
    the drive's friction resists the actuator's motion, so it damps the mechanism)."""
    cd = 0.5
    scene = class2_scene(effects=["inertia", "springs", "damping",
                                  {"actuator_compliance": {"stiffness": 1e7, "drive_damping": cd}}],
                         duration=1.2, integrator={"method": "Radau", "rtol": 1e-9, "atol": 1e-12})
    traj = simulate(scene)
    p = scene.model.params
    dyn = Class2Dynamics(p)
    b = float(equilibrium_beta(0.7, 0.7, p))
    ref = solve_ivp(lambda t, y: dyn.rhs(t, y, 10 * y[0] * t + cd * y[3], 10 * y[1] * t + cd * y[4]), (0, 1.2),
                    [0.7, 0.7, b, 0, 0, 0], method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    deviation = np.abs(traj.states[:, :6] - ref.sol(traj.times).T).max()
    assert deviation < 1e-5                       # O(c_d / k_a) with k_a / c_d = 2e7 1/s
    plain = simulate(class2_scene(duration=1.2))
    assert np.abs(plain.states[:, :6] - traj.states[:, :6]).max() > 1e-2   # the drive damping matters


def test_the_compliant_drive_is_stable_for_an_explicit_method_too():
    """The elongation's own eigenvalue is -k_a/c_d: an explicit method with steps inside its
    stability region follows the implicit solution (a sign error would make it blow up)."""
    effects = ["inertia", "springs", "damping", {"actuator_compliance": {"stiffness": 1e4, "drive_damping": 1.0}}]
    implicit = simulate(class2_scene(effects=effects, duration=0.5,
                                     integrator={"method": "Radau", "rtol": 1e-9, "atol": 1e-12}))
    explicit = simulate(class2_scene(effects=effects, duration=0.5,
                                     integrator={"method": "RK45", "rtol": 1e-9, "atol": 1e-12, "max_step": 1e-4}))
    assert explicit.success and np.abs(explicit.states - implicit.states).max() < 1e-6
    model = compile_scene(class2_scene(effects=effects))
    J = model.equations(model.initial_state()).jac(0.3, np.array([0.6, 0.6, 0.8, 0.1, -0.1, 0.2, 0.01, 0.02]))
    assert J[6, 6] == J[7, 7] == pytest.approx(-1e4)


def test_sensor_noise_has_the_listed_sigma_and_is_reproducible():
    sigma = {"q": 1e-3, "member_forces": 0.05}
    inputs = {"f1": {"law": "commanded"}, "f2": {"law": "commanded"}}
    scene = class2_scene(effects=["inertia", "springs", "damping", {"sensor_noise": sigma}], inputs=inputs, seed=11)
    sim = Simulator(scene)
    clean = Simulator(class2_scene(effects=["inertia", "springs", "damping"], inputs=inputs))
    times = np.arange(3000) * 1e-3
    obs, true = [], []
    for t in times:
        sim.advance(t)
        clean.advance(t)
        obs.append(sim.observe())
        true.append(clean.observe())
    dq = np.array([o.q for o in obs]) - np.array([o.q for o in true])
    df = np.array([o.member_forces for o in obs]) - np.array([o.member_forces for o in true])
    for dev, s in ((dq, sigma["q"]), (df, sigma["member_forces"])):
        assert abs(dev.mean()) < 5 * s / np.sqrt(dev.size)
        assert dev.std() == pytest.approx(s, rel=0.03)
        assert abs(np.corrcoef(dev[:-1, 0], dev[1:, 0])[0, 1]) < 5 / np.sqrt(len(dev))   # white in time
    np.testing.assert_array_equal(np.array([o.end_effector for o in obs]), np.array([o.end_effector for o in true]))
    again = Simulator(scene).observe()
    np.testing.assert_array_equal(again.q, obs[0].q)
    other = Simulator(class2_scene(effects=["inertia", "springs", "damping", {"sensor_noise": sigma}],
                                   inputs=inputs, seed=12)).observe()
    assert not np.array_equal(other.q, obs[0].q)


def test_sensor_noise_at_a_time_does_not_depend_on_what_was_observed_before():
    """A lockstep node observes more often than the core's sampled run: the noise a client
    sees at t_k must not depend on that (nor on observe vs joint_sample)."""
    scene = class2_scene(effects=["inertia", "springs", "damping", {"sensor_noise": {"q": 1e-3, "qdot": 1e-2}}],
                         inputs={"f1": {"law": "commanded"}, "f2": {"law": "commanded"}}, seed=5)
    busy, quiet = Simulator(scene), Simulator(scene)
    clean = Simulator(class2_scene(effects=["inertia", "springs", "damping"],
                                   inputs={"f1": {"law": "commanded"}, "f2": {"law": "commanded"}}))
    deviations = []
    for k in range(1, 6):
        t = k * 0.01
        for sim in (busy, quiet, clean):
            sim.advance(t)
        for _ in range(k):                      # extra observations on one of them
            busy.observe()
            busy.joint_sample()
        a, b = busy.joint_sample(), quiet.observe()
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.qdot, b.qdot)
        deviations.append(tuple(b.q - clean.observe().q))
    assert len(set(deviations)) == 5 and all(any(d) for d in deviations)   # new noise at every time


def test_noise_never_touches_the_simulated_state():
    noisy = simulate(class2_scene(effects=["inertia", "springs", "damping", {"sensor_noise": {"q": 0.1}}], seed=1))
    clean = simulate(class2_scene(effects=["inertia", "springs", "damping"]))
    np.testing.assert_array_equal(noisy.states, clean.states)
    assert np.std(noisy.measurements["q"] - clean.q) == pytest.approx(0.1, rel=0.1)


def test_an_unlisted_effect_is_never_built_nor_evaluated(monkeypatch):
    def boom(*args, **kwargs):
        raise RuntimeError("dampers built or evaluated")

    tensions = spring_members.spring_tensions

    def tensions_without_dampers(L, stiffness, damping, eps2, k):
        if damping is not None:
            boom()
        return tensions(L, stiffness, damping, eps2, k)

    monkeypatch.setattr(fx.Damping, "__init__", boom)
    simulate(class2_scene(effects=["inertia", "springs"], duration=0.2))
    with pytest.raises(RuntimeError, match="built or evaluated"):
        simulate(class2_scene(effects=["inertia", "springs", "damping"], duration=0.2))
    monkeypatch.undo()
    monkeypatch.setattr(spring_members, "spring_tensions", tensions_without_dampers)
    simulate(class2_scene(effects=["inertia", "springs"], duration=0.2))
    with pytest.raises(RuntimeError, match="built or evaluated"):
        simulate(class2_scene(effects=["inertia", "springs", "damping"], duration=0.2))
