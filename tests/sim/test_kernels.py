"""The general model's kernels: compiled loops and numpy arrays agree to rounding, and both
agree with Newton-Euler written out independently here (a 6 x 6 solve per body from its
point masses, forces summed member by member).

States are drawn by hypothesis (the suite's ``ci`` profile is derandomised) around the
initial states of shipped and generated structures: free nodes, partly pinned nodes, rigid
bodies with unequal point masses (their centre of mass off the centroid), slack strings,
dampers, loads and gravity.
"""

from __future__ import annotations

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.general import prism_tower
from tensegrity_core.general.rotation import exp_so3
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.general.kernels import body_arrays
from tensegrity_core.sim.general.kernels.evaluator import Evaluator
from tensegrity_core.sim.general.kernels.jit import have_numba

from .test_general import BODIES, general_scene

pytestmark = pytest.mark.skipif(not have_numba(), reason="the compiled kernels need numba (the 'fast' extra)")


def _tower():
    s = prism_tower(2, sides=3)
    nodes = {name: xyz.tolist() for name, xyz in zip(s.node_names, s.nodes)}
    members = [{"nodes": [s.node_names[a], s.node_names[b]], "type": "bar" if k == "bar" else "string",
                "EA": float(ea), "rest_length": float(l0)}
               for (a, b), k, ea, l0 in zip(s.members, s.member_kinds, s.EA, s.rest_lengths)]
    pinned = {s.node_names[i]: "xyz" for i in range(3)}
    pinned[s.node_names[3]] = "z"                                     # a partly pinned node
    return {"name": "tower", "nodes": nodes, "members": members, "pinned": pinned,
            "masses": {name: 0.2 + 0.01 * i for i, name in enumerate(s.node_names)}}


def _scenes():
    damped = ["inertia", "springs", {"damping": {"c": 0.4}}, {"gravity": {"vector": [0.0, 0.0, -9.81]}},
              {"loads": {"n": [1.0, -2.0, 0.5]}}]
    return {"table_gravity": load_scene("table_gravity"), "spine_release": load_scene("spine_release"),
            "bodies": general_scene(BODIES, damped),
            "tower": general_scene(_tower(), ["inertia", "springs", {"damping": {"c": 0.1}}])}


SCENES = _scenes()
_MODELS: dict[str, tuple] = {}


def _model(name):
    if name not in _MODELS:
        model = compile_scene(SCENES[name])
        state = model.initial_state()
        # the system before any state fixed its strings' slack set: slack where l < l0, as
        # the independent derivative decides
        _MODELS[name] = (model.plant, state.y.copy())
    return _MODELS[name]


def _state(name, seed, spread):
    """A state near the scene's initial one: positions moved by ``spread`` of the size (some
    strings go slack), velocities of order 1, rotation vectors up to ~1 rad."""
    eq, y0 = _model(name)
    rng = np.random.default_rng(seed)
    y = y0.copy()
    n = eq.n
    size = float(np.ptp(eq.structure.nodes, axis=0).max())
    y[:n] += rng.normal(0.0, spread * size, n)
    y[n:] = rng.normal(0.0, 1.0, n)
    R_ref = np.array([exp_so3(rng.normal(0.0, 0.5, 3)) for _ in range(eq.nb)]).reshape(-1, 3, 3)
    l0 = eq.structure.rest_lengths * rng.uniform(0.9, 1.1, eq.structure.n_members)
    return eq, y, R_ref, l0


