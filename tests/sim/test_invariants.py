"""Invariants of every dynamic model, as property tests over the parameters a scene accepts.

Each invariant is checked on class-2 scenes (the fold limit over stiffness, damping, input
gain, restitution; commanded forces that hold and release the stop) and on general scenes
(two free rigid bodies spinning through several re-chartings of their rotation charts,
joined by strings that go slack and taut, with and without dampers), through the public
``Model`` / ``State`` API only, and over every integration method the stepper registers:

- the fold limit: actuator lengths >= 0 (to the position tolerance ``atol``), a held actuator's contact force
  compressive, zero off the stop, and a held actuator exactly at zero length and rest;
- energy balance: the change of kinetic + potential energy equals the work of the inputs
  minus what the dampers dissipate (quadrature over the samples, with energies, member
  rates and powers computed here from node positions and velocities), and impacts never
  create energy;
- a state at rest in equilibrium stays there;
- ``advance(t)`` then an observation equals the recorded sample at ``t``, and both equal an
  independent reference integration (general: ``rigid_reference.py``, no rotation charts);
- a copy of a state, continued, equals the run it came from;
- events in time order, and never two contradicting at one instant.

Numbers come from the physics (energies, the reference integration), never from the code's
own output. The ``ci`` hypothesis profile is derandomised; example counts are kept small so
that the whole file runs in well under two minutes.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.integrate import cumulative_simpson

from tensegrity_core.sim import SimulationError, compile_scene, load_scene
from tensegrity_core.sim.class2.plant import PENETRATION_REL
from tensegrity_core.sim.scene import scene_from_dict, scene_path
from tensegrity_core.sim.stepper import SOLVERS

from .rigid_reference import FloatingReference

# among the suite's longest files: ./run test starts them first (tests/conftest.py)
pytestmark = pytest.mark.slow

#: The adaptive methods (RK4 takes fixed steps without error control, so it has no tolerance
#: to hold the invariants to); on general scenes "DOP853" runs the compiled DOP853 where numba
#: is installed, scipy's through the numpy kernels otherwise.
METHODS = tuple(m for m in SOLVERS if m != "RK4")


# -- scenes ------------------------------------------------------------------------------------
def fold_scene(*, k, c, gain, restitution, method, duration=5.0, rate=1000, rtol=1e-8, atol=1e-10, extra=None):
    """The paper's fold scenario over spring stiffness, damping, input gain and restitution."""
    d = copy.deepcopy(load_scene("paper_fold").data)
    d["model"]["params"].update(k=k, c=c)
    d["inputs"] = {"f1": {"law": "proportional", "gain": gain}, "f2": {"law": "proportional", "gain": gain}}
    d["effects"] = ["inertia", "springs", "damping", {"fold_limit": {"restitution": restitution}}] + (extra or [])
    d["duration"] = duration
    d["output"] = {"rate": rate}
    d["integrator"] = {"method": method, "rtol": rtol, "atol": atol}
    return load_scene(d)


def commanded_scene(*, rho1, rho2, method, duration, rtol=1e-8, atol=1e-10, restitution=0.0):
    """The mechanism at rest at an equilibrium, commanded forces, the fold limit."""
    d = copy.deepcopy(load_scene("class2_at_rest").data)
    d["initial"] = {"equilibrium": {"rho1": rho1, "rho2": rho2}}
    d["effects"] = ["inertia", "springs", "damping", {"fold_limit": {"restitution": restitution}}]
    d["duration"] = duration
    d["integrator"] = {"method": method, "rtol": rtol, "atol": atol}
    return load_scene(d)


PAIR = {
    "name": "two free triangles joined by strings",
    "nodes": {"p1": [0, 0, 0], "p2": [1, 0, 0], "p3": [0, 1, 0],
              "q1": [0.2, 0.1, 1], "q2": [1.1, 0.3, 1.2], "q3": [0.1, 1.2, 0.9]},
    "members": [{"nodes": ["p1", "q1"], "EA": 50.0, "rest_length_ratio": 1.05},
                {"nodes": ["p2", "q2"], "EA": 60.0, "rest_length_ratio": 0.9},
                {"nodes": ["p3", "q3"], "EA": 40.0, "rest_length_ratio": 1.1}],
    "rigid_bodies": [{"name": "low", "nodes": ["p1", "p2", "p3"], "mass": 1.5},
                     {"name": "high", "nodes": ["q1", "q2", "q3"], "mass": 2.0}],
}


