"""Robot dynamics (back end ``robot/dynamic``): the compiled kernels and their numpy twin give
the same numbers; Newton-Euler balances written out here (momentum rates equal the external
forces and moments: gravity, floor); the cables are tension-only; energy never rises with the
motors held; a copied state continues the same run; the drop scenes land and rest on the
floor less than 1 mm deep.

States are drawn by hypothesis (the suite's ``ci`` profile is derandomised) around the
shipped robots' drawings: moved and turned rods, velocities, slack and taut cables, caps
in the floor with friction offsets, sticking and slipping.
"""

from __future__ import annotations

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.general.kernels import body_arrays
from tensegrity_core.sim.general.kernels.jit import have_numba
from tensegrity_core.sim.general.robot.loops import NO_ANCHOR, SLIPPING, STICKING
from tensegrity_core.sim.general.robot.system import RobotSystem

ALL = ["inertia", "cables", "motors", "gravity", "contact", "friction", "sensors"]


def robot_scene(robot: str, effects=ALL, **extra):
    return load_scene({"name": f"{robot}_test", "model": {"kind": "robot", "robot": robot},
                       "initial": {"drawn": True, "lift": extra.pop("lift", 0.0)}, "effects": effects,
                       "duration": extra.pop("duration", 1.0), **extra})


_MODELS: dict[str, object] = {}


def _model(robot: str):
    if robot not in _MODELS:
        effects = ALL if robot != "spine" else ["inertia", "cables", "motors", "gravity", "sensors"]   # no floor
        _MODELS[robot] = compile_scene(robot_scene(robot, effects))
    return _MODELS[robot]


def random_state(model, seed: int, spread: float = 0.01):
    """A state near the drawing (sunk 5 mm so some caps touch): positions moved by ``spread``
    [m], rates of order 1 (m/s, rad/s), rotation charts turned up to ~0.5 rad, motors within
    10 % of their drawn rest lengths, every cap anchored (sticking or slipping) with an offset
    of a few mm."""
    rng = np.random.default_rng(seed)
    p = model.plan
    y = model.y0.copy()
    n = p.n_dof
    y[:n] += rng.normal(0.0, spread, n)
    for d in p.body_dof:
        y[d + 2] -= 0.005
    y[n:2 * n] = rng.normal(0.0, 1.0, n)
    na, ncap = len(p.motor_cable), len(p.cap_node)
    y[2 * n:2 * n + na] *= rng.uniform(0.9, 1.1, na)
    a0 = 2 * n + na
    y[a0:a0 + 3 * ncap] = rng.normal(0.0, 0.003, 3 * ncap)
    y[a0 + 3 * ncap:] = rng.choice([NO_ANCHOR, STICKING, SLIPPING], ncap)
    nb = len(p.body_dof)
    R_ref = np.array([exp_so3(rng.normal(0.0, 0.3, 3)) for _ in range(nb)]).reshape(nb, 3, 3)
    return y, R_ref


ROBOTS = ["three_bar", "six_bar", "spine"]
#: Steps of 1 ms each twin runs from a drawn state: the spine crosses ~8 guards a step from
#: these states (~40 in 5 steps, measured over seeds), the bar robots 0-8 in 20 steps, so
#: 5 spine steps cross more guards than 20 bar-robot steps (and cost what 20 of theirs do).
RUN_STEPS = {"three_bar": 20, "six_bar": 20, "spine": 5}


@pytest.mark.skipif(not have_numba(), reason="the compiled kernels need numba (the 'fast' extra)")
@pytest.mark.parametrize("component_major_bodies", [10**9, 0], ids=["stacked", "component-major"])
@settings(max_examples=30)
@given(robot=st.sampled_from(ROBOTS), seed=st.integers(0, 2**32 - 1))
def test_compiled_kernels_and_numpy_twin_agree(component_major_bodies, robot, seed):
    """The numpy twin with the bodies' Newton-Euler in either layout
    (:data:`.body_arrays.COMPONENT_MAJOR_BODIES`: the robots have too few bodies for the
    component-major one by themselves), at a state and through a run of fixed steps with the
    motors moving (:data:`RUN_STEPS`: each run crosses guards, caps touching or leaving the
    floor and cables going slack or taut, on the way)."""
    model = _model(robot)
    y, R_ref = random_state(model, seed)
    fast = RobotSystem(model.plan, laws=model.system.laws, R_ref=R_ref, kernels="numba")
    slow = RobotSystem(model.plan, laws=model.system.laws, R_ref=R_ref, kernels="numpy")
    with mock.patch.object(body_arrays, "COMPONENT_MAJOR_BODIES", component_major_bodies):
        a, b = fast.evaluate(y[None]), slow.evaluate(y[None])
        for field in ("derivative", "positions", "forces", "tensions", "depth", "normal", "friction", "couple"):
            x, z = getattr(a, field), getattr(b, field)
            assert np.allclose(x, z, rtol=1e-11, atol=1e-9 * max(1.0, np.abs(z).max(initial=0.0))), field
        aims = np.tile(model.plan.cable_l0[model.plan.motor_cable] * 0.97, (RUN_STEPS[robot], 1))   # the motors move
        for x, z in zip(fast.run(y, R_ref, 1e-3, aims), slow.run(y, R_ref, 1e-3, aims)):
            assert np.allclose(x, z, rtol=1e-10, atol=1e-10 * max(1.0, np.abs(z).max(initial=0.0)))