def _independent_derivative(eq, y, R_ref, l0):
    """dy/dt from the point masses: nodes placed with exp_so3, member forces one by one, each
    body's Newton-Euler about its centre as a 6 x 6 solve."""
    s = eq.structure
    lay = s.layout
    masses = eq.masses
    n = eq.n
    x, v = y[:n], y[n:]
    X = s.nodes.copy()
    V = np.zeros_like(X)
    free = np.argwhere(lay.free_index >= 0)
    for node, axis in free:
        X[node, axis] = x[lay.free_index[node, axis]]
        V[node, axis] = v[lay.free_index[node, axis]]
    R = np.array([exp_so3(x[d + 3:d + 6]) @ R_ref[b] for b, d in enumerate(lay.body_dof)]).reshape(-1, 3, 3)
    for b, idx in enumerate(lay.body_nodes):
        d = lay.body_dof[b]
        for k in idx:
            r = R[b] @ lay.offsets[k]
            X[k] = x[d:d + 3] + r
            V[k] = v[d:d + 3] + np.cross(v[d + 3:d + 6], r)
    F = np.zeros_like(X) if eq.external is None else eq.external.copy()
    damping = eq.plan.damping
    for i, (a, b) in enumerate(s.members):
        h = X[b] - X[a]
        length = np.linalg.norm(h)
        if s.is_string[i] and length < l0[i]:
            continue
        u = h / length
        t = s.EA[i] * (length - l0[i]) / l0[i] + damping[i] * u @ (V[b] - V[a])
        F[a] += t * u
        F[b] -= t * u
    out = np.empty_like(y)
    for node, axis in free:
        j = lay.free_index[node, axis]
        out[j] = v[j]
        out[n + j] = F[node, axis] / masses.node[node]
    for b, idx in enumerate(lay.body_nodes):
        d = lay.body_dof[b]
        w = v[d + 3:d + 6]
        M = np.zeros((6, 6))
        rhs = np.zeros(6)
        for k in idx:
            r = X[k] - x[d:d + 3]
            mk = masses.node[k]
            M[:3, :3] += mk * np.eye(3)
            M[:3, 3:] -= mk * np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
            M[3:, 3:] += mk * (r @ r * np.eye(3) - np.outer(r, r))
            rhs[:3] += F[k] - mk * np.cross(w, np.cross(w, r))
            rhs[3:] += np.cross(r, F[k]) - mk * np.cross(r, np.cross(w, np.cross(w, r)))
        M[3:, :3] = -M[:3, 3:]
        out[n + d:n + d + 6] = np.linalg.solve(M, rhs)
        theta = x[d + 3:d + 6]
        a = np.linalg.norm(theta)
        K = np.array([[0, -theta[2], theta[1]], [theta[2], 0, -theta[0]], [-theta[1], theta[0], 0]])
        coef = 1 / 12 if a < 1e-8 else 1 / a**2 - (1 + np.cos(a)) / (2 * a * np.sin(a))
        out[d:d + 3] = v[d:d + 3]
        out[d + 3:d + 6] = (np.eye(3) - 0.5 * K + coef * K @ K) @ w
    return out


#: :data:`.body_arrays.COMPONENT_MAJOR_BODIES` for either layout of the bodies' Newton-Euler
#: whatever the number of bodies: stacked 3 x 3 products, component-major
LAYOUTS = {"stacked": 10**9, "component-major": 0}


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
@settings(max_examples=12)
@given(name=st.sampled_from(sorted(SCENES)), seed=st.integers(0, 2**31), spread=st.sampled_from([0.0, 1e-3, 0.05]))
def test_loops_arrays_and_an_independent_newton_euler_agree(layout, name, seed, spread):
    eq, y, R_ref, l0 = _state(name, seed, spread)
    fast = Evaluator(eq.plan, "numba").derivative(y, R_ref, l0)
    with mock.patch.object(body_arrays, "COMPONENT_MAJOR_BODIES", LAYOUTS[layout]):
        plain = Evaluator(eq.plan, "numpy").derivative(y, R_ref, l0)
    scale = np.abs(fast).max()
    np.testing.assert_allclose(plain, fast, rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(_independent_derivative(eq, y, R_ref, l0), fast, rtol=0, atol=1e-10 * scale)


@settings(max_examples=8)
@given(name=st.sampled_from(sorted(SCENES)), seed=st.integers(0, 2**31), spread=st.sampled_from([0.0, 0.05]))
def test_jacobians_agree_and_their_velocity_columns_are_exact(name, seed, spread):
    """The two kernels' Jacobians agree to rounding; ``d(dy/dt)/dv`` is exact anywhere (the
    position columns are exact at rest in equilibrium: test_general). ``dy/dt`` is at most
    quadratic in ``v`` (dampers linear, gyroscopic terms quadratic), so central differences
    in ``v`` are exact but for rounding: a large step keeps that small."""
    eq, y, R_ref, l0 = _state(name, seed, spread)
    fast = Evaluator(eq.plan, "numba")
    J = fast.jacobian(y, R_ref, l0).toarray()
    J_plain = Evaluator(eq.plan, "numpy").jacobian(y, R_ref, l0).toarray()
    np.testing.assert_allclose(J_plain, J, rtol=0, atol=1e-12 * np.abs(J).max())
    n, h = eq.n, 1e-2
    fd = np.empty((2 * n, n))
    for j in range(n):
        e = np.zeros(2 * n)
        e[n + j] = h
        fd[:, j] = (fast.derivative(y + e, R_ref, l0) - fast.derivative(y - e, R_ref, l0)) / (2 * h)
    rounding = 100 * np.finfo(float).eps * np.abs(fast.derivative(y, R_ref, l0)).max() / h
    np.testing.assert_allclose(J[:, n:], fd, rtol=0, atol=1e-9 * np.abs(fd).max() + rounding)


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_a_batch_is_its_states_one_by_one(layout):
    eq, _, R_ref, l0 = _state("bodies", 3, 0.01)
    rng = np.random.default_rng(5)
    Y = np.array([_state("bodies", k, 0.01)[1] for k in range(4)])
    charts = np.array([R_ref] * 4)
    lengths = l0 * rng.uniform(0.95, 1.05, (4, len(l0)))
    for kernels in ("numba", "numpy"):
        ev = Evaluator(eq.plan, kernels)
        with mock.patch.object(body_arrays, "COMPONENT_MAJOR_BODIES", LAYOUTS[layout]):
            batch = ev.evaluate(Y, charts, lengths).derivative
            one = np.array([ev.derivative(Y[k], charts[k], lengths[k]) for k in range(4)])
        np.testing.assert_array_equal(batch, one)


def test_the_general_and_the_robot_plans_start_with_the_same_placement():
    """The kernels that place nodes and apply Newton-Euler read the first twelve arrays of
    either plan: both must declare them as :class:`Placement` does, in its order."""
    from tensegrity_core.sim.general.kernels.plan import Placement, Plan
    from tensegrity_core.sim.general.robot.plan import RobotPlan

    n = len(Placement._fields)
    assert Plan._fields[:n] == Placement._fields == RobotPlan._fields[:n]


@settings(max_examples=40)
@given(n=st.integers(1, 6), ends=st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5)), max_size=12),
       kinds=st.lists(st.sampled_from(["free", "fixed", "body"]), min_size=18, max_size=18),
       bodies=st.lists(st.integers(0, 2), min_size=6, max_size=6), B=st.integers(1, 3), seed=st.integers(0, 2**31))
