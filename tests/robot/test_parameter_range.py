"""Robot physics over the whole accepted range of a robot's parameters, not only the shipped
values (issue 27 for robots): the three-bar robot drawn by hypothesis with its rods' mass,
its cables' stiffness and damping, the floor's stiffness, dissipation and friction and the
drop height each over decades. A scene the step check refuses is refused in one line naming
``integrator.max_step``; an accepted one, run 0.4 s with its motors holding:

- every observed number is finite;
- no cable pushes (tension-only: its force is ``k (l - l0) + c ldot`` when taut, else 0, and
  never negative);
- no cap sinks deeper than the floor can let it: the floor's energy ``k delta^2 / 2`` at one
  cap is at most what the robot can give it, ``E = M g (z_c - r) + V`` (its whole mass ``M``
  falling from its centre of mass ``z_c`` to the cap radius ``r`` above the floor, its cables'
  stored energy ``V`` as drawn; the motors hold, friction and dampers only take) plus
  ``M g delta``, so ``delta <= (M g + sqrt((M g)^2 + 2 k E)) / k``.

Cost: 8 examples (a few refused), about 4 s on a loaded 2-core machine, and 5 free-flying ones, 0.3 s.
"""

from __future__ import annotations

import copy
import re

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.robot.loading import robot_path
from tensegrity_core.sim import SceneError, compile_scene, load_scene

BASE = yaml.safe_load(robot_path("three_bar").read_text())
G, CAP, DURATION = 9.81, 0.0675, 0.4
decades = lambda lo, hi: st.floats(np.log10(lo), np.log10(hi)).map(lambda e: float(10.0**e))  # noqa: E731


def robot(mass: float, k: float, c: float, k_floor: float, d_floor: float, mu: float) -> dict:
    """The three-bar robot with rods of ``mass`` [kg] (inertia scaled with it), every cable
    of stiffness ``k`` [N/m] (the passive ones a tenth) and damping ``c`` [N s/m], a floor of
    ``k_floor`` [N/m], ``d_floor`` [s/m] and friction ``mu``."""
    r = copy.deepcopy(BASE)
    for rod in r["rods"]:
        rod["inertia"] = [i * mass / rod["mass"] for i in rod["inertia"]]
        rod["mass"] = mass
    r["cable_defaults"].update(stiffness=k, damping=c)
    for cable in r["cables"]:
        if "stiffness" in cable:
            cable.update(stiffness=k / 10, damping=c)
    r["floor"].update(stiffness=k_floor, dissipation=d_floor, mu_static=mu, mu_kinetic=mu)
    return r


@settings(max_examples=8)
@given(mass=decades(0.05, 50), k=decades(50, 2e4), c=st.sampled_from([0.0, 1.0, 50.0]),
       k_floor=decades(1e3, 1e7), d_floor=st.sampled_from([0.0, 0.5, 5.0]), mu=st.sampled_from([0.0, 0.3, 1.0, 2.0]),
       lift=st.floats(0.0, 0.3))
def test_an_accepted_robot_scene_stays_finite_pulls_only_and_sinks_within_its_energy(mass, k, c, k_floor, d_floor,
                                                                                     mu, lift):
    data = {"name": "range", "model": {"kind": "robot", "robot": robot(mass, k, c, k_floor, d_floor, mu)},
            "initial": {"drawn": True, "lift": lift}, "duration": DURATION,
            "effects": ["inertia", "cables", "motors", "gravity", "contact", "friction"]}
    try:
        scene = load_scene(data)
    except SceneError as err:
        assert re.match(r"^integrator\.max_step: .* give integrator\.max_step in \(0, \S+\] s$", str(err)), str(err)
        return
    model = compile_scene(scene)
    samples: list = []
    model.record(model.initial_state(t_end=DURATION), np.linspace(0.0, DURATION, 81), samples)
    seen = model.observe(samples)
    for name, values in seen.items():
        values = np.asarray(values)
        assert values.dtype.kind != "f" or np.all(np.isfinite(values)), name
    cables = seen["member_forces"][:, len(BASE["rods"]):]
    assert cables.min() >= 0.0
    total = 3 * mass
    lengths = seen["member_lengths"][0, len(BASE["rods"]):]
    rest = seen["member_rest_lengths"][0, len(BASE["rods"]):]
    stiffness = np.array([k] * 6 + [k / 10] * 3)
    stored = float(np.sum(0.5 * stiffness * np.maximum(lengths - rest, 0.0) ** 2))
    energy = total * G * (seen["centre_of_mass"][0, 2] - CAP) + stored
    bound = (total * G + np.sqrt((total * G) ** 2 + 2 * k_floor * energy)) / k_floor
    depth = CAP - seen["nodes"][..., 2].min()
    assert depth <= bound, (depth, bound)


def test_the_drawn_cables_are_the_ones_the_test_assumes():
    """Six motor cables then three passive ones, after the three rods."""
    assert len(BASE["rods"]) == 3 and [("motor" in c) for c in BASE["cables"]] == [True] * 6 + [False] * 3
    assert all(rod["cap_radius"] == pytest.approx(CAP) for rod in BASE["rods"])


@settings(max_examples=5)
@given(mass=decades(0.05, 50), k=decades(50, 2e4), c=st.sampled_from([0.0, 1.0, 50.0]), seed=st.integers(0, 2**32 - 1))
def test_without_floor_or_gravity_momentum_holds_and_energy_never_rises(mass, k, c, seed):
    """No external force (no ``gravity``, no ``contact``): the rods' total momentum ``sum m
    v_c`` stays what it was, to rounding, from any velocities; with the motors holding, the
    cables' energy and the kinetic energy never grow (the dampers and RK4 inside its stability
    region only take). About 0.1 s of CPU each."""
    data = {"name": "free", "model": {"kind": "robot", "robot": robot(mass, k, c, 1e5, 0.0, 0.0)},
            "initial": {"drawn": True}, "duration": 0.3, "effects": ["inertia", "cables", "motors"]}
    try:
        model = compile_scene(load_scene(data))
    except SceneError as err:
        assert str(err).startswith("integrator.max_step: "), str(err)
        return
    y = np.array(model.y0, dtype=float)
    y[len(y) // 2:] = np.random.default_rng(seed).normal(0.0, 0.3, len(y) // 2)     # every body moving
    samples: list = []
    model.record(model.state_from(y, t_end=0.3), np.linspace(0.0, 0.3, 31), samples)
    seen = model.observe(samples)
    momentum = mass * seen["body_velocities"].sum(axis=1)
    assert np.abs(momentum - momentum[0]).max() <= 1e-12 * (1.0 + np.abs(momentum[0]).max() + mass)
    energy = seen["kinetic_energy"] + seen["potential_energy"]
    assert energy.max() <= energy[0] * (1.0 + 1e-9)
