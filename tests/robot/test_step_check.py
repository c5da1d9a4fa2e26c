"""A robot scene whose fixed step RK4 cannot follow is refused before it runs, in one line
naming ``integrator.max_step``, its unit and the accepted range; the refusal is right.

The robot: a 1 kg rod along x held between two pinned points by two collinear cables of
``k = 8e6 N/m`` each, stretched 0.1 and 0.2 mm (no gravity, no floor): it starts 0.05 mm from
its equilibrium and neither cable goes slack as it oscillates. Its axial mode is the rod between the cables, ``omega = sqrt(2 k / m) = 4000
rad/s`` (their 1.2 kN only add a transverse stiffness ``2 T / l = 2.4e4 N/m``, far below
``2 k``), so RK4 follows it with steps up to ``2.96 / 4000 = 0.74 ms``: the default 1 ms is
refused. Undamped, the mode is on RK4's imaginary axis, stable up to ``h omega = 2 sqrt 2 =
2.83``: a run at 0.9 of the limit (2.66) keeps its energy, one at 1.05 of it (``h omega =
3.1``, growth ``|R(3.1 i)| = 1.87`` per step) gains energy from nowhere.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray

from tensegrity_core.sim import SceneError, compile_scene, load_scene
from tensegrity_core.sim.scene.robot_schema import RK4_REACH
from tensegrity_ros.cli import main

K, MASS = 8e6, 1.0
LIMIT = RK4_REACH / np.sqrt(2 * K / MASS)        # 0.74 ms
ROBOT = {"name": "hung", "nodes": {"p": [0.0, 0.0, 0.0], "a": [0.1, 0.0, 0.0], "b": [1.1, 0.0, 0.0],
                                   "q": [1.2, 0.0, 0.0]},
         "pinned": ["p", "q"], "rods": [{"name": "r", "nodes": ["a", "b"], "mass": MASS, "radius": 0.01}],
         "cables": [{"name": "c", "nodes": ["p", "a"], "stiffness": K, "rest_length": 0.0999},
                    {"name": "d", "nodes": ["b", "q"], "stiffness": K, "rest_length": 0.0998}]}


def scene(step: float | None = None) -> dict:
    out = {"name": "hung", "model": {"kind": "robot", "robot": ROBOT}, "initial": {"drawn": True},
           "effects": ["inertia", "cables"], "duration": 2.0}
    return out if step is None else dict(out, integrator={"max_step": step})


def test_rk4_s_reach():
    """The largest |z| in RK4's stability region, on a fine polar grid: 2.96 (to 0.005)."""
    angle = np.linspace(np.pi / 2, np.pi, 721)[:, None]
    radius = np.linspace(1e-3, 4.0, 8001)[None, :]
    z = radius * np.exp(1j * angle)
    stable = np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) <= 1.0
    first_unstable = np.argmin(stable, axis=1)
    assert abs(radius[0, first_unstable - 1].max() - RK4_REACH) < 5e-3


def test_a_step_too_long_for_a_cable_is_refused_in_one_line():
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.001 s \(the default\) is too "
                                         r"long for rod 'r' \(1 kg\): moved along cable 'c' it meets 1\.6e\+07 N/m of "
                                         r"taut cables, a mode of at least 4000 rad/s, which RK4 follows with steps "
                                         r"up to 0\.00074 s; give integrator\.max_step in \(0, 0\.00074\] s$"):
        load_scene(scene())
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.0008 s is too long"):
        load_scene(scene(8e-4))
    load_scene(scene(7e-4))
    slack = dict(ROBOT, cables=[dict(c, rest_length=0.1001) for c in ROBOT["cables"]])     # nothing to follow
    load_scene(dict(scene(), model={"kind": "robot", "robot": slack}))


def _energy(step: float, steps: int = 2000) -> float:
    """The largest energy (kinetic + cables) over ``steps`` steps of ``step`` [s], in units of
    the energy it starts with (validation passed at a step it accepts, then the model's step
    replaced)."""
    model = compile_scene(load_scene(scene(0.5 * LIMIT)))
    model.step = step
    state = model.initial_state(t_end=steps * step)
    samples: list = []
    model.record(state, np.arange(steps + 1) * step, samples)
    o = model.observe(samples)
    E = o["kinetic_energy"] + o["potential_energy"]
    return float(E.max() / E[0])