#: Spins of 5 to 10 rad/s about any axis: 3 to 6 rad in a run, several re-chartings.
spins = st.tuples(st.floats(5.0, 10.0), *[st.floats(-1.0, 1.0)] * 3).filter(
    lambda w: np.linalg.norm(w[1:]) > 0.1).map(lambda w: tuple(w[0] * np.asarray(w[1:]) / np.linalg.norm(w[1:])))


def pair_scene(*, method, damping, duration=0.6, rtol=1e-8, atol=1e-10, rate=500):
    effects = ["inertia", "springs"] + ([{"damping": {"c": damping}}] if damping else [])
    return load_scene({"model": {"kind": "general", "structure": PAIR}, "initial": {"drawn": True},
                       "effects": effects, "duration": duration, "output": {"rate": rate},
                       "integrator": {"method": method, "rtol": rtol, "atol": atol}})


def spun(model, omega, velocity):
    """A state of the pair's model with both bodies moving at ``velocity`` and spinning at ``omega``."""
    y = model.initial_state().y.copy()
    n = len(y) // 2
    lay = model.scene.model.structure.layout
    for slot, sign in zip(range(len(lay.moving_bodies)), (1.0, -1.0)):
        base = n + lay.body_dof[slot]
        y[base:base + 3] = sign * np.asarray(velocity)
        y[base + 3:base + 6] = sign * np.asarray(omega)
    return y


def pair_reference(omega, velocity, damping, duration, n):
    """Node positions (n, 6, 3) of the spun pair at ``linspace(0, duration, n)`` by the
    independent integration."""
    scene = pair_scene(method="DOP853", damping=damping, duration=duration)
    model = compile_scene(scene)
    s = scene.model.structure
    data, _ = record(model, model.state_from(spun(model, omega, velocity)), np.zeros(1))
    vel0 = pair_node_velocities(s, data["q"], data["qdot"], data["nodes"])[0]
    return FloatingReference(s, damping or None).run(data["nodes"][0], vel0, np.linspace(0.0, duration, n),
                                                    rtol=1e-11, atol=1e-12)


def pair_node_velocities(structure, q, qdot, nodes):
    """Node velocities (N, n, 3) from the pair's coordinates: body nodes move as ``v_c + w x r``."""
    lay = structure.layout
    vel = np.zeros_like(nodes)
    for slot, idx in enumerate(lay.body_nodes):
        b = lay.body_dof[slot]
        c, vc, w = q[:, b:b + 3], qdot[:, b:b + 3], qdot[:, b + 3:b + 6]
        for k in idx:
            vel[:, k] = vc + np.cross(w, nodes[:, k] - c)
    return vel


def record(model, state, times):
    """Observations at ``times`` (up to where the run stopped) and the error that stopped it."""
    samples = []
    try:
        model.record(state, times, samples)
    except SimulationError as err:
        return model.observe(samples), err
    return model.observe(samples), None


# -- shared checks -----------------------------------------------------------------------------
def assert_events_consistent(events):
    """Events in time order; at one instant no (kind, index) twice, and no fold and release of
    one actuator."""
    times = [t for t, _, _ in events]
    assert times == sorted(times), events
    at = {}
    for t, kind, index in events:
        seen = at.setdefault(t, set())
        assert (kind, index) not in seen, f"{kind} {index} twice at t = {t!r}: {events}"
        opposite = {"fold": "release", "release": "fold", "slack": "taut", "taut": "slack"}.get(kind)
        assert (opposite, index) not in seen, f"{kind} and {opposite} of {index} at t = {t!r}: {events}"
        seen.add((kind, index))


def length_tolerance(scene):
    """The lowest actuator length [m] the fold limit guarantees under ``scene``'s integrator:
    the fold event fires at ``rho = -PENETRATION_REL L``, and a dip of that event function
    inside one step is located if it is deeper than the position tolerance ``atol`` (a
    shallower one is not told from the interpolant's error)."""
    return scene.integrator.atol + PENETRATION_REL * scene.model.params.L


def assert_fold_limit_holds(data, events, scene):
    """Lengths at least ``-length_tolerance(scene)``, the stop never pulls, a held actuator at
    zero length and rest, events consistent."""
    q, qdot, lam = data["q"], data["qdot"], data["contact_forces"]
    assert q[:, :2].min() >= -length_tolerance(scene), f"actuator length {q[:, :2].min():.3g} m below zero"
    scale = 1.0 + np.abs(data["applied_forces"]).max() + np.abs(lam).max()
    assert lam.min() >= -1e-9 * scale, f"the stop pulls: contact force {lam.min():.3g} N"
    held = lam > 0
    assert np.all(q[:, :2][held] == 0.0) and np.all(qdot[:, :2][held] == 0.0)
    assert_events_consistent(events)