def _momentum_rates(model, y, R_ref):
    """``(dP/dt - M g - floor forces, dL/dt - moments of gravity and floor)`` about the origin,
    from the bodies' accelerations (Newton-Euler written out: rods' centres are their centres of
    mass; ``dL/dt = sum c x m a + I w' + w x I w``, ``I = R I_body R^T``)."""
    p = model.plan
    ev = RobotSystem(p, laws=model.system.laws, R_ref=R_ref, kernels="numpy").evaluate(y[None])
    n = p.n_dof
    dP, dL = np.zeros(3), np.zeros(3)
    F_ext, M_ext = np.zeros(3), np.zeros(3)
    for b, d in enumerate(p.body_dof):
        c, v, w = y[d:d + 3], y[n + d:n + d + 3], y[n + d + 3:n + d + 6]
        a, wdot = ev.derivative[0, n + d:n + d + 3], ev.derivative[0, n + d + 3:n + d + 6]
        assert np.allclose(p.body_first_moment[b], 0.0)
        R = ev.rotations[0, b]
        I_w = R @ p.body_inertia[b] @ R.T
        dP += p.body_mass[b] * a
        dL += np.cross(c, p.body_mass[b] * a) + I_w @ wdot + np.cross(w, I_w @ w)
        del v
    X = ev.positions[0]
    F_ext += p.external.sum(axis=0)
    M_ext += np.cross(X, p.external).sum(axis=0)
    nvec = p.floor_normal
    for k, node in enumerate(p.cap_node):
        fn, ff = ev.normal[0, k] * nvec, ev.friction[0, k]
        F_ext += fn + ff
        M_ext += np.cross(X[node], fn) + np.cross(X[node] - p.cap_radius[k] * nvec, ff) + ev.couple[0, k]
    scale = np.abs(p.external).sum() + ev.normal.sum() + np.abs(ev.friction).sum() + ev.tensions.sum()
    return dP - F_ext, dL - M_ext, scale


@settings(max_examples=25)
@given(robot=st.sampled_from(["three_bar", "six_bar"]), seed=st.integers(0, 2**32 - 1))
def test_cables_are_internal_and_the_floor_is_the_only_external_force(robot, seed):
    """Every cable pulls both ends equally along the line between them, so the momenta change
    only by gravity and the floor's normal and friction forces (and their moments) and its
    rolling and spin resistance couples."""
    model = _model(robot)
    y, R_ref = random_state(model, seed)
    if robot == "six_bar":
        assert np.all(model.plan.floor_params[6:] > 0.0)           # its caps resist rolling and spinning
    force, moment, scale = _momentum_rates(model, y, R_ref)
    assert np.abs(force).max() <= 1e-9 * scale
    assert np.abs(moment).max() <= 1e-9 * scale * 3.0


@settings(max_examples=40)
@given(robot=st.sampled_from(ROBOTS), seed=st.integers(0, 2**32 - 1), spread=st.floats(0.0, 0.05))
def test_cables_are_tension_only_and_carry_nothing_while_slack(robot, seed, spread):
    model = _model(robot)
    y, R_ref = random_state(model, seed, spread)
    ev = model.equations(model.initial_state()).with_chart(R_ref).evaluate(y[None])
    assert np.all(ev.tensions >= 0.0)
    slack = ev.lengths <= ev.rest_lengths
    assert np.all(ev.tensions[slack] == 0.0)
    assert np.all(ev.tensions <= model.plan.cable_t_max)
    assert np.all(ev.normal >= 0.0)


def _energy(model, samples):
    o = model.observe(samples)
    return o["kinetic_energy"] + o["potential_energy"], o


