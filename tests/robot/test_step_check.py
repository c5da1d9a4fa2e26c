"""A robot scene whose fixed step RK4 cannot follow is refused before it runs, in one line
naming ``integrator.max_step``, its unit and the accepted range; the refusal is right.

The robot: a 1 kg rod along x held between two pinned points by two collinear cables of
``k = 8e6 N/m`` each, stretched 0.1 and 0.2 mm (no gravity, no floor): it starts 0.05 mm from
its equilibrium and neither cable goes slack as it oscillates. Its axial mode is the rod between the cables, ``omega = sqrt(2 k / m) = 4000
rad/s`` (their 1.2 kN only add a transverse stiffness ``2 T / l = 2.4e4 N/m``, far below
``2 k``). Undamped, the mode's roots ``+-i omega`` put ``h omega`` on RK4's imaginary axis,
where ``|R(iy)|^2 = 1 - y^6/72 + y^8/576`` exceeds 1 exactly from ``y = 2 sqrt 2 = 2.83`` on:
RK4 follows it with steps up to ``2 sqrt 2 / 4000 = 0.707 ms`` and the default 1 ms is
refused. A run at 0.98 of that limit loses its energy to RK4; one at 1.02 of it (``h omega =
2.885``, ``|R|^2 = 1.33`` a step) gains energy from nowhere. Damped, the roots ``omega (-zeta +- i
sqrt(1 - zeta^2))`` leave the axis and the limit is the region's radius along them (2.62 at
``zeta = 1/2``, below the undamped 2.83).
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray

from tensegrity_core.sim import SceneError, compile_scene, load_scene
from tensegrity_core.sim.general.robot.loops import STICKING
from tensegrity_core.sim.general.robot.stepping import FixedStepper
from tensegrity_core.sim.model import State
from tensegrity_core.sim.scene.robot_schema import RK4_IMAGINARY_REACH, rk4_reach
from tensegrity_ros.cli import main

K, MASS = 8e6, 1.0
LIMIT = 2 * np.sqrt(2) / np.sqrt(2 * K / MASS)    # 0.707 ms
ROBOT = {"name": "hung", "nodes": {"p": [0.0, 0.0, 0.0], "a": [0.1, 0.0, 0.0], "b": [1.1, 0.0, 0.0],
                                   "q": [1.2, 0.0, 0.0]},
         "pinned": ["p", "q"], "rods": [{"name": "r", "nodes": ["a", "b"], "mass": MASS, "radius": 0.01}],
         "cables": [{"name": "c", "nodes": ["p", "a"], "stiffness": K, "rest_length": 0.0999},
                    {"name": "d", "nodes": ["b", "q"], "stiffness": K, "rest_length": 0.0998}]}


def scene(step: float | None = None) -> dict:
    out = {"name": "hung", "model": {"kind": "robot", "robot": ROBOT}, "initial": {"drawn": True},
           "effects": ["inertia", "cables"], "duration": 2.0}
    return out if step is None else dict(out, integrator={"max_step": step})


def _first_unstable(root: complex) -> float:
    """The largest ``r`` [1] with ``|R(r' root)| <= 1`` for every ``r' <= r``, on a grid of
    step 1e-5 (independent of the code's root finding)."""
    r = np.arange(1.0, 4.0, 1e-5)
    z = r * root
    return float(r[np.argmax(np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) > 1.0) - 1])


def test_rk4_s_reach_on_the_imaginary_axis_is_2_sqrt_2():
    assert RK4_IMAGINARY_REACH == pytest.approx(2 * np.sqrt(2), rel=1e-15) == rk4_reach(0.0)
    assert abs(_first_unstable(1j) - 2 * np.sqrt(2)) < 2e-5


@pytest.mark.parametrize("zeta", [1e-3, 0.1, 0.3, 0.5, 0.7, 0.9, 0.999])
def test_rk4_s_reach_along_a_damped_modes_roots(zeta):
    """The region's radius along ``-zeta + i sqrt(1 - zeta^2)`` (2.95 at 0.1, 2.62 at 0.5)."""
    assert abs(rk4_reach(zeta) - _first_unstable(complex(-zeta, np.sqrt(1 - zeta**2)))) < 2e-5


@pytest.mark.parametrize("zeta", [1.0, 1.5, 4.0])
def test_rk4_s_reach_for_an_overdamped_mode_is_its_fast_root_s(zeta):
    """Real roots ``-omega (zeta +- sqrt(zeta^2 - 1))``: the fast one within the real axis's 2.785."""
    assert abs(rk4_reach(zeta) * (zeta + np.sqrt(zeta**2 - 1)) - _first_unstable(-1.0)) < 2e-5


def test_a_step_too_long_for_a_cable_is_refused_in_one_line():
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.001 s \(the default\) is too "
                                         r"long for rod 'r' \(1 kg\): moved along cable 'c' it meets 1\.6e\+07 N/m of "
                                         r"taut cables, a mode of at least 4000 rad/s, which RK4 follows with steps "
                                         r"up to 0\.000707 s; give integrator\.max_step in \(0, 0\.000707\] s$"):
        load_scene(scene())
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.00072 s is too long"):
        load_scene(scene(7.2e-4))                 # h omega = 2.88: was taken within RK4's 2.96 off the axis
    load_scene(scene(7e-4))
    slack = dict(ROBOT, cables=[dict(c, rest_length=0.1001) for c in ROBOT["cables"]])     # nothing to follow
    load_scene(dict(scene(), model={"kind": "robot", "robot": slack}))


