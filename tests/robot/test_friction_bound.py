"""Coulomb's bound inside every step: every evaluated friction force obeys ``|F_t| <= mu_s
F_n`` where the cap sticks (spring and damper together) and is exactly ``mu_k F_n`` where it
slips, in the friction model and in both robot kernels; the force's power is the rate of the
anchor's potential less the damper's loss (energy never rises inside a step); with ``mu = 0``
the floor is frictionless at every stage (a robot sliding on it keeps its tangential
momentum to rounding). Hypothesis over the accepted ranges (``mu_s >= mu_k >= 0``; sizes 0 or
above 1e-12 of their units)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.robot import friction
from tensegrity_core.sim import compile_scene
from tensegrity_core.sim.general.kernels.jit import have_numba
from tensegrity_core.sim.general.kernels.plan import constant
from tensegrity_core.sim.general.robot.loops import SLIPPING, STICKING
from tensegrity_core.sim.general.robot.system import RobotSystem
from tests.robot.test_dynamics import _model, random_state, robot_scene

# among the suite's longest files: ./run test starts them first (tests/conftest.py)
pytestmark = pytest.mark.slow


def _size(lo: float, hi: float, signed: bool = False):
    """0 or a magnitude in [lo, hi] (with either sign): physical sizes, none so small that
    their squares underflow (a force of 1e-300 N is no test of Coulomb's bound)."""
    size = st.floats(lo, hi)
    return st.one_of(st.just(0.0), size, size.map(lambda x: -x) if signed else size)


vec = st.tuples(_size(1e-12, 1e-2, True), _size(1e-12, 1e-2, True))
vel = st.tuples(_size(1e-9, 100.0, True), _size(1e-9, 100.0, True))
mus = _size(1e-9, 3.0)
coefficients = dict(s2=vec, v2=vel, F_n=_size(1e-9, 1e4), k_t=st.floats(1.0, 1e7), c_t=_size(1e-9, 1e3), mu_a=mus,
                    mu_b=mus, slipping=st.booleans())


def _force(s2, v2, F_n, k_t, c_t, mu_a, mu_b, slipping):
    mu_s, mu_k = max(mu_a, mu_b), min(mu_a, mu_b)
    s = np.array([s2[0], s2[1], 0.0])
    v = np.array([v2[0], v2[1], 0.0])
    F = friction.stage_force(s, v, F_n, k_t, c_t, mu_s, mu_k, slipping)
    hold = (mu_k if slipping else mu_s) * F_n
    return s, v, F, mu_s, mu_k, hold, k_t * float(np.sqrt(s @ s)) <= hold and hold > 0.0


@given(**coefficients)
def test_every_evaluated_friction_force_obeys_coulomb(s2, v2, F_n, k_t, c_t, mu_a, mu_b, slipping):
    s, v, F, mu_s, mu_k, hold, sticks = _force(s2, v2, F_n, k_t, c_t, mu_a, mu_b, slipping)
    size = math.hypot(*F)                            # (scaled: no underflow of |F|^2)
    if sticks:
        assert size <= hold * (1 + 1e-12) + 1e-300
    elif float(s @ s) > 0.0:                         # kinetic friction against the offset
        assert abs(size - mu_k * F_n) <= 1e-12 * mu_k * F_n + 1e-300
        assert float(F @ s) <= 0.0 and abs(F[0] * s[1] - F[1] * s[0]) <= 1e-12 * size * float(np.linalg.norm(s))
    if mu_s == 0.0 or F_n == 0.0:
        assert np.all(F == 0.0)


@given(**coefficients)
def test_the_force_s_power_is_the_anchor_potential_s_rate_less_a_loss(s2, v2, F_n, k_t, c_t, mu_a, mu_b, slipping):
    """``F . v <= -k_t phi s . v`` (``phi = 1`` inside the hold, ``mu_k F_n / (k_t |s|)``
    beyond: the rate of the potential ``psi``, friction.py): a step never gains energy."""
    s, v, F, _, mu_k, _, sticks = _force(s2, v2, F_n, k_t, c_t, mu_a, mu_b, slipping)
    size = float(np.linalg.norm(s))
    phi = 1.0 if sticks else mu_k * F_n / (k_t * size) if size > 0.0 else 0.0   # (0: no hold, no force)
    rate = -k_t * phi * float(s @ v)
    assert float(F @ v) <= rate + 1e-12 * max(1.0, abs(rate), float(np.linalg.norm(F) * np.linalg.norm(v)))


@pytest.mark.parametrize("kernels", [pytest.param("numba", marks=pytest.mark.skipif(
    not have_numba(), reason="the compiled kernels need numba (the 'fast' extra)")), "numpy"])
@settings(max_examples=30)
@given(robot=st.sampled_from(["three_bar", "six_bar"]), seed=st.integers(0, 2**32 - 1), mu_a=mus, mu_b=mus,
       c_t=st.floats(0.0, 1e3), offset=st.floats(1e-5, 1e-2))
def test_the_kernels_friction_obeys_coulomb_at_every_state(kernels, robot, seed, mu_a, mu_b, c_t, offset):
    """Random states (caps in and out of the floor, offsets of any size, sticking and
    slipping, velocities of order 1 m/s): each cap's friction within its step's hold."""
    model = _model(robot)
    mu_s, mu_k = max(mu_a, mu_b), min(mu_a, mu_b)
    params = model.plan.floor_params.copy()
    params[2], params[3], params[5] = mu_s, mu_k, c_t
    # read-only, as every plan's arrays: a writable one is another numba signature, compiled
    # anew (~30 s of CPU) in each process instead of loaded from the cache
    plan = model.plan._replace(floor_params=constant(params))
    y, R_ref = random_state(model, seed)
    ncap = len(plan.cap_node)
    a0 = 2 * plan.n_dof + len(plan.motor_cable)
    y[a0:a0 + 3 * ncap] *= offset / 0.003
    ev = RobotSystem(plan, laws=model.system.laws, R_ref=R_ref, kernels=kernels).evaluate(y[None])
    state = y[a0 + 3 * ncap:]
    mu = np.where(state == STICKING, mu_s, np.where(state == SLIPPING, mu_k, 0.0))
    size = np.linalg.norm(ev.friction[0], axis=1)
    assert np.all(size <= mu * ev.normal[0] * (1 + 1e-12) + 1e-12)


def test_a_robot_sliding_on_a_frictionless_floor_keeps_its_tangential_momentum():
    """The 3-bar dropped 2 cm at 2 m/s along x onto a floor with ``mu_s = mu_k = 0``: the
    floor's forces are normal (its rolling and spin couples are moments), so the horizontal
    momentum stays ``M 2 m/s`` to rounding through the landing and the sliding (6x the speed
    at which the anchor's spring outran ``mu_k F_n``)."""
    scene = robot_scene("three_bar", ["inertia", "cables", "gravity", "contact",
                                      {"friction": {"mu_static": 0.0, "mu_kinetic": 0.0}}], lift=0.02, duration=0.4)
    model = compile_scene(scene)
    p = model.plan
    assert len(p.free_node) == 0                                     # every mass is on a rod
    y = model.y0.copy()
    n = p.n_dof
    for d in p.body_dof:
        y[n + d] = 2.0
    samples: list = []
    model.record(model.state_from(y, t_end=0.4), np.arange(0, 401, 10) * 1e-3, samples)
    o = model.observe(samples)
    assert o["contact_forces"][-1].max() > 0.0                       # it landed and slides on its caps
    momentum = np.einsum("b,tbi->ti", p.body_mass, o["body_velocities"])
    M = p.body_mass.sum()
    np.testing.assert_allclose(momentum[:, :2], np.tile([2.0 * M, 0.0], (len(momentum), 1)), rtol=0, atol=1e-12 * M)
