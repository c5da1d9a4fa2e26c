"""General structures: nodal and rigid-body dynamics, the implicit Jacobian, incremental form-finding.

Oracles: closed-form oscillation of a mass between two bars, energy and momentum balances
computed from node positions and point masses in the test, central finite differences of
the right-hand side, and the statics' form-finding called directly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensegrity_core.general import form_find
from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.sim import Simulator, compile_scene, load_scene, simulate
from tensegrity_core.sim.general.kernels import arrays, loops

from .helpers import central_jacobian

LINE = {
    "name": "mass between two bars",
    "nodes": {"a": [-1.0, 0, 0], "m": [0.0, 0, 0], "b": [1.0, 0, 0]},
    "members": [{"nodes": ["a", "m"], "type": "bar", "EA": 100.0, "rest_length": 1.0},
                {"nodes": ["m", "b"], "type": "bar", "EA": 100.0, "rest_length": 1.0}],
    "pinned": {"a": "xyz", "b": "xyz", "m": "yz"},
    "masses": {"m": 2.0},
}

BODIES = {
    "name": "two floating triangles",
    "nodes": {"p1": [0, 0, 0], "p2": [1, 0, 0], "p3": [0, 1, 0],
              "q1": [0.2, 0.1, 1], "q2": [1.1, 0.3, 1.2], "q3": [0.1, 1.2, 0.9], "n": [0.5, 0.5, 2.0]},
    "members": [{"nodes": ["p1", "q1"], "EA": 50.0, "rest_length_ratio": 0.8},
                {"nodes": ["p2", "q2"], "EA": 60.0, "rest_length_ratio": 0.7},
                {"nodes": ["p3", "q3"], "EA": 40.0, "rest_length_ratio": 0.9},
                {"nodes": ["p1", "q3"], "type": "bar", "EA": 80.0},
                {"nodes": ["q2", "n"], "EA": 30.0, "rest_length_ratio": 0.9},
                {"nodes": ["p3", "n"], "EA": 30.0, "rest_length_ratio": 0.9}],
    "rigid_bodies": [{"name": "low", "nodes": ["p1", "p2", "p3"], "mass": 1.5},
                     {"name": "high", "nodes": ["q1", "q2", "q3"], "mass": 2.0}],
    "masses": {"n": 0.3, "q2": 0.4},
}


def general_scene(structure, effects, **extra):
    d = {"model": {"kind": "general", "structure": structure}, "initial": {"drawn": True},
         "effects": effects, "duration": 1.0, "output": {"rate": 200},
         "integrator": {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12}}
    d.update(extra)
    return load_scene(d)


def test_a_mass_between_two_bars_oscillates_at_sqrt_2k_over_m():
    x0 = 0.05
    structure = dict(LINE, nodes={"a": [-1.0, 0, 0], "m": [x0, 0, 0], "b": [1.0, 0, 0]})
    traj = simulate(general_scene(structure, ["inertia", "springs"], duration=2.0))
    omega = np.sqrt(2 * 100.0 / 1.0 / 2.0)
    np.testing.assert_allclose(traj.nodes[:, 1, 0], x0 * np.cos(omega * traj.times), atol=1e-9)
    np.testing.assert_allclose(traj.member_forces[:, 0], 100.0 * traj.nodes[:, 1, 0], atol=1e-7)



def test_a_taut_strings_damper_pushes_while_the_string_shortens_fast():
    """A taut string's force is ``k x + c dx/dt`` (``x = l - l0``) both ways, as MuJoCo's tendon's
    (docs/scenes.md): 1 kg on a string of k = 100 N/m, c = 4 N s/m, released 0.5 m stretched,
    moves as the damped oscillator ``x = x0 e^{-z w t} (cos(w_d t) + z w / w_d sin(w_d t))`` until
    it goes slack (w = 10 rad/s, z = 0.2); the force turns compressive before that."""
    k, c, x0 = 100.0, 4.0, 0.5
    structure = {"name": "one damped string", "nodes": {"a": [0.0, 0, 0], "m": [0.5 + x0, 0, 0]},
                 "members": [{"nodes": ["a", "m"], "EA": k * 0.5, "rest_length": 0.5}],
                 "pinned": {"a": "xyz", "m": "yz"}, "masses": {"m": 1.0}}
    traj = simulate(general_scene(structure, ["inertia", "springs", {"damping": {"c": c}}], duration=0.2,
                                  output={"rate": 1000}))
    w = math.sqrt(k)                                    # 1 kg
    z = c / (2 * w)
    wd = w * math.sqrt(1 - z * z)
    t = traj.times
    x = x0 * np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))
    v = -x0 * w * w / wd * np.exp(-z * w * t) * np.sin(wd * t)
    taut = x > 0
    np.testing.assert_allclose(traj.nodes[taut, 1, 0] - 0.5, x[taut], atol=1e-8)
    np.testing.assert_allclose(traj.member_forces[taut, 0], (k * x + c * v)[taut], atol=1e-6)
    assert traj.member_forces[taut, 0].min() < -10.0            # c v = -13.9 N as it goes slack at 0.181 s

@pytest.mark.parametrize("kernels", ["loops", "arrays"])
def test_left_jacobian_and_its_inverse(kernels):
    rng = np.random.default_rng(0)
    for theta in list(rng.normal(size=(5, 3))) + [np.array([1e-6, 0, 0]), np.array([0, 2e-4, 1e-5]), np.zeros(3)]:
        if kernels == "loops":
            Jl, Jl_inv = np.empty((3, 3)), np.empty((3, 3))
            loops.chart_jacobians(*theta, Jl, Jl_inv)
        else:
            (Jl,), (Jl_inv,) = arrays.chart_jacobians(theta[None])
        np.testing.assert_allclose(Jl @ Jl_inv, np.eye(3), atol=1e-12)
        # omega from d/dt exp(hat(theta)): hat(omega) = dR/dt R^T
        v = rng.normal(size=3)
        h = 1e-6
        dR = (exp_so3(theta + h * v) - exp_so3(theta - h * v)) / (2 * h)
        W = dR @ exp_so3(theta).T
        np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], Jl @ v, atol=1e-8)


def _lumped(structure):
    """Point masses per node, as the docs define them (independent of the simulator code)."""
    s = structure
    m = s.node_masses.copy()
    for body in s.bodies:
        m[list(body.nodes)] += body.mass / len(body.nodes)
    return m


def _node_velocities(traj, structure):
    """Node velocities from q, qdot: free coordinates directly, body nodes v_c + omega x r."""
    lay = structure.layout
    vel = np.zeros_like(traj.nodes)
    free = np.argwhere(lay.free_index >= 0)
    for node, axis in free:
        vel[:, node, axis] = traj.qdot[:, lay.free_index[node, axis]]
    for slot, idx in enumerate(lay.body_nodes):
        base = lay.body_dof[slot]
        c, vc, w = traj.q[:, base:base + 3], traj.qdot[:, base:base + 3], traj.qdot[:, base + 3:base + 6]
        for k in idx:
            vel[:, k] = vc + np.cross(w, traj.nodes[:, k] - c)
    return vel


def _spin(scene, seed=1):
    """A simulator of ``scene`` started from the drawing with random velocities."""
    sim = Simulator(scene, t_end=scene.duration)
    y = sim.state.y.copy()
    n = len(y) // 2
    y[n:] = np.random.default_rng(seed).normal(0, 1.5, n)
    sim.state = sim.model.state_from(y, t_end=scene.duration)
    return sim


def _run(sim, times):
    samples = []
    sim.model.record(sim.state, times, samples)
    return sim.model.observe(samples)


def test_free_bodies_conserve_energy_momentum_and_angular_momentum_through_rechartings():
    scene = general_scene(BODIES, ["inertia", "springs"], duration=1.5)
    s = scene.model.structure
    sim = _spin(scene)
    data = _run(sim, np.linspace(0, 1.5, 151))

    class T:                                           # the arrays _node_velocities reads
        q, qdot, nodes = data["q"], data["qdot"], data["nodes"]
    m = _lumped(s)
    vel = _node_velocities(T, s)
    momentum = np.einsum("k,tki->ti", m, vel)
    angular = np.einsum("k,tki->ti", m, np.cross(data["nodes"], vel))
    np.testing.assert_allclose(momentum - momentum[0], 0.0, atol=1e-8)
    np.testing.assert_allclose(angular - angular[0], 0.0, atol=1e-8)
    kinetic = 0.5 * np.einsum("k,tki,tki->t", m, vel, vel)
    np.testing.assert_allclose(kinetic, data["kinetic_energy"], rtol=1e-10)
    l = data["member_lengths"]
    taut = (l >= s.rest_lengths) | ~s.is_string
    strain = 0.5 * np.sum(np.where(taut, s.EA * (l - s.rest_lengths) ** 2 / s.rest_lengths, 0.0), axis=1)
    E = kinetic + strain
    assert np.ptp(E) < 1e-8 * E[0]
    assert sim.stats()["restarts"] >= 1                 # the rotation charts were re-anchored
    assert np.abs(data["q"][:, 9:12]).max() <= np.pi + 1e-9


def test_gravity_and_loads_do_their_work():
    g = np.array([0.0, 0.0, -9.81])
    load = np.array([1.0, -2.0, 0.5])
    scene = general_scene(BODIES, ["inertia", "springs", {"gravity": {"vector": g.tolist()}},
                                   {"loads": {"n": load.tolist()}}], duration=1.0)
    s = scene.model.structure
    sim = _spin(scene, seed=3)
    data = _run(sim, np.linspace(0, 1.0, 101))
    m = _lumped(s)
    l = data["member_lengths"]
    taut = (l >= s.rest_lengths) | ~s.is_string
    strain = 0.5 * np.sum(np.where(taut, s.EA * (l - s.rest_lengths) ** 2 / s.rest_lengths, 0.0), axis=1)
    heights = np.einsum("k,tk->t", m, data["nodes"] @ g)
    n = s.node_names.index("n")
    E = data["kinetic_energy"] + strain - heights - data["nodes"][:, n] @ load
    assert np.ptp(E) < 1e-8 * np.abs(E).max()
    np.testing.assert_allclose(data["potential_energy"], strain - heights - data["nodes"][:, n] @ load,
                               rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("name", ["table_gravity", "spine_release"])
def test_the_sparse_jacobian_is_exact_at_rest_in_equilibrium(name):
    scene = load_scene(name)
    model = compile_scene(scene)
    state = model.initial_state()
    equations, y = model.equations(state), state.y.copy()
    J = equations.jac(0.0, y).toarray()
    fd = central_jacobian(lambda z: equations.fun(0.0, z), y, h=1e-7)
    n = equations.n
    if name == "spine_release":          # the released preload leaves it at rest out of balance:
        J, fd = J[:, n:], fd[:, n:]      # only the velocity columns are exact there
    scale = np.abs(fd).max()
    np.testing.assert_allclose(J, fd, atol=1e-5 * scale)


def test_quasi_static_general_equals_form_finding_and_the_damped_dynamics_settle_there():
    scene = load_scene("table_gravity")
    d = dict(scene.data)
    d["effects"] = ["springs", "gravity", {"loads": {"c1": [0.0, 0.0, -500.0]}}]
    d["model"] = dict(d["model"], structure=str(scene.model.source))
    qs = simulate(load_scene(d), duration=0.05)
    s = scene.model.structure
    loads = s.loads.copy()
    loads[s.node_names.index("c1")] += [0, 0, -500.0]
    ref = form_find(s.replace(gravity=np.array([0, 0, -9.80665]), loads=loads))
    assert qs.success and ref.success
    np.testing.assert_allclose(qs.nodes[-1], ref.nodes, atol=1e-9)
    np.testing.assert_allclose(qs.member_forces[-1], ref.member_forces, rtol=1e-9)
    assert np.all(qs.kinetic_energy == 0.0) and np.all(qs.qdot == 0.0)
    dyn = simulate(scene, duration=0.2)
    np.testing.assert_allclose(dyn.nodes[-1], ref.nodes, atol=2e-8)


def test_quasi_static_actuator_members_follow_their_rest_lengths():
    structure = dict(LINE, members=[{"nodes": ["a", "m"], "type": "actuator", "EA": 100.0, "rest_length": 1.0,
                                     "name": "act"},
                                    {"nodes": ["m", "b"], "type": "bar", "EA": 100.0, "rest_length": 1.0}])
    scene = general_scene(structure, ["springs"], inputs={"act": {"law": "ramp", "from": 1.0, "to": 0.8, "t1": 1.0}})
    traj = simulate(scene)
    # equilibrium: EA (x + 1 - l0)/l0 = EA (1 - x - 1)/1 ... solved for the node's x
    l0 = traj.applied_forces[:, 0]
    x = traj.nodes[:, 1, 0]
    np.testing.assert_allclose((x + 1 - l0) / l0, (1 - x - 1.0), atol=1e-9)
    np.testing.assert_allclose(l0, np.clip(1.0 - 0.2 * traj.times, 0.8, 1.0), atol=1e-12)
    dxdt = traj.qdot[:, 0]
    np.testing.assert_allclose(dxdt[1:-1], np.gradient(x, traj.times)[1:-1], atol=1e-4)


STRINGS = {
    "name": "a mass between two strings",
    "nodes": {"a": [-1.0, 0, 0], "m": [0.3, 0, 0], "b": [1.0, 0, 0]},
    "members": [{"nodes": ["a", "m"], "type": "string", "EA": 100.0, "rest_length": 0.9},
                {"nodes": ["m", "b"], "type": "string", "EA": 100.0, "rest_length": 0.9}],
    "pinned": {"a": "xyz", "b": "xyz", "m": "yz"},
    "masses": {"m": 2.0},
}


def _strings_reference(c, times):
    """x(t) of the mass between two strings (rest length 0.9 m of a 1 m span each side, EA 100 N,
    dampers c, slack when shorter), by solve_ivp restarted at every slack/taut crossing."""
    from scipy.integrate import solve_ivp

    def tension(length, rate):
        return np.where(length >= 0.9, 100.0 * (length - 0.9) / 0.9 + c * rate, 0.0)

    def rhs(t, y):
        x, v = y
        return [v, (-tension(x + 1.0, v) + tension(1.0 - x, -v)) / 2.0]

    crossings = [lambda t, y: y[0] + 1.0 - 0.9, lambda t, y: 1.0 - y[0] - 0.9]
    out, t0, y0 = [], 0.0, [0.3, 0.0]
    while t0 < times[-1]:
        sol = solve_ivp(rhs, (t0, times[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True,
                        events=[_terminal(f) for f in crossings])
        inside = times[(times >= t0) & (times <= sol.t[-1])]
        out += [(t, sol.sol(t)[0]) for t in inside if not out or t > out[-1][0]]
        t0, y0 = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:                       # past the crossing by a hair, on the new side
            t0 = t0 + 1e-12
            y0 = sol.sol(t0)
    return np.array([x for _, x in out])


def _terminal(f):
    def g(t, y):
        return f(t, y)
    g.terminal, g.direction = True, 0
    return g


def test_strings_with_dampers_go_slack_and_taut_as_events_and_no_step_straddles_the_jump():
    """The damper's force jumps by c dl/dt where a string goes slack or taut: each crossing is
    an event (slack and taut alternating per string), the motion equals an independent
    integration restarted at the crossings, and the steps cost DOP853's 12 evaluations plus
    the dense output's 3 and a restart's first evaluation (22 when the solver had to reject its way
    through them)."""
    scene = general_scene(STRINGS, ["inertia", "springs", {"damping": {"c": 0.5}}], duration=8.0,
                          integrator={"method": "DOP853", "rtol": 1e-8, "atol": 1e-10}, output={"rate": 100})
    traj = simulate(scene)
    reference = _strings_reference(0.5, traj.times)
    np.testing.assert_allclose(traj.nodes[:, 1, 0], reference, atol=1e-6)
    for member in (0, 1):
        kinds = [k for _, k, i in traj.events if i == member]
        assert len(kinds) >= 4 and all(a != b for a, b in zip(kinds, kinds[1:]))
    assert {k for _, k, _ in traj.events} == {"slack", "taut"}
    assert traj.stats["nfev"] <= 17 * traj.stats["steps"]
