"""Friction never adds energy in whole runs over the accepted range (issue 29).

The three-bar robot dropped in any orientation onto a lossless floor (no dissipation,
undamped cables) with friction, over the accepted range of rod mass, floor stiffness,
friction coefficients, anchor stiffness and damping and drop height (a step the scene check
refuses is replaced by the longest it allows), never gains more over a step than RK4's local
error on its smooth pieces, ``(h omega)^5 / 120`` of the energy of motion
(tests/robot/test_touch_down_energy.py), ``omega`` now also bounding the anchor's mode on the
contact point's effective mass ``1 / m_t = 1/m + (L/2)^2 / I_t + r^2 / I_a`` (the rod spun
about its axis by the force at its cap's contact point). The light robots' rise of up to
4.7e-3 J in a step at 1 ms was the anchor's damper on that mode (``h c_t / m_t`` up to 9.8,
beyond RK4's reach), which the scene check now refuses (docs/design/robots.md, "Light
robots with friction").

Cost: 8 drops, ~2 s (``--durations``).
"""

from __future__ import annotations

import re

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.sim import SceneError, compile_scene, load_scene

from .test_parameter_range import BASE, CAP, G, decades, robot
from .test_touch_down_energy import local_error, rotations, turned

DURATION = 0.3
#: At most this many steps of a drop (the check's step can be short for a light rod).
STEPS = 2000


def friction_drop(mass: float, k_floor: float, lift: float, rotvec: list[float], mu_s: float, mu_k: float,
                  k_t: float, c_t: float):
    """``(energies per step, the energy of motion [J], a bound [rad/s] of the fastest root,
    the step [s])`` of the three-bar robot (cables 2000 N/m, undamped) dropped onto a lossless
    floor with friction, at 1 ms or the longest step the scene check allows, for at most
    :data:`STEPS` steps: drawn touching the floor and falling at ``sqrt(2 g lift)``, the speed
    of a drop from ``lift`` [m]."""
    description = turned(robot(mass, 2000.0, 0.0, k_floor, 0.0, mu_k), rotvec)
    description["floor"].update(mu_static=mu_s, tangential_stiffness=k_t, tangential_damping=c_t)
    data = {"name": "drop", "model": {"kind": "robot", "robot": description},
            "initial": {"drawn": True}, "duration": DURATION,
            "effects": ["inertia", "cables", "gravity", "contact", "friction"]}
    try:
        model = compile_scene(load_scene(data))
    except SceneError as err:
        longest = re.search(r"give integrator\.max_step in \(0, (\S+)\] s$", str(err))
        assert longest, str(err)
        model = compile_scene(load_scene(dict(data, integrator={"max_step": float(longest.group(1))})))
    h = model.step
    steps = min(int(DURATION / h), STEPS)
    y = model.y0.copy()
    speed = np.sqrt(2.0 * G * lift)
    y[model.plan.n_dof + model.plan.body_dof + 2] = -speed            # every rod's centre falling
    samples: list = []
    model.record(model.state_from(y, t_end=steps * h), np.arange(steps + 1) * h, samples)
    seen = model.observe(samples)
    energy = seen["kinetic_energy"] + seen["potential_energy"]
    lengths, rest = seen["member_lengths"][0, 3:], seen["member_rest_lengths"][0, 3:]
    stiffness = np.array([2000.0] * 6 + [200.0] * 3)
    motion = 3 * mass * (G * (seen["centre_of_mass"][0, 2] - CAP) + speed**2 / 2) + float(
        np.sum(0.5 * stiffness * np.maximum(lengths - rest, 0.0) ** 2))
    rod = BASE["rods"][0]
    I_t, I_a = (i * mass / rod["mass"] for i in rod["inertia"])
    half = 0.5 * float(np.linalg.norm(np.subtract(*(description["nodes"][n] for n in rod["nodes"]))))
    m_cap = 1.0 / (1.0 / mass + half**2 / I_t)
    m_point = 1.0 / (1.0 / mass + half**2 / I_t + CAP**2 / I_a)      # the contact point, across the axis
    omega = max(np.sqrt((k_floor + 4 * 2000.0 + 2 * 200.0) / m_cap), np.sqrt(k_t / m_point), c_t / m_point)
    return energy, motion, float(omega), h


@settings(max_examples=8, deadline=None)
@given(mass=decades(0.05, 50), k_floor=decades(1e3, 1e6), lift=st.floats(0.0, 0.3), rotvec=rotations,
       mu_a=st.sampled_from([0.0, 0.3, 1.0, 2.0]), mu_b=st.sampled_from([0.0, 0.3, 1.0, 2.0]),
       k_t=decades(1e3, 1e6), c_t=st.one_of(st.just(0.0), decades(1.0, 1e3)))
def test_a_drop_with_friction_never_gains_beyond_rk4_s_local_error(mass, k_floor, lift, rotvec, mu_a, mu_b, k_t,
                                                                    c_t):
    energy, motion, omega, h = friction_drop(mass, k_floor, lift, rotvec, max(mu_a, mu_b), min(mu_a, mu_b), k_t,
                                             c_t)
    assert np.diff(energy).max() <= local_error(h, omega, motion, energy), (np.diff(energy).max(), h * omega)