def taut(damping: float) -> dict:
    """The robot with its cables stretched 1.0 and 1.1 mm (starting 0.05 mm from equilibrium,
    as drawn: a mode that grows stays linear until it is 20 times that) and damped ``damping``
    [N s/m] each."""
    return dict(ROBOT, cables=[dict(c, damping=damping, rest_length=r) for c, r in zip(ROBOT["cables"],
                                                                                      (0.0990, 0.0989))])


def state_at_step(model, step: float, t_end: float, y: NDArray | None = None) -> State:
    """A state of the robot ``model`` that its fixed-step RK4 advances by ``step`` [s] instead
    of the scene's (validation passed at a step it accepts; the model itself is frozen), from
    ``y`` (its initial state vector by default)."""
    events: list = []
    start = model.y0.copy() if y is None else y
    return State(model.initial_commands, events, FixedStepper(model.system, start, step, t_end=t_end, log=events),
                 owner=model)


def _kinetic_growth(robot: dict, step: float, steps: int = 100) -> float:
    """The largest kinetic energy over the last 10 of ``steps`` steps of ``step`` [s] over
    the largest over the first 6 (three periods): below 1 when RK4 follows the mode, above
    when it grows (validation passed at a step it accepts, then the model's step replaced)."""
    model = compile_scene(load_scene(dict(scene(1e-5), model={"kind": "robot", "robot": robot})))
    samples: list = []
    model.record(state_at_step(model, step, steps * step), np.arange(steps + 1) * step, samples)
    kinetic = model.observe(samples)["kinetic_energy"]
    return float(kinetic[-10:].max() / kinetic[:6].max())


def test_the_refusal_is_right_just_below_and_just_above_it():
    """Undamped: just below the refused steps (0.98 of the limit, ``h omega = 2.77``) RK4
    takes energy out, ``|R(2.77 i)|^2 = 0.75`` a step, so 100 steps leave less than 1e-3 of
    it; just above them (1.02, ``h omega = 2.885``) it puts energy in from nowhere,
    ``|R(2.885 i)|^2 = 1.33`` a step, until the cables slacken by turns (over 10 times)."""
    assert _kinetic_growth(taut(0.0), 0.98 * LIMIT) < 1e-3
    assert _kinetic_growth(taut(0.0), 1.02 * LIMIT) > 10.0


#: The cables damped at ``c = zeta m omega`` each (2000 N s/m: along the rod both act, ``2 c
#: = 2 zeta m omega``), damping ratio ``zeta = 1/2``: the roots at 120 degrees, where RK4's
#: region reaches 2.62 (less than the 2.83 of an undamped mode).
DAMPING = 0.5 * MASS * 4000.0
DAMPED_LIMIT = 2.6225 / 4000.0                     # 0.656 ms


