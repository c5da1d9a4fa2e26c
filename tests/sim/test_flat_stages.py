"""The numpy kernels' flat RK4 stages (tensegrity_core.sim.general.kernels.flat_stages).

Oracles: the compiled RK4 stages (the explicit loops of ``loops.py``, another program for the
same formulas) or, without numba, the numpy kernels' general stages (``array_stages.py``),
on random structures of free and fixed coordinates (no member, shared nodes, nodes without
members, slack members of no stiffness, dampers), both linear maps (dense and gathers); and
whole runs with strings going slack and taut, whose events, steps and states must be the
compiled run's.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.sim.general.kernels import flat_stages
from tensegrity_core.sim.general.kernels.array_stages import ArrayStages
from tensegrity_core.sim.general.kernels.arrays import plan_sums
from tensegrity_core.sim.general.kernels.flat_layout import whole_nodes
from tensegrity_core.sim.general.kernels.flat_stages import FlatStages, flat_ready
from tensegrity_core.sim.general.kernels.jit import KERNELS_VARIABLE, have_numba
from tensegrity_core.sim.general.kernels.plan import Plan
from tensegrity_core.sim.general.kernels.stages import CompiledStages
from tensegrity_core.sim.general.model import RECHART_ANGLE


def _plan(n, pairs, kinds, EA, damping, rng, whole=False) -> tuple[Plan, np.ndarray]:
    """A plan of ``n`` nodes (coordinate kinds ``free``/``fixed``; ``whole``: a node's three
    coordinates of the kind of its first, one mass per node), members ``pairs`` with
    stiffness ``EA`` [N] and dampers [N s/m], random geometry, masses and loads; and rest
    lengths [m] of 0.6-1.4 of the drawn lengths."""
    if whole:
        kinds = [kinds[3 * (j // 3)] for j in range(3 * n)]
    free = np.array([(k, c) for k in range(n) for c in range(3) if kinds[3 * k + c] == "free"],
                    dtype=np.int64).reshape(-1, 2)
    inverse_mass = 1.0 / rng.uniform(0.1, 2.0, len(free))
    if whole:
        inverse_mass = np.repeat(inverse_mass[::3], 3)
    base = rng.normal(size=(n, 3))
    a = np.array([p[0] for p in pairs], dtype=np.int64)
    b = np.array([p[1] for p in pairs], dtype=np.int64)
    m = len(pairs)
    plan = Plan(base=base, free_node=free[:, 0].copy(), free_axis=free[:, 1].copy(),
                free_inv_mass=inverse_mass, on_node=np.zeros(0, dtype=np.int64),
                on_body=np.zeros(0, dtype=np.int64), on_offset=np.zeros((0, 3)), body_dof=np.zeros(0, dtype=np.int64),
                body_mass=np.zeros(0), body_first_moment=np.zeros((0, 3)), body_inertia=np.zeros((0, 3, 3)),
                body_inv_inertia_cm=np.zeros((0, 3, 3)), member_a=a, member_b=b,
                EA=np.array(EA[:m], dtype=float), damping=np.array(damping[:m], dtype=float),
                is_string=np.zeros(m, dtype=bool), external=rng.normal(size=(n, 3)))
    lengths = np.linalg.norm(base[b] - base[a], axis=1) if m else np.zeros(0)
    return plan, lengths * rng.uniform(0.6, 1.4, m)


def _oracle(plan: Plan, l0: np.ndarray):
    screen = dict(strings=np.zeros(0, dtype=np.int64), moving=np.zeros(0, dtype=bool), rechart_angle=RECHART_ANGLE)
    if have_numba():
        return CompiledStages(plan, np.zeros((0, 3, 3)), lambda t: l0, True, **screen)
    return ArrayStages(plan, plan_sums(plan), np.zeros((0, 3, 3)), lambda t: l0, True, **screen)


@settings(max_examples=60)
@given(n=st.integers(2, 6), ends=st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5)), max_size=12),
       kinds=st.lists(st.sampled_from(["free", "free", "fixed"]), min_size=18, max_size=18),
       EA=st.lists(st.sampled_from([0.0, 10.0, 300.0, 2e4]), min_size=12, max_size=12),
       damping=st.lists(st.sampled_from([0.0, 0.0, 0.5, 20.0]), min_size=12, max_size=12),
       whole=st.booleans(), dense=st.booleans(), identity=st.booleans(), h=st.sampled_from([1e-5, 1e-3]),
       seed=st.integers(0, 2**31))
def test_a_flat_step_is_the_compiled_step_to_rounding(n, ends, kinds, EA, damping, whole, dense, identity, h, seed):
    """One RK4 step and the rate at its end, node-major dense (states of whole nodes; the
    velocities carried by the rate product or copied) or gathered (any state), against the
    oracle's. The flat stages write a member's force ``k h - EA u``: two terms of the size
    of ``EA`` where the loops add one of the size of ``t``, so the rates agree to a few ``eps`` of the
    largest force per mass, ``sum (EA + EA l / l0 + c |dv|) / m`` over a coordinate's
    members, and the step to ``h`` times that."""
    pairs = [(a % n, b % n) for a, b in ends if a % n != b % n]
    rng = np.random.default_rng(seed)
    plan, l0 = _plan(n, pairs, kinds, EA, damping, rng, whole)
    assert flat_ready(plan)
    assert (whole_nodes(plan) is not None) == (whole or not len(plan.free_node))
    N = 2 * len(plan.free_node)
    y = rng.normal(size=N)
    f = rng.normal(size=N)
    flat = FlatStages(plan, lambda t: l0, True, strings=np.zeros(0, dtype=np.int64), moving=np.zeros(0, dtype=bool),
                      dense=dense and whole, identity=identity)
    y_flat, f_flat = flat.rk4(0.0, y, f, h)
    y_ref, f_ref = _oracle(plan, l0).rk4(0.0, y, f, h)
    # the largest force per mass any evaluation of the step can see (positions within |y| + 2h|f| of y)
    reach = np.abs(y).max(initial=0.0) + 1.0 + 10.0 * h * (np.abs(f).max(initial=0.0) + 1.0)
    span = np.linalg.norm(plan.base, axis=1).max() + reach
    scale = np.abs(plan.external).max() + sum(EA[i] * (2.0 + 2.0 * span / l0[i]) + damping[i] * 4.0 * reach
                                               for i in range(len(pairs)))
    scale *= plan.free_inv_mass.max(initial=0.0)
    tol = 64 * np.finfo(float).eps * scale * (1.0 + scale * h * h)
    np.testing.assert_allclose(f_flat, f_ref, rtol=1e-12, atol=tol)
    np.testing.assert_allclose(y_flat, y_ref, rtol=1e-12, atol=h * tol + 4 * np.finfo(float).eps * reach)


def _with_kernels(monkeypatch, kernels: str, dense_limit: int | None = None) -> None:
    monkeypatch.setenv(KERNELS_VARIABLE, kernels)
    if dense_limit is not None:
        monkeypatch.setattr(flat_stages, "DENSE_LIMIT", dense_limit)


def _tower_run(monkeypatch, kernels: str, dense_limit: int | None = None):
    """A damped 3-prism tower of two stages shaken hard (random node velocities, fixed seed):
    its strings go slack and taut. RK4 at 0.5 ms over 0.3 s; the model, the recorded samples
    (y per 5 ms) and the final state."""
    from tensegrity_core.general import prism_tower
    from tensegrity_core.general.writing import structure_to_dict
    from tensegrity_core.sim import compile_scene, load_scene

    _with_kernels(monkeypatch, kernels, dense_limit)
    s = prism_tower(2, sides=3, EA=2e3)
    s = s.replace(node_masses=np.full(s.n_nodes, 0.1))
    scene = load_scene({"model": {"kind": "general", "structure": structure_to_dict(s)}, "initial": {"drawn": True},
                        "effects": ["inertia", "springs", {"damping": {"c": 0.2}}], "duration": 0.3,
                        "output": {"rate": 200}, "integrator": {"method": "RK4", "max_step": 5e-4}})
    model = compile_scene(scene)
    y0 = model.initial_state().y.copy()
    half = len(y0) // 2
    y0[half:] = np.random.default_rng(5).normal(0.0, 3.0, half)
    state = model.state_from(y0, t_end=scene.duration)
    samples: list = []
    model.record(state, np.arange(61) * 5e-3, samples)
    return model, state, np.array([s[1] for s in samples])


@pytest.mark.skipif(not have_numba(), reason="the oracle is the compiled run (numba, the 'fast' extra)")
@pytest.mark.parametrize("dense_limit", [None, 0], ids=["dense", "gathers"])
def test_a_flat_run_takes_the_compiled_runs_steps_and_events(monkeypatch, dense_limit):
    """A whole run through the flat stages (the numpy kernels' choice for a model without
    bodies) against the compiled run: the same slack/taut events at the same times, the
    same number of steps, the same states to rounding."""
    compiled, fast, fast_y = _tower_run(monkeypatch, "numba")
    model, plain, plain_y = _tower_run(monkeypatch, "numpy", dense_limit)
    system = model.equations(plain).resume(plain.t, plain.y).system
    stages = system.stages
    assert isinstance(stages, FlatStages) and stages.dense == (dense_limit is None)
    assert [e[1:] for e in plain.events] == [e[1:] for e in fast.events] and len(fast.events) >= 4
    np.testing.assert_allclose([e[0] for e in plain.events], [e[0] for e in fast.events], rtol=0, atol=1e-11)
    assert plain.work.n_steps == fast.work.n_steps
    np.testing.assert_allclose(plain_y, fast_y, rtol=0, atol=1e-9)


def test_a_flat_stretch_takes_the_steps_of_one_step_per_call_and_stops_at_every_crossing(monkeypatch):
    """The stretch (steps until a string's gap may change sign) gives, bit for bit, the
    states of one RK4 step per call from the same start, and stops at every step after which
    a string's gap has changed sign."""
    model, state, _ = _tower_run(monkeypatch, "numpy")
    system = model.equations(state).resume(state.t, state.y).system
    stages = system.stages
    assert isinstance(stages, FlatStages)
    # the plans of other slack sets share the layout (index arrays and dense maps built once)
    assert system.with_slack(np.ones(len(system.strings), dtype=bool)).stages.layout is stages.layout
    l0 = system.rest_lengths(0.0)
    y0 = state.y.copy()
    y0[len(y0) // 2:] = np.random.default_rng(9).normal(0.0, 3.0, len(y0) // 2)
    t, y, f = 0.0, y0, system.fun(0.0, y0)
    one = {}
    while t < 0.2:                                  # the stretch's grid: fixed steps, the last one to 0.2 s
        h = 0.2 - t if 0.2 - t < 5e-4 * (1.0 + 1e-9) else 5e-4
        y, f = stages.rk4(t, y, f, h)
        t = 0.2 if h == 0.2 - t else t + h
        one[t] = (y, f)
    stops, t, y, f = [], 0.0, y0, system.fun(0.0, y0)
    while t < 0.2:
        run = stages.rk4_run(t, y, f, 5e-4, 0.2, 0.2, np.zeros(0), 0)
        t, y, f = run.t_end, run.y_end, run.f_end
        stops.append(t)
        assert np.array_equal(y, one[t][0]) and np.array_equal(f, one[t][1])
    assert len(stops) < 400
    strings = system.strings
    crossings = 0
    previous = np.sign(system.string_gaps(0.0, y0)[0])
    for t_k in sorted(one):
        sign = np.sign(system.string_gaps(t_k, one[t_k][0])[0])
        if np.any(sign != previous):
            crossings += 1
            assert t_k in stops, f"a gap changed sign in the step to t = {t_k} s, inside a stretch"
        previous = sign
    assert crossings > 0 and len(strings) and np.all(l0[strings] > 0)


@settings(max_examples=80)
@given(gaps=st.lists(st.tuples(st.sampled_from([0.0, 1e-9, -1e-9, 1e-4, -1e-4, 0.3, np.inf]),
                                st.sampled_from([0.0, 1e-9, -1e-9, 1e-4, -1e-4, 0.3, np.inf]),
                                st.sampled_from([0.0, 1.0, -1.0, 1e3]), st.sampled_from([0.0, 1.0, -1e3])),
                      max_size=6),
       h=st.sampled_from([1e-6, 2e-4, 1e-2]))
def test_the_flat_screen_decides_as_the_loops_do(gaps, h):
    """The flat stretch's screen (the gaps signed by their signs at the stretch's start, at
    once from the least of them and the largest rates, else member by member) decides as the
    compiled one on every kind of end: a gap at zero, crossing zero, on one side but within
    reach of its rates, far away; members that are not screened strings (gap +inf) never stop
    a step."""
    from tensegrity_core.sim.general.kernels import loops
    from tensegrity_core.sim.general.kernels.flat_stages import quiet_ends

    g0, g1, r0, r1 = (np.array([g[k] for g in gaps], dtype=float) for k in range(4))
    screened = np.isfinite(g0) & np.isfinite(g1)
    g0[~screened] = g1[~screened] = np.inf
    sign = np.sign(g0)                              # the step is a stretch's first
    E0, E1 = np.stack([sign * g0, r0, -r0]), np.stack([sign * g1, r1, -r1])
    ends = [(float(E[0].min(initial=np.inf)), float(np.abs(E[1]).max(initial=0.0))) for E in (E0, E1)]
    expected = loops.quiet_step(g0[screened], r0[screened], g1[screened], r1[screened],
                                np.zeros(int(screened.sum()), dtype=bool), h)
    assert quiet_ends(E0, E1, *ends[0], *ends[1], h) == expected


@pytest.mark.skipif(not have_numba(), reason="the oracle is the compiled run (numba, the 'fast' extra)")
def test_flat_steps_under_a_moving_rest_length_are_the_compiled_ones(monkeypatch):
    """A cable of the tower reeled in by a ramp law: the flat stages take one step per call
    with the rest lengths of each stage's time; the run equals the compiled one to rounding."""
    from tensegrity_core.general import prism_tower
    from tensegrity_core.general.writing import structure_to_dict
    from tensegrity_core.sim import compile_scene, load_scene, simulate

    s = prism_tower(1, sides=3, EA=2e3)
    s = s.replace(node_masses=np.full(s.n_nodes, 0.1))
    structure = structure_to_dict(s)
    cable = next(m for m in structure["members"] if m.get("type", "string") == "string")
    cable.update(type="actuator", name="act")
    l0 = cable.get("rest_length")
    assert l0 is not None
    scene = load_scene({"model": {"kind": "general", "structure": structure}, "initial": {"drawn": True},
                        "effects": ["inertia", "springs", {"damping": {"c": 0.2}}], "duration": 0.2,
                        "inputs": {"act": {"law": "ramp", "from": l0, "to": 0.8 * l0, "t1": 0.2}},
                        "output": {"rate": 200}, "integrator": {"method": "RK4", "max_step": 5e-4}})
    runs = {}
    for kernels in ("numba", "numpy"):
        monkeypatch.setenv(KERNELS_VARIABLE, kernels)
        runs[kernels] = simulate(scene)
    model = compile_scene(scene)
    state = model.initial_state()
    assert isinstance(model.equations(state).resume(state.t, state.y).system.stages, FlatStages)
    fast, plain = runs["numba"], runs["numpy"]
    assert fast.stats["steps"] == plain.stats["steps"]
    assert [e[1:] for e in plain.events] == [e[1:] for e in fast.events]
    np.testing.assert_allclose([e[0] for e in plain.events], [e[0] for e in fast.events], rtol=0, atol=1e-11)
    assert np.abs(fast.nodes[-1] - fast.nodes[0]).max() > 1e-3             # the ramp moves the tower
    np.testing.assert_allclose(plain.nodes, fast.nodes, rtol=0, atol=1e-11)
