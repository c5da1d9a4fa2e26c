"""The compiled integrators (tensegrity_core.sim.integrators) on general structures.

Oracles: the closed-form oscillation of a mass between two bars (RK4's error falls 16-fold
per halved step: fourth order), scipy's DOP853 (the same method, its stages in Python) and
RK4 with its stages through the numpy kernels (the same arithmetic, not compiled).
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.sim import SceneError, simulate
from tensegrity_core.sim.general.kernels.jit import KERNELS_VARIABLE, have_numba

from .test_general import BODIES, LINE, general_scene

pytestmark = pytest.mark.skipif(not have_numba(), reason="the compiled integrators need numba (the 'fast' extra)")

X0 = 0.05
OMEGA = np.sqrt(2 * 100.0 / 1.0 / 2.0)       # two bars of EA/l0 = 100 N/m on 2 kg


def _line(method, **integrator):
    structure = dict(LINE, nodes={"a": [-1.0, 0, 0], "m": [X0, 0, 0], "b": [1.0, 0, 0]})
    return general_scene(structure, ["inertia", "springs"], duration=2.0,
                         integrator={"method": method, "rtol": 1e-10, "atol": 1e-12, **integrator})


def _with_kernels(kernels, fn):
    old = os.environ.get(KERNELS_VARIABLE)
    os.environ[KERNELS_VARIABLE] = kernels
    try:
        return fn()
    finally:
        if old is None:
            os.environ.pop(KERNELS_VARIABLE)
        else:
            os.environ[KERNELS_VARIABLE] = old


def test_rk4_is_fourth_order_against_the_closed_form():
    errors = []
    for step in (0.02, 0.01, 0.005):
        traj = simulate(_line("RK4", max_step=step))
        assert traj.stats["steps"] == round(2.0 / step)
        errors.append(np.abs(traj.nodes[:, 1, 0] - X0 * np.cos(OMEGA * traj.times)).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 13) & (ratios < 19)), (errors, ratios)      # 2^4 = 16


def test_rk4_compiled_and_through_the_numpy_kernels_agree_to_rounding():
    scene = general_scene(BODIES, ["inertia", "springs", {"damping": {"c": 0.3}}], duration=0.3,
                          integrator={"method": "RK4", "max_step": 1e-3})
    fast = simulate(scene)
    plain = _with_kernels("numpy", lambda: simulate(scene))
    # steps of 1 ms, a string's slack/taut event cutting one of them in two (the grid restarts
    # there, its last step shortened to land on the end)
    assert [e[1:] for e in fast.events] == [e[1:] for e in plain.events]
    np.testing.assert_allclose([e[0] for e in fast.events], [e[0] for e in plain.events], rtol=0, atol=1e-12)
    assert fast.stats["steps"] == plain.stats["steps"]
    assert 300 <= fast.stats["steps"] <= 300 + len(fast.events)
    np.testing.assert_allclose(plain.nodes, fast.nodes, rtol=0, atol=1e-12)


def test_compiled_dop853_agrees_with_scipys():
    """The same tableau and step control: the two runs agree to their tolerance (their step
    sizes part at rounding level, so not bit for bit)."""
    traj = simulate(_line("DOP853"))
    scipy_run = _with_kernels("numpy", lambda: simulate(_line("DOP853")))
    np.testing.assert_allclose(traj.nodes, scipy_run.nodes, rtol=0, atol=1e-10)
    np.testing.assert_allclose(traj.nodes[:, 1, 0], X0 * np.cos(OMEGA * traj.times), atol=1e-9)
    assert abs(traj.stats["steps"] - scipy_run.stats["steps"]) <= 2


def test_rk4_without_a_step_says_so():
    with pytest.raises(SceneError, match="RK4 takes fixed steps of max_step"):
        _line("RK4")


def _solver_runs(method, scene, y0, stretch, kernels="numba"):
    """Integrate the system of ``scene`` from ``y0`` with the bare solver (no events handled):
    ``stretch`` -- whole stretches per call, else one step per call through the one-step
    stages (the controller in Python); the ``(t, y, steps so far)`` after every call."""
    from tensegrity_core.sim import compile_scene, integrators
    from tensegrity_core.sim.general.kernels.array_stages import ArrayStages
    from tensegrity_core.sim.general.kernels.stages import CompiledStages
    from tensegrity_core.sim.general.model import RECHART_ANGLE

    model = _with_kernels(kernels, lambda: compile_scene(scene))
    system = model.equations(model.state_from(y0))
    assert system.evaluator.kernels == kernels
    screen = dict(strings=system.strings, moving=np.zeros(len(system.strings), dtype=bool),
                  rechart_angle=RECHART_ANGLE)
    if stretch:
        stages = system.stages
    elif kernels == "numba":
        stages = CompiledStages(system.plan, system.R_ref, system.rest_lengths, False, **screen)
    else:
        stages = ArrayStages(system.plan, system.evaluator.sums, system.R_ref, system.rest_lengths, False, **screen)
    cls = {"RK4": integrators.RK4, "DOP853": integrators.DOP853}[method]
    solver = cls(system.fun, 0.0, y0, scene.duration, stages=stages, rtol=1e-9, atol=1e-11, max_step=2e-3)
    solver.horizon = scene.duration if stretch else -np.inf
    out, steps = [], 0
    while solver.status == "running":
        solver.step()
        steps += solver.steps_taken
        out.append((solver.t, solver.y.copy(), steps))
    return out


@pytest.mark.parametrize(("method", "kernels"), [("RK4", "numba"), ("DOP853", "numba"), ("RK4", "numpy")])
def test_a_stretch_of_compiled_steps_takes_the_steps_of_one_step_per_call(method, kernels):
    """The stretch (compiled, or the numpy kernels' loop) chooses, attempts and accepts every
    step exactly as the solver's one-step path does (bit for bit), and stops at least at every
    step where a string's gap may cross zero and where a rotation vector passes the
    re-charting angle."""
    from tensegrity_core.sim import compile_scene
    from tensegrity_core.sim.general.model import RECHART_ANGLE

    scene = general_scene(BODIES, ["inertia", "springs", {"damping": {"c": 0.3}}], duration=0.4)
    y0 = _spinning_start(scene)
    single = _solver_runs(method, scene, y0, stretch=False, kernels=kernels)
    stretched = _solver_runs(method, scene, y0, stretch=True, kernels=kernels)
    at = {t: (y, k) for t, y, k in single}
    assert len(stretched) < len(single)
    for t, y, k in stretched:
        assert t in at and np.array_equal(y, at[t][0]) and k == at[t][1]
    assert stretched[-1][0] == single[-1][0] == scene.duration
    # where one step per call sees a sign change of a gap or a big rotation vector, the stretch stopped
    stops = {t for t, _, _ in stretched}
    model = compile_scene(scene)
    system = model.equations(model.state_from(y0))
    previous = np.sign(system.string_gaps(0.0, y0)[0])
    rot = system.lay.body_dof[:, None] + 3 + np.arange(3)[None, :]
    crossings = rechartings = 0
    for t, y, _ in single:
        sign = np.sign(system.string_gaps(t, y)[0])
        if np.any(sign != previous):
            crossings += 1
            assert t in stops, f"a gap changed sign in the step to t = {t} s, inside a stretch"
        if np.any(np.linalg.norm(y[rot], axis=1) > RECHART_ANGLE):
            rechartings += 1
            assert t in stops, f"a rotation vector passed the re-charting angle at t = {t} s, inside a stretch"
        previous = sign
    assert crossings > 0 and rechartings > 0          # the scene exercises both stops


def _spinning_start(scene):
    """The scene's initial state with the bodies and the free node spinning and drifting
    (random rates, fixed seed): strings go slack and taut, rotation vectors grow past 1 rad."""
    from tensegrity_core.sim import compile_scene

    y = compile_scene(scene).initial_state().y.copy()
    n = len(y) // 2
    y[n:] = np.random.default_rng(3).normal(0.0, 6.0, n)
    return y


_gaps = st.lists(st.one_of(st.sampled_from([0.0, 1e-12, -1e-12]), st.floats(-1e-2, 1e-2)), min_size=4, max_size=4)
_rates = st.lists(st.floats(-10.0, 10.0), min_size=4, max_size=4)


@settings(max_examples=300)
@given(g0=_gaps, g1=_gaps, r0=_rates, r1=_rates, h=st.floats(1e-6, 1e-2),
       moving=st.lists(st.booleans(), min_size=4, max_size=4))
def test_the_compiled_screen_stops_at_every_step_the_stepper_would_look_into(g0, g1, r0, r1, h, moving):
    """A stretch goes on past a step only if :func:`candidates` (the stepper's check after a
    step, rates unknown -- nan -- for strings whose rest length moves) finds nothing in it."""
    from tensegrity_core.sim.event_location import candidates
    from tensegrity_core.sim.general.kernels import loops

    g0, g1, r0, r1 = (np.array(v, dtype=float) for v in (g0, g1, r0, r1))
    mask = np.array(moving, dtype=bool)
    known0, known1 = np.where(mask, np.nan, r0), np.where(mask, np.nan, r1)
    if candidates(0.0, g0, known0, g1, known1, 0.0, h):
        assert not loops.quiet_step(g0, r0, g1, r1, mask, h)


@pytest.mark.parametrize("method", ["RK4", "DOP853"])
def test_samples_taken_inside_a_stretch_are_those_taken_one_advance_at_a_time(method):
    """``record`` lets a stretch interpolate the samples its quiet steps cover in compiled
    code; advancing to each sample time in turn returns to Python at every one. Same steps,
    same events, the same states to rounding (a step ending exactly at one of several samples
    it covers gives its end state to ``advance``, its interpolant's value at its end to
    ``record``: 1 ulp apart)."""
    from tensegrity_core.sim import compile_scene

    scene = general_scene(BODIES, ["inertia", "springs", {"damping": {"c": 0.3}}], duration=0.4,
                          integrator={"method": method, "rtol": 1e-9, "atol": 1e-11, "max_step": 2e-3})
    model = compile_scene(scene)
    y0 = _spinning_start(scene)
    times = np.arange(0, 401) * 1e-3
    recorded = model.state_from(y0, t_end=scene.duration)
    samples: list = []
    model.record(recorded, times, samples)
    stepped = model.state_from(y0, t_end=scene.duration)
    one_by_one = []
    for t in times:
        model.advance(stepped, float(t))
        one_by_one.append(stepped.y.copy())
    assert recorded.events == stepped.events and len(recorded.events) > 0
    assert recorded.work.n_steps == stepped.work.n_steps
    np.testing.assert_allclose(np.array([s[1] for s in samples]), np.array(one_by_one), rtol=1e-14, atol=1e-14)
