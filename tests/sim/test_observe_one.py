"""One observation on floats (``Simulator.observe``, the ROS node's call) against the
vectorised path a whole run takes: the same quantities to rounding, in every contact mode
and with every effect."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.sim import Simulator, compile_scene, load_scene
from tensegrity_core.sim.class2 import path_samples
from tensegrity_core.sim.class2.observe import Class2Observer
from tensegrity_core.sim.class2.setup import force_effects

from .helpers import class2_scene, random_states

EVERYTHING = ["inertia", "springs", "damping", {"gravity": {"vector": [0.05, -0.3, -9.8]}},
              {"loads": {"B": [0.3, 0.0, 0.0], "D": [0.2, -0.4, 0.0], "E": [-0.1, 0.3, 0.0], "F": [0.0, 0.5, 0.0]}},
              {"actuator_lag": {"tau": 0.05}}, {"actuator_compliance": {"stiffness": 500.0, "drive_damping": 2.0}},
              "fold_limit"]
KEYS = ("t", "state", "q", "qdot", "qddot", "applied_forces", "contact_forces", "nodes", "member_lengths",
        "member_forces", "end_effector", "potential_energy", "kinetic_energy", "folded")


def assert_same_observation(one: dict, many: dict, row: int = 0):
    for key in KEYS:
        np.testing.assert_allclose(np.asarray(one[key], dtype=float), np.asarray(many[key][row], dtype=float),
                                   rtol=1e-12, atol=1e-12, err_msg=key)


@pytest.mark.parametrize("bits", [0, 1, 2, 3])
def test_one_dynamic_sample_equals_the_vectorised_observation(bits):
    scene = class2_scene(effects=EVERYTHING, model={"kind": "class2", "params": {"k": 1.3, "c": 0.05, "m": 1.7}},
                         initial={"q": [0.5, 0.6, 0.8]})
    model = compile_scene(scene)
    observer = model.observer
    transmitted = model.equations(model.initial_state()).drive.forces
    for y in random_states(6, seed=11 + bits, extra=4):
        for i in (0, 1):
            if bits >> i & 1:
                y[i] = y[3 + i] = 0.0
        T = transmitted(0.4, y.tolist())
        one = observer.one(0.4, y, bits, T)
        many = observer.many([0.4], [y], [bits], [T])
        assert_same_observation(one, many)


@pytest.mark.parametrize("bits", [0, 1, 2, 3])
def test_one_quasi_static_sample_equals_the_vectorised_observation(bits):
    scene = class2_scene(effects=["springs", EVERYTHING[3], EVERYTHING[4], "fold_limit"])
    observer = Class2Observer(scene, force_effects(scene), inertia=False)
    rng = np.random.default_rng(bits)
    for y in random_states(6, seed=21 + bits):
        y[3:] = rng.normal(0, 0.3, 3)
        for i in (0, 1):
            if bits >> i & 1:
                y[i] = y[3 + i] = 0.0
        T, lam = rng.normal(0, 0.5, 2), np.where([bits & 1, bits & 2], rng.uniform(0, 1, 2), 0.0)
        one = observer.one(0.7, y, bits, T, contact=lam)
        many = observer.many([0.7], [y], [bits], [T], contact=[lam])
        assert_same_observation(one, many)


@pytest.mark.parametrize("name, times", [("paper_fold", (0.0, 0.37, 1.2, 1.381, 2.5)),
                                         ("stiff_fold", (0.0, 0.05, 0.2)),
                                         ("class2_at_rest", (0.0, 0.3))])
def test_simulator_observe_equals_the_models_vectorised_path_dynamic(name, times):
    sim = Simulator(name)
    if name == "class2_at_rest":
        sim.set_command([0.4, -0.3])
    for t in times:
        sim.advance(t)
        one = sim.model.observe_now(sim.state)
        assert_same_observation(one, sim.model.observe([sim.model.sample(sim.state)]))
        obs = sim.observe()
        np.testing.assert_array_equal(obs.member_forces, one["member_forces"])


@pytest.mark.parametrize("t", [0.0, 0.004, 0.0207, 0.03, 0.0745, 0.075, 0.3, 4.9])
def test_simulator_observe_equals_the_vectorised_path_quasi_static(t, monkeypatch):
    """Every stage: the start, on the moving branches in both modes, at the fold events and
    resting folded; the vectorised path forced (no sample taken one by one)."""
    sim = Simulator("paper_fold_quasistatic")
    sim.advance(t)
    one = sim.model.observe_now(sim.state)
    monkeypatch.setattr(path_samples, "FEW", -1)
    assert_same_observation(one, sim.model.observe([sim.model.sample(sim.state)]))


def test_joint_sample_and_observe_agree_for_quasi_static_scenes():
    sim = Simulator(load_scene("paper_fold_quasistatic"))
    sim.advance(0.05)
    js, obs = sim.joint_sample(), sim.observe()
    for name in ("q", "qdot", "applied_forces", "end_effector"):
        np.testing.assert_array_equal(getattr(js, name), getattr(obs, name))