@settings(max_examples=12)
@given(robot=st.sampled_from(["three_bar", "six_bar"]), seed=st.integers(0, 2**32 - 1),
       lift=st.floats(0.0, 0.05), mu=st.one_of(st.just(0.0), st.floats(1e-15, 1.5)), speed=st.floats(0.0, 1.0),
       rolling=st.one_of(st.just(0.0), st.floats(1e-15, 1e-3)), torsional=st.one_of(st.just(0.0), st.floats(1e-15, 0.01)))
def test_energy_never_rises_with_the_motors_held(robot, seed, lift, mu, speed, rolling, torsional):
    """Kinetic + gravity + cable strain + floor contact + friction offsets never rise over a
    step with no input (motors holding their rest lengths: no ``motors`` effect), from a
    drop or a throw (velocities up to ``speed``), for any friction coefficient and rolling
    and torsional friction up to 1 mm and 10 mm (MuJoCo's defaults: 0.1 mm, 5 mm)."""
    scene = robot_scene(robot, ["inertia", "cables", "gravity", "contact",
                                {"friction": {"mu_static": mu, "mu_kinetic": mu, "rolling_friction": rolling,
                                              "torsional_friction": torsional}}], lift=lift, duration=0.3)
    model = compile_scene(scene)
    y = model.y0.copy()
    n = model.plan.n_dof
    y[n:2 * n] = np.random.default_rng(seed).uniform(-speed, speed, n)
    state = model.state_from(y, t_end=0.3)
    samples: list = []
    model.record(state, np.arange(301) * 1e-3, samples)
    E, _ = _energy(model, samples)
    assert np.all(np.diff(E) <= 1e-9 * E.max() + 1e-9), np.diff(E).max()


def test_a_copied_state_continues_the_same_run():
    model = _model("six_bar")
    state = model.initial_state()
    model.advance(state, 0.2505)                   # between grid points: the step ahead is kept
    twin = state.copy()
    a, b = [], []
    model.record(state, [0.3, 0.4], a)
    model.record(twin, [0.3, 0.4], b)
    for (ta, ya, _), (tb, yb, _) in zip(a, b):
        assert ta == tb and np.array_equal(ya, yb)


@pytest.fixture(scope="module")
def drops():
    """The shipped drop scenes run for 3 s, observed at 100 Hz."""
    from tensegrity_core.sim import simulate
    return {name: simulate(name) for name in ("three_bar_drop", "six_bar_drop")}


@pytest.mark.parametrize("name", ["three_bar_drop", "six_bar_drop"])
def test_a_dropped_robot_lands_on_three_caps_less_than_1_mm_deep(drops, name):
    tr = drops[name]
    model = compile_scene(load_scene(name))
    p = model.plan
    heights = (tr.nodes[:, p.cap_node] - p.floor_point) @ p.floor_normal
    depth = p.cap_radius - heights
    assert tr.success
    assert depth[0].max() < 0.0                              # starts in the air (lift 5 cm)
    assert np.all(depth[-50:].max(axis=1) < 1e-3)            # the last 0.5 s: less than 1 mm deep
    assert np.all((depth[-50:] > 0).sum(axis=1) >= 3)        # on a face (at least three caps)
    E = tr.kinetic_energy + tr.potential_energy
    assert tr.kinetic_energy[-1] < 0.02 * (E[0] - E[-1])     # the fall's energy is spent


def test_the_spine_let_go_sags_and_settles():
    """Drawn at its weightless rest shape, the spine sags under gravity into its equilibrium:
    less than 1 mJ of motion is left after 3 s."""
    from tensegrity_core.sim import simulate
    tr = simulate("spine_settle")
    E = tr.kinetic_energy + tr.potential_energy
    assert tr.success and E[-1] < E[0]
    assert tr.kinetic_energy[-50:].max() < 1e-3


def test_rod_forces_are_tension_positive_and_match_the_statics_at_rest():
    """Free of gravity and floor, the drawn 6-bar is its form-found rest shape: every rod in
    441.2 N of compression (-441.2 N), every cable at 180.1 N (docs/robots.md, the statics)."""
    model = compile_scene(robot_scene("six_bar", ["inertia", "cables"]))
    obs = model.observe_now(model.initial_state())
    forces = obs["member_forces"]
    assert np.allclose(forces[:6], -441.2, rtol=1e-3) and np.allclose(forces[6:], 180.1, rtol=1e-3)
    assert np.abs(obs["state"][model.plan.n_dof:2 * model.plan.n_dof]).max() == 0.0