def test_the_numpy_kernels_gathers_are_the_sums_written_out(n, ends, kinds, bodies, B, seed):
    """The gathers of the numpy kernels against sums written out member by member: no
    member, members sharing nodes, nodes without members, free, fixed and body coordinates,
    bodies without nodes, batches. Node coordinates and ``h = x_b - x_a`` are exact (one
    subtraction); the nodal forces too: their table adds the external force and then the
    members in member order, as the loop below does."""
    from tensegrity_core.sim.general.kernels import arrays

    pairs = [(a % n, b % n) for a, b in ends if a % n != b % n]
    a = np.array([p[0] for p in pairs], dtype=np.int64)
    b = np.array([p[1] for p in pairs], dtype=np.int64)
    on_node = np.array([k for k in range(n) if kinds[3 * k] == "body"], dtype=np.int64)
    on_body = np.array([bodies[k] for k in on_node], dtype=np.int64)
    free = np.array([(k, c) for k in range(n) for c in range(3) if k not in on_node and kinds[3 * k + c] == "free"],
                    dtype=np.int64).reshape(-1, 2)
    free_node, free_axis = free[:, 0], free[:, 1]
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(n, 3))
    body_dof = len(free_node) + 6 * np.arange(3)
    sums = arrays.sums(base, free_node, free_axis, on_node, on_body, rng.normal(size=(len(on_node), 3)), body_dof,
                       a, b)
    n_dof = len(free_node) + 18
    y = rng.normal(size=(B, 2 * n_dof))
    on_x, on_v = rng.normal(size=(B, len(on_node), 3)), rng.normal(size=(B, len(on_node), 3))
    X, V = np.broadcast_to(base, (B, n, 3)).copy(), np.zeros((B, n, 3))
    X[:, free_node, free_axis], V[:, free_node, free_axis] = y[:, :len(free_node)], y[:, n_dof:n_dof + len(free_node)]
    X[:, on_node], V[:, on_node] = on_x, on_v
    src = arrays.sources(sums, y, np.stack([on_x, on_v], axis=1) if len(on_node) else None)
    np.testing.assert_array_equal(src.take(sums.node_position, axis=1), X)
    np.testing.assert_array_equal(src.take(sums.node_velocity, axis=1), V)
    h = src.take(sums.position_b, axis=1) - src.take(sums.position_a, axis=1)
    np.testing.assert_array_equal(h.transpose(0, 2, 1), X[:, b] - X[:, a])
    np.testing.assert_array_equal((src.take(sums.velocity_b, axis=1) - src.take(sums.velocity_a, axis=1))
                                  .transpose(0, 2, 1), V[:, b] - V[:, a])
    external, pulls = rng.normal(size=(n, 3)), rng.normal(size=(B, 3, len(pairs)))
    F = np.broadcast_to(external, (B, n, 3)).copy()
    for i in range(len(pairs)):
        F[:, a[i]] += pulls[:, :, i]
        F[:, b[i]] -= pulls[:, :, i]
    c, into = arrays.contributions(external, B, len(pairs))
    into[...] = pulls
    arrays.pull_back(c, len(pairs))
    np.testing.assert_array_equal(arrays.gather_sum(c, sums.free_table), F[:, free_node, free_axis])
    np.testing.assert_array_equal(arrays.gather_sum(c, sums.on_table), F[:, on_node])
    w = rng.normal(size=(B, len(on_node) + 1, 6))
    w[:, -1] = 0.0                                    # the zero row that pads the bodies' table
    total = np.zeros((B, 3, 6))
    for j, body in enumerate(on_body):
        total[:, body] += w[:, j]
    np.testing.assert_array_equal(arrays.gather_sum(w, sums.bodies.table), total)