def test_a_damped_modes_refusal_takes_its_damping_and_is_right():
    """Refused from 2.62 / omega (a step the undamped limit takes); just below it
    ``|R|^2 = 0.88`` a step, just above ``1.14``: the damped mode grows from nowhere."""
    damped = dict(scene(0.99 * LIMIT), model={"kind": "robot", "robot": taut(DAMPING)})
    with pytest.raises(SceneError, match=r"follows with steps up to 0\.000655 s"):     # 0.6556, rounded down
        load_scene(damped)
    load_scene(dict(damped, integrator={"max_step": 0.99 * DAMPED_LIMIT}))
    assert _kinetic_growth(taut(DAMPING), 0.98 * DAMPED_LIMIT) < 1e-3
    assert _kinetic_growth(taut(DAMPING), 1.02 * DAMPED_LIMIT) > 10.0


def test_the_cli_says_it_in_one_line_with_exit_2(tmp_path, capsys):
    path = tmp_path / "hung.yaml"
    path.write_text(yaml.safe_dump(scene()))
    assert main(["simulate", str(path), "-o", str(tmp_path / "out.csv"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "integrator.max_step" in err and "give integrator.max_step in (0, 0.000707] s" in err


#: A 1 kg rod 1 m long lying on a floor of stiffness 1e8 N/m (no damping, no friction): a cap
#: pressed into it moves with ``m_eff = 1 / (1/m + (L/2)^2 / I)`` of the rod, ``I = m L^2 / 12``
#: (a thin rod's, given), 0.25 kg, so it meets a
#: mode of at least ``sqrt(k / m_eff) = 2e4 rad/s`` (the rod on both caps rocks at ``sqrt(6 k
#: / m)``, bounces at ``sqrt(2 k / m)``), undamped as it touches, which RK4 follows with steps
#: up to ``2 sqrt 2 / 2e4 = 0.141 ms``.
FLOOR_K = 1e8
CAP_MASS = 1.0 / (1.0 / MASS + 0.25 / (MASS / 12))
FLOOR_LIMIT = 2 * np.sqrt(2) / np.sqrt(FLOOR_K / CAP_MASS)
LYING = {"name": "lying", "nodes": {"a": [0.0, 0.0, 0.01], "b": [1.0, 0.0, 0.01]},
         "rods": [{"name": "r", "nodes": ["a", "b"], "mass": MASS, "radius": 0.01, "cap_radius": 0.01,
                   "inertia": [MASS / 12, 5e-5]}],
         "cables": [{"name": "c", "nodes": ["a", "b"], "stiffness": 1.0, "rest_length": 2.0}],
         "gravity": [0.0, 0.0, -9.81],
         "floor": {"stiffness": FLOOR_K, "dissipation": 0.0, "mu_static": 0.0, "tangential_stiffness": 1.0}}


def floor_scene(step: float | None = None) -> dict:
    out = {"name": "lying", "model": {"kind": "robot", "robot": LYING}, "initial": {"drawn": True},
           "effects": ["inertia", "gravity", "cables", "contact"], "duration": 1.0}
    return out if step is None else dict(out, integrator={"max_step": step})


def test_a_step_too_long_for_the_floor_is_refused_in_one_line():
    with pytest.raises(SceneError, match=r"^integrator\.max_step: a fixed step of 0\.001 s \(the default\) is too "
                                         r"long for rod 'r' \(1 kg\): a cap pressed into the floor \(0\.25 kg of the "
                                         r"rod moving with it\) meets 1e\+08 N/m of contact stiffness, a mode of at "
                                         r"least 2e\+04 rad/s, which RK4 follows with steps up to 0\.000141 s; give "
                                         r"integrator\.max_step in \(0, 0\.000141\] s$"):
        load_scene(floor_scene())
    load_scene(floor_scene(0.99 * FLOOR_LIMIT))
    without_contact = dict(floor_scene(), effects=["inertia", "gravity", "cables"])
    load_scene(without_contact)                       # no floor force, nothing to follow
    with pytest.raises(SceneError, match=r"a cap sticking on the floor \(0\.167 kg of the rod moving with its contact "
                                         r"point, spinning it\) meets 1e\+08 N/m and 0 N s/m of friction anchor, a "
                                         r"mode of at least 2\.449e\+04 rad/s"):
        load_scene(dict(floor_scene(), effects=[
            "inertia", "gravity", "cables", {"contact": {"stiffness": 1.0}},
            {"friction": {"mu_static": 0.5, "tangential_stiffness": FLOOR_K}}]))


def test_the_floor_s_refusal_takes_the_cap_at_its_lightest_whatever_the_drawing():
    """A rod drawn standing on a cap (its axis along the floor's normal) would push the floor
    with its whole 1 kg, but it can fall and land flat, a cap then moving with 0.25 kg of it:
    the check takes that (the mode ``sqrt(k / 0.25 kg)``, steps up to 0.141 ms), not the
    drawing's 1 kg (0.283 ms)."""
    standing = dict(LYING, nodes={"a": [0.0, 0.0, 0.01], "b": [0.0, 0.0, 1.01]})
    scene = dict(floor_scene(0.2e-3), model={"kind": "robot", "robot": standing})
    with pytest.raises(SceneError, match=r"\(0\.25 kg of the rod moving with it\) .* give integrator\.max_step in "
                                         r"\(0, 0\.000141\] s$"):
        load_scene(scene)
    load_scene(dict(scene, integrator={"max_step": 0.99 * FLOOR_LIMIT}))


def test_the_floor_s_refusal_is_right():
    """Past the refused step the rod resting on its caps gains energy from nowhere (its
    rocking on both caps, ``sqrt(6 k / m)``, has ``h omega = 1.05 * 2.83 * sqrt(6/4) = 3.6``,
    beyond RK4's 2.83 on the imaginary axis): its tilt grows more than tenfold, until
    a cap leaves the floor and the steps split at its lift-offs and touch-downs, so it rattles
    on its caps with ten times its weight's sinking energy and more; well inside it (a tenth:
    ``h omega`` of the rocking mode about 0.35) it stays at rest to the sinking of its weight,
    its tilt and energy never above their start. Tilted 1e-7 rad (its caps 5e-8 m up and
    down), so that the rocking is there to grow."""
    def run(step: float, steps: int) -> NDArray:
        model = compile_scene(load_scene(floor_scene(0.5 * FLOOR_LIMIT)))
        y = model.y0.copy()
        y[model.plan.body_dof[0] + 4] = 1e-7                             # turned about y
        samples: list = []
        model.record(state_at_step(model, step, steps * step, y), np.arange(steps + 1) * step, samples)
        seen = model.observe(samples)
        return (seen["body_positions"][:, 0, 2], np.abs(seen["q"][:, 4]),
                seen["kinetic_energy"] + seen["potential_energy"])

    heights, tilt, energy = run(0.1 * FLOOR_LIMIT, 400)
    sink = MASS * 9.81 / (2 * FLOOR_K)                # 4.9e-8 m on each cap
    assert np.all(np.abs(heights - 0.01) <= 2.0 * sink + 5e-8 + 1e-12)    # and the raised cap's 5e-8 m
    assert tilt.max() <= 1e-7 * (1 + 1e-9) and energy.max() <= energy[0] * (1 + 1e-12)
    with np.errstate(all="ignore"):
        heights, tilt, energy = run(1.05 * FLOOR_LIMIT, 200)
    assert tilt.max() > 10 * 1e-7                                       # measured: 38 times
    assert energy.max() - energy[0] > 10 * MASS * 9.81 * sink           # measured: 56 times


#: A 1 kg rod of 1 m (radius 1 cm: ``I_t = 0.0856 kg m^2``) held along x between two points
#: pinned 1000 m beyond its caps by soft cables (``k = 1 N/m``) at ``T = 999 N``: moving along
#: them it meets only 2 N/m, but turned by ``theta`` each cap's arc shortens its cable by
#: ``theta^2 L / 4``, so the pair stores ``T L theta^2 / 2`` and the rod swings back to align
#: with them at ``omega = sqrt(T L / I_t) = 108 rad/s`` (their transverse stiffness ``T / l =
#: 1 N/m`` adds 0.05 %), undamped (the cables' lengths change only to second order in
#: ``theta``): RK4 follows it with steps up to ``2 sqrt 2 / 108 = 26.2 ms``.
T_PULL, TURN_I = 999.0, 0.0856008553
TURN_OMEGA = np.sqrt(T_PULL * 1.0 / TURN_I)
TURN_LIMIT = 2 * np.sqrt(2) / TURN_OMEGA
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
                                         r"which RK4 follows with steps up to 0\.0261 s; give integrator\.max_step in "
                                         r"\(0, 0\.0261\] s$"):
        load_scene(turning_scene(0.05))
    load_scene(turning_scene(0.99 * TURN_LIMIT))


def test_the_turning_refusal_is_right():
    """Turned 0.01 rad and let go: just below the refused step (0.98 of it, ``h omega =
    2.77``) the swing stays below its start's ``theta omega`` = 1.08 rad/s; just past the
    refusal (1.02 of it, ``h omega = 2.885``) it grows from nowhere, ``|R(2.885 i)| = 1.15``
    a step, past 10 times that within 2 s."""
    def swing(step: float, duration: float) -> float:
        model = compile_scene(load_scene(turning_scene(0.5 * TURN_LIMIT)))
        p = model.plan
        y = model.y0.copy()
        y[p.body_dof[0] + 5] = 0.01                                     # turned about z
        samples: list = []
        steps = int(duration / step)
        model.record(state_at_step(model, step, steps * step, y), np.arange(steps + 1) * step, samples)
        return max(abs(float(s[1][p.n_dof + p.body_dof[0] + 5])) for s in samples)

    assert swing(0.98 * TURN_LIMIT, 5.0) < 0.01 * TURN_OMEGA * 1.01
    assert swing(1.02 * TURN_LIMIT, 2.0) > 10 * 0.01 * TURN_OMEGA


#: The lying rod dropped 0.2 m onto a floor of 1e6 N/m with Hunt-Crossley dissipation 10 s/m:
#: it falls as one body and touches down at ``v = sqrt(2 g 0.2) = 1.98 m/s``, where the force
#: ``k delta (1 + d deltadot)`` stiffens to ``k (1 + d v) = 2.08e7 N/m``: on the cap's 0.25 kg
#: a mode of ``9.12e3 rad/s``, which RK4 follows with steps up to ``2 sqrt 2 / 9.12e3 = 0.31 ms``
#: (``k`` alone would allow 1.41 ms).
DROP_LIFT, DROP_K, DROP_D = 0.2, 1e6, 10.0
DROP_LIMIT = 2 * np.sqrt(2) / np.sqrt(DROP_K * (1 + DROP_D * np.sqrt(2 * 9.81 * DROP_LIFT)) / CAP_MASS)


def drop_scene(lift: float, step: float | None = None) -> dict:
    robot = dict(LYING, floor=dict(LYING["floor"], stiffness=DROP_K, dissipation=DROP_D))
    return dict(floor_scene(step), model={"kind": "robot", "robot": robot}, initial={"drawn": True, "lift": lift})


def test_a_dissipative_floor_s_refusal_takes_the_touch_down_speed():
    load_scene(drop_scene(0.0))                        # resting: 1.41 ms for k alone
    with pytest.raises(SceneError, match=r"a cap pressed into the floor \(0\.25 kg of the rod moving with it\) "
                                         r"meets 1e\+06 N/m of contact stiffness \(with its dissipation 10 s/m, "
                                         r"2\.081e\+07 N/m at up to 1\.98 m/s\), a mode of at least 9123 rad/s, "
                                         r"which RK4 follows with steps up to 0\.00031 s; give integrator\.max_step "
                                         r"in \(0, 0\.00031\] s$"):
        load_scene(drop_scene(DROP_LIFT))
    assert DROP_LIMIT == pytest.approx(3.1e-4, rel=1e-2)
    load_scene(drop_scene(DROP_LIFT, 3.1e-4))          # the step it suggests is accepted


def test_the_dissipative_floor_s_refusal_is_right():
    """At the 1 ms step the check took before it knew the touch-down speed, the bounce gains
    energy from nowhere (threefold); at the step it suggests the floor only takes energy.
    About 0.1 s of CPU."""
    def most_energy(step: float) -> float:
        model = compile_scene(load_scene(drop_scene(DROP_LIFT, 3.1e-4)))
        samples: list = []
        model.record(state_at_step(model, step, 0.4), np.arange(0.0, 0.4, step), samples)
        seen = model.observe(samples)
        energy = seen["kinetic_energy"] + MASS * 9.81 * seen["centre_of_mass"][:, 2]
        return float(energy.max() / energy[0])

    assert most_energy(3.1e-4) <= 1.0 + 1e-9
    assert most_energy(1e-3) > 3.0


#: The lying rod on a soft floor (1e4 N/m) with a stiff friction anchor (1e6 N/m, undamped,
#: ``mu = 1``): a tangential force across the rod at a contact point (``r = 0.01 m`` below its
#: cap's centre) moves the rod, turns it about the normal (lever ``L/2``) and spins it about
#: its axis (lever ``r``, ``I_a = 5e-5 kg m^2``): ``1 / m_eff = 1/m + (L/2)^2 / I_t + r^2 /
#: I_a = 1 + 3 + 2``, 0.167 kg, a mode of at least ``sqrt(6 k_t)`` = 2449 rad/s. Both caps
#: stuck, the rod's sideways slide with its spin (``2 k_t (1/m + r^2/I_a)``) and its turning
#: (``2 k_t (L/2)^2 / I_t``) are exactly that mode: RK4 follows it with steps up to
#: ``2 sqrt 2 / 2449`` = 1.155 ms. The check once took the whole rod's 1 kg (2.83 ms).
ANCHOR_K = 1e6
ANCHOR_LIMIT = 2 * np.sqrt(2) / np.sqrt(6 * ANCHOR_K)


def anchor_scene(step: float) -> dict:
    return {"name": "anchored", "model": {"kind": "robot", "robot": LYING}, "initial": {"drawn": True},
            "integrator": {"max_step": step}, "duration": 1.0,
            "effects": ["inertia", "gravity", "cables", {"contact": {"stiffness": 1e4}},
                        {"friction": {"mu_static": 1.0, "tangential_stiffness": ANCHOR_K,
                                      "tangential_damping": 0.0}}]}


def test_a_step_too_long_for_the_friction_anchor_is_refused_and_the_refusal_is_right():
    """Spun about its axis at 1e-4 rad/s (its caps' contact points 1 um/s across it, the
    anchors' force 1e-3 of the 4.9 N hold) the rod sticking on its caps rocks in the anchors'
    mode: at 0.98 of the refused step its kinetic energy never exceeds its start, at 1.02 of
    it (``|R(2.885 i)|^2 = 1.33`` a step) it grows tenfold within 100 steps. About 0.1 s."""
    with pytest.raises(SceneError, match=r"meets 1e\+06 N/m and 0 N s/m of friction anchor, a mode of at least "
                                         r"2449 rad/s, which RK4 follows with steps up to 0\.00115 s"):
        load_scene(anchor_scene(1.02 * ANCHOR_LIMIT))
    model = compile_scene(load_scene(anchor_scene(0.98 * ANCHOR_LIMIT)))

    def growth(step: float) -> float:
        p = model.plan
        y = model.y0.copy()
        y[p.body_dof[0] + 2] -= MASS * 9.81 / (2 * 1e4)                # at rest: each cap carries half the weight
        a0 = 2 * p.n_dof + len(p.motor_cable)
        y[a0 + 3 * len(p.cap_node):a0 + 4 * len(p.cap_node)] = STICKING  # anchored where they rest
        y[p.n_dof + p.body_dof[0] + 3] = 1e-4                          # spun about x, the rod's axis
        samples: list = []
        model.record(state_at_step(model, step, 100 * step, y), np.arange(101) * step, samples)
        kinetic = model.observe(samples)["kinetic_energy"]
        return float(kinetic.max() / kinetic[0])

    assert growth(0.98 * ANCHOR_LIMIT) <= 1.0 + 1e-6
    assert growth(1.02 * ANCHOR_LIMIT) > 10.0
