"""Benchmarks of the class-2 equations of motion.

- one scalar evaluation (state -> qddot) on the pure-math fast path, against a
  straightforward numpy implementation measured in the same run (the same closed forms
  with M, C and the spring terms as small arrays, then ``np.linalg.solve``) and against
  the module's own validated matrix functions + solve; target < 15 us;
- ``Class2Dynamics.rhs`` as solve_ivp calls it (ndarray in, ndarray out);
- the batch path: states per second for N states at once.
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.class2 import dynamics as dyn
from tensegrity_core.class2.params import PAPER_PARAMS
from tests.bench.harness import Context, Row, benchmark, time_per_call

STATE = (0.7, 0.6, 0.8, 0.1, -0.2, 0.3)
FORCES = (1.0, 2.0)


def numpy_straightforward(q: np.ndarray, qdot: np.ndarray, f1: float, f2: float, p=PAPER_PARAMS) -> np.ndarray:
    """A straightforward numpy implementation for one state: the same closed forms, with
    M, C, the spring vectors/Jacobians and the right-hand side as small arrays, then
    ``np.linalg.solve``."""
    rho1, rho2, beta = q
    L, m = p.L, p.m
    s = rho1 + rho2
    lam1, lam2 = np.sqrt(4 * L**2 - s**2), np.sqrt(L**2 - rho1**2)
    sb, cb = np.sin(beta), np.cos(beta)
    mu = m / 2 + 2 * m * L**2 / (3 * lam1**2)
    M = np.array([[m + mu + m * L**2 / (3 * lam2**2), mu, -m * L * sb / 2], [mu, mu, 0.0],
                  [-m * L * sb / 2, 0.0, m * L**2 / 3]])
    k1 = 2 * m * L**2 * s / (3 * lam1**4) * (qdot[0] + qdot[1]) ** 2
    C = np.array([k1 + m * L**2 * rho1 / (3 * lam2**4) * qdot[0] ** 2 - m * L * cb / 2 * qdot[2] ** 2, k1, 0.0])
    e1, h = s / lam1, (rho2 - rho1) / 2
    springs = [  # (d, J, k, c) for CD, DE, EF, BE
        (np.array([L * cb - rho2, L * sb]), np.array([[0, -1, -L * sb], [0, 0, L * cb]]), p.k3, p.c3),
        (np.array([h - L * cb, lam1 / 2 - L * sb]),
         np.array([[-0.5, 0.5, L * sb], [-e1 / 2, -e1 / 2, -L * cb]]), p.k2, p.c2),
        (np.array([-s / 2, lam2 - lam1 / 2]),
         np.array([[-0.5, -0.5, 0], [e1 / 2 - rho1 / lam2, e1 / 2, 0]]), p.k1, p.c1),
        (np.array([h, lam1 / 2]), np.array([[-0.5, 0.5, 0], [-e1 / 2, -e1 / 2, 0]]), p.k4, p.c4),
    ]
    Q = np.zeros(3)
    for d, J, k, c in springs:
        Q += (k + c * (d @ (J @ qdot)) / (d @ d)) * (J.T @ d)
    return np.linalg.solve(M, -(C + Q + np.array([f1, f2, 0.0])))


def numpy_matrix_api(q: np.ndarray, qdot: np.ndarray, f1: float, f2: float) -> np.ndarray:
    """The validated, broadcasting matrix functions of the module for one state, then a solve."""
    M = dyn.mass_matrix(q, PAPER_PARAMS)
    rhs = -(dyn.velocity_terms(q, qdot, PAPER_PARAMS) + dyn.damping_matrix(q, PAPER_PARAMS) @ qdot
            + dyn.potential_gradient(q, PAPER_PARAMS) + np.array([f1, f2, 0.0]))
    return np.linalg.solve(M, rhs)


@benchmark
def eom_scalar(ctx: Context) -> list[Row]:
    model = dyn.Class2Dynamics(PAPER_PARAMS)
    q, qdot = np.array(STATE[:3]), np.array(STATE[3:])
    y = np.array(STATE)
    fast = model.acceleration_scalar(*STATE, *FORCES)
    for other in (numpy_straightforward, numpy_matrix_api):
        if not np.allclose(fast, other(q, qdot, *FORCES), rtol=1e-12, atol=1e-12):
            raise AssertionError(f"fast path and {other.__name__} disagree")
    min_time = None if ctx.quick else 0.5          # quick: the mode's (harness.QUICK_TIMING)
    t_np = time_per_call(lambda: numpy_straightforward(q, qdot, *FORCES), min_time=min_time)
    t_api = time_per_call(lambda: numpy_matrix_api(q, qdot, *FORCES), min_time=min_time)
    t_fast = time_per_call(lambda: model.acceleration_scalar(*STATE, *FORCES), min_time=min_time)
    t_rhs = time_per_call(lambda: model.rhs(0.0, y, *FORCES), min_time=min_time)
    return [
        Row("class2_dyn", "eom_numpy_straightforward", t_np * 1e6, "us",
            note="closed forms in small numpy arrays + np.linalg.solve"),
        Row("class2_dyn", "eom_numpy_matrix_api", t_api * 1e6, "us", baseline="eom_numpy_straightforward",
            note="mass_matrix, velocity_terms, damping_matrix, potential_gradient + solve"),
        Row("class2_dyn", "eom_scalar_fast", t_fast * 1e6, "us", baseline="eom_numpy_straightforward",
            target="< 15 us", note="Class2Dynamics.acceleration_scalar (pure math)"),
        Row("class2_dyn", "rhs_for_solve_ivp", t_rhs * 1e6, "us", baseline="eom_numpy_straightforward",
            note="Class2Dynamics.rhs, ndarray (6,) in and out"),
    ]


@benchmark
def eom_batch(ctx: Context) -> list[Row]:
    model = dyn.Class2Dynamics(PAPER_PARAMS)
    rng = np.random.default_rng(0)
    n = 10_000 if ctx.quick else 1_000_000
    y = np.column_stack([rng.uniform(0.05, 0.9, n), rng.uniform(0.05, 0.9, n), rng.uniform(-3, 3, n),
                         rng.normal(size=(n, 3))])
    f1, f2 = rng.normal(size=n), rng.normal(size=n)
    t = time_per_call(lambda: model.acceleration_batch(y, f1, f2), min_time=None if ctx.quick else 1.0,
                      repeat=None if ctx.quick else 3)
    rows_list = y[:1000].tolist()
    forces = list(zip(f1[:1000].tolist(), f2[:1000].tolist()))

    def loop():
        for row, (a, b) in zip(rows_list, forces):
            model.acceleration_scalar(*row, a, b)

    t_loop = time_per_call(loop, min_time=None if ctx.quick else 1.0) / len(rows_list)
    return [
        Row("class2_dyn", "eom_scalar_loop_per_state", t_loop * 1e9, "ns", note="Python loop over the scalar path"),
        Row("class2_dyn", f"eom_batch_{n}_per_state", t / n * 1e9, "ns", baseline="eom_scalar_loop_per_state",
            note="Class2Dynamics.acceleration_batch, per-state forces"),
        Row("class2_dyn", f"eom_batch_{n}", n / t, "states/s", note="throughput of the batch path"),
    ]