# -- class-2: the fold limit -------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=3)
@given(k=st.floats(0.25, 8.0), c=st.one_of(st.just(0.0), st.floats(0.0, 0.5)), gain=st.floats(1.0, 50.0),
       restitution=st.one_of(st.just(0.0), st.floats(0.0, 0.9)), rtol=st.sampled_from([1e-7, 1e-8]))
@example(k=0.25 * 2**3.75, c=0.05, gain=10.0, restitution=0.0, rtol=1e-7)
@example(k=1.0625, c=0.0, gain=4.0, restitution=0.09375, rtol=1e-7)
def test_property_the_fold_limit_holds_for_any_stiffness_damping_gain_and_restitution(method, k, c, gain,
                                                                                       restitution, rtol):
    """Also at the shipped scenes' tolerance (rtol 1e-7): the longer steps it allows are where a
    held actuator's contact force can cross zero and come back inside one step (the first
    example: a point of the ``fold_time_kc`` grid where it does, with DOP853), and where both
    actuators chatter on the stop, each impact changing the other's speed (the second: every
    bounce inside the step of the one before must be found, none taken for a repeat)."""
    scene = fold_scene(k=k, c=c, gain=gain, restitution=restitution, method=method, rtol=rtol, atol=rtol / 100)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    data, _ = record(model, state, np.linspace(0.0, scene.duration, 2501))
    assert_fold_limit_holds(data, state.events, scene)


@pytest.mark.parametrize(("k", "c"), [(0.25 * 2**3.5, 0.0), (0.25 * 2**3.5, 0.01), (0.25 * 2**3.75, 0.05)])
def test_a_contact_force_that_dips_below_zero_inside_one_step_releases_the_actuator(k, c):
    """The shipped fold scenario at three points of the ``fold_time_kc`` grid (N/m, N s/m), with
    the scene's own integrator: both actuators held, the mechanism steps long (~0.3 s), and the
    contact force of rho1 passes through zero and back between two step ends. The stop may
    only push: at every sample (1 kHz) each contact force is compressive, within the
    integrator's tolerance of the force scale, and a held actuator sits at zero length."""
    d = copy.deepcopy(load_scene("paper_fold").data)
    d["model"]["params"].update(k=k, c=c)
    scene = load_scene(d)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    data, err = record(model, state, np.linspace(0.0, scene.duration, 5001))
    assert err is None
    assert_fold_limit_holds(data, state.events, scene)


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
def test_a_lift_off_under_a_loose_implicit_method_goes_on(method):
    """The paper's fold under an implicit method at rtol 1e-3 (the loose end of the precision
    benchmark) ends, with the events of the same method at rtol 1e-9 in the same order: the
    long first step after a bounce, whose interpolant wiggles about the stop and about a held
    actuator's zero contact force, must not be taken for a crossing (each one would restart
    the run a few ns later, without end)."""
    import copy

    from tensegrity_core.sim import load_scene, simulate

    base = load_scene("paper_fold").data
    runs = []
    for rtol in (1e-3, 1e-9):
        d = copy.deepcopy(base)
        d["integrator"] = {"method": method, "rtol": rtol, "atol": rtol * 1e-2}
        runs.append(simulate(load_scene(d)).events)
    loose, tight = runs
    assert [(k, i) for _, k, i in loose] == [(k, i) for _, k, i in tight]
    assert np.allclose([t for t, _, _ in loose], [t for t, _, _ in tight], atol=0.05)


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=2)
@given(rho=st.tuples(st.floats(0.0, 0.9), st.floats(0.0, 0.9)), seed=st.integers(0, 2**16),
       restitution=st.one_of(st.just(0.0), st.floats(0.0, 0.9)))
