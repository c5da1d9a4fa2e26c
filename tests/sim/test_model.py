"""Compile, then run: the frozen Model, the State it runs on, the back-end registry."""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from tensegrity_core.sim import (
    BACKENDS,
    DynamicModel,
    Model,
    SimulationError,
    Simulator,
    compile_scene,
    load_scene,
    scene_names,
    simulate,
)
from tensegrity_core.sim import simulator as simulator_module
from tensegrity_core.sim.backends import backend, backend_name

from .helpers import class2_scene


def protocol_members(protocol) -> set[str]:
    """The attributes and methods a Protocol class declares (its own and its bases')."""
    names = set()
    for cls in protocol.__mro__:
        if cls in (object,) or cls.__name__ in ("Protocol", "Generic"):
            continue
        names |= set(getattr(cls, "__annotations__", {}))
        names |= {n for n, v in vars(cls).items() if inspect.isfunction(v) and not n.startswith("_")}
    return names


@pytest.mark.parametrize("name", scene_names())
def test_every_shipped_scene_compiles_to_a_registered_back_end_with_the_whole_protocol(name):
    scene = load_scene(name)
    key = backend_name(scene)
    assert key in BACKENDS
    model = compile_scene(scene)
    assert isinstance(model, backend(key)) and model.scene is scene
    wanted = protocol_members(DynamicModel if not scene.quasi_static else Model)
    assert wanted >= {"initial_state", "set_command", "advance", "observe", "observe_now", "stats"}
    missing = sorted(n for n in wanted if not hasattr(model, n))
    assert not missing, f"{key} lacks {missing}"
    assert model.kind == scene.model.kind and model.quasi_static == scene.quasi_static
    state = model.initial_state(t_end=scene.duration)
    assert state.t == 0.0 and len(state.y) == len(model.state_names) and np.all(np.isfinite(state.y))
    assert isinstance(state.mode, frozenset) and (model.kind == "class2" or state.mode == frozenset())
    assert len(state.commands) == len(model.actuator_names) == len(scene.inputs)
    # Frozen: no attribute can be set or deleted, and the arrays it holds are read-only.
    with pytest.raises(AttributeError, match="frozen"):
        model.scene = scene
    with pytest.raises(AttributeError, match="frozen"):
        model.patched = 1
    with pytest.raises(AttributeError, match="frozen"):
        del model.interface
    assert model.scene is scene
    assert not any(v.flags.writeable for v in vars(model).values() if isinstance(v, np.ndarray))


def test_the_registry_names_each_model_kind_and_regime_once():
    assert sorted(BACKENDS) == ["class2/dynamic", "class2/quasi-static", "general/dynamic", "general/quasi-static",
                              "robot/dynamic"]
    for key in BACKENDS:
        cls = backend(key)
        assert f"{cls.kind}/{'quasi-static' if cls.quasi_static else 'dynamic'}" == key


def test_compile_takes_a_checked_scene_only():
    with pytest.raises(TypeError, match="load_scene"):
        compile_scene({"model": {"kind": "class2"}})


def test_simulate_loads_the_scene_once(monkeypatch):
    calls = []
    real = simulator_module.load_scene

    def counting(source):
        calls.append(source)
        return real(source)

    monkeypatch.setattr(simulator_module, "load_scene", counting)
    data = dict(load_scene("paper_fold").data)
    simulate(data, duration=0.05)
    assert len(calls) == 1 and calls[0] is data


@pytest.mark.parametrize("name", ["paper_fold", "paper_fold_quasistatic"])
def test_states_of_one_model_are_independent_and_running_them_leaves_the_model_unchanged(name):
    """Two states of one model run the same commands to the same result, bit for bit, and a
    third state made after them starts where the first did: nothing in the model changed."""
    model = compile_scene(load_scene(name))
    first = model.initial_state(t_end=2.0)
    y0, events0 = first.y.copy(), list(first.events)
    second = model.initial_state(t_end=2.0)
    for t in (0.3, 1.2, 1.6, 2.0):
        model.advance(first, t)
    for t in (0.3, 1.2, 1.6, 2.0):
        model.advance(second, t)
        assert second.t == t                       # to exactly the target time
    np.testing.assert_array_equal(first.y, second.y)
    assert first.events == second.events and any(kind == "fold" for _, kind, _ in first.events)
    third = model.initial_state(t_end=2.0)
    np.testing.assert_array_equal(third.y, y0)
    assert third.t == 0.0 and third.events == events0 and third.mode == frozenset()


