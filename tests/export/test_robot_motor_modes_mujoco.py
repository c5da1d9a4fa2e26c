"""The motor modes exported to MuJoCo do there what each mode means.

The robot is the tug of war of tests/robot/test_motor_modes.py with its anchors on a fixed
rigid body (MJCF rods cannot be pinned): a point mass ``p`` [0.5 kg] between a passive cable
``spring`` (k 200 N/m, rest 0.45 m) from ``a`` and a driven one ``drive`` (k 500 N/m, drawn
rest length 0.48 m, so 10 N as drawn) to ``b``, 1 m apart, no gravity. Numbers come from
the statics of two springs in series: at rest under a tension ``T`` in ``drive`` the spring
carries ``T`` too and is ``0.45 + T / 200`` long. MuJoCo's side is its own actuator
dynamics and integrator; the project's side (the same scene simulated) is compared where
the modes' definitions say the two agree.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.export import export_mjcf
from tensegrity_core.robot.loading import load_robot
from tensegrity_core.sim import load_scene, simulate

TUG = {"name": "tug", "units": "SI",
       "nodes": {"a": [0, 0, 0], "p": [0.5, 0, 0], "b": [1.0, 0, 0], "e": [0.5, 0.1, 0]},
       "rigid_bodies": [{"name": "frame", "nodes": ["a", "b", "e"], "mass": 1.0, "fixed": True}],
       "masses": {"p": 0.5},
       "cables": [{"name": "spring", "nodes": ["a", "p"], "stiffness": 200.0, "damping": 5.0, "rest_length": 0.45},
                  {"name": "drive", "nodes": ["p", "b"], "stiffness": 500.0, "damping": 5.0, "rest_length": 0.48,
                   "motor": {"range": [0.2, 0.6], "tau": 0.05, "max_speed": 0.1, "max_tension": 50.0}}]}


def tug_scene(mode, command, duration=5.0):
    return load_scene({"name": "tug", "model": {"kind": "robot", "robot": TUG}, "initial": {"drawn": True},
                       "effects": ["inertia", "cables", {"motors": {"modes": {"drive": mode}}}],
                       "inputs": {"drive": command}, "duration": duration, "output": {"rate": 100}})


def mujoco_tug(scene):
    import mujoco

    m = mujoco.MjModel.from_xml_string(export_mjcf(scene).xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("initial").id)
    return m, d


@pytest.mark.parametrize("tension", [5.0, 15.0, 40.0])
def test_a_tension_mode_cable_pulls_with_its_command_in_mujoco(tension):
    """Held as drawn (10 N) by the keyframe; commanded ``tension`` [N]: after 5 s the drive's
    actuator pulls with the command and the spring has stretched to carry it, where the
    project's run of the same scene puts it too."""
    import mujoco

    scene = tug_scene("tension", tension)
    m, d = mujoco_tug(scene)
    drive = m.actuator("cable:drive").id
    mujoco.mj_forward(m, d)
    assert d.actuator_force[drive] == pytest.approx(-10.0, abs=1e-12)
    d.ctrl[drive] = tension
    mujoco.mj_step(m, d, nstep=5000)
    spring = d.ten_length[m.tendon("cable:spring").id]
    assert d.actuator_force[drive] == pytest.approx(-tension, abs=1e-9)
    assert spring == pytest.approx(0.45 + tension / 200.0, abs=1e-6)
    run = simulate(scene)
    assert run.member_lengths[-1, run.member_names.index("spring")] == pytest.approx(spring, abs=1e-5)


def test_a_tension_mode_command_is_clamped_to_pulling_within_the_limit():
    """A push (-5 N) gives no force, 80 N the motor's 50 N limit (each after 2 s: 40 motor
    lags, the filtered command within 15 exp(-40) N of its end)."""
    import mujoco

    m, d = mujoco_tug(tug_scene("tension", 15.0))
    drive = m.actuator("cable:drive").id
    for command, force in ((-5.0, 0.0), (80.0, -50.0)):
        d.ctrl[drive] = command
        mujoco.mj_step(m, d, nstep=2000)
        assert d.actuator_force[drive] == pytest.approx(force, abs=1e-9)


@settings(max_examples=15, deadline=None)
@given(tension=st.floats(0.0, 50.0), speed=st.floats(-0.1, 0.1))
def test_every_accepted_command_does_what_its_mode_means_in_mujoco(tension, speed):
    """Over each mode's whole command range ([0, 50] N, [-0.1, 0.1] m/s): a tension-mode
    cable pulls with the command after 3 s (60 motor lags) and the spring in series carries
    it (length ``0.45 + T / 200`` from 5 N up, where it never goes slack); a reel's rest length is
    ``clip(0.48 + u t, 0.2, 0.6)`` after 3 s."""
    import mujoco

    m, d = mujoco_tug(tug_scene("tension", 10.0))
    d.ctrl[m.actuator("cable:drive").id] = tension
    mujoco.mj_step(m, d, nstep=3000)
    assert d.actuator_force[m.actuator("cable:drive").id] == pytest.approx(-tension, abs=1e-9)
    if tension >= 5.0:     # the spring stays taut (from 10 N it overshoots by 0.44 of the step: damping
        # ratio 5 / (2 sqrt(200 x 0.5)) = 0.25) and is linear: 3 s decay it by exp(-15)
        assert d.ten_length[m.tendon("cable:spring").id] == pytest.approx(0.45 + tension / 200.0, abs=1e-6)
    m, d = mujoco_tug(tug_scene("reel_speed", 0.0))
    d.ctrl[m.actuator("cable:drive").id] = speed
    mujoco.mj_step(m, d, nstep=3000)
    assert d.act[0] == pytest.approx(np.clip(0.48 + speed * 3.0, 0.2, 0.6), abs=1e-12)