def test_property_commands_that_press_and_pull_on_the_stop_never_leak_nor_pull(method, rho, seed, restitution):
    """Forces commanded every 50 ms (random, up to 4 N either way) from an equilibrium, some on
    the stop: a held actuator is released as soon as a command makes its contact force pull."""
    scene = commanded_scene(rho1=rho[0], rho2=rho[1], method=method, duration=2.0, restitution=restitution)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    rng = np.random.default_rng(seed)
    samples = []
    try:
        for k in range(40):
            model.set_command(state, rng.uniform(-4.0, 4.0, 2))
            model.record(state, np.linspace(0.05 * k, 0.05 * (k + 1), 11)[1:], samples)
    except SimulationError:
        pass                                        # a singular configuration stops the run
    assert_fold_limit_holds(model.observe(samples), state.events, scene)


# -- energy balance ------------------------------------------------------------------------------
SPRINGS = (("CD", "k3", "c3"), ("DE", "k2", "c2"), ("EF", "k1", "c1"), ("BE", "k4", "c4"))
STRUTS = ("AE", "BF", "BD", "CE")


def class2_node_velocities(q, qdot, L):
    """Velocities (N, 6, 2) of nodes A..F, differentiated by hand from the node positions
    (docs: B = (rho1, 0), C = (s, 0), D = B + L (cos b, sin b), E = (s, lambda1)/2, F = (0, lambda2))."""
    r1, r2, b = q.T
    v1, v2, vb = qdot.T
    s, sd = r1 + r2, v1 + v2
    lam1 = np.sqrt(4 * L * L - s * s)
    lam2 = np.sqrt(L * L - r1 * r1)
    zero = np.zeros_like(r1)
    vx = np.stack([zero, v1, sd, v1 - L * np.sin(b) * vb, sd / 2, zero], -1)
    vy = np.stack([zero, zero, zero, L * np.cos(b) * vb, -s * sd / (2 * lam1), -r1 * v1 / lam2], -1)
    return np.stack([vx, vy], -1)


def class2_energy_terms(data, p):
    """(kinetic + spring energy [J], power of the actuators on the mechanism minus the dampers'
    dissipation [W]) per sample, from node positions and velocities."""
    nodes = data["nodes"][..., :2]
    vel = class2_node_velocities(data["q"], data["qdot"], p.L)
    idx = {n: i for i, n in enumerate("ABCDEF")}
    kinetic = sum(p.m / 6 * (np.sum(vel[:, idx[a]] ** 2, 1) + np.sum(vel[:, idx[a]] * vel[:, idx[b]], 1)
                             + np.sum(vel[:, idx[b]] ** 2, 1)) for a, b in STRUTS)
    potential = np.zeros(len(nodes))
    power = -np.sum(data["applied_forces"] * data["qdot"][:, :2], axis=1)
    for (a, b), k, c in SPRINGS:
        d = nodes[:, idx[b]] - nodes[:, idx[a]]
        dv = vel[:, idx[b]] - vel[:, idx[a]]
        length = np.sqrt(np.sum(d * d, 1))
        potential += 0.5 * getattr(p, k) * length**2
        # the damper's force c dL/dt along d, regularised at zero length as the docs define it
        power -= getattr(p, c) * np.sum(d * dv, 1) ** 2 / (length**2 + (1e-12 * p.L) ** 2)
    return kinetic + potential, power


def spring_lengths(data):
    nodes = data["nodes"][..., :2]
    idx = {n: i for i, n in enumerate("ABCDEF")}
    return np.stack([np.linalg.norm(nodes[:, idx[b]] - nodes[:, idx[a]], axis=1) for (a, b), _, _ in SPRINGS], 1)


def balance_residual(times, energy, power, cuts):
    """The largest ``|E(t) - E(t_a) - int_{t_a}^t power|`` over the pieces between ``cuts``
    (the indices where a piece starts; the interval before each is skipped: a jump of the
    energy or of the power lies in it), each integrated by Simpson's rule."""
    worst = 0.0
    bounds = [0, *cuts, len(times)]
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        end = hi - 1 if hi < len(times) else hi        # up to the sample before the next cut
        if end - lo < 3:
            continue
        work = cumulative_simpson(power[lo:end], x=times[lo:end], initial=0.0)
        worst = max(worst, float(np.abs(energy[lo:end] - energy[lo] - work).max()))
    return worst


#: The sample after an event is taken this long after it [s].
AFTER = 1e-10


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=2)
@given(k=st.floats(0.25, 8.0), c=st.floats(0.0, 0.5), gain=st.floats(1.0, 50.0),
       restitution=st.one_of(st.just(0.0), st.floats(0.0, 1.0)))
