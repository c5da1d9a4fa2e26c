"""Scene builders shared by the simulator tests."""

from __future__ import annotations

import copy

import numpy as np

from tensegrity_core.sim import load_scene

BASE = {
    "model": {"kind": "class2", "params": {"L": 1.0, "k": 1.0, "c": 0.01, "m": 2.0}},
    "initial": {"equilibrium": {"rho1": 0.7, "rho2": 0.7}},
    "inputs": {"f1": {"law": "proportional", "gain": 10.0}, "f2": {"law": "proportional", "gain": 10.0}},
    "effects": ["inertia", "springs", "damping"],
    "duration": 1.0,
    "output": {"rate": 100},
    "integrator": {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12},
}


def class2_scene(**changes):
    """The paper's scenario (without fold limit) with top-level keys replaced by ``changes``."""
    d = copy.deepcopy(BASE)
    for key, value in changes.items():
        d[key] = value
    return load_scene(d)


def random_states(n: int, seed: int = 0, *, extra: int = 0):
    """Random class-2 states well inside the domain: (rho1, rho2, beta, rates, [extra])."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        r1, r2 = rng.uniform(0.05, 0.85, 2)
        if r1 + r2 > 1.8:
            continue
        out.append(np.concatenate([[r1, r2, rng.uniform(-3, 3)], rng.normal(0, 0.7, 3), rng.normal(0, 0.5, extra)]))
    return out


def central_jacobian(fun, y, h=1e-6):
    """Central finite differences of ``fun`` (vector -> vector) at ``y``."""
    y = np.asarray(y, dtype=float)
    cols = []
    for j in range(len(y)):
        step = h * max(1.0, abs(y[j]))
        e = np.zeros_like(y)
        e[j] = step
        cols.append((np.asarray(fun(y + e)) - np.asarray(fun(y - e))) / (2 * step))
    return np.stack(cols, axis=-1)
