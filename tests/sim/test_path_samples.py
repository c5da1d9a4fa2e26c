"""Equilibria at sample times from the quasi-static path: one by one and vectorised agree, the
rates are the path's, a stationary stretch costs no Newton and reports zero rate."""

from __future__ import annotations

import numpy as np
import pytest

from tensegrity_core.class2.dynamics import potential_gradient
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.sim import compile_scene, load_scene
from tensegrity_core.sim.class2 import path_samples as samples

from .helpers import class2_scene


def ramp_scene(T: float = 20.0, rate: float = 5.0):
    p = class2_scene().model.params
    q0 = np.array([0.4, 0.8, float(equilibrium_beta(0.4, 0.8, p))])
    hold = -potential_gradient(q0, p)[:2]
    inputs = {"f1": {"law": "ramp", "from": float(hold[0]), "to": float(hold[0]) + 0.3, "t0": 2.0, "t1": T - 5.0},
              "f2": {"law": "ramp", "from": float(hold[1]), "to": float(hold[1]) - 0.2, "t1": T / 2}}
    return class2_scene(effects=["springs"], inputs=inputs, initial={"equilibrium": {"rho1": 0.4, "rho2": 0.8}},
                        duration=T, output={"rate": rate})


def recorded(scene):
    """``(potential, blocks (times, segment))`` of a whole run at the output rate, and the
    model (its strut length L and duration T scale the path)."""
    model = compile_scene(scene)
    state = model.initial_state()
    n = int(round(scene.duration * scene.output_rate)) + 1
    blocks = []
    model.record(state, np.arange(n) / scene.output_rate, blocks)
    assert all(b[2] is model.potential(state) for b in blocks)      # no command changed on the way
    return model.potential(state), [(t, seg) for t, seg, _ in blocks], model


@pytest.mark.parametrize("scene", [load_scene("paper_fold_quasistatic"), ramp_scene()], ids=["paper", "ramps"])
def test_one_by_one_and_vectorised_samples_agree(scene, monkeypatch):
    potential, blocks, model = recorded(scene)
    monkeypatch.setattr(samples, "FEW", 10**9)
    one_by_one = samples.equilibria(potential, blocks, model.L, model.T)
    monkeypatch.setattr(samples, "FEW", -1)
    vectorised = samples.equilibria(potential, blocks, model.L, model.T)
    for a, b, name in zip(one_by_one, vectorised, ("t", "q", "qdot", "contact", "forces", "bits")):
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-12, err_msg=name)


def test_samples_are_equilibria_and_their_rates_the_paths():
    """Oracles: the closed-form gradient of the springs' energy plus the ramped forces, and
    central differences of the samples in time for the rates."""
    scene = ramp_scene(rate=50.0)
    potential, blocks, model = recorded(scene)
    t, q, qd, lam, u, bits = samples.equilibria(potential, blocks, model.L, model.T)
    p = scene.model.params
    assert np.all(bits == 0) and np.all(lam == 0.0)
    for tk, qk, uk in zip(t, q, u):
        np.testing.assert_allclose(potential_gradient(qk, p) + np.r_[uk, 0.0], 0.0, atol=1e-12)
        np.testing.assert_allclose(uk, [law.value_at(tk, x) for law, x in zip(model.laws, qk[:2])], rtol=1e-13)
    h = t[1] - t[0]
    inner = (t > 2.1) & (t < 9.9)             # both ramps on, away from their corners
    fd = (q[2:] - q[:-2]) / (2 * h)
    np.testing.assert_allclose(qd[1:-1][inner[1:-1]], fd[inner[1:-1]], rtol=1e-4, atol=1e-8)


def test_a_standing_stretch_is_its_end_point_with_zero_rate_and_the_laws_forces():
    """Folded and held, the paper's mechanism stands still: every sample after t = 0.075 s is
    the fold (0, 0, pi/2) at rest; the forces follow f = 10 rho t = 0 and the contact forces
    are dU/drho there (the closed-form gradient)."""
    scene = load_scene("paper_fold_quasistatic")
    potential, blocks, model = recorded(scene)
    assert any(seg.stationary for _, seg in blocks)
    t, q, qd, lam, u, bits = samples.equilibria(potential, blocks, model.L, model.T)
    rest = t > 0.076
    fold = np.array([0.0, 0.0, np.pi / 2])
    assert np.all(bits[rest] == 3) and np.all(qd[rest] == 0.0) and np.all(u[rest] == 0.0)
    np.testing.assert_allclose(q[rest], np.broadcast_to(fold, q[rest].shape), atol=1e-15)
    np.testing.assert_allclose(lam[rest], np.broadcast_to(potential_gradient(fold, scene.model.params)[:2],
                                                          lam[rest].shape), atol=1e-15)


def test_masked_solves_equal_lapack_on_the_free_block():
    rng = np.random.default_rng(4)
    n = 40
    A = rng.normal(size=(n, 3, 3))
    K = A @ A.transpose(0, 2, 1) + 0.5 * np.eye(3)
    b = rng.normal(size=(n, 3))
    bits = rng.integers(0, 4, n)
    entries = (K[:, 0, 0], K[:, 0, 1], K[:, 0, 2], K[:, 1, 1], K[:, 1, 2], K[:, 2, 2])
    x = samples.masked_solve(entries, b, bits)
    for k in range(n):
        free = list(samples.MODE_FREE[int(bits[k])])
        expected = np.zeros(3)
        expected[free] = np.linalg.solve(K[k][np.ix_(free, free)], b[k, free])
        np.testing.assert_allclose(x[k], expected, rtol=1e-11, atol=1e-13)