def _quasi_static_table():
    """table_gravity without inertia: the general quasi-static back end."""
    scene = load_scene("table_gravity")
    d = dict(scene.data)
    d["effects"] = ["springs", "gravity"]
    d["model"] = dict(d["model"], structure=str(scene.model.source))
    return load_scene(d)


@pytest.mark.parametrize("key, scene", [("class2/dynamic", lambda: load_scene("paper_fold")),
                                        ("class2/quasi-static", lambda: load_scene("paper_fold_quasistatic")),
                                        ("general/dynamic", lambda: load_scene("table_gravity")),
                                        ("general/quasi-static", _quasi_static_table)])
def test_every_back_end_advances_only_forwards_to_a_finite_time_and_keeps_its_state(key, scene):
    scene = scene()
    assert backend_name(scene) == key
    model = compile_scene(scene)
    state = model.initial_state(t_end=1.0)
    model.advance(state, 0.01)
    y = state.y.copy()
    for target, words in ((math.inf, "target time must be a finite number of seconds, got inf"),
                          (math.nan, "target time must be a finite number of seconds, got nan"),
                          (0.005, "cannot advance backwards: t = 0.01 s, target 0.005 s")):
        with pytest.raises(SimulationError, match=words) as err:
            model.advance(state, target)
        assert err.value.t == 0.01
        assert state.t == 0.01
        np.testing.assert_array_equal(state.y, y)


def test_the_state_shows_time_contact_mode_commands_and_located_events():
    model = compile_scene(load_scene("paper_fold"))
    state = model.initial_state()
    model.advance(state, 1.54)
    assert [kind for _, kind, _ in state.events] == ["fold", "fold"]     # rho2 bounces off, rho1 stays
    t_fold, _, index = state.events[-1]
    assert 1.3 < t_fold < 1.54 and state.mode == frozenset({index})
    assert state.y[index] == 0.0 and state.y[3 + index] == 0.0 and state.y[1 - index] > 0.0
    model.advance(state, 1.8)
    assert state.events[-1][1] == "release" and state.mode == frozenset()
    assert all(math.isnan(c) for c in state.commands)              # both inputs follow laws
    held = compile_scene(load_scene("class2_at_rest"))
    state = held.initial_state()
    hold = state.commands
    held.set_command(state, [0.4, -0.3])
    assert state.commands == (0.4, -0.3) and hold != state.commands
    with pytest.raises(SimulationError, match="must be finite"):
        held.set_command(state, [math.nan, 0.0])
    assert state.commands == (0.4, -0.3)


def test_a_zero_order_hold_between_exact_times_equals_one_run_with_the_same_commands():
    """Commands at t_k, advance to t_k+1: two states of one model, the same sequence, the same
    trajectory bit for bit (the loop a lockstep client runs)."""
    model = compile_scene(load_scene("class2_at_rest"))
    runs = []
    for _ in range(2):
        state = model.initial_state()
        ys = []
        for k in range(40):
            model.set_command(state, [0.3 * math.sin(0.2 * k), -0.2 + 0.01 * k])
            model.advance(state, (k + 1) * 0.01)
            ys.append(state.y.copy())
        runs.append(np.array(ys))
    np.testing.assert_array_equal(runs[0], runs[1])