def test_property_class2_energy_balance_through_impacts(method, k, c, gain, restitution):
    """Between events, T + U changes by the actuators' work minus the dampers' dissipation;
    at an event (impact, release), the energy never rises."""
    scene = fold_scene(k=k, c=c, gain=gain, restitution=restitution, method=method, duration=2.5,
                       rtol=1e-9, atol=1e-11)
    model = compile_scene(scene)
    first = model.initial_state(t_end=scene.duration)
    grid = np.linspace(0.0, scene.duration, 2501)
    coarse, err = record(model, first, grid)
    end = err.t if err is not None else scene.duration
    events = sorted({t for t, _, _ in first.events if t < end})
    # the grid, each event's instant (the state before it) and just after it, and a finer
    # grid where a spring nears zero length (its damper's power then changes within |d|/|d'|)
    short = np.flatnonzero(spring_lengths(coarse).min(axis=1) < 0.05 * scene.model.params.L)
    fine = [np.linspace(grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)], 41) for i in short]
    times = np.unique(np.concatenate([grid, events, np.add(events, AFTER), *fine]))
    times = times[times <= end]
    data, _ = record(model, model.initial_state(t_end=scene.duration), times)
    times = data["t"]
    E, P = class2_energy_terms(data, scene.model.params)
    cuts = [int(np.searchsorted(times, t + AFTER)) for t in events]
    scale = 1.0 + np.abs(E).max()
    jumps = [E[i] - E[i - 1] - AFTER * max(P[i - 1], P[i]) for i in cuts if 0 < i < len(E)]
    assert max(jumps, default=0.0) <= 1e-9 * scale, "an event created energy"
    assert balance_residual(times, E, P, cuts) <= 1e-6 * scale


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=2)
@given(omega=spins, velocity=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
       damping=st.one_of(st.just(0.0), st.floats(0.05, 2.0)))
def test_property_general_energy_balance_spinning_through_rechartings(method, omega, velocity, damping):
    """Two spinning bodies, strings going slack and taut: T + U falls by the dampers' dissipation
    (none without dampers), at every sample -- including those in a step that re-charts."""
    scene = pair_scene(method=method, damping=damping)
    model = compile_scene(scene)
    s = scene.model.structure
    state = model.state_from(spun(model, omega, velocity), t_end=scene.duration)
    data, _ = record(model, state, np.linspace(0.0, scene.duration, 601))
    m = FloatingReference(s).m
    vel = pair_node_velocities(s, data["q"], data["qdot"], data["nodes"])
    kinetic = 0.5 * np.einsum("k,tki,tki->t", m, vel, vel)
    a, b = s.members[:, 0], s.members[:, 1]
    d = data["nodes"][:, b] - data["nodes"][:, a]
    length = np.linalg.norm(d, axis=2)
    taut = length >= s.rest_lengths
    strain = 0.5 * np.sum(np.where(taut, s.EA * (length - s.rest_lengths) ** 2 / s.rest_lengths, 0.0), 1)
    rate = np.einsum("tmi,tmi->tm", d, vel[:, b] - vel[:, a]) / length
    power = -np.sum(np.where(taut, damping * rate**2, 0.0), 1)
    E = kinetic + strain
    # the dampers' power jumps where a string goes slack or taut: the pieces between are checked
    cuts = list(np.flatnonzero(np.any(taut[1:] != taut[:-1], axis=1)) + 1)
    assert balance_residual(data["t"], E, power, cuts) <= 1e-6 * (1 + E.max())


# -- rest --------------------------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=3)
@given(rho=st.tuples(st.floats(0.0, 0.9), st.floats(0.0, 0.9)))
def test_property_a_class2_state_at_rest_in_equilibrium_stays_there(method, rho):
    """Holding forces keep any equilibrium (on the stop or off it) at rest, with no event."""
    scene = commanded_scene(rho1=rho[0], rho2=rho[1], method=method, duration=1.0)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    q0 = state.y[:3].copy()
    data, err = record(model, state, np.linspace(0.0, 1.0, 101))
    assert err is None
    assert np.abs(data["q"] - q0).max() <= 1e-9 and np.abs(data["qdot"]).max() <= 1e-9
    assert state.events == []