@settings(max_examples=60)
@given(gaps=st.lists(st.tuples(st.sampled_from([0.0, 1e-9, -1e-9, 1e-4, -1e-4, 0.3]),
                                st.sampled_from([0.0, 1e-9, -1e-9, 1e-4, -1e-4, 0.3]),
                                st.sampled_from([0.0, 1.0, -1.0, 1e3]), st.sampled_from([0.0, 1.0, -1e3]),
                                st.booleans()), max_size=6),
       h=st.sampled_from([1e-6, 2e-4, 1e-2]))
def test_the_numpy_stretch_screens_steps_as_the_loops_do(gaps, h):
    """The numpy stretch's quiet-step screen (gap magnitudes computed once per step end)
    decides as the compiled one on every kind of end: a gap at zero, crossing zero, on one
    side but within reach of its rates, far away; strings whose rest length moves."""
    from tensegrity_core.sim.general.kernels import loops
    from tensegrity_core.sim.general.kernels.array_stages import quiet_step

    g0, g1, r0, r1, moving = (np.array([g[k] for g in gaps], dtype=bool if k == 4 else float) for k in range(5))
    fixed = ~moving if moving.any() else None
    assert quiet_step(g0, np.abs(g0), np.abs(r0), g1, np.abs(g1), np.abs(r1), fixed, h) == \
        loops.quiet_step(g0, r0, g1, r1, moving, h)


@settings(max_examples=60)
@given(angles=st.lists(st.sampled_from([0.0, 1e-5, 0.5, 1.0 - 1e-12, 1.0, 1.0 + 1e-12, 3.0]), max_size=4),
       seed=st.integers(0, 2**31))
def test_the_numpy_stretch_sees_a_chart_due_as_the_loops_do(angles, seed):
    """The numpy stretch's re-charting test (every body's rotation vector at once) decides
    as the compiled one: rotation vectors of random directions whose angles sit below, at
    and past the limit of 1 rad, and no body at all."""
    from tensegrity_core.sim.general.kernels import loops
    from tensegrity_core.sim.general.kernels.array_stages import chart_due

    rng = np.random.default_rng(seed)
    body_dof = 6 * np.arange(len(angles), dtype=np.int64) + 2          # after two free coordinates
    y = rng.normal(size=2 * (2 + 6 * len(angles)))
    for d, angle in zip(body_dof, angles):
        axis = rng.normal(size=3)
        y[d + 3:d + 6] = angle * axis / np.linalg.norm(axis)
    assert chart_due(body_dof[:, None] + 3 + np.arange(3), y, 1.0) == loops.chart_due(body_dof, y, 1.0)


@settings(max_examples=40)
@given(angles=st.lists(st.one_of(st.just(0.0), st.floats(1e-9, 1e-4), st.floats(1e-4, 3.0)), min_size=1, max_size=6),
       seed=st.integers(0, 2**31))
def test_the_numpy_rotation_coefficients_are_the_loops_on_either_side_of_the_series(angles, seed):
    """The numpy kernels' ``[-1/2, s, c, k]`` of a batch mixing angles below and above the
    series' switch (each angle its own branch) give the loops' rotation and chart-rate
    coefficient (the same formulas: ``k`` exactly; near the switch it cancels two terms of
    ~1e8, so only the same ``|theta|^2`` gives the same ``k``); at zero the exact identity
    and 1/12."""
    from tensegrity_core.sim.general.kernels import body_arrays, loops

    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(len(angles), 3))
    theta = np.array(angles)[:, None] * axes / np.linalg.norm(axes, axis=1)[:, None]
    a2 = np.array([t[0] * t[0] + t[1] * t[1] + t[2] * t[2] for t in theta])     # as the loops add it
    coef = body_arrays.coefficients(a2)
    for t, a2_t, (half, s, c, k) in zip(theta, a2, coef):
        K = np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])
        R = np.empty((3, 3))
        loops.rotate(t[0], t[1], t[2], np.eye(3), R)
        np.testing.assert_allclose(np.eye(3) + s * K + c * (K @ K), R, rtol=0, atol=4e-16)
        assert half == -0.5
        assert k == loops.chart_rate_coefficient(a2_t)
    zero = body_arrays.coefficients(np.zeros(2))
    np.testing.assert_array_equal(zero, [[-0.5, 1.0, 0.5, 1.0 / 12.0]] * 2)