@pytest.mark.parametrize("name, exact", [("paper_fold", False), ("paper_fold_quasistatic", True)])
def test_a_copy_of_a_state_runs_on_its_own(name, exact):
    model = compile_scene(load_scene(name))
    state = model.initial_state()
    model.advance(state, 0.5)
    snapshot = state.copy()
    model.advance(state, 2.0)
    assert snapshot.t == 0.5 and len(snapshot.events) <= len(state.events)
    model.advance(snapshot, 2.0)
    assert snapshot.events[-1][1] == state.events[-1][1]
    if exact:                                 # the path's pieces are copied as they are
        np.testing.assert_array_equal(snapshot.y, state.y)
        assert snapshot.events == state.events
    else:                                     # the integrator restarts at the copy's time
        np.testing.assert_allclose(snapshot.y, state.y, atol=1e-5)
        np.testing.assert_allclose([e[0] for e in snapshot.events], [e[0] for e in state.events], atol=1e-6)


def test_reset_is_a_new_state_and_replays_the_same_run():
    sim = Simulator(class2_scene(effects=["inertia", "springs", "damping", {"sensor_noise": {"q": 1e-3}}],
                                 inputs={"f1": {"law": "commanded"}, "f2": {"law": "commanded"}}, seed=3))
    model = sim.model

    def run():
        out = []
        for k in range(20):
            sim.set_command([0.1 * k, -0.05 * k])
            sim.advance((k + 1) * 0.005)
            out.append(sim.observe().q)
        return np.array(out)

    first = run()
    old_state = sim.state
    sim.reset()
    assert sim.model is model and sim.state is not old_state and sim.t == 0.0
    np.testing.assert_array_equal(run(), first)                 # noise sequence restarted too
    np.testing.assert_array_equal(Simulator(sim.scene).observe().q, Simulator(model).observe().q)


def test_a_dynamic_model_starts_from_any_state_vector_and_refuses_bad_ones():
    model = compile_scene(load_scene("class2_at_rest"))
    y = model.initial_state().y.copy()
    y[3:6] = (0.2, -0.1, 0.5)
    state = model.state_from(y)
    np.testing.assert_array_equal(state.y, y)
    assert model.equations(state).fun(0.0, y)[:3].tolist() == [0.2, -0.1, 0.5]
    with pytest.raises(SimulationError, match="6 entries"):
        model.state_from(y[:5])
    with pytest.raises(SimulationError, match="domain"):
        model.state_from([0.5, 1.6, 0.0, 0.0, 0.0, 0.0])          # rho1 + rho2 > 2L
    assert not hasattr(compile_scene(load_scene("paper_fold_quasistatic")), "state_from")


def _robot_scene():
    return load_scene("three_bar_drop")


@pytest.mark.parametrize("key, scene", [("class2/dynamic", lambda: load_scene("paper_fold")),
                                        ("class2/quasi-static", lambda: load_scene("paper_fold_quasistatic")),
                                        ("general/dynamic", lambda: load_scene("table_gravity")),
                                        ("general/quasi-static", _quasi_static_table),
                                        ("robot/dynamic", _robot_scene)])
def test_a_state_runs_only_on_the_model_that_made_it(key, scene):
    """A state carries its model's integrator and laws: another model, even one compiled from
    the same scene, refuses it in one line instead of running the first model's equations."""
    scene = scene()
    assert backend_name(scene) == key
    mine, other = compile_scene(scene), compile_scene(scene)
    state = mine.initial_state(t_end=1.0)
    command = [0.0 if math.isnan(c) else c for c in state.commands]
    calls = {"advance": lambda m, s: m.advance(s, 0.001), "set_command": lambda m, s: m.set_command(s, command),
             "record": lambda m, s: m.record(s, [0.001], []), "observe_now": lambda m, s: m.observe_now(s),
             "joint_sample": lambda m, s: m.joint_sample(s)}
    for name, call in calls.items():
        for foreign in (state, state.copy()):
            with pytest.raises(SimulationError, match=r"^this state was made by another model \(compiled from "
                                                      rf"scene '{scene.name}'\); a state runs only on the model"):
                call(other, foreign)
        assert state.t == 0.0, name
    mine.advance(state.copy(), 0.001)          # its copies run on the model that made it
    mine.advance(state, 0.001)
    assert state.t == 0.001