def test_the_refusal_is_right():
    """Below the refused steps the energy stays what it was (RK4's error: below 1 % over 2000
    steps); above them it grows, ``|R(3.1 i)|^2 = 3.5`` times in a step while both cables are
    taut, until the amplitude slackens them by turns (then more than doubled: 2.3 times)."""
    assert _energy(0.9 * LIMIT) < 1.01
    assert _energy(1.05 * LIMIT, steps=20) > 2.0


def test_the_cli_says_it_in_one_line_with_exit_2(tmp_path, capsys):
    path = tmp_path / "hung.yaml"
    path.write_text(yaml.safe_dump(scene()))
    assert main(["simulate", str(path), "-o", str(tmp_path / "out.csv"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "integrator.max_step" in err and "give integrator.max_step in (0, 0.00074] s" in err


#: A 1 kg rod lying on a floor of stiffness 1e8 N/m (no damping, no friction): a cap pressed
#: into it meets a mode of at least ``sqrt(k / m) = 1e4 rad/s`` (the rod on both caps bounces
#: at ``sqrt(2 k / m)``), so RK4 follows it with steps up to ``2.96 / 1e4 = 0.296 ms``.
FLOOR_K = 1e8
FLOOR_LIMIT = RK4_REACH / np.sqrt(FLOOR_K / MASS)
LYING = {"name": "lying", "nodes": {"a": [0.0, 0.0, 0.01], "b": [1.0, 0.0, 0.01]},
         "rods": [{"name": "r", "nodes": ["a", "b"], "mass": MASS, "radius": 0.01, "cap_radius": 0.01}],
         "cables": [{"name": "c", "nodes": ["a", "b"], "stiffness": 1.0, "rest_length": 2.0}],
         "gravity": [0.0, 0.0, -9.81],
         "floor": {"stiffness": FLOOR_K, "dissipation": 0.0, "mu_static": 0.0, "tangential_stiffness": 1.0}}


def floor_scene(step: float | None = None) -> dict:
    out = {"name": "lying", "model": {"kind": "robot", "robot": LYING}, "initial": {"drawn": True},
           "effects": ["inertia", "gravity", "cables", "contact"], "duration": 1.0}
    return out if step is None else dict(out, integrator={"max_step": step})


def test_a_step_too_long_for_the_floor_is_refused_in_one_line():
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.001 s \(the default\) is too "
                                         r"long for rod 'r' \(1 kg\): pressed into the floor it meets 1e\+08 N/m of "
                                         r"contact stiffness, a mode of at least 1e\+04 rad/s, which RK4 follows with "
                                         r"steps up to 0\.000296 s; give integrator\.max_step in \(0, 0\.000296\] s$"):
        load_scene(floor_scene())
    load_scene(floor_scene(0.99 * FLOOR_LIMIT))
    without_contact = dict(floor_scene(), effects=["inertia", "gravity", "cables"])
    load_scene(without_contact)                       # no floor force, nothing to follow
    with pytest.raises(SceneError, match=r"sticking on the floor it meets 1e\+08 N/m of friction anchor"):
        load_scene(dict(floor_scene(), effects=[
            "inertia", "gravity", "cables", {"contact": {"stiffness": 1.0}},
            {"friction": {"mu_static": 0.5, "tangential_stiffness": FLOOR_K}}]))


def test_the_floor_s_refusal_is_right():
    """Past the refused step the rod resting on its caps gains energy from nowhere (its bounce
    on both caps has ``h omega >= 1.05 * 2.96 * sqrt 2 = 4.4``, beyond RK4's 2.83 on the
    imaginary axis); well inside it (a tenth: ``h omega`` of the rocking mode
    ``sqrt(6 k / m)`` about 0.7) it stays at rest to the sinking of its weight."""
    def run(step: float, steps: int) -> NDArray:
        model = compile_scene(load_scene(floor_scene(0.5 * FLOOR_LIMIT)))
        model.step = step
        samples: list = []
        model.record(model.initial_state(t_end=steps * step), np.arange(steps + 1) * step, samples)
        return model.observe(samples)["body_positions"][:, 0, 2]

    heights = run(0.1 * FLOOR_LIMIT, 400)
    sink = MASS * 9.81 / (2 * FLOOR_K)                # 4.9e-8 m on each cap
    assert np.all(np.abs(heights - 0.01) <= 2.0 * sink + 1e-12)
    with np.errstate(all="ignore"):
        heights = run(1.05 * FLOOR_LIMIT, 60)
    assert not np.all(np.abs(heights - 0.01) <= 1e3 * sink)


#: A 1 kg rod of 1 m (radius 1 cm: ``I_t = 0.0856 kg m^2``) held along x between two points
#: pinned 1000 m beyond its caps by soft cables (``k = 1 N/m``) at ``T = 999 N``: moving along
#: them it meets only 2 N/m, but turned by ``theta`` each cap's arc shortens its cable by
#: ``theta^2 L / 4``, so the pair stores ``T L theta^2 / 2`` and the rod swings back to align
#: with them at ``omega = sqrt(T L / I_t) = 108 rad/s`` (their transverse stiffness ``T / l =
#: 1 N/m`` adds 0.05 %): RK4 follows it with steps up to ``2.96 / 108 = 27.4 ms``.
T_PULL, TURN_I = 999.0, 0.0856008553
TURN_OMEGA = np.sqrt(T_PULL * 1.0 / TURN_I)
TURN_LIMIT = RK4_REACH / TURN_OMEGA
TURNING = {"name": "aligned", "nodes": {"p": [-1000.0, 0.0, 0.0], "a": [0.0, 0.0, 0.0], "b": [1.0, 0.0, 0.0],
                                        "q": [1001.0, 0.0, 0.0]},
           "pinned": ["p", "q"], "rods": [{"name": "r", "nodes": ["a", "b"], "mass": MASS, "radius": 0.01}],
           "cables": [{"name": "c", "nodes": ["b", "q"], "stiffness": 1.0, "rest_length": 1.0},
                      {"name": "d", "nodes": ["p", "a"], "stiffness": 1.0, "rest_length": 1.0}]}


def turning_scene(step: float) -> dict:
    return {"name": "aligned", "model": {"kind": "robot", "robot": TURNING}, "initial": {"drawn": True},
            "effects": ["inertia", "cables"], "duration": 5.0, "integrator": {"max_step": step}}


def test_a_step_too_long_for_a_rod_turning_into_its_cables_is_refused():
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.05 s is too long for rod 'r' "
                                         r"\(1 kg\): turned towards cable 'c' \(its transverse inertia 0\.0856009 kg "
                                         r"m\^2\) it meets 999 N m/rad of taut cables, a mode of at least 108 rad/s, "
                                         r"which RK4 follows with steps up to 0\.0274 s; give integrator\.max_step in "
                                         r"\(0, 0\.0274\] s$"):
        load_scene(turning_scene(0.05))
    load_scene(turning_scene(0.99 * TURN_LIMIT))


def test_the_turning_refusal_is_right():
    """Turned 0.01 rad and let go: at 0.9 of the refused step (``h omega = 2.66``, inside
    RK4's 2.83 on the imaginary axis) the swing stays below its start's ``theta omega`` = 1.08
    rad/s; past the refusal (1.05 of it, ``h omega = 3.1``) it grows from nowhere, ``|R(3.1
    i)| = 1.87`` per step, past 10 times that within 2 s (69 times, tumbling)."""
    def swing(step: float, duration: float) -> float:
        model = compile_scene(load_scene(turning_scene(0.5 * TURN_LIMIT)))
        model.step = step
        p = model.plan
        y = model.y0.copy()
        y[p.body_dof[0] + 5] = 0.01                                     # turned about z
        samples: list = []
        steps = int(duration / step)
        model.record(model.state_from(y, t_end=steps * step), np.arange(steps + 1) * step, samples)
        return max(abs(float(s[1][p.n_dof + p.body_dof[0] + 5])) for s in samples)

    assert swing(0.9 * TURN_LIMIT, 5.0) < 0.01 * TURN_OMEGA * 1.01
    assert swing(1.05 * TURN_LIMIT, 2.0) > 10 * 0.01 * TURN_OMEGA
