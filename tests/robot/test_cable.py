"""The cable element: tension only for every input, never adds energy, the statics' string at
rest, and its force Jacobians against central differences."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.general import Structure, member_forces
from tensegrity_core.robot import cable

# The accepted range of the robot descriptions: stiffness and damping > 0 (damping >= 0),
# rest lengths > 0, limits > 0 (inf for passive cables); lengths and rates any.
lengths = st.floats(1e-3, 10.0)
rates = st.floats(-50.0, 50.0)
stiffness = st.floats(1e-2, 1e7)
damping = st.floats(0.0, 1e4)
limits = st.one_of(st.just(np.inf), st.floats(1e-2, 1e5))


@given(lengths, rates, lengths, stiffness, damping, limits)
def test_tension_only_for_every_input(l, ldot, l0, k, c, t_max):
    T = float(cable.tension(l, ldot, l0, k, c, t_max))
    assert 0.0 <= T <= t_max
    if l <= l0:
        assert T == 0.0                                   # slack: neither spring nor damper


@given(lengths, rates, lengths, stiffness, damping, limits)
def test_a_cable_never_adds_energy(l, ldot, l0, k, c, t_max):
    """dV/dt - T ldot = (k (l - l0)^+ - T) ldot <= 0 at a fixed rest length, with the motor's
    payout keeping k (l - l0) <= t_max (the state an actuated cable is always in)."""
    l = min(l, l0 + t_max / k)
    T = float(cable.tension(l, ldot, l0, k, c, t_max))
    power = (k * max(l - l0, 0.0) - T) * ldot
    assert power <= 1e-9 * max(1.0, abs(k * (l - l0) * ldot), abs(c * ldot * ldot))   # rounding of l


def test_at_rest_it_is_the_statics_string():
    """With ldot = 0 the element gives the forces the statics computes for strings of
    EA = k l0 (one model for "which rest lengths hold this shape" and the dynamics)."""
    rng = np.random.default_rng(1)
    m = 40
    nodes = rng.normal(size=(2 * m, 3))
    pairs = np.arange(2 * m).reshape(m, 2)
    l = np.linalg.norm(nodes[pairs[:, 1]] - nodes[pairs[:, 0]], axis=1)
    l0 = l * rng.uniform(0.7, 1.3, m)                     # half taut, half slack
    k = rng.uniform(10.0, 1e4, m)
    s = Structure.from_arrays(nodes, pairs, EA=cable.statics_EA(k, l0), rest_lengths=l0, kinds="string",
                              pinned=np.ones(2 * m, dtype=bool))
    np.testing.assert_allclose(cable.tension(l, 0.0, l0, k, 5.0), member_forces(s, nodes), rtol=1e-12, atol=1e-9)


def test_the_damper_switches_on_with_tautness_and_never_pushes():
    k, c, l0 = 1000.0, 50.0, 1.0
    assert cable.tension(1.0, 2.0, l0, k, c) == 0.0                       # at l0: slack
    assert abs(cable.tension(1.0 + 1e-9, 2.0, l0, k, c) - c * 2.0) < 1e-5   # just taut: the damper at once
    assert cable.tension(1.001, -1.0, l0, k, c) == 0.0                    # k dl = 1 N < c |ldot| = 50 N: no push
    assert cable.tension(1.1, 0.5, l0, k, c, t_max=80.0) == 80.0          # the motor's limit


def _random_taut_states(n, seed):
    rng = np.random.default_rng(seed)
    xa = rng.normal(size=(n, 3))
    xb = xa + rng.normal(size=(n, 3))
    va, vb = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    l = np.linalg.norm(xb - xa, axis=1)
    l0 = 0.8 * l
    k = rng.uniform(10.0, 1000.0, n)
    c = rng.uniform(0.0, 1.0, n)
    return xa, xb, va, vb, l0, k, c


def test_force_jacobians_match_central_differences():
    xa, xb, va, vb, l0, k, c = _random_taut_states(20, 2)
    K, D = cable.end_force_jacobians(xa, xb, va, vb, l0, k, c)
    h = 1e-6
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        fp = cable.end_forces(xa, xb + e, va, vb, l0, k, c)[0]
        fm = cable.end_forces(xa, xb - e, va, vb, l0, k, c)[0]
        np.testing.assert_allclose(K[:, :, j], (fp - fm) / (2 * h), rtol=1e-6, atol=1e-6)
        fpa = cable.end_forces(xa + e, xb, va, vb, l0, k, c)[0]
        fma = cable.end_forces(xa - e, xb, va, vb, l0, k, c)[0]
        np.testing.assert_allclose(-K[:, :, j], (fpa - fma) / (2 * h), rtol=1e-6, atol=1e-6)
        gp = cable.end_forces(xa, xb, va, vb + e, l0, k, c)[0]
        gm = cable.end_forces(xa, xb, va, vb - e, l0, k, c)[0]
        np.testing.assert_allclose(D[:, :, j], (gp - gm) / (2 * h), rtol=1e-6, atol=1e-6)


def test_tension_derivatives_match_central_differences():
    rng = np.random.default_rng(3)
    l0 = rng.uniform(0.5, 1.0, 50)
    l = l0 * rng.uniform(1.01, 1.2, 50)
    ldot = rng.uniform(-0.1, 0.1, 50)
    k, c = rng.uniform(100, 1000, 50), rng.uniform(0, 10, 50)
    d_l, d_v, d_l0 = cable.tension_derivatives(l, ldot, l0, k, c)
    h = 1e-7
    np.testing.assert_allclose(d_l, (cable.tension(l + h, ldot, l0, k, c) - cable.tension(l - h, ldot, l0, k, c))
                               / (2 * h), rtol=1e-6)
    np.testing.assert_allclose(d_v, (cable.tension(l, ldot + h, l0, k, c) - cable.tension(l, ldot - h, l0, k, c))
                               / (2 * h), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(d_l0, (cable.tension(l, ldot, l0 + h, k, c) - cable.tension(l, ldot, l0 - h, k, c))
                               / (2 * h), rtol=1e-6)
    slack = cable.tension_derivatives(0.5, 1.0, 1.0, 100.0, 1.0)
    assert all(float(x) == 0.0 for x in slack)


def test_the_tension_at_rest_is_the_energy_s_derivative():
    """T(l, 0) = dE/dl for the stored energy k max(0, l - l0)^2 / 2 (central differences)."""
    l = np.linspace(0.5, 1.5, 41)
    h = 1e-7
    dE = (cable.energy(l + h, 1.0, 800.0) - cable.energy(l - h, 1.0, 800.0)) / (2 * h)
    np.testing.assert_allclose(cable.tension(l, 0.0, 1.0, 800.0, 3.0), dE, atol=1e-4)   # k h at the kink