@pytest.mark.parametrize("method", METHODS)
def test_a_general_structure_at_rest_in_equilibrium_stays_there(method):
    """The table on the floor in equilibrium under its weight (no load): nothing moves."""
    d = copy.deepcopy(load_scene("table_gravity").data)
    d["effects"] = [e for e in d["effects"] if not (isinstance(e, dict) and "loads" in e)]
    d["duration"] = 0.05
    d["integrator"] = {"method": method, "rtol": 1e-8, "atol": 1e-10}
    scene = scene_from_dict(d, base=scene_path("table_gravity").parent)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    y0 = state.y.copy()
    data, err = record(model, state, np.linspace(0.0, scene.duration, 11))
    assert err is None and state.events == []
    # the form-found equilibrium balances ~1e3 N of string forces to ~1e-6 N
    n = len(y0) // 2
    assert np.abs(data["state"][:, :n] - y0[:n]).max() <= 1e-9        # m, rad
    assert np.abs(data["state"][:, n:]).max() <= 1e-7                 # m/s, rad/s


# -- samples, copies, references ------------------------------------------------------------------
def assert_observations_equal(a, b, tol):
    """The observed motion and forces of ``a`` and ``b`` agree to ``tol``, relative to each
    quantity's largest magnitude over the run."""
    for key in ("t", "q", "qdot", "nodes", "member_forces", "contact_forces"):
        scale = 1.0 + np.abs(b[key]).max()
        np.testing.assert_allclose(a[key], b[key], atol=tol * scale, rtol=0, err_msg=key)


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=2)
@given(k=st.floats(0.25, 8.0), c=st.floats(0.0, 0.5), gain=st.floats(1.0, 50.0),
       restitution=st.one_of(st.just(0.0), st.floats(0.0, 0.9)), cut=st.floats(0.0, 1.0))
def test_property_class2_advance_observe_and_copies_agree_with_the_recorded_run(method, k, c, gain, restitution,
                                                                                cut):
    """Observing after ``advance(t)`` gives the recorded sample at ``t`` (events included); a copy
    taken at any time and continued gives the same samples as the run it came from."""
    scene = fold_scene(k=k, c=c, gain=gain, restitution=restitution, method=method, duration=3.0, rate=100)
    model = compile_scene(scene)
    times = np.linspace(0.0, 3.0, 301)
    recorded, err = record(model, model.initial_state(t_end=3.0), times)
    n = len(recorded["t"])
    state = model.initial_state(t_end=3.0)
    stepped = []
    split = int(cut * (n - 1))
    copied = None
    for i in range(n):
        model.advance(state, times[i])
        stepped.append(model.observe_now(state))
        if i == split:
            copied = state.copy()
    stepped = {key: np.array([o[key] for o in stepped]) for key in stepped[0]}
    assert_observations_equal(stepped, recorded, 1e-12)
    rest, _ = record(model, copied, times[split:n])
    tol = 1e3 * scene.integrator.rtol
    assert_observations_equal(rest, {k: v[split:n] for k, v in recorded.items()}, tol)
    assert_events_consistent(state.events)
    assert [e[1:] for e in copied.events] == [e[1:] for e in state.events]


@settings(max_examples=3)
@given(omega=spins, velocity=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
       damping=st.one_of(st.just(0.0), st.floats(0.05, 2.0)), cut=st.floats(0.0, 1.0))
def test_property_general_samples_and_copies_match_a_reference_through_rechartings(omega, velocity, damping, cut):
    """Every sample of the spinning pair -- recorded, or observed after ``advance`` -- and every
    copied state continued equals an independent integration without rotation charts, under
    every method (the reference, most of the cost, is integrated once per example)."""
    times = np.linspace(0.0, 0.6, 301)
    reference = pair_reference(omega, velocity, damping, times[-1], len(times))
    tol = 1e-6
    for method in METHODS:
        scene = pair_scene(method=method, damping=damping, duration=times[-1])
        model = compile_scene(scene)
        y0 = spun(model, omega, velocity)
        recorded, err = record(model, model.state_from(y0, t_end=scene.duration), times)
        assert err is None, (method, err)
        np.testing.assert_allclose(recorded["nodes"], reference, atol=tol, rtol=0, err_msg=method)
        state = model.state_from(y0, t_end=scene.duration)
        split = int(cut * (len(times) - 1))
        observed = []
        for t in times[:split + 1]:
            model.advance(state, t)
            observed.append(model.observe_now(state)["nodes"])
        np.testing.assert_allclose(observed, recorded["nodes"][:split + 1], atol=1e-12, rtol=0, err_msg=method)
        copied = state.copy()
        rest, _ = record(model, copied, times[split:])
        np.testing.assert_allclose(rest["nodes"], reference[split:], atol=tol, rtol=0, err_msg=method)
        assert_events_consistent(copied.events)
