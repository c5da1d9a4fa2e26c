"""Benchmarks of the class-2 kinematics: scalar FK/IK and vectorised IK against baselines.

Baselines measured in the same run: FK by numeric energy minimisation (scipy), IK by a
per-point scipy root find of FK(rho) = D, and per-point loops of the scalar functions.
"""

from __future__ import annotations

import time

import numpy as np
from scipy import optimize

from tensegrity_core.class2 import PAPER_PARAMS
from tensegrity_core.class2.ik_arrays import ik_array
from tensegrity_core.class2.inverse_kinematics import inverse_kinematics
from tensegrity_core.class2.kinematics import fk_array, forward_kinematics, forward_kinematics_numeric
from tests.bench.harness import Row, benchmark, time_per_call

# A target with all four real candidates (two genuine equilibria) and one with two.
TARGET4 = (0.5726731646460115, 0.944911182523068)
TARGET2 = (1.4, 0.7141428428542851)


def _ik_by_root_find(x: float, y: float, seed=(0.5, 0.5)) -> np.ndarray:
    """Baseline IK: solve FK(rho) = (x, y) with scipy's hybrid Powell method from a seed."""
    def residual(rho):
        fk = fk_array(rho[0], rho[1], PAPER_PARAMS)
        return [float(fk.x) - x, float(fk.y) - y]

    return optimize.root(residual, seed, method="hybr", options={"xtol": 1e-12}).x


def _targets(n: int, seed: int = 11):
    rng = np.random.default_rng(seed)
    rho1 = rng.uniform(0.0, 1.0, n)
    beta = rng.uniform(0.0, np.pi / 2, n)
    return rho1 + np.cos(beta), np.sin(beta)


@benchmark
def scalar_calls(ctx):
    repeat = 1 if ctx.quick else 7
    fk = time_per_call(lambda: forward_kinematics(0.7, 0.7), repeat=repeat) * 1e6
    fk_num = time_per_call(lambda: forward_kinematics_numeric(0.7, 0.7), min_time=0.1, repeat=repeat) * 1e6
    ik4 = time_per_call(lambda: inverse_kinematics(*TARGET4), repeat=repeat) * 1e6
    ik2 = time_per_call(lambda: inverse_kinematics(*TARGET2), repeat=repeat) * 1e6
    ik_root = time_per_call(lambda: _ik_by_root_find(*TARGET2), min_time=0.1, repeat=repeat) * 1e6
    return [
        Row("class2_kin", "fk_numeric_scipy", fk_num, "us/call", note="baseline: energy minimisation"),
        Row("class2_kin", "fk_scalar", fk, "us/call", baseline="fk_numeric_scipy", target="< 20 us"),
        Row("class2_kin", "ik_root_find_scipy", ik_root, "us/call", note="baseline: scipy root of FK(rho) = D"),
        Row("class2_kin", "ik_scalar_4_candidates", ik4, "us/call", baseline="ik_root_find_scipy", target="< 20 us"),
        Row("class2_kin", "ik_scalar_2_candidates", ik2, "us/call", baseline="ik_root_find_scipy", target="< 20 us"),
    ]


def _best_time(fn, repeat: int) -> float:
    """Best wall time [s] of ``repeat`` calls of ``fn`` (each call is long: no inner loop)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


@benchmark
def vectorised(ctx):
    n = 1_000_000
    repeat = 1 if ctx.quick else 7
    x, y = _targets(n)
    ik_ns = _best_time(lambda: ik_array(x, y), repeat) / n * 1e9
    m = 2000 if ctx.quick else 20000
    t0 = time.perf_counter()
    for xi, yi in zip(x[:m], y[:m]):
        inverse_kinematics(xi, yi)
    loop_ns = (time.perf_counter() - t0) / m * 1e9
    r1 = np.random.default_rng(3).uniform(0, 1, n)
    r2 = np.random.default_rng(4).uniform(0, 1, n)
    fk_ns = _best_time(lambda: fk_array(r1, r2), repeat) / n * 1e9
    return [
        Row("class2_kin", "ik_scalar_loop", loop_ns, "ns/target", note=f"baseline: loop of inverse_kinematics over {m}"),
        Row("class2_kin", "ik_array_1e6", ik_ns, "ns/target", baseline="ik_scalar_loop",
            target="<= 500 ns (>= 2e6 targets/s)", note=f"{1e3 / ik_ns:.3g} M targets/s"),
        Row("class2_kin", "fk_array_1e6", fk_ns, "ns/point", note=f"{1e3 / fk_ns:.3g} M points/s"),
    ]
