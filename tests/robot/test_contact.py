"""Floor contact and friction: forces never pull, energy never rises (hypothesis over the
accepted ranges), the normal force's derivatives against central differences, a cap held
still below static friction and sliding with kinetic friction above it."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.robot import contact, friction

stiff = st.floats(1.0, 1e8)
dissip = st.floats(0.0, 1e3)
depth = st.floats(-0.1, 0.1)
speed = st.floats(-100.0, 100.0)
mus = st.floats(0.0, 3.0)


@given(depth, speed, stiff, dissip)
def test_normal_force_never_pulls_and_never_adds_energy(delta, rate, k, d):
    F = float(contact.normal_force(delta, rate, k, d))
    assert F >= 0.0
    if delta <= 0.0:
        assert F == 0.0
    power = (k * max(delta, 0.0) - F) * rate            # dV/dt - F deltadot
    assert power <= 1e-9 * max(1.0, abs(k * delta * rate))


def test_normal_force_is_continuous_at_touch_down_and_the_spring_at_rest():
    for rate in (-5.0, 0.0, 5.0):                                # F -> 0 with delta, whatever the speed
        assert float(contact.normal_force(0.0, rate, 1e5, 3.0)) == 0.0
        assert float(contact.normal_force(1e-12, rate, 1e5, 3.0)) <= 1e5 * 1e-12 * 16.0
    k, W = 2.0e5, 60.0
    assert abs(float(contact.normal_force(W / k, 0.0, k, 5.0)) - W) < 1e-12 * W   # rests W / k deep (0.3 mm)


def test_the_normal_force_at_rest_is_the_contact_energy_s_derivative():
    delta = np.linspace(-1e-3, 2e-3, 31)
    h = 1e-9
    dV = (contact.contact_energy(delta + h, 2e5) - contact.contact_energy(delta - h, 2e5)) / (2 * h)
    np.testing.assert_allclose(contact.normal_force(delta, 0.0, 2e5, 5.0), dV, atol=1e-4)


def test_normal_force_derivatives_match_central_differences():
    rng = np.random.default_rng(4)
    delta = rng.uniform(1e-4, 1e-2, 30)
    rate = rng.uniform(-0.1, 0.1, 30)
    k, d = 1e5, 2.0
    by_delta, by_rate = contact.normal_force_derivatives(delta, rate, k, d)
    h = 1e-9
    np.testing.assert_allclose(by_delta, (contact.normal_force(delta + h, rate, k, d)
                                          - contact.normal_force(delta - h, rate, k, d)) / (2 * h), rtol=1e-6)
    h = 1e-7
    np.testing.assert_allclose(by_rate, (contact.normal_force(delta, rate + h, k, d)
                                         - contact.normal_force(delta, rate - h, k, d)) / (2 * h), rtol=1e-6)


def test_penetration_on_an_inclined_floor():
    n = contact.floor_normal(np.deg2rad(30.0), 0.0)            # rises towards +x
    assert abs(np.linalg.norm(n) - 1.0) < 1e-15
    x = np.array([[2.0, 0.0, 2.0 * np.tan(np.deg2rad(30.0)) + 0.05 / np.cos(np.deg2rad(30.0))]])
    delta, rate = contact.penetration(x, [[0.0, 0.0, -1.0]], 0.06, n, [0, 0, 0])
    np.testing.assert_allclose(delta, [0.01], atol=1e-12)       # 5 cm above the slope, radius 6 cm
    np.testing.assert_allclose(rate, [np.cos(np.deg2rad(30.0))])


vec = st.tuples(st.floats(-1e-2, 1e-2), st.floats(-1e-2, 1e-2))
vel = st.tuples(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0))


@given(vec, vel, st.floats(0.0, 1e4), st.floats(1e-4, 1e-2), st.floats(1.0, 1e7), st.floats(0.0, 1e3), mus, mus,
       st.booleans())
def test_a_friction_step_never_adds_energy(s2, v2, F_n, dt, k_t, c_t, mu_a, mu_b, slipping):
    mu_s, mu_k = max(mu_a, mu_b), min(mu_a, mu_b)
    s = np.array([[s2[0], s2[1], 0.0]])
    v = np.array([[v2[0], v2[1], 0.0]])
    new, F, _ = friction.friction_step(s, v, F_n, dt, k_t, c_t, mu_s, mu_k, slipping)
    work = float(np.sum(F * v) * dt)                            # on the cap, over the step
    before = float(friction.anchor_energy(s, k_t)[0])
    stored = float(friction.anchor_energy(new, k_t)[0]) - before
    assert work + stored <= 1e-12 * max(1.0, before, k_t * float(np.sum(v * v)) * dt * dt)
    assert float(np.linalg.norm(new)) * k_t <= mu_s * F_n * (1 + 1e-12) + 1e-12 or F_n == 0.0


def _slide(load, mu_s, mu_k, steps=3000, dt=1e-3):
    """A 2 kg point on a flat floor (weight carried, F_n = m g) pushed along x by ``load`` [N],
    ramped up over the first 0.5 s, from rest; semi-implicit Euler at 1 kHz with the friction
    step."""
    m, g, k_t, c_t = 2.0, 9.81, 2.0e5, 300.0
    x = v = 0.0
    s = np.zeros((1, 3))
    slipping = np.zeros(1, dtype=bool)
    xs = []
    for i in range(steps):
        s, F, slipping = friction.friction_step(s, [[v, 0.0, 0.0]], m * g, dt, k_t, c_t, mu_s, mu_k, slipping)
        v += dt * (load * min(1.0, i * dt / 0.5) + F[0, 0]) / m
        x += dt * v
        xs.append(x)
    return np.array(xs), v, bool(slipping[0])


def test_a_cap_below_static_friction_stays_put():
    """15 N against mu_s m g = 19.6 N: the cap moves only the anchor's elastic offset
    (load / k_t = 0.075 mm) and comes to rest; a regularised law would creep on."""
    xs, v, slipping = _slide(15.0, 1.0, 0.8)
    assert not slipping
    assert abs(xs[-1] - 15.0 / 2.0e5) < 1e-9
    assert abs(v) < 1e-9
    assert np.ptp(xs[-1000:]) < 1e-12


def test_a_cap_above_static_friction_slides_with_kinetic_friction():
    """25 N > mu_s m g: it breaks loose and accelerates at (25 - mu_k m g) / m = 4.652 m/s^2."""
    xs, v, slipping = _slide(25.0, 1.0, 0.8)
    assert slipping
    a = np.diff(xs[-200:], 2).mean() / 1e-6
    assert abs(a - (25.0 - 0.8 * 2.0 * 9.81) / 2.0) < 1e-6
