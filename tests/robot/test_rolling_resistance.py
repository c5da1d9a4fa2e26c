"""The caps' rolling and spin resistance (:mod:`tensegrity_core.robot.contact`): the couple
only takes energy out and is limited by ``b F_n`` (hypothesis over the accepted ranges); a
rod spinning flat on a frictionless floor and a rod rolling on its caps slow down at the
rates derived here from the angular momentum balance; a negative lever arm is one line."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.robot.contact import SPIN_TOLERANCE, resisting_couple
from tensegrity_core.sim import SceneError, compile_scene, load_scene

G = 9.81


@given(st.tuples(*[st.floats(-50.0, 50.0)] * 3), st.floats(0.0, 1e4), st.floats(0.0, 0.01), st.floats(0.0, 0.05),
       st.floats(0.0, 1.5))
def test_the_couple_only_takes_energy_out_and_is_limited_by_b_times_the_normal_force(w, F_n, rolling, torsional,
                                                                                      incline):
    n = np.array([-np.sin(incline), 0.0, np.cos(incline)])
    w = np.array(w)
    M = resisting_couple(w, F_n, n, rolling, torsional)
    assert float(M @ w) <= 0.0
    spin, roll = float(M @ n), M - (M @ n) * n
    # of the projections onto n here; at subnormal sizes (a lever of 2e-311 m) a product
    # rounds to a multiple of the smallest subnormal, not to a relative error
    rounding = 1e-12 * (rolling + torsional) * F_n + 4 * np.finfo(float).smallest_subnormal
    assert abs(spin) <= torsional * F_n + rounding
    assert np.linalg.norm(roll) <= rolling * F_n + rounding
    w_n = float(w @ n)
    if abs(w_n) >= SPIN_TOLERANCE:                       # above the regularisation: the full Coulomb couple
        assert abs(spin + np.sign(w_n) * torsional * F_n) <= rounding


ROD = {"mass": 1.0, "radius": 0.01, "cap_radius": 0.05, "inertia": [0.1, 0.001]}


def rod_on_the_floor(friction: dict, duration: float):
    """A 1 kg rod 1 m long (inertia 0.1 kg m^2 across, 0.001 kg m^2 about its axis) lying
    along x on its two caps, with the given floor friction override."""
    robot = {"name": "rod", "nodes": {"a": [-0.5, 0.0, 0.05], "b": [0.5, 0.0, 0.05]},
             "rods": [{"name": "r", "nodes": ["a", "b"], **ROD}],
             "cables": [{"name": "c", "nodes": ["a", "b"], "stiffness": 1.0, "rest_length": 1.5}],   # slack
             "floor": {"stiffness": 1.0e6, "dissipation": 1.0, "mu_static": 1.0,
                       "tangential_stiffness": 1.0e5, "tangential_damping": 10.0}}
    scene = load_scene({"name": "rod", "model": {"kind": "robot", "robot": robot}, "initial": {"drawn": True},
                        "effects": ["inertia", "cables", "gravity", "contact", {"friction": friction}], "duration": duration})
    return compile_scene(scene)


def turning(model, w0, duration: float):
    """The rod's angular velocities [rad/s] (world) at 0, 0.1, .., ``duration`` [s] from
    resting on its caps (sunk to carry its weight) turning at ``w0`` (3,) [rad/s] and moving
    with it as it would roll (centre at ``w0 x (0, 0, r)``)."""
    p = model.plan
    y = model.y0.copy()
    n, d = p.n_dof, p.body_dof[0]
    y[d + 2] -= G * ROD["mass"] / 2 / 1.0e6              # each cap carries half the weight
    y[n + d + 3:n + d + 6] = w0
    y[n + d:n + d + 3] = np.cross(w0, [0.0, 0.0, ROD["cap_radius"]])
    state = model.state_from(y, t_end=duration)
    samples: list = []
    model.record(state, np.linspace(0.0, duration, round(duration * 10) + 1), samples)
    return model.observe(samples)["body_angular_velocities"][:, 0]


def test_a_rod_spinning_flat_on_a_frictionless_floor_slows_at_b_s_m_g_over_its_inertia():
    """Spin couple ``b_s F_n`` at each cap, ``F_n = m g / 2``: ``I w' = -b_s m g`` about the
    vertical. No sliding friction (``mu = 0``: the anchor's force is 0 at every stage): the
    caps circle freely."""
    b_s, w0, t = 0.005, 2.0, 2.0
    model = rod_on_the_floor({"mu_static": 0.0, "tangential_stiffness": 0.01, "tangential_damping": 0.0,
                              "rolling_friction": 0.0, "torsional_friction": b_s}, t)
    w = turning(model, np.array([0.0, 0.0, w0]), t)
    expected = w0 - b_s * ROD["mass"] * G / ROD["inertia"][0] * np.linspace(0.0, t, len(w))   # to 1.019 rad/s
    np.testing.assert_allclose(w[:, 2], expected, rtol=2e-3)
    assert np.abs(w[:, :2]).max() < 1e-6


def test_a_rod_rolling_on_its_caps_slows_at_b_r_m_g_over_its_inertia_about_the_floor():
    """Rolling without slipping about its axis (x) at ``w``, centre at ``w r``: kinetic
    energy ``(m r^2 + I_a) w^2 / 2``, rolling couple ``b_r F_n`` at each cap, so
    ``(m r^2 + I_a) w' = -b_r m g``."""
    b_r, w0, t = 0.001, 10.0, 2.0
    model = rod_on_the_floor({"rolling_friction": b_r, "torsional_friction": 0.0}, t)
    w = turning(model, np.array([w0, 0.0, 0.0]), t)
    inertia = ROD["mass"] * ROD["cap_radius"] ** 2 + ROD["inertia"][1]
    expected = w0 - b_r * ROD["mass"] * G / inertia * np.linspace(0.0, t, len(w))           # to 4.39 rad/s
    np.testing.assert_allclose(w[:, 0], expected, rtol=5e-3)


@pytest.mark.parametrize("key", ["rolling_friction", "torsional_friction"])
def test_a_negative_lever_arm_is_one_line(key):
    with pytest.raises(SceneError, match=rf"^effects\[3\]\.friction\.{key}: must be >= 0 m, got -0.1 m$"):
        load_scene({"name": "s", "model": {"kind": "robot", "robot": "six_bar"}, "initial": {"drawn": True},
                    "duration": 1.0, "effects": ["inertia", "cables", "contact", {"friction": {key: -0.1}}]})