def test_a_reel_speed_motor_moves_its_rest_length_at_that_speed_in_mujoco():
    """Paid out at 0.05 m/s: MuJoCo's activation (the rest length) is ``0.48 + 0.05 t`` [m]
    until the range's end (0.6 m) as in the project, and while the cable is taut the force
    is minus the cable law ``k (l - l0) + c dl/dt`` on that rest length."""
    import mujoco

    scene = tug_scene("reel_speed", 0.05, duration=3.0)
    m, d = mujoco_tug(scene)
    drive, tendon = m.actuator("cable:drive").id, m.tendon("cable:drive").id
    d.ctrl[drive] = 0.05
    rest, taut = [], 0
    for _ in range(3000):
        mujoco.mj_step(m, d)
        rest.append(d.act[0])
        mujoco.mj_forward(m, d)
        pull = 500.0 * (d.ten_length[tendon] - d.act[0]) + 5.0 * d.ten_velocity[tendon]
        if pull > 0:
            taut += 1
            assert d.actuator_force[drive] == pytest.approx(-pull, abs=1e-9)
    t = np.arange(1, 3001) * 1e-3
    np.testing.assert_allclose(rest, np.clip(0.48 + 0.05 * t, 0.2, 0.6), rtol=0, atol=1e-12)
    assert taut > 500
    run = simulate(scene)
    np.testing.assert_allclose(run.applied_forces[1:, 0], np.array(rest)[9::10], rtol=0, atol=1e-12)


def test_each_mode_exports_its_own_actuator():
    """rest_length: a position actuator on the tendon; reel_speed: an integrator limited to
    the range; tension: a force actuator (gain -1) limited to [0, T_max]; the mode of the
    robot file as well as the scene's."""
    xml = {mode: export_mjcf(tug_scene(mode, command)).xml
           for mode, command in (("rest_length", 0.45), ("reel_speed", 0.0), ("tension", 10.0))}
    assert '<position name="cable:drive"' in xml["rest_length"]
    assert 'dyntype="integrator"' in xml["reel_speed"] and 'actrange="0.2 0.6"' in xml["reel_speed"]
    assert 'gainprm="-1"' in xml["tension"] and 'ctrlrange="0.0 50.0"' in xml["tension"]
    own = copy.deepcopy(TUG)
    own["cables"][1]["motor"]["mode"] = "reel_speed"
    assert 'dyntype="integrator"' in export_mjcf(load_robot(own)).xml


@pytest.mark.parametrize("h", [1e-3, 5e-4])
def test_a_sampled_motor_pulls_off_mujocos_by_half_a_step_of_its_reel(h):
    """The project's motor is sampled: its rest length ``l0`` holds through a step's RK4
    stages and jumps at its end, where MuJoCo's activation moves within the step. Over a
    step the cable pulls as with ``l0`` half a step late, and a sample pairs the length that
    resulted with the new ``l0``: the tension differs from MuJoCo's by ``-k r h / 2`` (``r`` =
    dl0/dt of the lag) plus half a step of the tension's own change, which here (the length
    following ``l0`` through the stiff rods) is 1-2 % of it (docs/mujoco.md, robots)."""
    import mujoco

    robot = load_robot("three_bar")
    k, tau, drawn, command = robot.cables.stiffness[0], robot.motors.tau[0], robot.cables.rest_length[0], 0.40
    scene = load_scene({"name": "reel", "model": {"kind": "robot", "robot": "three_bar"}, "initial": {"drawn": True},
                        "inputs": {"td_0": {"law": "constant", "value": command}},
                        "effects": ["inertia", "cables", "motors"], "duration": 0.3,
                        "integrator": {"method": "RK4", "max_step": h}, "output": {"rate": 10}})
    run = simulate(scene)
    m, d = mujoco_tug(scene)
    drive = m.actuator("cable:td_0").id
    for t, tension in zip(run.times[1:], run.member_forces[1:, run.member_names.index("td_0")]):
        mujoco.mj_step(m, d, nstep=int(round((t - d.time) / h)))
        mujoco.mj_forward(m, d)                             # the force at t (mj_step's is the step's start)
        rate = (command - (drawn + (command - drawn) * (1 - np.exp(-t / tau)))) / tau
        assert abs(rate) > 0.05                             # the motor is reeling in, 0.069-0.085 m/s
        assert tension + d.actuator_force[drive] == pytest.approx(-k * rate * h / 2, rel=0.05)
